"""Tables handed to the native code: a CSV file's path, a pandas DataFrame, a dict of columns or
a list of row dicts, all passed on as CSV text (or the path) so that the same reader, with the
same checks and messages, reads them as `demcal doe` and `demcal surrogate` read a file."""

from __future__ import annotations

import csv
import io
import os
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union, cast

TableLike = Union[str, "os.PathLike[str]", Mapping[str, Sequence[Any]], Sequence[Mapping[str, Any]], Any]


def table_args(data: TableLike, name: str = "data") -> Tuple[Optional[str], Optional[str], str]:
    """(path, csv_text, source) for the native functions."""
    if isinstance(data, (str, os.PathLike)):
        path = os.fspath(data)
        return path, None, path
    # A pandas DataFrame (without importing pandas: it is optional).
    if hasattr(data, "to_csv") and hasattr(data, "columns"):
        return None, data.to_csv(index=False), name
    if isinstance(data, Mapping):
        columns = [str(k) for k in data.keys()]
        values = [list(v) for v in data.values()]
        lengths = {len(v) for v in values}
        if len(lengths) > 1:
            raise ValueError(f"{name}: the columns have different lengths: " + ", ".join(
                f"{c} {len(v)}" for c, v in zip(columns, values)))
        rows = list(zip(*values)) if values else []
        return None, _csv(columns, rows), name
    if isinstance(data, Sequence) and all(isinstance(r, Mapping) for r in data):
        records: List[Mapping[str, Any]] = list(cast(Sequence[Mapping[str, Any]], data))
        names: List[str] = []
        for r in records:
            for k in r.keys():
                if str(k) not in names:
                    names.append(str(k))
        return None, _csv(names, [[r.get(c, "") for c in names] for r in records]), name
    raise TypeError(
        f"{name}: expected a CSV file's path, a pandas DataFrame, a dict of columns or a list of row dicts, "
        f"got {type(data).__name__}")


def _csv(columns: Sequence[str], rows: Sequence[Sequence[Any]]) -> str:
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    w.writerow(columns)
    for r in rows:
        w.writerow([repr(float(v)) if isinstance(v, float) else v for v in r])
    return out.getvalue()


def rows_from_csv(text: str) -> List[Dict[str, Any]]:
    """CSV text as a list of row dicts, numbers as numbers."""
    rows = []
    for r in csv.DictReader(io.StringIO(text)):
        rows.append({k: _number(v) for k, v in r.items()})
    return rows


def _number(v: str) -> Any:
    try:
        i = int(v)
        return i
    except ValueError:
        pass
    try:
        return float(v)
    except ValueError:
        return v


def frame_or_rows(rows: List[Dict[str, Any]], frame: Optional[bool]) -> Any:
    """A pandas DataFrame when `frame` is True, or None and pandas is installed; else the rows."""
    if frame is False:
        return rows
    try:
        import pandas as pd  # type: ignore
    except ImportError:
        if frame:
            raise ImportError("frame=True needs pandas: pip install pandas") from None
        return rows
    return pd.DataFrame(rows)

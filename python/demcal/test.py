"""Virtual lab tests: a test file (or a dict in its format) run at a parameter point.

    t = demcal.Test.load("examples/quickstart/repose.toml")
    r = t.run({"interaction[bead,bead].rolling_friction": 0.12}, seed=1)
    r.responses["angle_of_repose_deg"], r.wall_s
"""

from __future__ import annotations

import copy
import json
import os
from dataclasses import dataclass, field
from typing import Any, Dict, List, Mapping, Optional, Union

import numpy as np

from . import _demcal
from .errors import for_kind, whole

Number = Union[float, int]
PathLike = Union[str, "os.PathLike[str]"]


@dataclass(frozen=True)
class Curve:
    """A measured curve (a force-displacement curve): x and y as numpy arrays, with their names
    and units."""

    x: np.ndarray
    y: np.ndarray
    x_name: str = ""
    x_unit: str = ""
    y_name: str = ""
    y_unit: str = ""

    def __len__(self) -> int:
        return len(self.x)

    @property
    def peak(self) -> float:
        """The largest y (the peak force of a shear or compression curve)."""
        return float(np.max(self.y)) if len(self.y) else float("nan")


@dataclass
class Result:
    """One run of a virtual test.

    `responses` holds the numbers a study can calibrate against (`angle_deg`, `peak_force_n`,
    ...), `curves` the curves, `outcome` everything the test measured (what `demcal test --json`
    prints), `wall_s` the run's wall time. A failed run (with `check=False`) has `ok` False and
    says why in `error` and `error_kind` (the kinds a study stores: `diverged`, `escaped`,
    `bad_settings`, `measurement_failed`, `not_quasi_static`, `output_failed`).
    """

    ok: bool
    responses: Dict[str, float]
    curves: Dict[str, Curve]
    outcome: Any
    summary: str
    wall_s: float
    params: Dict[str, Any] = field(default_factory=dict)
    seed: Optional[int] = None
    error: Optional[str] = None
    error_kind: Optional[str] = None

    def __getitem__(self, name: str) -> float:
        """The response `name` (`r["angle_of_repose_deg"]`)."""
        return self.responses[name]

    @property
    def warnings(self) -> List[str]:
        """What the run warned about (a time step long for the bond stiffness, ...), as the
        binary prints on standard error."""
        w = self.outcome.get("warnings") if isinstance(self.outcome, dict) else None
        return [str(x) for x in w] if isinstance(w, list) else []

    def raise_for_error(self) -> "Result":
        """Raises the failure's exception (a `RunError` subclass) when the run failed."""
        if not self.ok:
            e = for_kind(self.error_kind or "")(self.error or "the run failed")
            e.kind = self.error_kind  # type: ignore[attr-defined]
            e.result = self  # type: ignore[attr-defined]
            raise e
        return self


def _result(answer: Mapping[str, Any], params: Dict[str, Any], seed: Optional[int]) -> Result:
    curves = {
        name: Curve(
            x=np.asarray(c["x"], dtype=float),
            y=np.asarray(c["y"], dtype=float),
            x_name=c.get("x_name", ""),
            x_unit=c.get("x_unit", ""),
            y_name=c.get("y_name", ""),
            y_unit=c.get("y_unit", ""),
        )
        for name, c in answer["curves"].items()
    }
    return Result(
        ok=bool(answer["ok"]),
        # A response that is not finite (an infinite stiffness) comes through JSON as null.
        responses={k: float("nan") if v is None else float(v) for k, v in answer["responses"].items()},
        curves=curves,
        outcome=answer["outcome"],
        summary=answer["summary"],
        wall_s=float(answer["wall_s"]),
        params=params,
        seed=seed,
        error=answer.get("error"),
        error_kind=answer.get("error_kind"),
    )


class Test:
    """A virtual lab test: the contents of a test file (`test = "angle_of_repose"`, the
    materials, interactions and particle types, and the test's table), as a dict.

    Relative paths in it (an STL file, a lab curve) are taken from `folder`: the file's folder
    for `Test.load`, the working folder for `Test.from_dict` unless given.
    """

    __test__ = False  # not a pytest test class

    def __init__(self, table: Mapping[str, Any], name: str = "test", folder: PathLike = ".") -> None:
        self._table = copy.deepcopy(dict(table))
        self.name = name
        self.folder = os.fspath(folder)
        info = json.loads(_demcal.test_info(self._json(), self.name, self.folder))
        #: The test's kind (`angle_of_repose`, `shear`, ...).
        self.kind: str = info["test"]
        #: The responses a study can calibrate against, the usual one first.
        self.response_names: List[str] = list(info["responses"])
        #: How the file is written that the user should hear about (a friction alias).
        self.warnings: List[str] = list(info["warnings"])

    @classmethod
    def load(cls, path: PathLike) -> "Test":
        """Reads a test file; errors name the file and the key (`InputError`)."""
        path = os.fspath(path)
        table = json.loads(_demcal.read_table(path))
        return cls(table, name=path, folder=os.path.dirname(path) or ".")

    @classmethod
    def from_dict(cls, table: Mapping[str, Any], folder: PathLike = ".", name: str = "test") -> "Test":
        """A test from a dict in the test file's format."""
        return cls(table, name=name, folder=folder)

    def to_dict(self) -> Dict[str, Any]:
        """The test's contents (a copy: change it and make a new `Test` from it)."""
        return copy.deepcopy(self._table)

    def _json(self) -> str:
        return json.dumps(self._table)

    def run(
        self,
        params: Optional[Mapping[str, Union[Number, str]]] = None,
        seed: Optional[int] = None,
        threads: Optional[int] = None,
        out: Optional[PathLike] = None,
        check: bool = True,
    ) -> Result:
        """Runs the test with `params` set and returns its `Result`.

        `params` maps parameter paths, as a study's `paths` write them
        (`"interaction[bead,bead].rolling_friction"`, `"material[steel].shear_modulus"`), to
        numbers or quantities with a unit (`"29 MPa"`). `seed` places the particles (the file's
        `seed`, else 1, when None); `threads` is the number of cores (all when None); `out` a
        folder for its pictures, curve and `result.json`. The GIL is released while it runs and
        Ctrl-C stops it (`KeyboardInterrupt`).

        A run that fails raises a `RunError` subclass (`DivergedError`, ...) with the `Result`
        as its `result`; with `check=False` the `Result` comes back with `ok` False instead. A
        wrong key or value raises `InputError` before anything runs.
        """
        params = dict(params or {})
        seed = whole("seed", seed, 0)
        threads = whole("threads", threads, 1)
        answer = json.loads(
            _demcal.test_run(
                self._json(),
                self.name,
                self.folder,
                params,
                seed,
                threads,
                None if out is None else os.fspath(out),
            )
        )
        result = _result(answer, params, seed)
        return result.raise_for_error() if check else result

    def __repr__(self) -> str:
        return f"Test({self.kind!r}, name={self.name!r})"

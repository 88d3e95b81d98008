"""Calibration studies: what `demcal run`, `status` and `report` do, from Python.

    s = demcal.Study.load("examples/quickstart/study.toml")
    print(s.run(jobs=2))
    s.results()          # a pandas DataFrame when pandas is installed, else a list of dicts
    s.summary()["calibrated"]
"""

from __future__ import annotations

import json
import os
from typing import Any, Dict, List, Optional, Union

from . import _demcal
from ._tables import frame_or_rows
from .errors import whole

PathLike = Union[str, "os.PathLike[str]"]


class Study:
    """A study file: its parameters, plan and targets; its runs are kept in a store beside it
    (`<study>.db`), so a run that was interrupted goes on where it stopped."""

    def __init__(self, path: PathLike) -> None:
        self.path = os.fspath(path)
        info = json.loads(_demcal.study_info(self.path))
        self.name: str = info["name"]
        #: Each parameter: name, display_name, min, max and the test paths it is written to.
        self.parameters: List[Dict[str, Any]] = info["parameters"]
        #: The stages' kinds, in order (`screening`, `steepest`, `rsm`, `optimize`, ...).
        self.plan: List[str] = info["plan"]
        #: The tests' names (a study of one test names it after its kind) and their files
        #: (`"inline"` for a test written in the study).
        self.tests: List[str] = info["tests"]
        self.test_files: List[str] = info["test_files"]
        #: The response a run is scored by (the combined objective's with several targets).
        self.response: str = info["response"]
        #: The lab targets: test, response, value (the replicates' mean), replicates, unit,
        #: minimised, weight.
        self.targets: List[Dict[str, Any]] = info["targets"]
        self.store: str = info["store"]
        self.report_dir: str = info["report_dir"]
        self.seed: int = info["seed"]

    @classmethod
    def load(cls, path: PathLike) -> "Study":
        """Reads and checks a study file and its tests (`InputError` names the file and key)."""
        return cls(path)

    def run(self, jobs: int = 1, restart: bool = False, retry_failed: bool = False,
            backend: Optional[str] = None) -> str:
        """Runs (or resumes) the study on this machine, `jobs` simulations at once, writes its
        report and returns what `demcal run` prints. The GIL is released; Ctrl-C keeps every
        finished run and raises `KeyboardInterrupt` (the same call goes on from them). A study
        that stopped (too few runs finished) raises `StudyError`; one another process runs,
        `StudyLockedError`."""
        jobs = whole("jobs", jobs, 1)
        return _demcal.study_run(self.path, jobs, restart, retry_failed, backend)

    def status(self) -> str:
        """What `demcal status` prints: the stages, their runs, the best so far."""
        return _demcal.study_status(self.path)

    def results(self, frame: Optional[bool] = None) -> Any:
        """Every stored run, one row each: stage, stage_kind, index, seed, status, response,
        each parameter's value (by name), wall_s, error and error_kind. A pandas DataFrame when
        pandas is installed (or `frame=True`), else a list of dicts (`frame=False`)."""
        rows = []
        for r in json.loads(_demcal.study_results(self.path)):
            row: Dict[str, Any] = {
                "stage": r["stage"] + 1,
                "stage_kind": r["stage_kind"],
                "run": r["index"] + 1,
                "seed": r["seed"],
                "status": r["status"],
                "response": r["response"],
            }
            inputs = r.get("inputs") or {}
            if isinstance(inputs, dict):
                # In the study's order (the store keeps them by name).
                for p in self.parameters:
                    if p["name"] in inputs:
                        row[p["name"]] = inputs[p["name"]]
                row.update({k: v for k, v in inputs.items() if k not in row})
            row.update({"wall_s": r["wall_s"], "error": r.get("error"), "error_kind": r.get("error_kind"),
                        "outputs": r.get("outputs")})
            rows.append(row)
        return frame_or_rows(rows, frame)

    def report(self, out: Optional[PathLike] = None) -> str:
        """Writes the report (into `out`, or the study's `report/`) and returns its folder."""
        return os.fspath(_demcal.study_report(self.path, None if out is None else os.fspath(out)))

    def summary(self) -> Dict[str, Any]:
        """The report's `summary.json`: calibrated values with their 95 % intervals, the
        validation, each stage's outcome. Written by `run` and `report`."""
        p = os.path.join(self.report_dir, "summary.json")
        if not os.path.exists(p):
            raise FileNotFoundError(f"{p}: no report yet; run the study or call report() first")
        with open(p, encoding="utf-8") as f:
            return json.load(f)

    def __repr__(self) -> str:
        return f"Study({self.path!r}, plan={self.plan})"

# Type stubs of the native module (python/src/*.rs). The public API is the pure-Python one in
# this package; these functions take and give JSON text.
from os import PathLike
from pathlib import Path
from typing import Dict, List, Optional, Sequence, Tuple, Union, final

_Path = Union[str, PathLike[str]]

__all__ = [
    "DemcalError",
    "InputError",
    "RunError",
    "SettingsError",
    "DivergedError",
    "EscapedError",
    "MeasurementError",
    "NotQuasiStaticError",
    "OutputError",
    "StudyError",
    "StudyLockedError",
    "version",
    "read_table",
    "test_info",
    "test_run",
    "scene_info",
    "scene_run",
    "study_info",
    "study_run",
    "study_status",
    "study_results",
    "study_report",
    "doe_design",
    "doe_analyze",
    "doe_optimize",
    "NativeSurrogate",
    "surrogate_fit",
    "surrogate_optimize",
]

class DemcalError(Exception): ...
class InputError(DemcalError): ...
class RunError(DemcalError): ...
class SettingsError(RunError): ...
class DivergedError(RunError): ...
class EscapedError(RunError): ...
class MeasurementError(RunError): ...
class NotQuasiStaticError(RunError): ...
class OutputError(RunError): ...
class StudyError(DemcalError): ...
class StudyLockedError(StudyError): ...

def version() -> str: ...
def read_table(path: str) -> str: ...
def test_info(table_json: str, name: str, folder: str) -> str: ...
def test_run(
    table_json: str,
    name: str,
    folder: str,
    params: Optional[Dict[str, Union[float, str]]] = None,
    seed: Optional[int] = None,
    threads: Optional[int] = None,
    out: Optional[_Path] = None,
) -> str: ...
def scene_info(table_json: str, name: str, folder: str) -> str: ...
def scene_run(
    table_json: str, name: str, folder: str, steps: Optional[int] = None, threads: Optional[int] = None
) -> str: ...
def study_info(path: _Path) -> str: ...
def study_run(
    path: _Path, jobs: int = 1, restart: bool = False, retry_failed: bool = False, backend: Optional[str] = None
) -> str: ...
def study_status(path: _Path) -> str: ...
def study_results(path: _Path) -> str: ...
def study_report(path: _Path, out: Optional[_Path] = None) -> Path: ...
def doe_design(
    kind: str,
    factors: str,
    center_points: Optional[int] = None,
    alpha: Optional[str] = None,
    runs: Optional[int] = None,
    resolution: Optional[int] = None,
    fraction: Optional[int] = None,
    half_fraction: Optional[bool] = None,
    lhs: Optional[str] = None,
    direction: Optional[str] = None,
    step: Optional[float] = None,
    seed: int = 1,
) -> str: ...
def doe_analyze(
    responses: Sequence[str],
    path: Optional[_Path] = None,
    csv: Optional[str] = None,
    source: str = "data",
    factors: Optional[str] = None,
    model: Optional[str] = None,
    reduce: bool = False,
    alpha_out: float = 0.1,
    no_hierarchy: bool = False,
    no_curvature: bool = False,
    plots: Optional[_Path] = None,
) -> str: ...
def doe_optimize(
    responses: Sequence[str],
    goals: Sequence[str],
    path: Optional[_Path] = None,
    csv: Optional[str] = None,
    source: str = "data",
    factors: Optional[str] = None,
    model: Optional[str] = None,
    reduce: bool = False,
    alpha_out: float = 0.1,
    solutions: int = 10,
    starts: int = 100,
    seed: int = 1,
) -> str: ...

@final
class NativeSurrogate:
    @property
    def factors(self) -> List[str]: ...
    @property
    def ranges(self) -> List[Tuple[float, float]]: ...
    @property
    def summary_json(self) -> str: ...
    def predict(self, x: List[List[float]]) -> List[Tuple[float, Optional[float]]]: ...

def surrogate_fit(
    response: str,
    path: Optional[_Path] = None,
    csv: Optional[str] = None,
    source: str = "data",
    factors: Optional[Sequence[str]] = None,
    model: str = "gp",
    kernel: Optional[str] = None,
    seed: int = 1,
    train_fraction: float = 0.8,
) -> NativeSurrogate: ...
def surrogate_optimize(
    response: str,
    goal: str,
    path: Optional[_Path] = None,
    csv: Optional[str] = None,
    source: str = "data",
    factors: Optional[Sequence[str]] = None,
    model: str = "gp",
    kernel: Optional[str] = None,
    seed: int = 1,
    train_fraction: float = 0.8,
    target_of: Optional[str] = None,
    value: Optional[float] = None,
) -> str: ...

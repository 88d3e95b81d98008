"""demcal from Python: calibrate DEM models of agricultural materials.

The engine, the virtual lab tests, the studies, the designed experiments and the surrogates of
the `demcal` binary, in-process:

- `Test` runs a virtual lab test at a parameter point and gives its responses and curves;
- `Scene` builds and simulates a DEM scene;
- `Study` runs a whole calibration study, resumes it, and reads its results and report;
- `doe` makes designs, fits response-surface models with Design-Expert's ANOVA, optimises;
- `surrogate` fits Gaussian processes and GA-BP networks, predicts with variance, optimises.

Simulations release the GIL and stop on Ctrl-C. Errors are `DemcalError`s: `InputError` for a
wrong file, key or argument (the message names it), a `RunError` subclass for a simulation that
gave no result. See docs/python.md.
"""

from . import doe, surrogate
from ._demcal import version as _version
from .errors import (
    DemcalError,
    DivergedError,
    EscapedError,
    InputError,
    MeasurementError,
    NotQuasiStaticError,
    OutputError,
    RunError,
    SettingsError,
    StudyError,
    StudyLockedError,
)
from .scene import Scene, SceneState
from .study import Study
from .test import Curve, Result, Test

__version__ = _version()

__all__ = [
    "Curve",
    "DemcalError",
    "DivergedError",
    "EscapedError",
    "InputError",
    "MeasurementError",
    "NotQuasiStaticError",
    "OutputError",
    "Result",
    "RunError",
    "Scene",
    "SceneState",
    "SettingsError",
    "Study",
    "StudyError",
    "StudyLockedError",
    "Test",
    "doe",
    "surrogate",
]

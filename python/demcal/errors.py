"""The exceptions demcal raises. Every one is a `DemcalError`; a simulation that gave no result
raises a `RunError` subclass named after why (the kinds a study stores with a failed run)."""

from ._demcal import (  # noqa: F401
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

#: The exception for each failure kind (`Result.error_kind`).
BY_KIND = {
    "bad_settings": SettingsError,
    "diverged": DivergedError,
    "escaped": EscapedError,
    "measurement_failed": MeasurementError,
    "not_quasi_static": NotQuasiStaticError,
    "output_failed": OutputError,
}


def for_kind(kind: str) -> type:
    """The exception class for a failure kind (`RunError` for a kind without its own)."""
    return BY_KIND.get(kind, RunError)

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

# The native module makes its exceptions in a module it calls `_demcal`, which cannot be imported
# by that name: tracebacks said `_demcal.InputError` and pickle (multiprocessing,
# concurrent.futures) failed to find the class. They are all importable from `demcal`.
for _cls in (DemcalError, InputError, RunError, SettingsError, DivergedError, EscapedError, MeasurementError,
             NotQuasiStaticError, OutputError, StudyError, StudyLockedError):
    _cls.__module__ = "demcal"
del _cls

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


def whole(name: str, value, least: int):  # type: ignore[no-untyped-def]
    """`value` when it is a whole number (not a bool) of at least `least`, or None; else an
    `InputError` naming the argument (rather than the OverflowError a negative number gives on
    its way into the native module)."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int):
        try:
            import numpy as np

            if isinstance(value, np.integer):
                value = int(value)
            else:
                raise TypeError
        except TypeError:
            raise InputError(f"{name}={value!r}: expected a whole number >= {least}") from None
    if value < least:
        raise InputError(f"{name}={value}: expected a whole number >= {least}")
    if value >= 2**63:
        raise InputError(f"{name}={value}: expected a whole number below 2**63")
    return value

"""Typed exceptions for everything that can go wrong in a tmafm run.

The Fortran core reports failures as an integer code and a one-line message
(``fortran/src/base/tmafm_errors.f90``); :func:`raise_for` maps each code to one class.
"""

__all__ = ["TmafmError", "InputError", "InputTypeError", "InputFileError", "BlowUpError",
           "SolverError", "MissingExtraError", "TmafmWarning", "UnsteadyWarning", "FailedRunWarning",
           "ContinuationWarning",
           "raise_for"]


class TmafmError(Exception):
    """Base class of every tmafm error."""


class InputError(TmafmError, ValueError):
    """A namelist key is unknown, a value has the wrong type, or a value is out of range."""


class InputTypeError(InputError, TypeError):
    """An argument is not of a type tmafm accepts (e.g. ``tmafm.run(42)``): an InputError that is
    also the TypeError Python code expects."""


class InputFileError(TmafmError, FileNotFoundError):
    """An input or output file is missing or cannot be read or written."""


class MissingExtraError(TmafmError, ImportError):
    """An optional dependency is not installed (e.g. xarray for tmafm.sweep): the message names
    the extra to install, ``pip install 'tmafm[sweep]'``.  Also the ImportError Python code
    expects."""


class SolverError(TmafmError, RuntimeError):
    """A run failed inside the solver."""


class BlowUpError(SolverError, ArithmeticError):
    """The integration blew up: NaN, Inf or a runaway amplitude (usually a step past the
    stability limit)."""


class TmafmWarning(UserWarning):
    """Base class of every tmafm warning."""


class UnsteadyWarning(TmafmWarning):
    """An observed run ended without a steady state; ``Observation.unsteady_reason`` says why
    (docs/observables.md, "Steady state")."""


class FailedRunWarning(TmafmWarning):
    """Runs of a sweep failed (SolverError, BlowUpError): their points hold NaN and
    ``failed`` = 1, and the Dataset's attributes ``failures`` and ``first_failure`` say how many
    and why.  One warning per sweep (docs/sweeps.md)."""


class ContinuationWarning(TmafmWarning):
    """A branch of tmafm.continuation ended early (max_points, a corrector that failed, a
    non-smooth point not crossed): the Dataset's ``end_reason`` and ``end_detail`` at the
    branch's last point say why (docs/continuation.md, section 6)."""


_BY_CODE = {2: InputError, 3: InputFileError, 4: BlowUpError, 5: SolverError}


def raise_for(ierr: int, errmsg) -> None:
    """Raise the exception for a Fortran error code; do nothing when ``ierr == 0``."""
    if ierr == 0:
        return
    if isinstance(errmsg, (bytes, bytearray)):
        errmsg = errmsg.decode("latin-1")
    # As the executable prints it: bytes outside printable ASCII as \xNN, one printable line.
    message = "".join(c if " " <= c < "\x7f" else f"\\x{ord(c):02x}" for c in str(errmsg).strip())
    raise _BY_CODE.get(int(ierr), SolverError)(message)

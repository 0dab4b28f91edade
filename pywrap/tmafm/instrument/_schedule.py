"""A run whose tip-sample distance Z follows a schedule, one value per drive period."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import _fortran
from .._run import Config
from ..errors import InputError, raise_for

#: The columns of a period's observables (tmafm.observe's, in its physical units).
_COLUMNS = tuple((row["name"], row["si_unit"], row["index"]) for row in _fortran.OBSERVABLE_TABLE
                 if row["kind"] == "column")
_N_OBSERVABLES = max(index for _, _, index in _COLUMNS)


@dataclass(frozen=True)
class ZSchedule:
    """Per-period observables of a run stepped through a Z schedule.

    ``z`` (m) is the schedule, ``time`` (s) each period's end, ``values[name]`` each period's
    observable in ``units[name]`` (nm, deg, nN, us, aJ: tmafm.observe's physical units)."""

    z: np.ndarray
    time: np.ndarray
    values: dict
    units: dict


def distances(z) -> np.ndarray:
    """``z`` as a contiguous 1-D float array of tip-sample distances (m), or a one-line
    InputError naming the first bad entry."""
    z = np.ascontiguousarray(z, dtype=float)
    if z.ndim != 1 or z.size == 0:
        raise InputError(f"z: must be a non-empty 1-D array of distances (m), got shape {z.shape}")
    bad = np.flatnonzero(~np.isfinite(z))
    if bad.size:
        raise InputError(f"z[{bad[0]}] = {float(z[bad[0]])}: must be finite")
    return z


def z_schedule(base, z, **overrides) -> ZSchedule:
    """Run ``base`` (an input with a &physical scene; ``overrides`` patch it) for one drive period
    per entry of ``z`` (m): period k at the tip-sample distance z[k], from the state period k - 1
    ended in (the first from &initial).  The model is rebuilt at each new Z and the state carried
    over in metres (docs/instrument.md, "The period stepper")."""
    z = distances(z)
    config = base if isinstance(base, Config) and not overrides else Config(base, **overrides)
    values = np.zeros((z.size, _N_OBSERVABLES), order="F")
    ends = np.zeros(z.size)
    done, ierr, errmsg = _fortran.api_instrument.z_schedule_run(config._f, z, _fortran.polls(), values,
                                                                ends)
    raise_for(ierr, errmsg)
    assert done == z.size
    return ZSchedule(z=z, time=ends,
                     values={name: values[:, index - 1].copy() for name, _, index in _COLUMNS},
                     units={name: unit for name, unit, _ in _COLUMNS})

"""Result <-> .npz, in the layout the executable writes for ``&output format = 'npy'``.

Members: tau, vt, vtdot (<f8, n), contact (|i1, n), a, adot (<f8, n x N, Fortran order),
switches (<f8), counters (<i8, 5: steps, contact_steps, rejected_steps, rhs_evaluations,
phase_switches), resolved (0-d |S: the resolved namelist text), version (0-d |S: 'tmafm X.Y.Z').
"""

from __future__ import annotations

import io
import zipfile
from pathlib import Path

import numpy as np

from .errors import InputError, InputFileError

__all__ = ["save", "load", "MEMBERS"]

#: Every member of the file, in writing order.
MEMBERS = ("tau", "vt", "vtdot", "contact", "a", "adot", "switches", "counters", "resolved",
           "version")


def _version() -> str:
    from . import __version__
    return f"tmafm {__version__}"


def save(result, path) -> Path:
    """Write `result` to `path` (.npz), atomically: a temporary file, then a rename."""
    from ._run import COUNTER_KEYS, _atomic_write
    path = Path(path)
    arrays = {
        "tau": np.asarray(result.tau, dtype="<f8"),
        "vt": np.asarray(result.vt, dtype="<f8"),
        "vtdot": np.asarray(result.vtdot, dtype="<f8"),
        "contact": np.asarray(result.contact, dtype="|i1"),
        "a": np.asfortranarray(result.a, dtype="<f8"),
        "adot": np.asfortranarray(result.adot, dtype="<f8"),
        "switches": np.asarray(result.switches, dtype="<f8"),
        "counters": np.array([result.counters.get(k, 0) for k in COUNTER_KEYS], dtype="<i8"),
        "resolved": np.array(result.resolved_text.encode("utf-8"), dtype="S"),
        "version": np.array(_version().encode("ascii"), dtype="S"),
    }
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    _atomic_write(path, buffer.getvalue())
    return path


def load(path):
    """Read a Result from a .npz written by Result.save or by the executable."""
    from ._run import COUNTER_KEYS, Result
    path = Path(path)
    if not path.is_file():
        raise InputFileError(f"result file '{path}' not found")
    try:
        with np.load(path, allow_pickle=False) as data:
            missing = [m for m in MEMBERS if m not in data.files]
            if missing:
                raise InputError(f"{path}: not a tmafm result (missing {', '.join(missing)})")
            members = {m: data[m] for m in MEMBERS}
    except (OSError, ValueError, zipfile.BadZipFile) as exc:
        if isinstance(exc, InputError):
            raise
        raise InputError(f"{path}: not a readable .npz file: {exc}") from exc
    n = members["tau"].shape[0]
    a = np.asfortranarray(members["a"], dtype=np.float64)
    if a.ndim != 2 or a.shape[0] != n or members["adot"].shape != a.shape:
        raise InputError(f"{path}: a and adot must be samples x N with {n} samples")
    counters = dict(zip(COUNTER_KEYS, map(int, members["counters"])))
    resolved = members["resolved"].item()
    return Result(tau=members["tau"].astype(np.float64), vt=members["vt"].astype(np.float64),
                  vtdot=members["vtdot"].astype(np.float64),
                  contact=members["contact"].astype(np.int8), a=a,
                  adot=np.asfortranarray(members["adot"], dtype=np.float64), counters=counters,
                  switches=members["switches"].astype(np.float64),
                  resolved_text=resolved.decode("utf-8") if isinstance(resolved, bytes)
                  else str(resolved))

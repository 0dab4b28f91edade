"""Result <-> .npz, in the layout the executable writes for ``&output format = 'npy'``.

Members: tau, vt, vtdot (<f8, n), contact (|i1, n), a, adot (<f8, n x N, Fortran order),
switches (<f8), counters (<i8, 5: steps, contact_steps, rejected_steps, rhs_evaluations,
phase_switches), resolved (0-d |S: the resolved namelist text), version (0-d |S: 'tmafm X.Y.Z').
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from ._namelist import shown
from .errors import InputError, InputFileError, InputTypeError

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
    try:
        resolved_text = result.resolved_text
    except AttributeError:
        raise InputError("Result.save: this Result has no resolved input (build it with config=, "
                         "resolved= or resolved_text=): a saved result must be rerunnable") from None
    arrays = {
        "tau": np.asarray(result.tau, dtype="<f8"),
        "vt": np.asarray(result.vt, dtype="<f8"),
        "vtdot": np.asarray(result.vtdot, dtype="<f8"),
        "contact": np.asarray(result.contact, dtype="|i1"),
        "a": np.asfortranarray(result.a, dtype="<f8"),
        "adot": np.asfortranarray(result.adot, dtype="<f8"),
        "switches": np.asarray(result.switches, dtype="<f8"),
        "counters": np.array([result.counters.get(k, 0) for k in COUNTER_KEYS], dtype="<i8"),
        "resolved": np.array(resolved_text.encode("utf-8", "surrogateescape"), dtype="S"),
        "version": np.array(_version().encode("ascii"), dtype="S"),
    }
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    return _atomic_write(path, buffer.getvalue())


#: The dtype kind and item size of each member (either byte order: a big-endian host writes >f8).
_TYPES = {"tau": ("f", 8), "vt": ("f", 8), "vtdot": ("f", 8), "contact": ("i", 1), "a": ("f", 8),
          "adot": ("f", 8), "switches": ("f", 8), "counters": ("i", 8), "resolved": ("S", None),
          "version": ("S", None)}
#: Most bytes the members may hold together: the largest .npz the executable writes (no zip64).
_MAX_BYTES = 2**32 - 2


def _members(path: Path, name: str) -> dict:
    """The members of a tmafm .npz, read with allow_pickle=False; InputError for anything else."""
    try:
        data = np.load(path, allow_pickle=False)
    except Exception as exc:  # not a zip, not .npy, empty, unreadable: numpy raises many kinds
        raise InputError(f"{name}: not a readable .npz file: {shown(str(exc))[1:-1]}") from None
    if not isinstance(data, np.lib.npyio.NpzFile):
        raise InputError(f"{name}: not a .npz archive (a single .npy array)")
    with data:
        missing = [m for m in MEMBERS if m not in data.files]
        if missing:
            raise InputError(f"{name}: not a tmafm result (missing {', '.join(missing)})")
        size = sum(info.file_size for info in data.zip.infolist())
        if size > _MAX_BYTES:
            raise InputError(f"{name}: the members hold {size} bytes, more than a tmafm .npz "
                             f"({_MAX_BYTES})")
        try:
            return {m: data[m] for m in MEMBERS}
        except Exception as exc:  # a bad header, a pickled member, a CRC error, a cut file
            raise InputError(f"{name}: a member cannot be read: {shown(str(exc))[1:-1]}") from None


def _check(name: str, members: dict) -> None:
    """The layout of docs/output-format.md: dtypes, shapes, and values a run can give."""
    for member, (kind, size) in _TYPES.items():
        dtype = members[member].dtype
        if dtype.kind != kind or (size is not None and dtype.itemsize != size):
            raise InputError(f"{name}: member {member} has dtype {dtype.str}, not "
                             f"{kind}{size or ''} (not a tmafm result)")
    n = members["tau"].shape[0] if members["tau"].ndim == 1 else -1
    shapes = {"tau": (n,), "vt": (n,), "vtdot": (n,), "contact": (n,), "counters": (5,),
              "resolved": (), "version": ()}
    shapes["a"] = shapes["adot"] = (n, members["a"].shape[1] if members["a"].ndim == 2 else -1)
    for member, shape in shapes.items():
        if members[member].shape != shape:
            modes = ", N modes" if member in ("a", "adot") else ""
            raise InputError(f"{name}: member {member} has shape {members[member].shape}, not "
                             f"{shape} (n = {n} samples{modes})")
    if members["switches"].ndim != 1:
        raise InputError(f"{name}: member switches has shape {members['switches'].shape}, not "
                         f"(n_switches,)")
    for member in ("tau", "vt", "vtdot", "a", "adot", "switches"):
        if not np.all(np.isfinite(members[member])):
            raise InputError(f"{name}: member {member} holds non-finite values")
    if not np.all((members["contact"] == 0) | (members["contact"] == 1)):
        raise InputError(f"{name}: member contact holds values other than 0 and 1")
    if np.any(members["counters"] < 0):
        raise InputError(f"{name}: member counters holds negative counts")


def _text(member: str, value) -> str:
    """A text member; bytes that are not UTF-8 (a Latin-1 file name) stay surrogate escapes, as
    in Config.text, and the core judges them."""
    return value.item().decode("ascii" if member == "version" else "utf-8", "surrogateescape")


def load(path):
    """Read a Result from a .npz written by Result.save or by the executable.

    The file is checked against the layout of docs/output-format.md (members, dtypes, shapes,
    finite values, contact flags of 0 and 1) and its resolved input is read by the core, which
    must give the archive's N and sample count: anything else is an InputError.
    """
    from ._run import COUNTER_KEYS, Result, _config_from_resolved_text
    try:
        path = Path(path)
    except TypeError as exc:
        raise InputTypeError(f"path must be a file name, not {type(path).__name__}: "
                             f"{exc}") from None
    name = shown(str(path))
    try:
        is_file = path.is_file()
    except (OSError, ValueError):
        is_file = False
    if not is_file:
        raise InputFileError(f"result file {name} not found")
    members = _members(path, name)
    _check(name, members)
    resolved = _text("resolved", members["resolved"])
    version = _text("version", members["version"])
    if not version.startswith("tmafm "):
        raise InputError(f"{name}: member version is {shown(version)}, not 'tmafm <version>'")
    try:
        config = _config_from_resolved_text(resolved, f"{name} (resolved)")
    except InputError as exc:
        raise InputError(f"{name}: the resolved input is not a valid tmafm input: {exc}") from None
    n, n_modes = members["a"].shape
    if (config.n_modes, config.n_samples) != (n_modes, n):
        raise InputError(f"{name}: the resolved input gives {config.n_samples} samples of "
                         f"N = {config.n_modes} modes, but the arrays hold {n} of N = {n_modes}")
    counters = dict(zip(COUNTER_KEYS, map(int, members["counters"])))
    real = lambda m: members[m].astype(np.float64)  # noqa: E731 (native byte order)
    return Result(tau=real("tau"), vt=real("vt"), vtdot=real("vtdot"),
                  contact=members["contact"].astype(np.int8),
                  a=np.asfortranarray(members["a"], dtype=np.float64),
                  adot=np.asfortranarray(members["adot"], dtype=np.float64), counters=counters,
                  switches=real("switches"), resolved_text=resolved)

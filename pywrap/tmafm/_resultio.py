"""Result <-> .npz, in the layout the executable writes for ``&output format = 'npy'``.

Members: tau, vt, vtdot (<f8, n), contact (|i1, n), a, adot (<f8, n x N, Fortran order),
switches (<f8), counters (<i8, 5: steps, contact_steps, rejected_steps, rhs_evaluations,
phase_switches), resolved (0-d |S: the resolved namelist text), version (0-d |S: 'tmafm X.Y.Z');
and for a scene given in &physical, its SI series (<f8, n each: tmafm.SERIES_UNITS).
"""

from __future__ import annotations

import io
import re
from pathlib import Path

import f90nml
import numpy as np

from ._namelist import _NOT_NUMBERS, shown
from .errors import InputError, InputFileError, InputTypeError

__all__ = ["save", "load", "MEMBERS"]

#: Every member of the file, in writing order.
MEMBERS = ("tau", "vt", "vtdot", "contact", "a", "adot", "switches", "counters", "resolved",
           "version")


def _version() -> str:
    from . import __version__
    return f"tmafm {__version__}"


def _real_member(member: str, value, fortran: bool = False) -> np.ndarray:
    """A float member of a Result as <f8; InputError for what is not real numbers (complex
    numbers, objects, strings: a cast would drop or garble them)."""
    try:
        array = np.asarray(value)
        if array.dtype.kind not in "biuf":
            raise TypeError(f"dtype {array.dtype.str}")
        return (np.asfortranarray if fortran else np.asarray)(array, dtype="<f8")
    except (TypeError, ValueError, OverflowError) as exc:
        raise InputError(f"Result.save: {member} must be real numbers: "
                         f"{shown(str(exc))[1:-1]}") from None


def _result_members(result) -> dict:
    """The members Result.save writes, from `result`; InputError for anything the layout of
    docs/output-format.md cannot hold as it is (no value is cast into another)."""
    from ._run import COUNTER_KEYS
    try:
        resolved_text = result.resolved_text
    except AttributeError:
        raise InputError("Result.save: this Result has no resolved input (build it with config=, "
                         "resolved= or resolved_text=): a saved result must be rerunnable") from None
    if not isinstance(resolved_text, str):
        raise InputTypeError(f"Result.save: the resolved input must be text, not "
                             f"{type(resolved_text).__name__}")
    try:
        resolved = resolved_text.encode("utf-8", "surrogateescape")
    except UnicodeEncodeError as exc:
        raise InputError(f"Result.save: the resolved input is not UTF-8 text: {exc.reason} at "
                         f"character {exc.start}") from None
    members = {name: _real_member(name, getattr(result, name, None))
               for name in ("tau", "vt", "vtdot", "switches")}
    for name in ("a", "adot"):
        members[name] = _real_member(name, getattr(result, name, None), fortran=True)
    contact = _real_member("contact", getattr(result, "contact", None))
    if not np.all((contact == 0) | (contact == 1)):
        raise InputError("Result.save: contact holds values other than 0 and 1")
    members["contact"] = contact.astype("|i1")
    counters = getattr(result, "counters", None)
    if not isinstance(counters, dict):
        raise InputTypeError(f"Result.save: counters must be a dict, not {type(counters).__name__}")
    values = [counters.get(k, 0) for k in COUNTER_KEYS]
    if any(isinstance(v, _NOT_NUMBERS) or not isinstance(v, (int, np.integer))
           or not 0 <= v < 2**63 for v in values):
        raise InputError(f"Result.save: counters must be integers from 0 to 2**63 - 1, got "
                         f"{shown(dict(zip(COUNTER_KEYS, values)))}")
    members["counters"] = np.array([int(v) for v in values], dtype="<i8")
    members["resolved"] = np.array(resolved, dtype="S")
    members["version"] = np.array(_version().encode("ascii"), dtype="S")
    physical = getattr(result, "physical", None)
    if physical is not None:
        from ._run import SERIES_UNITS
        if not isinstance(physical, dict) or set(physical) != set(SERIES_UNITS):
            raise InputError(f"Result.save: physical must be None or a dict of the SI series "
                             f"{', '.join(SERIES_UNITS)}")
        members.update({name: _real_member(name, physical[name]) for name in SERIES_UNITS})
    return members


def save(result, path) -> Path:
    """Write `result` to `path` (.npz), atomically: a temporary file, then a rename.  The members
    are checked first as load checks them, so a file is written only if load reads it back; a
    Result that load would refuse is an InputError and nothing is written."""
    from ._run import _atomic_write
    members = _result_members(result)
    _verify("Result.save", members)
    size = sum(members[m].nbytes for m in members)
    if size > _MAX_BYTES:
        raise InputError(f"Result.save: the members hold {size} bytes, more than a tmafm .npz "
                         f"({_MAX_BYTES})")
    buffer = io.BytesIO()
    np.savez(buffer, **members)
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
        from ._run import SERIES_UNITS
        series = [m for m in SERIES_UNITS if m in data.files]
        if series and len(series) != len(SERIES_UNITS):
            raise InputError(f"{name}: holds some SI series but not all ({', '.join(series)})")
        try:
            return {m: data[m] for m in (*MEMBERS, *series)}
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
    from ._run import SERIES_UNITS
    for member in SERIES_UNITS:
        if member not in members:
            continue
        value = members[member]
        if value.dtype.kind != "f" or value.dtype.itemsize != 8 or value.shape != (n,):
            raise InputError(f"{name}: member {member} has dtype {value.dtype.str} and shape "
                             f"{value.shape}, not f8 ({n},)")
        if not np.all(np.isfinite(value)):
            raise InputError(f"{name}: member {member} holds non-finite values")


def _text(member: str, value) -> str:
    """A text member; bytes that are not UTF-8 (a Latin-1 file name) stay surrogate escapes, as
    in Config.text, and the core judges them."""
    return value.item().decode("ascii" if member == "version" else "utf-8", "surrogateescape")


#: "! chosen n_modes = K" in a resolved input with &model n_modes = 0 (tmafm_namelist): the N
#: the search chose, recorded where the core writes the resolved input.
_CHOSEN = re.compile(r"^[ \t]*![ \t]*chosen n_modes = ([0-9]+)", re.MULTILINE)


def _recorded_modes(name: str, text: str) -> tuple[int | None, str | None]:
    """(the N an automatic-N resolved input records as chosen, the override text that fixes it:
    &model n_modes = N and the &initial lists cut to N), or (None, None) for a fixed N.
    InputError when the text asks for an automatic N and records none, or when an initial value
    past N is not zero.  f90nml reads the keys: nothing runs."""
    from ._namelist import to_text
    try:
        groups = f90nml.reads(text)
        model, initial = groups.get("model", {}), groups.get("initial", {})
        n_modes = model.get("n_modes")
    except Exception as exc:  # f90nml raises many kinds on text it cannot read
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise InputError(f"{name}: the resolved input is not a valid tmafm input: "
                         f"{shown(first)[1:-1]}") from None
    chosen = _CHOSEN.findall(text)
    if isinstance(n_modes, bool) or n_modes != 0:
        if chosen:
            raise InputError(f"{name}: the resolved input records a chosen N but gives "
                             f"&model n_modes = {shown(n_modes)}, not 0")
        return None, None
    if len(chosen) != 1:
        raise InputError(f"{name}: the resolved input asks for an automatic N (n_modes = 0) and "
                         f"records {'no' if not chosen else 'more than one'} chosen N ('! chosen "
                         f"n_modes = K', as tmafm writes it)")
    n = int(chosen[0])
    override = {"model": {"n_modes": n}}
    for key in ("a0", "adot0"):
        if key not in initial:
            continue
        values = initial[key] if isinstance(initial[key], list) else [initial[key]]
        if any(not isinstance(v, (int, float)) for v in values) or any(values[n:]):
            raise InputError(f"{name}: the resolved input records the chosen N = {n} but &initial "
                             f"{key} = {shown(values)} has a nonzero value past mode {n}")
        override.setdefault("initial", {})[key] = (list(values[:n]) + [0.0] * n)[:n]
    return n, to_text(override, f"{name} (chosen N)")


def _verify(name: str, members: dict):
    """The checks of a result's members, for load and for save alike: the layout
    (docs/output-format.md), the version, and the resolved input read by the core, which must
    give the arrays' N and sample count.  An automatic N is read as the one the input records
    (``! chosen n_modes = K``): nothing runs.  Returns (the Config, the resolved text)."""
    from ._run import MAX_INPUT_BYTES, _config_from_resolved_text
    _check(name, members)
    if members["resolved"].nbytes > MAX_INPUT_BYTES:
        raise InputError(f"{name}: the resolved input holds {members['resolved'].nbytes} bytes, "
                         f"more than a tmafm input ({MAX_INPUT_BYTES})")
    resolved = _text("resolved", members["resolved"])
    if "\0" in resolved:
        raise InputError(f"{name}: the resolved input holds a NUL byte")
    version = _text("version", members["version"])
    if not version.startswith("tmafm "):
        raise InputError(f"{name}: member version is {shown(version)}, not 'tmafm <version>'")
    n, n_modes = members["a"].shape
    chosen, override = _recorded_modes(name, resolved)
    if chosen is not None and chosen != n_modes:
        raise InputError(f"{name}: the resolved input records the chosen N = {chosen}, but the "
                         f"arrays hold N = {n_modes}")
    try:
        config = _config_from_resolved_text(resolved, f"{name} (resolved)", override)
    except InputError as exc:
        raise InputError(f"{name}: the resolved input is not a valid tmafm input: {exc}") from None
    if (config.n_modes, config.n_samples) != (n_modes, n):
        raise InputError(f"{name}: the resolved input gives {config.n_samples} samples of "
                         f"N = {config.n_modes} modes, but the arrays hold {n} of N = {n_modes}")
    from ._run import SERIES_UNITS
    if all(m in members for m in SERIES_UNITS) and config.derived is None:
        raise InputError(f"{name}: holds SI series but the resolved input is given in &scene")
    return config, resolved


def load(path):
    """Read a Result from a .npz written by Result.save or by the executable.

    The file is checked against the layout of docs/output-format.md (members, dtypes, shapes,
    finite values, contact flags of 0 and 1) and its resolved input is read by the core, which
    must give the archive's N and sample count: anything else is an InputError.  Nothing runs:
    an automatic N is the one the resolved input records as chosen.  The Result has the
    resolved input as saved and its Config (``config``), as a fresh one has.
    """
    from ._run import COUNTER_KEYS, Result
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
    config, resolved = _verify(name, members)
    counters = dict(zip(COUNTER_KEYS, map(int, members["counters"])))
    real = lambda m: members[m].astype(np.float64)  # noqa: E731 (native byte order)
    from ._run import SERIES_UNITS
    physical = ({m: real(m) for m in SERIES_UNITS} if all(m in members for m in SERIES_UNITS)
                else None)
    return Result(physical=physical, tau=real("tau"), vt=real("vt"), vtdot=real("vtdot"),
                  contact=members["contact"].astype(np.int8),
                  a=np.asfortranarray(members["a"], dtype=np.float64),
                  adot=np.asfortranarray(members["adot"], dtype=np.float64), counters=counters,
                  switches=real("switches"), config=config, resolved_text=resolved)

"""Sweep files: the &sweep group read by tmafm's strict reader and checked
(read_sweep_file), and the sweep it describes run (run_sweep_file, docs/sweeps.md)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .._namelist import shown
from .._run import Config, _read_text
from ..errors import InputError, InputFileError, raise_for
from .basin import basin
from .bifurcation import bifurcation
from .curves import approach, frequency_sweep
from .grid import sweep
from .points import OBSERVE_KEYWORDS, _check_points, _input_name


_FILE_KEYS = {"kind": str, "base": str, "key": str, "start": float, "stop": float, "count": int,
              "values": list, "key2": str, "start2": float, "stop2": float, "count2": int,
              "curve_key": str, "curve_values": list, "reverse": bool, "max_periods": int,
              "p_max": int, "steady_tol": float, "steady_repeats": int, "harmonics": int,
              "stop_at_steady": bool, "periods_kept": int, "tol": float,
              "jump_threshold": float, "workers": int, "output": str, "method": str,
              "rtol": float, "atol": float, "observables": list, "known_attractors": bool,
              "coarse": int}
_KINDS = ("grid", "approach", "frequency", "bifurcation", "basin")


#: Keys whose list entries are numbers, and those whose entries are strings.
_NUMBER_LISTS, _STRING_LISTS = ("values", "curve_values"), ("observables",)
#: Value kinds of the strict reader (tmafm_nml_syntax value_*).
_INTEGER, _REAL, _LOGICAL, _STRING, _WORD = 1, 2, 3, 4, 5


def _syntax_codes(data: bytes, label: str) -> list[int]:
    """The codes of tmafm's strict reader (tmafm_nml_syntax) for the text of a file: the only
    call into the core of the sweeps' file reader."""
    from .._fortran import api
    codes = np.zeros(8 * len(data) + 1024, dtype=np.int32)
    length, ierr, errmsg = api.namelist_syntax(data, label.encode("utf-8", "backslashreplace"), codes)
    raise_for(ierr, errmsg)
    if length < 0:
        raise InputError(f"{label}: the file is too complex to read")
    return codes[:length].tolist()


def _records(codes: list[int]):
    """Each record of the reader's codes: [ordinal, group, entry, key, kind, repeat, text]
    (fields of bytes ended by -1, records ended by another negative code)."""
    record: list = []
    field: list = []
    for code in codes:
        if code >= 0:
            field.append(code)
            continue
        if code == -1:
            record.append(bytes(field).decode("utf-8", "surrogateescape"))
            field = []
            continue
        yield record
        record = []


def _parsed_value(kind: int, text: str, where: str, key: str):
    """The Python value of one value the reader found; InputError for an unquoted string and
    anything else that is no number, logical or quoted string."""
    if kind == _INTEGER:
        return int(text)
    if kind == _REAL:
        return float(text.replace("d", "e").replace("D", "E"))
    if kind == _LOGICAL:
        return text.lstrip(".")[:1].lower() == "t"
    if kind == _STRING:
        return text
    if kind == _WORD:
        raise InputError(f"{where} = {text}: a string must be quoted: write {key} = '{text}'")
    raise InputError(f"{where} = {shown(text)}: not a number, a logical or a quoted string")


def _sweep_groups(path: Path) -> dict:
    """{group: {key: [values]}} of a sweep file, parsed by tmafm's strict reader (the one the
    executable uses): text outside a group, an empty value, an indexed key, an unquoted
    string, a NUL byte, a key or a group given twice are errors, never skipped or merged."""
    label = shown(str(path))[1:-1]
    groups: dict = {}
    seen_groups: dict = {}
    entries: dict = {}
    for ordinal, group, entry, key, kind, repeat, text in _records(
            _syntax_codes(_read_text(path), label)):
        if seen_groups.setdefault(group, ordinal) != ordinal:
            raise InputError(f"{label}: &{group} appears twice: give one &{group} group")
        where = f"{label}: &{group} {key}"
        if entries.setdefault((group, key), entry) != entry:
            raise InputError(f"{where}: the key is given twice")
        value = _parsed_value(int(kind), text, where, key)
        groups.setdefault(group, {}).setdefault(key, []).extend([value] * int(repeat))
    return groups


def _packaged_sweep(path: Path) -> Path:
    """The packaged sweep file of a missing path named "sweeps/<stem>[.nml]" (tmafm.inputs);
    InputFileError otherwise."""
    from .. import inputs
    if path.suffix in ("", ".nml") and len(path.parts) == 2 and path.parts[0] == inputs.SWEEPS:
        try:
            return inputs.path("/".join(path.parts))
        except InputFileError:
            pass
    raise InputFileError(f"sweep file '{path}' not found, and no packaged sweep file has that "
                         f"name ({', '.join(inputs.sweep_names())})")


def read_sweep_file(path) -> dict:
    """The &sweep group of a sweep file, checked: a dict of its keys (docs/sweeps.md)."""
    path = _input_name(path, "sweep file")
    try:
        is_file = path.is_file()
    except (OSError, ValueError):  # a name too long, a NUL byte
        is_file = False
    if not is_file:
        path = _packaged_sweep(path)
    groups = _sweep_groups(path)
    if "sweep" not in groups:
        raise InputError(f"{path}: no &sweep group")
    extra = [g for g in groups if g != "sweep"]
    if extra:
        raise InputError(f"{path}: unknown group(s) &{', &'.join(extra)} (a sweep file has &sweep)")
    spec = {}
    for key, values in groups["sweep"].items():
        if key not in _FILE_KEYS:
            raise InputError(f"{path}: &sweep {key}: unknown key (known: {', '.join(_FILE_KEYS)})")
        kind = _FILE_KEYS[key]
        if kind is list:
            item = str if key in _STRING_LISTS else (int, float)
            if any(isinstance(v, bool) or not isinstance(v, item) for v in values):
                raise InputError(f"{path}: &sweep {key} = {shown(values)}: every entry must be a "
                                 f"{'quoted string' if item is str else 'number'}")
            spec[key] = list(values)
            continue
        if len(values) != 1:
            raise InputError(f"{path}: &sweep {key} = {shown(values)}: give one value")
        value = values[0]
        if kind is float and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        if not isinstance(value, kind) or (kind is int and isinstance(value, bool)) or (
                kind is float and isinstance(value, bool)):
            raise InputError(f"{path}: &sweep {key} = {value!r}: must be a {kind.__name__}")
        spec[key] = value
    for key in ("kind", "base"):
        if key not in spec:
            raise InputError(f"{path}: &sweep {key}: missing (required)")
    if spec["kind"] not in _KINDS:
        raise InputError(f"{path}: &sweep kind = '{spec['kind']}': must be one of "
                         f"{', '.join(_KINDS)}")
    base = Path(spec["base"])
    if not base.is_absolute() and (path.parent / base).is_file():
        spec["base"] = str(path.parent / base)
    spec["_file"] = str(path)
    return spec


def _axis_size(spec: dict, suffix: str = "") -> tuple[int, str]:
    """(number of values, 'key = value' as the file gives them) of one axis of a sweep file."""
    where = spec["_file"]
    if suffix == "" and "values" in spec:
        return len(spec["values"]), f"values ({len(spec['values'])} entries)"
    missing = [k + suffix for k in ("start", "stop", "count") if k + suffix not in spec]
    if missing:
        raise InputError(f"{where}: &sweep {', '.join(missing)}: missing (give start{suffix}, "
                         f"stop{suffix}, count{suffix}" + (" or values)" if not suffix else ")"))
    count = spec["count" + suffix]
    if count < 1:
        raise InputError(f"{where}: &sweep count{suffix} = {count}: must be at least 1")
    for key in ("start" + suffix, "stop" + suffix):
        if not math.isfinite(spec[key]):
            raise InputError(f"{where}: &sweep {key} = {spec[key]}: must be finite")
    return count, f"count{suffix} = {count}"


def _axis_of(spec: dict, suffix: str = "") -> np.ndarray:
    _axis_size(spec, suffix)
    if suffix == "" and "values" in spec:
        return np.asarray(spec["values"], dtype=float)
    return np.linspace(spec["start" + suffix], spec["stop" + suffix], spec["count" + suffix])


def _check_file_size(spec: dict) -> None:
    """Before any array is built: the sweep's points fit in the memory available
    (_check_points), the message naming the file's keys and values."""
    kind = spec["kind"]
    axes = [_axis_size(spec)]
    if kind == "basin" or (kind == "grid" and "key2" in spec):
        axes.append(_axis_size(spec, "2"))
    points = math.prod(count for count, _ in axes)
    floats = 0
    if kind in ("approach", "frequency"):
        points *= max(1, len(spec.get("curve_values", []))) * (2 if spec.get("reverse", True)
                                                               else 1)
    elif kind == "bifurcation":
        floats = 8 * spec.get("periods_kept", 32)
    elif kind == "basin":
        floats = 2 * (2 * spec.get("p_max", 8) + 2)
    _check_points(points, f"{spec['_file']}: &sweep {', '.join(text for _, text in axes)}",
                  floats)


def run_sweep_file(path, *, workers=None, client=None, progress=False):
    """Run the sweep a file describes; return its Dataset."""
    spec = read_sweep_file(path)
    _check_file_size(spec)
    kind, base = spec["kind"], spec["base"]
    solver = {k: spec[k] for k in ("method", "rtol", "atol") if k in spec}
    if solver:
        base = Config(base, solver=solver)
    keywords = {k: spec[k] for k in OBSERVE_KEYWORDS if k in spec}
    workers = workers if workers is not None else spec.get("workers")
    common = dict(workers=workers, client=client, progress=progress)
    curves = ({spec["curve_key"]: spec["curve_values"]} if "curve_key" in spec else None)
    if kind == "grid":
        axes = {spec.get("key", "scene.delta_hat"): _axis_of(spec)}
        if "key2" in spec:
            axes[spec["key2"]] = _axis_of(spec, "2")
        return sweep(base, axes, **common, **keywords)
    if kind in ("approach", "frequency"):
        # A base in SI units (&physical) sweeps Z (m) or the drive frequency (Hz).
        physical = "physical" in (base if isinstance(base, Config) else Config(base)).to_dict()
        name = {("approach", False): "delta_hat", ("approach", True): "z",
                ("frequency", False): "omega", ("frequency", True): "frequency"}[kind, physical]
        run = approach if kind == "approach" else frequency_sweep
        back = {"retract" if kind == "approach" else "reverse": spec.get("reverse", True)}
        return run(base, **{name: _axis_of(spec)}, **back, curves=curves,
                   jump_threshold=spec.get("jump_threshold", 0.2), **common, **keywords)
    if kind == "bifurcation":
        if "key" not in spec:
            raise InputError(f"{spec['_file']}: &sweep key: missing (required for bifurcation)")
        extra = {k: spec[k] for k in ("periods_kept",) if k in spec}
        return bifurcation(base, spec["key"], _axis_of(spec), **extra, **common, **keywords)
    extra = {k: spec[k] for k in ("known_attractors", "coarse") if k in spec}
    return basin(base, _axis_of(spec), _axis_of(spec, "2"), tol=spec.get("tol", 1e-3), **extra,
                 **common, **keywords)

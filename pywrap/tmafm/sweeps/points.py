"""The points of a sweep: the swept keys and values checked, each point's input built and
validated (a tmafm.Config), the keywords passed on to the core's observers, and the memory a
grid would hold, all checked before anything runs."""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .._namelist import _NOT_NUMBERS, GROUPS, KEY_TYPES, shown
from .._run import Config
from ..errors import InputError, InputTypeError
from ..observe import _options, observable_groups, observed_config


#: The keywords of tmafm.observe that a sweep passes on.
OBSERVE_KEYWORDS = ("max_periods", "p_max", "steady_tol", "steady_repeats", "harmonics",
                    "stop_at_steady", "observables")


def _split_key(key) -> tuple[str, str]:
    """('scene', 'delta_hat') of 'scene.delta_hat'; InputError for a key the core does not know."""
    if not isinstance(key, str) or key.count(".") != 1:
        raise InputError(f"sweep key {shown(key)}: must be 'group.key', e.g. 'scene.delta_hat'")
    group, name = key.split(".")
    if group not in GROUPS:
        raise InputError(f"sweep key {shown(key)}: unknown group '{group}' (known: {', '.join(GROUPS)})")
    if name not in KEY_TYPES[group]:
        raise InputError(f"sweep key {shown(key)}: &{group} {name}: unknown key (known: "
                         f"{', '.join(KEY_TYPES[group])})")
    if group == "output":
        raise InputError(f"sweep key {shown(key)}: the &output group cannot be swept (a sweep writes "
                         f"no run output)")
    return group, name


#: The most modes the core takes (fortran/src/physics/tmafm_modes.f90 max_modes).
MAX_MODES = 30


class _Axis(np.ndarray):
    """The values of one axis: a 1-D array (the coordinate) that remembers the values as given
    (``raw``), so an integer key gets integers and a bad value is named as the user wrote it."""

    raw: list


def _axis_values(key: str, values, real: bool = False) -> np.ndarray:
    """The values of one axis as a 1-D array; InputError when empty or not 1-D (``real``: not
    finite real numbers either, for axes that are not input keys, e.g. a basin's a1)."""
    try:
        if isinstance(values, (str, bytes, Mapping)) or not hasattr(values, "__iter__"):
            raise TypeError
        size = len(values)
    except TypeError:  # a number, a 0-d array, a generator
        raise InputTypeError(f"sweep axis {shown(key)}: values must be a 1-D sequence, not "
                             f"{shown(values)}") from None
    _check_points(size, f"sweep axis {shown(key)} ({size} values)")
    raw = [_value(v) for v in values]
    try:
        array = np.asarray(raw)
    except Exception as exc:  # ragged lists and the like
        raise InputError(f"sweep axis {shown(key)}: values must be a 1-D sequence "
                         f"({shown(str(exc))[1:-1]})") from None
    if array.ndim != 1:
        raise InputError(f"sweep axis {shown(key)}: values must be a 1-D sequence, got shape "
                         f"{array.shape}")
    if array.size == 0:
        raise InputError(f"sweep axis {shown(key)}: no values (an empty axis)")
    if real:
        for value in raw:
            if not _is_real(value):
                raise InputError(f"sweep axis {shown(key)}: values must be finite real numbers, got "
                                 f"{shown(value)}")
        array = np.asarray(raw, dtype=float)
    axis = array.view(_Axis)
    axis.raw = raw
    return axis


def _is_real(value) -> bool:
    """Whether `value` is a finite real number (a bool is not; an int too large for a float is
    not)."""
    if isinstance(value, _NOT_NUMBERS) or not isinstance(value, (int, float, np.integer,
                                                                     np.floating)):
        return False
    try:
        return math.isfinite(float(value))
    except OverflowError:
        return False


def _raw(axis) -> list:
    return getattr(axis, "raw", None) or list(axis)


def _check_axes(axes) -> dict:
    """{key: 1-D values} of a Mapping of axes, keys checked; InputError otherwise."""
    if not isinstance(axes, Mapping):
        raise InputTypeError(f"axes must be a dict 'group.key' -> values, not "
                             f"{type(axes).__name__}")
    if not axes:
        raise InputError("sweep: no axes given (give at least one 'group.key' -> values)")
    checked = {}
    for key, values in axes.items():
        _split_key(key)
        checked[key] = _axis_values(key, values)
    return checked


def _value(value):
    """A numpy scalar as a Python number (namelist text wants plain values)."""
    return value.item() if isinstance(value, np.generic) else value


def _overrides(point: Mapping) -> dict:
    """{group: {key: value}} of {'group.key': value}."""
    groups: dict = {}
    for key, value in point.items():
        group, name = _split_key(key)
        groups.setdefault(group, {})[name] = _value(value)
    return groups


def _base_dict(base) -> dict:
    """The resolved base input as a dict of groups (picklable, for other processes)."""
    config = base if isinstance(base, Config) else Config(base)
    groups = config.to_dict()
    groups.pop("output", None)
    return groups


#: The &physical keys each &physical key given instead replaces (the core refuses both): a
#: swept key takes the place of these in the base (docs/model.md, the physical routes).
REPLACES = {"tip_sample_distance": ("gap", "static_offset"),
            "gap": ("tip_sample_distance",), "static_offset": ("tip_sample_distance",),
            "drive_frequency": ("drive_angular_frequency",),
            "drive_angular_frequency": ("drive_frequency",),
            "free_amplitude": ("drive_amplitude",), "drive_amplitude": ("free_amplitude",)}


def _for_keys(base: dict, keys) -> dict:
    """The base's groups with the &physical keys that the swept ``keys`` replace taken out
    (sweeping physical.tip_sample_distance of a base given by gap and static_offset, say)."""
    physical = base.get("physical")
    drop = {old for key in keys if key.startswith("physical.")
            for old in REPLACES.get(key.split(".", 1)[1], ())}
    if not physical or not drop & set(physical):
        return base
    return dict(base, physical={k: v for k, v in physical.items() if k not in drop})


def _merged(base: dict, overrides: Mapping) -> dict:
    groups = {g: dict(v) for g, v in base.items()}
    for group, values in overrides.items():
        groups.setdefault(group, {}).update(values)
    return groups


def _resized_initial(groups: dict, point: Mapping) -> dict:
    """When n_modes is swept, the base's &initial vectors cut or padded with zeros to N."""
    n = point.get("model.n_modes")
    initial = groups.get("initial")
    if not isinstance(n, (int, np.integer)) or isinstance(n, _NOT_NUMBERS) or not initial \
            or not 0 <= n <= MAX_MODES:
        return groups  # the core refuses an N out of range, by name
    for name in ("a0", "adot0"):
        if name in initial and f"initial.{name}" not in point:
            values = np.atleast_1d(np.asarray(initial[name], dtype=float))
            if n > 0:
                initial[name] = np.concatenate([values, np.zeros(n)])[:n].tolist()
            elif not values.any():
                del initial[name]  # automatic N: zero initial values need no length
    return groups


def _config(base: dict, point: Mapping) -> Config:
    """The Config of one point; InputError naming the point when the core refuses it."""
    try:
        return Config(_resized_initial(_merged(base, _overrides(point)), point))
    except InputError as exc:
        where = ", ".join(f"{k} = {_short(v)}" for k, v in point.items())
        raise type(exc)(f"sweep point {where}: {exc}") from None


def _short(value) -> str:
    value = _value(value)
    try:
        if isinstance(value, (list, tuple, np.ndarray)) and len(value) <= 30:
            return "[" + ", ".join(f"{float(v):.6g}" for v in value) + "]"
        return f"{value:.6g}" if isinstance(value, float) else shown(value)
    except (TypeError, ValueError, OverflowError):  # not numbers: as messages show any value
        return shown(value)


def _observe_keywords(keywords: Mapping) -> dict:
    """The keywords passed on to tmafm.observe, every value checked now (before any run)."""
    unknown = set(keywords) - set(OBSERVE_KEYWORDS)
    if unknown:
        raise InputTypeError(f"unknown keyword(s) {', '.join(sorted(map(str, unknown)))} (a "
                             f"sweep passes on: {', '.join(OBSERVE_KEYWORDS)})")
    out = dict(keywords)
    defaults = dict(max_periods=100, p_max=8, steady_tol=1e-6, steady_repeats=3, harmonics=3,
                    stop_at_steady=True)
    _options(**{k: out.get(k, v) for k, v in defaults.items()})
    if out.get("observables") is not None:
        # Kept as the tuple of groups it selects.
        out["observables"] = observable_groups(out["observables"])
    return out


#: Bytes a sweep holds per grid point while it runs, at most: the point, its validated Config,
#: its summary and its share of the Dataset.  Measured: 8.3 kB per point (the peak resident
#: memory of a 1500-point grid of fig2_n4, N = 4: ``pytest -s tests/test_sweep_limits.py -k
#: memory`` prints it and checks it is below this); this is about twice that, for a margin.
BYTES_PER_POINT = 16384


def _available_memory() -> int:
    """Bytes of memory available now: MemAvailable of /proc/meminfo, else the physical memory."""
    try:
        with open("/proc/meminfo", encoding="ascii") as handle:
            for line in handle:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return 2**62


def _bytes(count: int) -> str:
    for unit, size in (("PB", 1e15), ("TB", 1e12), ("GB", 1e9), ("MB", 1e6)):
        if count >= size:
            return f"{count / size:.3g} {unit}"
    return f"{count / 1e3:.3g} kB"


def _check_points(points: int, what: str, floats_per_point: int = 0) -> None:
    """InputError naming `what` (the axes and their sizes, as given) when a sweep of `points`
    points would hold more memory than is available (BYTES_PER_POINT each, plus
    `floats_per_point` kept values of 8 bytes)."""
    need = points * (BYTES_PER_POINT + 8 * floats_per_point)
    available = _available_memory()
    if need > available:
        raise InputError(f"{what}: {points} points would hold about {_bytes(need)} in memory, "
                         f"more than the {_bytes(available)} available")


def _sizes(axes: Mapping) -> str:
    return " x ".join(f"{key} ({len(values)} values)" for key, values in axes.items())


def _check_flag(name: str, value) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise InputTypeError(f"{name} = {shown(value)}: must be True or False")
    return bool(value)


def _check_positive(name: str, value, upper: float = math.inf) -> float:
    """A finite real number > 0 (and < upper); InputError otherwise."""
    if not _is_real(value) or not 0 < float(value) < upper:
        bound = "" if upper == math.inf else f" and < {upper:g}"
        raise InputError(f"{name} = {shown(value)}: must be a finite number > 0{bound}")
    return float(value)


def _base_config(base) -> Config:
    # An input that names no &solver method runs the observed runs' default (flight_exact).
    return base if isinstance(base, Config) else observed_config(base)


def _noiseless(config: Config, what: str) -> None:
    """InputError when the input asks for thermal noise (&solver thermal_noise = 1): periodic
    orbits and their continuation are those of the noiseless model (docs/model.md section 21)."""
    if int(config.to_dict().get("solver", {}).get("thermal_noise", 0)) == 1:
        raise InputError(f"{what}: &solver thermal_noise = 1: periodic orbits are the noiseless "
                         f"model's; remove thermal_noise (and noise_seed, noise_step, thermal_energy)")


#: The swept key of a physical base that stands for each &scene key a dimensionless base sweeps.
_PHYSICAL_FOR = {"delta_hat": "physical.tip_sample_distance (tmafm.approach(base, z=...))",
                 "omega": "physical.drive_frequency (tmafm.frequency_sweep(base, frequency=...))",
                 "alpha2": "physical.free_amplitude or physical.drive_amplitude"}


def _check_groups(base: dict, points: list[dict]) -> None:
    """InputError naming the key when a point sets a &scene key on a &physical base (or a
    &physical key on a dimensionless one): the core takes one of the two groups, and the sweep
    must not add the other."""
    keys = dict.fromkeys(k for point in points[:1] for k in point)
    for key in keys:
        group, name = _split_key(key)
        if group == "scene" and "physical" in base:
            instead = _PHYSICAL_FOR.get(name, "the &physical key it derives from")
            raise InputError(f"sweep key {shown(key)}: the base is given in &physical (SI "
                             f"units), so &scene cannot be set; sweep {instead}")
        if group == "physical" and "physical" not in base:
            raise InputError(f"sweep key {shown(key)}: the base is dimensionless (&scene), so "
                             f"&physical cannot be set; sweep its &scene key instead")


def _validate(base: dict, points: list[dict]) -> list[Config]:
    """Every point's Config, built up front: the first bad one raises, before any run."""
    _check_groups(base, points)
    return [_config(base, point) for point in points]


def _input_name(path, what: str) -> Path:
    """A file name (str or os.PathLike) as a Path; InputTypeError for anything else."""
    try:
        name = os.fspath(path)
        if not isinstance(name, str):
            raise TypeError
    except TypeError:
        raise InputTypeError(f"{what} name must be a str or an os.PathLike, not "
                             f"{type(path).__name__}") from None
    return Path(name)

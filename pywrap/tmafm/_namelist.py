"""Python input -> namelist text, with every value's type checked before the core sees it.

The core's strict parser is the second line of defence; this one gives Python users an
InputError that names the group and key for what Python can tell on its own: None, bools
where a number is expected, nested lists, strings where numbers are expected, non-finite
numbers, unknown groups, non-dict groups, non-string keys.  Keys the core knows are typed by
KEY_TYPES; any other key is passed on (as a number, string or list) and the core refuses it.
"""

from __future__ import annotations

import math
import numbers
import re
import reprlib
from collections.abc import Mapping

import numpy as np

from .errors import InputError

__all__ = ["GROUPS", "KEY_TYPES", "check_groups", "merge", "shown", "to_text"]

#: The namelist groups, in the order the text is written.
GROUPS = ("model", "scene", "physical", "initial", "solver", "output")

_REAL, _INT, _STR, _LIST = "real", "integer", "string", "list of reals"
_PHYSICAL = ("length", "width", "thickness", "density", "youngs_modulus_tip", "poisson_ratio_tip",
             "youngs_modulus_sample", "poisson_ratio_sample", "tip_radius", "adhesion_energy",
             "tilt", "gap", "tip_length", "static_offset", "tip_position", "tip_mass",
             "beam_damping", "contact_damping", "drive_amplitude", "drive_angular_frequency")
_SCENE = ("alpha1", "alpha2", "alpha3", "alpha4", "alpha5", "alpha6", "beta", "omega", "theta",
          "l_over_d", "g0_over_d", "delta_hat", "xi0")

#: The type of every key the core knows: group -> key -> 'real' | 'integer' | 'string' | list.
KEY_TYPES = {
    "model": {"n_modes": _INT, "mode_tol": _REAL, "mode_horizon": _REAL, "contact_law": _STR,
              "convention": _STR, "errata": _STR},
    "scene": {key: _REAL for key in _SCENE},
    "physical": {key: _REAL for key in _PHYSICAL},
    "initial": {"a0": _LIST, "adot0": _LIST},
    "solver": {"method": _STR, "dtau": _REAL, "contact_refine": _INT, "rtol": _REAL,
               "atol": _REAL, "tau_end": _REAL, "blowup_limit": _REAL, "max_steps": _INT},
    "output": {"file": _STR, "sample_dtau": _REAL, "format": _STR},
}

_KEY = re.compile(r"[a-z][a-z0-9_]*\Z")

_SHORT = reprlib.Repr()
_SHORT.maxlevel, _SHORT.maxstring, _SHORT.maxother = 3, 80, 80
_SHORT.maxlist = _SHORT.maxtuple = _SHORT.maxdict = _SHORT.maxset = 8


def shown(value) -> str:
    """A value as an error message shows it: a repr cut to about 80 characters, nested at most
    3 deep, with control and non-ASCII characters as escapes, so the message stays one short
    line whatever the value (a 2-D array's repr spans lines, a 10**6-entry list is megabytes,
    a list nested 10**5 deep exceeds the recursion limit, an object's __repr__ may raise)."""
    try:
        text = _SHORT.repr(value)
    except Exception:  # a broken __repr__ inside a container
        text = f"<{type(value).__name__} object>"
    return text.encode("ascii", "backslashreplace").decode("ascii").replace("\n", "\\n").replace(
        "\r", "\\r").translate({c: f"\\x{c:02x}" for c in [*range(32), 127]})


#: Types that pass for numbers but are not: np.timedelta64 is a subclass of np.signedinteger.
_NOT_NUMBERS = (bool, np.bool_, np.timedelta64, np.datetime64)


def _is_real(value) -> bool:
    return isinstance(value, (numbers.Real, np.floating, np.integer)) and not isinstance(
        value, _NOT_NUMBERS)


def _is_int(value) -> bool:
    return isinstance(value, (numbers.Integral, np.integer)) and not isinstance(
        value, _NOT_NUMBERS)


def _real_text(where: str, value) -> str:
    try:
        number = float(value)
    except (OverflowError, ValueError, TypeError) as exc:
        raise InputError(f"{where} = {shown(value)}: not a finite double ({exc})") from None
    if not math.isfinite(number):
        raise InputError(f"{where} = {shown(value)}: must be a finite number")
    return repr(number)


def _value_text(group: str, key: str, value, what: str) -> str:
    """The namelist text of one value, after the type checks."""
    where = f"{what}: &{group} {key}"
    kind = KEY_TYPES.get(group, {}).get(key)
    if value is None:
        raise InputError(f"{where} = None: give a value (or leave the key out for its default)")
    if isinstance(value, (bool, np.bool_)):
        raise InputError(f"{where} = {shown(value)}: a bool is not a {kind or 'value'} here")
    if isinstance(value, (np.timedelta64, np.datetime64)):
        raise InputError(f"{where} = {shown(value)}: a {type(value).__name__} is not a "
                         f"{kind or 'value'}")
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, (list, tuple)):
        if kind not in (_LIST, None):
            raise InputError(f"{where} = {shown(value)}: must be one {kind}, not a list")
        if not value:
            raise InputError(f"{where} = []: give at least one value (or leave the key out)")
        for item in value:
            if isinstance(item, (list, tuple, np.ndarray, Mapping)):
                raise InputError(f"{where} = {shown(value)}: nested lists are not allowed")
            if not _is_real(item):
                raise InputError(f"{where} = {shown(value)}: every entry must be a number, "
                                 f"got {shown(item)}")
        return ", ".join(_real_text(where, item) for item in value)
    if isinstance(value, str):
        if kind in (_REAL, _INT, _LIST):
            article = "an" if kind == _INT else "a"
            raise InputError(f"{where} = {shown(value)}: must be {article} {kind}, not a string")
        if any(ch in value for ch in "\n\r\0"):
            raise InputError(f"{where} = {shown(value)}: a string must be one line")
        return "'" + value.replace("'", "''") + "'"
    if _is_int(value):
        if kind == _STR:
            raise InputError(f"{where} = {shown(value)}: must be a quoted string, not a number")
        return str(int(value))
    if _is_real(value):
        if kind == _STR:
            raise InputError(f"{where} = {shown(value)}: must be a quoted string, not a number")
        if kind == _INT:
            raise InputError(f"{where} = {shown(value)}: must be an integer")
        return _real_text(where, value)
    raise InputError(f"{where} = {shown(value)}: a {type(value).__name__} is not a namelist value")


def check_groups(groups, what: str = "input") -> dict:
    """Validate the shape of a dict of groups; return it with lower-case names (a new dict)."""
    if not isinstance(groups, Mapping):
        raise InputError(f"{what}: must be a dict of groups, not {type(groups).__name__}")
    checked: dict = {}
    for group, values in groups.items():
        if not isinstance(group, str):
            raise InputError(f"{what}: group names must be strings, got {shown(group)}")
        name = group.lower()
        if name not in GROUPS:
            raise InputError(f"{what}: unknown namelist group &{shown(group)[1:-1]} "
                             f"(known: {', '.join('&' + g for g in GROUPS)})")
        if not isinstance(values, Mapping):
            raise InputError(f"{what}: &{name} must be a dict of keys, not {shown(values)}")
        if name in checked:  # as the core refuses a group that appears twice in a file
            raise InputError(f"{what}: namelist group &{name} appears twice (names differ only "
                             f"in case)")
        target = checked[name] = {}
        for key, value in values.items():
            if not isinstance(key, str):
                raise InputError(f"{what}: &{name}: key names must be strings, got {shown(key)}")
            low = key.lower()
            if not _KEY.match(low):
                raise InputError(f"{what}: &{name} key {shown(key)} is not a namelist name")
            if low in target:
                raise InputError(f"{what}: &{name} {low}: the key is given twice (names differ "
                                 f"only in case)")
            target[low] = value
    return checked


def merge(base: Mapping, overrides: Mapping) -> dict:
    """Groups of `base` patched key by key with those of `overrides` (both already checked)."""
    merged = {group: dict(values) for group, values in base.items()}
    for group, values in overrides.items():
        merged.setdefault(group, {}).update(values)
    return merged


def to_text(groups: Mapping, what: str = "<dict input>") -> str:
    """Namelist text of checked groups; raises InputError naming the input (`what`), the group
    and the key of a bad value."""
    lines = []
    for group in GROUPS:
        if group not in groups:
            continue
        lines.append(f"&{group}")
        for key, value in groups[group].items():
            lines.append(f"    {key} = {_value_text(group, key, value, what)}")
        lines.append("/")
    return "\n".join(lines) + "\n"

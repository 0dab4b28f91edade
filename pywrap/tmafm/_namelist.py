"""Python input -> namelist text, with every value's type checked before the core sees it.

The core's strict parser is the second line of defence; this one gives Python users an
InputError that names the group and key for what Python can tell on its own: None, bools
where a number is expected, nested lists, strings where numbers are expected, non-finite
numbers, unknown groups, non-dict groups, non-string keys.  Keys the core knows are typed by
KEY_TYPES; any other key is passed on (as a number, string or list) and the core refuses it.

The groups, keys and types come from the core's key table (fortran/src/config/tmafm_keys.f90,
read through tmafm_api key_entry at import): ``KEYS`` holds every row, and README's input
table is written from it (docs/key_table.py; tests/test_tables.py checks both).
"""

from __future__ import annotations

import math
import numbers
import re
import reprlib
from collections.abc import Mapping
from typing import NamedTuple

import numpy as np

from ._fortran import api as _api
from ._fortran import text as _text
from .errors import InputError

__all__ = ["GROUPS", "KEYS", "KEY_TYPES", "Key", "check_groups", "merge", "shown", "to_text"]

_REAL, _INT, _STR, _LIST = "real", "integer", "string", "list of reals"

#: The widths of tmafm_api key_entry's texts: a text that fills its field may have been cut.
_WIDTHS = (16, 32, 16, 256, 256, 16, 256)


class Key(NamedTuple):
    """One row of the core's key table."""

    group: str
    name: str
    type: str
    range: str
    default: str
    unit: str
    meaning: str


def _core_keys() -> tuple[Key, ...]:
    rows = []
    for k in range(1, int(_api.key_count()) + 1):
        fields = [_text(f) for f in _api.key_entry(k)]
        if any(len(f) >= width for f, width in zip(fields, _WIDTHS, strict=True)):
            raise ImportError(f"tmafm: key {k} of the core's table has a text as long as its field in "
                              f"tmafm_api key_entry: widen the field ({fields[:2]})")
        key = Key(*fields)
        if key.type not in (_REAL, _INT, _STR, _LIST):
            raise ImportError(f"tmafm: key &{key.group} {key.name} has a type Python does not know: "
                              f"{key.type!r}")
        rows.append(key)
    return tuple(rows)


#: Every key of the core's table, group by group in the order of the resolved text.
KEYS = _core_keys()

#: The namelist groups, in the order the text is written.
GROUPS = tuple(dict.fromkeys(key.group for key in KEYS))

#: The type of every key the core knows: group -> key -> 'real' | 'integer' | 'string' |
#: 'list of reals'.
KEY_TYPES = {group: {key.name: key.type for key in KEYS if key.group == group} for group in GROUPS}

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

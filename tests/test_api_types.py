"""Every numpy scalar type (and a 0-d array of it) as a key's value: tmafm.Config either
reads the value exactly as Python's float()/int() gives it, or raises one of tmafm's typed
errors; never a raw exception.  np.timedelta64 is a subclass of np.signedinteger, so it was
taken for an integer and int() raised a raw TypeError."""

import math
import re

import numpy as np
import pytest

import tmafm

SCALARS = [np.int8(3), np.int16(3), np.int32(3), np.int64(3), np.uint8(3), np.uint64(3),
           np.float16(0.5), np.float32(0.5), np.float64(0.5), np.longdouble(0.5),
           np.complex64(1), np.complex128(1), np.bool_(True), np.str_("x"), np.bytes_(b"x"),
           np.datetime64("2020-01-01"), np.timedelta64(5, "s"), np.timedelta64(5), np.void(b"ab"),
           np.uint64(2**64 - 1), np.float32("nan"), np.longdouble("inf")]
SCALARS += [np.array(s) for s in SCALARS[:12]]
KEYS = [("solver", "tau_end", float), ("model", "n_modes", int), ("solver", "max_steps", int),
        ("scene", "theta", float)]


@pytest.mark.parametrize("group, key, kind", KEYS, ids=[k[1] for k in KEYS])
@pytest.mark.parametrize("value", SCALARS, ids=[f"{type(s).__name__}_{k}" for k, s in enumerate(SCALARS)])
def test_a_numpy_scalar_is_read_exactly_or_refused_with_a_typed_error(group, key, kind, value):
    try:
        config = tmafm.Config("fig2_n4", **{group: {key: value}})
    except tmafm.TmafmError as exc:
        message = str(exc)
        assert "\n" not in message, message
        # The key itself, or (a value in range that breaks a rule between keys, e.g. a small
        # max_steps for the fixed steps) the other key of the rule.
        assert f"&{group} {key}" in message or re.search(r"&[a-z]+ [a-z0-9_]+ = ", message), message
        return
    got = config.to_dict()[group][key]
    assert isinstance(got, kind)
    assert got == kind(value) and math.isfinite(got)
    assert not isinstance(value, (np.timedelta64, np.datetime64, np.bool_, np.complexfloating))


@pytest.mark.parametrize("value", [np.timedelta64(2, "s"), np.timedelta64(2)])
def test_a_timedelta_is_not_a_count(value):
    with pytest.raises(tmafm.InputError, match="max_switches"):
        tmafm.run("fig2_n4", max_switches=value, solver={"tau_end": 0.1})

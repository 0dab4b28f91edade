"""Fuzz of Python dict inputs: every call ends in a Result with finite arrays or in one of
tmafm's documented exceptions, never a raw ValueError/TypeError/AttributeError or a crash."""

import math

import numpy as np
import pytest

import tmafm
from tmafm._namelist import KEY_TYPES

hypothesis = pytest.importorskip("hypothesis")
st = hypothesis.strategies

#: Keys that set how long a run takes: fuzzed with wrong types, or values in a cheap range.
CHEAP = {
    ("solver", "tau_end"): st.floats(0.01, 0.3),
    ("solver", "dtau"): st.floats(1e-3, 5e-2),
    ("solver", "contact_refine"): st.integers(1, 8),
    ("solver", "rtol"): st.floats(1e-8, 1e-3),
    ("solver", "max_steps"): st.integers(1, 10**6),
    ("output", "sample_dtau"): st.floats(1e-3, 0.3),
    ("model", "n_modes"): st.integers(1, 6),
    ("model", "mode_horizon"): st.floats(0.1, 1.0),
}

scalars = st.one_of(
    st.none(), st.booleans(), st.integers(-10**20, 10**20),
    st.floats(allow_nan=True, allow_infinity=True), st.floats(-2, 2),
    st.text(max_size=12), st.sampled_from(["hertz", "dmt", "dmt_vdw", "paper", "consistent", "dopri5",
                                           "rk4_event", "flight_exact", "E1,E4", "all", "npy"]))
values = st.one_of(scalars, st.lists(scalars, max_size=5),
                   st.lists(st.lists(st.floats(-1, 1), max_size=2), max_size=2),
                   st.dictionaries(st.text(max_size=3), scalars, max_size=2))
bad_types = st.one_of(st.none(), st.booleans(), st.text(max_size=5),
                      st.lists(st.floats(0.01, 0.1), min_size=2, max_size=3))


@st.composite
def inputs(draw):
    groups = {"solver": {"tau_end": 0.1}}
    for group in draw(st.lists(st.sampled_from(list(KEY_TYPES) + ["bogus", "Solver"]), max_size=4)):
        if draw(st.integers(0, 20)) == 0:
            groups[group] = draw(values)  # a group that is not a dict
            continue
        target = groups.setdefault(group, {})
        if not isinstance(target, dict):
            continue
        known = list(KEY_TYPES.get(group.lower(), {}))
        for key in draw(st.lists(st.sampled_from(known + ["junk", "A0", 3]) if known
                                 else st.text(max_size=4), max_size=4)):
            cheap = CHEAP.get((group.lower(), str(key).lower()))
            if cheap is not None:
                target[key] = draw(st.one_of(cheap, bad_types))
            else:
                target[key] = draw(values)
    return groups


@hypothesis.settings(max_examples=300, deadline=None, derandomize=True,
                     suppress_health_check=list(hypothesis.HealthCheck))
@hypothesis.given(inputs())
def test_every_dict_input_gives_a_result_or_a_tmafm_error(groups):
    try:
        result = tmafm.run(groups)
    except tmafm.TmafmError as exc:
        message = str(exc)
        assert message and "\n" not in message
        return
    for name in ("tau", "vt", "vtdot", "a", "adot"):
        assert np.all(np.isfinite(getattr(result, name))), name
    assert result.tau.size >= 1 and result.a.shape[0] == result.tau.size
    assert math.isfinite(result.scene["omega"])

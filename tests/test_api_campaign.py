"""The hostile Python calls campaign (studies/api_campaign.py), its seeded CI tier, and the
calls it found that broke the contract: each raised a raw Python exception where a typed
tmafm error naming the argument was due (issue 27)."""

import numpy as np
import pytest

import tmafm
from tmafm import analysis

import api_campaign

BISTABLE = str(api_campaign.BISTABLE)


def test_a_seeded_tier_of_the_campaign_keeps_the_contract():
    """300 calls (seeds 0-299; the campaign runs 6000, docs/reliability.md), each in the
    campaign's worker process: every one returns finite results or raises a typed tmafm error of
    one line, and none crashes or hangs."""
    rows = api_campaign.campaign(range(300), timeout=120)
    bad = [r for r in rows if r["outcome"] not in api_campaign.GOOD]
    assert not bad, bad[:3]
    outcomes = {r["outcome"] for r in rows}
    entries = {r["entry"].split(".")[0] for r in rows}
    # The tier reaches both outcomes and every family of entry points.
    assert outcomes == {"ok", "ok-error"}
    assert {"run", "Config", "observe", "Result", "analysis", "Model", "load", "continuation"} <= entries


def test_the_campaign_rebuilds_a_call_from_its_seed(tmp_path):
    cache = api_campaign.Cache(tmp_path)
    first = api_campaign.generate(1869, tmp_path, cache)
    again = api_campaign.generate(1869, tmp_path, cache)
    assert first.what == again.what and first.entry == again.entry


@pytest.mark.parametrize("keywords, words", [
    ({"rtol": 10**400}, "rtol = 1"),
    ({"y0": "x" * 80}, "y0 must be real numbers"),
    ({"y0": ((0.1,), (0.2, 0.3))}, "y0 must be real numbers"),
    ({"settle": np.timedelta64(3, "s")}, "settle = np.timedelta64(3,'s'): must be a positive integer"),
])
def test_continuation_refuses_what_the_campaign_found(keywords, words):
    """rtol = 10**400 raised OverflowError, a text y0 numpy's ValueError, and a timedelta64
    settle (a numpy integer) int()'s TypeError."""
    with pytest.raises(tmafm.TmafmError) as error:
        tmafm.continuation(BISTABLE, "scene.delta_hat", 2.0e-3, 1.98e-3,
                           **{"max_points": 2, "settle": 20, "workers": 1, **keywords})
    assert words in str(error.value) and "\n" not in str(error.value)


def test_a_timedelta_is_not_a_count_or_a_tolerance():
    """np.timedelta64 is a numpy integer: observe's max_periods, approach's and steady_state's
    tol took it and failed in int() or float() with a TypeError."""
    with pytest.raises(tmafm.InputTypeError, match="observe max_periods = np.timedelta64"):
        tmafm.observe("fig2_n4", max_periods=np.timedelta64(3, "s"))
    with pytest.raises(tmafm.InputTypeError, match="max_periods"):
        tmafm.approach("fig2_n4", [0.2, 0.1], max_periods=np.timedelta64(3, "s"), workers=1)
    result = tmafm.run("fig2_n4", solver={"tau_end": 0.1})
    with pytest.raises(tmafm.InputError, match="tol = np.timedelta64"):
        analysis.steady_state(result, tol=np.timedelta64(3, "s"))
    with pytest.raises(tmafm.InputError, match="in_contact must be True or False"):
        result.config.model().derivative(0.0, np.zeros(8), np.timedelta64(1))

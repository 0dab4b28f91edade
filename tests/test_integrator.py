"""The paper's integrator rk4_paper (docs/model.md §9): order, step-for-step agreement with an
independent implementation, and the stability limit."""

import math
from pathlib import Path

import numpy as np
import pytest

import tmafm

from conftest import INPUTS, write_nml

REFERENCE = np.load(Path(__file__).parent / "reference" / "fig2_independent_tau0-10.npz")


def free_state_at_end(dtau):
    """A scene that never touches (delta_hat = 1 gap): the model is linear and smooth."""
    result = tmafm.run({"model": {"n_modes": 2},
                        "scene": {"delta_hat": 1.0},
                        "initial": {"a0": [2e-4, -1e-5], "adot0": [0.0, 3e-4]},
                        "solver": {"dtau": dtau, "tau_end": 4.0},
                        "output": {"sample_dtau": 0.5}})
    assert result.contact.sum() == 0
    assert result.counters["contact_steps"] == 0
    return np.concatenate([result.a[-1], result.adot[-1]])


def test_rk4_is_fourth_order_out_of_contact():
    reference = free_state_at_end(0.00125 / 16)
    errors = [np.max(np.abs(free_state_at_end(h) - reference)) for h in (0.005, 0.0025, 0.00125)]
    orders = [math.log2(e1 / e2) for e1, e2 in zip(errors, errors[1:])]
    for order in orders:
        assert 3.9 <= order <= 4.1, (errors, orders)


@pytest.mark.parametrize("convention", ["paper", "consistent"])
@pytest.mark.parametrize("law", ["hertz", "dmt"])
def test_rk4_paper_matches_independent_implementation(convention, law):
    """Step for step: the reference README expects ~1e-11 in a and ~1e-9 in adot."""
    result = tmafm.run(INPUTS / "fig2_n4.nml",
                       model={"contact_law": law, "convention": convention},
                       solver={"tau_end": 10.0})
    key = f"{convention}_{law}_n4_rk4_paper"
    np.testing.assert_allclose(result.tau, REFERENCE["tau"], rtol=0, atol=1e-12)
    assert np.max(np.abs(result.a - REFERENCE[key + "_a"])) < 1e-11
    assert np.max(np.abs(result.adot - REFERENCE[key + "_adot"])) < 1e-9
    assert np.max(np.abs(result.vt - REFERENCE[key + "_vt"])) < 1e-11
    # And the paper's scheme is a first-order distance away from the located solution.
    located_gap = np.max(np.abs(result.a - REFERENCE[f"{convention}_{law}_n4_located_a"]))
    if law == "hertz":
        assert 1e-8 < located_gap < 1e-5


def test_first_step_is_a_contact_step():
    """V_T(0) = 0 counts as contact, so the run starts with dtau/16 steps."""
    result = tmafm.run(INPUTS / "fig2_n4.nml", solver={"tau_end": 0.01},
                       output={"sample_dtau": 0.01})
    assert result.counters["contact_steps"] >= 1


def test_step_count_follows_the_phase_rule():
    result = tmafm.run(INPUTS / "fig2_n4.nml", solver={"tau_end": 10.0})
    c = result.counters
    free_steps = c["steps"] - c["contact_steps"]
    # The steps tile [0, tau_end] (the last step may overshoot by less than one step).
    covered = free_steps * 2e-3 + c["contact_steps"] * 2e-3 / 16
    assert 10.0 <= covered < 10.0 + 2e-3 + 1e-9


def blowup_input(tmp_path):
    return write_nml(tmp_path / "n14.nml", base=INPUTS / "fig2_n4.nml",
                     model={"n_modes": 14}, initial={"a0": [0.0] * 14},
                     solver={"tau_end": 10.0}, output={"file": "n14.dat"})


def test_past_stability_limit_blows_up_from_python(tmp_path):
    """beta_14^2 ~ 1.79e3 gives dtau * omega_max ~ 3.6 > 2.83 (docs/model.md §9)."""
    with pytest.raises(tmafm.BlowUpError, match="blow-up at tau"):
        tmafm.run(blowup_input(tmp_path))


def test_past_stability_limit_blows_up_from_executable(tmp_path, run_exe):
    path = blowup_input(tmp_path)
    proc = run_exe(path)
    assert proc.returncode == 4
    assert "blow-up at tau" in proc.stderr and "dtau" in proc.stderr
    assert "Backtrace" not in proc.stderr
    assert not (tmp_path / "n14.dat").exists()
    assert not list(tmp_path.glob("*.partial"))


def test_thirteen_modes_fail_and_twelve_run(tmp_path):
    """The stability edge of docs/model.md §9: 2 sqrt(2)/omega_max(N) < 2e-3 from N = 13 on."""
    for n, stable in ((12, True), (13, False)):
        groups = dict(model={"n_modes": n}, initial={"a0": [0.0] * n}, solver={"tau_end": 20.0})
        if stable:
            result = tmafm.run(INPUTS / "fig2_n4.nml", **groups)
            assert np.all(np.isfinite(result.a))
        else:
            with pytest.raises(tmafm.BlowUpError):
                tmafm.run(INPUTS / "fig2_n4.nml", **groups)

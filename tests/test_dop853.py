"""dop853 (Dormand-Prince 8(5,3)), the work counters, the step budget, switch chatter and
the runs that used to hang."""

import subprocess

import numpy as np
import pytest

import tmafm

from conftest import INPUTS, write_nml

#: A scene that never touches (delta_hat = 1 gap): linear and smooth, and flight_exact is its
#: exact solution (up to round-off), so it is the reference for the order of the pairs.
FREE = {"model": {"n_modes": 2}, "scene": {"delta_hat": 1.0},
        "initial": {"a0": [2e-4, -1e-5], "adot0": [0.0, 3e-4]},
        "solver": {"tau_end": 4.0}, "output": {"sample_dtau": 0.5}}
RTOLS = (1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9)


def free_error(method, rtol):
    """Largest error of a and a' over the samples (interior ones come from the dense output)
    against the exact flight, and the steps tried."""
    exact = tmafm.run(FREE, solver={"method": "flight_exact"})
    result = tmafm.run(FREE, solver={"method": method, "rtol": rtol, "atol": 0.0})
    assert result.counters["phase_switches"] == 0
    error = max(np.max(np.abs(result.a - exact.a)), np.max(np.abs(result.adot - exact.adot)))
    return error, result.counters["steps"] + result.counters["rejected_steps"]


def observed_order(method):
    """Slope of log(error) against log(1/steps): the order p of error ~ h^p."""
    points = [free_error(method, rtol) for rtol in RTOLS]
    errors = np.array([e for e, _ in points])
    steps = np.array([n for _, n in points], dtype=float)
    assert np.all(errors > 1e-14), errors   # above round-off: the slope measures the method
    return -np.polyfit(np.log(steps), np.log(errors), 1)[0], errors


def test_dop853_is_eighth_order_in_free_flight():
    order, errors = observed_order("dop853")
    assert order >= 7.0, (order, errors)
    # Tolerance-proportional: each decade of rtol buys about a decade of error.
    ratios = errors[:-1] / errors[1:]
    assert np.all((ratios > 3) & (ratios < 30)), ratios


def test_dopri5_is_fifth_order_on_the_same_problem():
    """The same fit tells the pairs apart: it would fail dop853 if it were fifth order."""
    order, errors = observed_order("dopri5")
    assert 4.5 <= order <= 5.6, (order, errors)


def test_dop853_counters_add_up_in_free_flight():
    """No switch and one sample in the last step only: 12 evaluations per step tried, the
    first derivative, and the 3 dense-output stages of that one step, nothing else."""
    result = tmafm.run(FREE, solver={"method": "dop853", "rtol": 1e-8},
                       output={"sample_dtau": 4.0})
    c = result.counters
    assert c["rhs_evaluations"] == 12 * (c["steps"] + c["rejected_steps"]) + 1 + 3, c


@pytest.mark.parametrize("n_modes", [1, 2, 3, 4, 5, 30])
def test_dop853_every_state_length_matches_the_exact_flight(n_modes):
    """The stage registers have a fixed number of rows (2 max_modes = 60, tmafm_dop853 lead)
    whatever the state's length 2N, and the stage sums run over even lengths: every N from 1
    to max_modes = 30 (a state that fills the rows) must integrate the free flight as
    flight_exact does.  Each step holds its V_T error to rtol S_V (tmafm_error_scale, atol =
    0); the global error stays below that (0.07-0.53 rtol S_V measured, bound 10) and each
    mode's below steps x rtol x its amplitude.  A stage register read in the wrong rows errs
    by O(1)."""
    rtol = 1e-10
    free = {"model": {"n_modes": n_modes}, "scene": {"delta_hat": 1.0},
            "initial": {"a0": [2e-4] + [-1e-5] * (n_modes - 1),
                        "adot0": [0.0] + [3e-4 / j**2 for j in range(2, n_modes + 1)]},
            "solver": {"tau_end": 2.0 if n_modes < 30 else 0.25}, "output": {"sample_dtau": 0.125}}
    exact = tmafm.run(free, solver={"method": "flight_exact"})
    result = tmafm.run(free, solver={"method": "dop853", "rtol": rtol, "atol": 0.0})
    assert result.counters["phase_switches"] == 0
    tip_size = np.max(np.abs(exact.vt - 1.0))   # V_T - delta_hat: the tip's motion
    assert np.max(np.abs(result.vt - exact.vt)) <= 10 * rtol * tip_size
    steps = result.counters["steps"]
    mode_size = np.max(np.abs(exact.a), axis=0)
    assert np.all(np.max(np.abs(result.a - exact.a), axis=0) <= steps * rtol * mode_size)


def test_dop853_agrees_with_flight_exact_through_contacts():
    exact = tmafm.run(INPUTS / "fig2_n4.nml", model={"convention": "consistent"},
                      solver={"method": "flight_exact", "tau_end": 20.0, "rtol": 1e-12, "atol": 1e-16})
    located = tmafm.run(INPUTS / "fig2_n4.nml", model={"convention": "consistent"},
                        solver={"method": "dop853", "tau_end": 20.0, "rtol": 1e-11, "atol": 1e-15})
    assert located.counters["phase_switches"] == exact.counters["phase_switches"] >= 10
    np.testing.assert_allclose(located.switches, exact.switches, rtol=0, atol=1e-8)
    assert np.max(np.abs(located.vt - exact.vt)) <= 1e-10


def test_tolerance_controls_the_tip_gap():
    """atol is in gap units: with rtol out of the way, the V_T error follows atol."""
    reference = tmafm.run(INPUTS / "fig2_n4.nml",
                          solver={"method": "flight_exact", "tau_end": 10.0, "rtol": 1e-13, "atol": 1e-18})
    errors = []
    for atol in (1e-8, 1e-10, 1e-12):
        run = tmafm.run(INPUTS / "fig2_n4.nml",
                        solver={"method": "dop853", "tau_end": 10.0, "rtol": 1e-15, "atol": atol})
        errors.append(np.max(np.abs(run.vt - reference.vt)))
        # Per step |e(V_T)| <= atol; over the run the errors add up, but not by much.
        assert errors[-1] <= 30 * atol, (atol, errors)
    assert errors[0] > errors[1] > errors[2]


# --- runs that cannot hang ---------------------------------------------------------------

def test_step_budget_stops_an_adaptive_run(tmp_path):
    with pytest.raises(tmafm.SolverError, match=r"&solver max_steps = 50 spent at tau"):
        tmafm.run(INPUTS / "fig2_n4.nml", solver={"method": "dop853", "max_steps": 50, "tau_end": 10.0})
    # Enough budget: the same run completes, and its steps tried fit in it.
    result = tmafm.run(INPUTS / "fig2_n4.nml", solver={"method": "dop853", "max_steps": 5000,
                                                       "tau_end": 10.0})
    assert result.counters["steps"] + result.counters["rejected_steps"] <= 5000


def test_step_budget_counts_flight_scans(tmp_path, exe):
    """flight_exact takes one 'step' per flight, but its scan points are charged too."""
    path = write_nml(tmp_path / "budget.nml", base=INPUTS / "fig2_n4.nml",
                     solver={"method": "flight_exact", "max_steps": 200, "tau_end": 10.0},
                     output={"file": "budget.dat"})
    proc = subprocess.run([exe, str(path)], cwd=tmp_path, capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 5 and "&solver max_steps = 200" in proc.stderr, proc.stderr
    assert not (tmp_path / "budget.dat").exists()


def test_switch_chatter_ends_with_an_error(tmp_path, exe):
    """Contact damping at its largest accepted value makes RK4's contact step (dtau/16)
    unstable in contact: the located switches flip back and forth.  That used to grow the
    switch list without bound; now it ends at once, naming the cause."""
    path = write_nml(tmp_path / "chatter.nml", base=INPUTS / "fig2_n4.nml",
                     scene={"alpha4": 1e4}, solver={"method": "rk4_event", "tau_end": 10.0},
                     output={"file": "chatter.dat"})
    proc = subprocess.run([exe, "-q", str(path)], cwd=tmp_path, capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 5, proc.stderr
    assert "switch chatter at tau =" in proc.stderr and "dtau" in proc.stderr
    with pytest.raises(tmafm.SolverError, match="switch chatter"):
        tmafm.run(path)


def test_rk4_event_with_a_huge_step_ends(tmp_path, exe):
    """dtau = 1 from rest used to hang: V_T = 0 at tau = 0 with a zero switch margin let the
    phase end where it began, forever.  Now the step is seen to be unstable."""
    path = write_nml(tmp_path / "huge.nml", base=INPUTS / "fig2_n4.nml",
                     solver={"method": "rk4_event", "dtau": 1.0, "tau_end": 10.0},
                     output={"file": "huge.dat"})
    proc = subprocess.run([exe, "-q", str(path)], cwd=tmp_path, capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 4, proc.stderr
    assert "stability limit: reduce &solver dtau" in proc.stderr


def test_adaptive_blowup_names_another_cause():
    """An adaptive step is stable by construction: its blow-up message does not say dtau, and
    exponents of three digits keep their E."""
    with pytest.raises(tmafm.BlowUpError) as info:
        tmafm.run(INPUTS / "fig2_n4.nml", solver={"method": "dop853", "tau_end": 5.0,
                                                  "blowup_limit": 1e-100})
    message = str(info.value)
    assert "dtau" not in message and "blowup_limit" in message and "diverged" in message
    assert "1.000E-100" in message, message

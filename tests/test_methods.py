"""The located and adaptive methods (rk4_event, dopri5, dop853, flight_exact): observed order through
contact switches, tolerance-proportional error, agreement between methods, grazing contacts,
blow-up reporting, and the automatic number of modes."""

import math
import re
from pathlib import Path

import numpy as np
import pytest

import tmafm

from conftest import INPUTS, write_nml
from scenes import grazing_scene as grazing_scene_dict  # studies/scenes.py (conftest's sys.path)

REFERENCE = np.load(Path(__file__).parent / "reference" / "fig2_independent_tau0-10.npz")
#: Scenes with at least 10 switches in tau <= 10 (Hertz; and DMT in `consistent`, where
#: the tip leaves the sample; in `paper` the DMT tip sticks after one bounce).
SWITCHING_SCENES = [("hertz", "paper"), ("dmt", "consistent")]


def vt_error(method, law, convention, **solver):
    result = tmafm.run(INPUTS / "fig2_n4.nml", model={"contact_law": law, "convention": convention},
                       solver={"method": method, "tau_end": 10.0, **solver})
    located = REFERENCE[f"{convention}_{law}_n4_located_vt"]
    return np.max(np.abs(result.vt - located)), result


def observed_orders(method, law, convention, steps=(4e-3, 2e-3, 1e-3)):
    errors = [vt_error(method, law, convention, dtau=h)[0] for h in steps]
    return [math.log2(e1 / e2) for e1, e2 in zip(errors, errors[1:])], errors


@pytest.mark.parametrize("law,convention", SWITCHING_SCENES)
def test_rk4_event_is_fourth_order_through_switches(law, convention):
    _, result = vt_error("rk4_event", law, convention, dtau=2e-3)
    assert result.counters["phase_switches"] >= 10
    orders, errors = observed_orders("rk4_event", law, convention)
    for order in orders:
        assert 3.8 <= order <= 4.2, (orders, errors)


@pytest.mark.parametrize("law,convention", SWITCHING_SCENES)
def test_rk4_paper_is_first_order_on_the_same_scene(law, convention):
    """Why events matter: the unlocated switch costs one order per halving, not four."""
    orders, errors = observed_orders("rk4_paper", law, convention)
    for order in orders:
        assert 0.7 <= order <= 1.5, (orders, errors)
    event_error = vt_error("rk4_event", law, convention, dtau=2e-3)[0]
    assert errors[1] > 100 * event_error


@pytest.mark.parametrize("law,convention", SWITCHING_SCENES)
@pytest.mark.parametrize("rtol", [1e-6, 1e-8, 1e-10])
@pytest.mark.parametrize("method", ["dopri5", "dop853"])
def test_adaptive_error_follows_the_tolerance(method, law, convention, rtol):
    """atol far below: rtol alone, relative to the tip's motion (tmafm_error_scale)."""
    error, result = vt_error(method, law, convention, rtol=rtol, atol=rtol * 1e-6)
    scale = np.max(np.abs(REFERENCE[f"{convention}_{law}_n4_located_vt"]))
    assert error <= 100 * rtol * scale, (error, rtol)
    c = result.counters
    assert c["steps"] > 0
    assert result.counters["phase_switches"] == len(REFERENCE[f"{convention}_{law}_n4_located_switches"])
    attempts = c["steps"] + c["rejected_steps"]
    # One fresh derivative after each switch to free flight; none at a contact entry, whose
    # warped first step starts with dy/dsigma = 0 (tmafm_method_adaptive).  Switches alternate
    # from the initial phase.
    starts_in_contact = bool(result.contact[0])
    exits = (c["phase_switches"] + starts_in_contact) // 2
    if method == "dopri5":
        # Every attempted step (accepted or rejected) costs 6 evaluations, plus the first one
        # and one after each exit: the counters must account for all work.
        assert c["rhs_evaluations"] == 6 * attempts + 1 + exits
    else:
        # 12 per attempt, the first one, one after each exit, and 3 per dense output
        # (built only for steps that hold a sample or a switch, so at most once per step).
        dense = c["rhs_evaluations"] - (12 * attempts + 1 + exits)
        assert dense % 3 == 0 and 0 < dense // 3 <= c["steps"], (dense, c)


def test_dopri5_switch_times_match_independent_reference():
    _, result = vt_error("dopri5", "hertz", "paper", rtol=1e-11, atol=1e-17)
    np.testing.assert_allclose(result.switches, REFERENCE["paper_hertz_n4_located_switches"],
                               rtol=0, atol=1e-9)


@pytest.mark.parametrize("law", ["hertz", "dmt"])
def test_flight_exact_matches_rk4_event(law):
    groups = dict(model={"contact_law": law, "convention": "consistent"})
    exact = tmafm.run(INPUTS / "fig2_n4.nml", **groups,
                      solver={"method": "flight_exact", "tau_end": 20.0, "rtol": 1e-11, "atol": 1e-17})
    fine = tmafm.run(INPUTS / "fig2_n4.nml", **groups,
                     solver={"method": "rk4_event", "tau_end": 20.0, "dtau": 2.5e-4})
    assert exact.counters["phase_switches"] == fine.counters["phase_switches"] >= 10
    assert np.max(np.abs(exact.vt - fine.vt)) <= 1e-9
    assert np.max(np.abs(exact.a - fine.a)) <= 1e-9
    # Out of contact nothing is integrated: far fewer evaluations than the fine RK4 run.
    assert exact.counters["rhs_evaluations"] < fine.counters["rhs_evaluations"] / 10


@pytest.fixture(scope="module")
def grazing_scene():
    """Contacts about 1.4e-3 long, shorter than one free step of 2e-3 (studies/scenes.py)."""
    return grazing_scene_dict(depth=1e-9)


GRAZING_METHODS = {"flight_exact": {"rtol": 1e-12, "atol": 1e-18},
                   "dopri5": {"rtol": 1e-10, "atol": 1e-16},
                   "dop853": {"rtol": 1e-10, "atol": 1e-16},
                   "rk4_event": {"dtau": 2e-3}}


def run_grazing(scene, method, **solver):
    return tmafm.run(scene, solver={"method": method, "tau_end": 10 * math.pi, **solver},
                     output={"sample_dtau": 0.01})


def test_grazing_contacts_are_all_found(grazing_scene):
    exact = run_grazing(grazing_scene, "flight_exact", **GRAZING_METHODS["flight_exact"])
    assert len(exact.switches) == 20                   # one contact per period
    durations = exact.switches[1::2] - exact.switches[0::2]
    assert np.all(durations < 2e-3) and np.all(durations > 5e-4)
    for method in ("dopri5", "dop853", "rk4_event"):
        located = run_grazing(grazing_scene, method, **GRAZING_METHODS[method])
        assert len(located.switches) == 20, method
        # Grazing switches are ill-conditioned in time (dV_T/dtau ~ 3e-6 there).
        np.testing.assert_allclose(located.switches, exact.switches, rtol=0, atol=1e-7,
                                   err_msg=method)


def free_phase_min_vt(result):
    """The lowest sampled V_T outside the run's own contact phases (from its switches)."""
    switches_before = np.searchsorted(result.switches, result.tau, side="right")
    return float(np.min(result.vt[switches_before % 2 == 0]))


@pytest.mark.parametrize("method", ["dop853", "dopri5"])
@pytest.mark.parametrize("depth", [1e-9, 1e-10])
@pytest.mark.parametrize("rtol", [1e-7, 1e-8, 1e-5])
def test_pairs_find_grazing_contacts_at_loose_tolerances(method, depth, rtol):
    """At the default tolerance a pair's free steps are far longer than these contacts: the cubic
    test alone let dop853 run through all 20 of them with V_T < 0 in its free phase (down to
    -1e-9 at rtol 1e-7, -4e-9 at 1e-5).  Whatever the trajectory's own error, no sample of a free
    phase may lie in contact, and where the trajectory dips (it does at these depths) the
    contacts are found."""
    result = tmafm.run(grazing_scene_dict(depth=depth),
                       solver={"method": method, "tau_end": 10 * math.pi, "rtol": rtol, "atol": rtol * 1e-3},
                       output={"sample_dtau": 2e-4})
    assert free_phase_min_vt(result) > 0
    if rtol <= 1e-7:
        assert len(result.switches) == 20


def test_rk4_paper_misses_short_contacts(grazing_scene):
    paper = run_grazing(grazing_scene, "rk4_paper")
    assert paper.counters["phase_switches"] < 20


@pytest.mark.parametrize("method", ["rk4_event", "rk4_paper"])
def test_blowup_past_the_stability_limit(tmp_path, run_exe, method):
    path = write_nml(tmp_path / "n14.nml", base=INPUTS / "fig2_n4.nml",
                     model={"n_modes": 14}, initial={"a0": [0.0] * 14},
                     solver={"method": method, "tau_end": 10.0}, output={"file": "n14.dat"})
    with pytest.raises(tmafm.BlowUpError, match="stability limit"):
        tmafm.run(path)
    proc = run_exe(path)
    assert proc.returncode == 4 and "blow-up at tau" in proc.stderr
    assert not (tmp_path / "n14.dat").exists()


def test_adaptive_methods_cope_where_fixed_steps_fail():
    """The same 14-mode scene that blows up rk4_paper at dtau = 2e-3 runs under dopri5."""
    result = tmafm.run(INPUTS / "fig2_n4.nml", model={"n_modes": 14}, initial={"a0": [0.0] * 14},
                       solver={"method": "dopri5", "tau_end": 5.0, "rtol": 1e-7})
    assert np.all(np.isfinite(result.a)) and result.vt.min() < 0


def test_auto_modes_never_touching_scene_picks_one():
    result = tmafm.run({"model": {"n_modes": 0, "mode_tol": 1e-2}, "scene": {"delta_hat": 1.0},
                        "solver": {"method": "dopri5", "tau_end": 5.0}})
    assert result.n_modes == 1
    assert result.resolved["model"]["n_modes"] == 0


def test_auto_modes_fig2_tight_tolerance_picks_at_least_three(tmp_path, run_exe):
    path = write_nml(tmp_path / "auto.nml", base=INPUTS / "fig2_n4.nml",
                     model={"n_modes": 0, "mode_tol": 1e-3}, initial={"a0": [0.0]},
                     solver={"method": "dopri5", "tau_end": 5.0}, output={"file": "auto.dat"})
    result = tmafm.run(path)
    assert result.n_modes >= 3
    proc = run_exe(path, "-q")
    assert proc.returncode == 0, proc.stderr
    header = (tmp_path / "auto.dat").read_text()
    assert re.search(rf"chosen n_modes = {result.n_modes}\b", header)
    assert np.loadtxt(tmp_path / "auto.dat").shape[1] == 4 + 2 * result.n_modes

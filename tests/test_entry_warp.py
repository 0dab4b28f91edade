"""Warped steps after a contact entry (tmafm_method_adaptive; time_map_t and stage_clock of
tmafm_embedded_pair): the first stretch of a contact is integrated in sigma = sqrt(tau - tau_e),
where the state is smooth although the Hertz force ~ (tau - tau_e)^(3/2) is not.  Fewer contact
steps, the V_T error no larger, every switch still located (short contacts that end inside the
warped stretch included), and the dense output of a warped step read through its time map.
benchmarks/contact_steps.py measures the cost (docs/performance.md)."""

import math

import numpy as np
import pytest

import tmafm

from conftest import INPUTS

#: benchmarks/period_cost.py's untilted_3 and tilted_hertz_3: two Hertz contacts per period.
UNTILTED = {"model": {"n_modes": 3, "convention": "paper"}, "scene": {"alpha2": 7e-4, "theta": 0.0, "alpha4": 0.0},
            "initial": {"a0": [2e-4, 0.0, 0.0]}}
TILTED = {"model": {"n_modes": 3, "convention": "paper"}, "scene": {"alpha2": 7e-4, "theta": 0.2},
          "initial": {"a0": [2e-4, 0.0, 0.0]}}
PERIODS = 20
#: Before the warp (main at a5c81a8, the build of benchmarks/contact_steps.py's docstring), on
#: this test's runs (untilted_3, flight_exact, 20 periods): contact steps per contact (711 and
#: 1934 over 40 contacts) and the V_T error against flight_exact at rtol 1e-13, sampled every
#: 0.05 (docs/performance.md, "Warped steps after a contact entry").
BEFORE = {1e-7: (17.8, 9.25e-10), 1e-10: (48.35, 3.44e-13)}


def run(scene, method, rtol, atol, periods=PERIODS, sample=0.05):
    return tmafm.run(INPUTS / "fig2_n4.nml", **scene,
                     solver={"method": method, "rtol": rtol, "atol": atol, "tau_end": periods * math.pi},
                     output={"sample_dtau": sample})


@pytest.fixture(scope="module")
def reference():
    return run(UNTILTED, "flight_exact", 1e-13, 1e-18)


@pytest.mark.parametrize("rtol,atol", [(1e-7, 1e-10), (1e-10, 1e-14)])
def test_warped_entry_takes_fewer_contact_steps_at_no_larger_error(reference, rtol, atol):
    result = run(UNTILTED, "flight_exact", rtol, atol)
    c = result.counters
    contacts = c["phase_switches"] / 2
    assert c["phase_switches"] == reference.counters["phase_switches"]
    steps_before, error_before = BEFORE[rtol]
    # The ramp of 4 (rtol 1e-7) or 7 (1e-10) growing steps after each entry becomes two
    # warped steps and a shorter ramp: about one step per contact fewer (16.7 and 47.3).
    assert c["contact_steps"] / contacts <= steps_before - 0.5, c
    assert np.max(np.abs(result.vt - reference.vt)) <= error_before


@pytest.mark.parametrize("method", ["flight_exact", "dop853", "dopri5"])
def test_every_switch_is_located_after_warped_entries(method):
    """Each method enters its contacts through a switch (a flight's root, or its own located
    switch) and warps them; the switches are where the reference has them."""
    reference = run(TILTED, "flight_exact", 1e-13, 1e-18)
    rtol, atol = 1e-9, 1e-13
    result = run(TILTED, method, rtol, atol)
    assert result.counters["phase_switches"] == reference.counters["phase_switches"]
    # A V_T error e moves a switch by e / |V_T'|, |V_T'| ~ 1e-3 at these switches.
    tolerance = atol + rtol * np.max(np.abs(reference.vt))
    np.testing.assert_allclose(result.switches, reference.switches, rtol=0, atol=10 * tolerance / 1e-4)
    assert np.max(np.abs(result.vt - reference.vt)) <= 10 * tolerance


def test_dense_output_of_warped_steps_follows_the_time_map():
    """Samples every 1e-3 over two periods: each entry's warped steps hold several; read at
    an affine fraction of the step instead of sigma's, their V_T would be off by ~1e-5."""
    rtol, atol = 1e-9, 1e-13
    reference = run(UNTILTED, "flight_exact", 1e-13, 1e-18, periods=2, sample=1e-3)
    result = run(UNTILTED, "flight_exact", rtol, atol, periods=2, sample=1e-3)
    entries = reference.switches[0::2]
    near_entry = np.zeros(len(result.tau), dtype=bool)
    for entry in entries:
        near_entry |= (result.tau > entry) & (result.tau < entry + 0.02)
    assert near_entry.sum() >= 10 * len(entries)
    tolerance = atol + rtol * np.max(np.abs(reference.vt))
    assert np.max(np.abs(result.vt - reference.vt)[near_entry]) <= 10 * tolerance


@pytest.mark.parametrize("method,rtol,atol", [("flight_exact", 1e-7, 1e-10), ("dopri5", 1e-7, 1e-10),
                                              ("dop853", 1e-9, 1e-13)])
def test_grazing_contacts_end_inside_the_warp_and_are_located(method, rtol, atol):
    """Contacts 1.4e-3 long end inside the first warped step; each is still found, at the time
    flight_exact at rtol 1e-12 has it.  (dop853's free steps at rtol 1e-7 step over these
    1e-9-deep dips, before and after the warp alike: tmafm_events says why.)"""
    from scenes import grazing_scene  # studies/scenes.py (conftest's sys.path)
    scene = grazing_scene(depth=1e-9)
    solver = {"tau_end": 10 * math.pi}
    exact = tmafm.run(scene, solver={**solver, "method": "flight_exact", "rtol": 1e-12, "atol": 1e-18})
    located = tmafm.run(scene, solver={**solver, "method": method, "rtol": rtol, "atol": atol})
    assert len(exact.switches) == 20
    assert len(located.switches) == 20
    # Grazing switches are ill-conditioned in time (dV_T/dtau ~ 3e-6): a V_T error of atol
    # moves them by ~atol / 3e-6.
    np.testing.assert_allclose(located.switches, exact.switches, rtol=0, atol=10 * atol / 3e-6)

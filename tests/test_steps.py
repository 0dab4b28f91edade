"""Step control at a contact exit and at the stability limit (tmafm_method_adaptive, the
controller of tmafm_embedded_pair): exits are approached and crossed without rejected steps,
the PI mode of the controller stops the accept/reject cycle of the free flight of dop853, and
the V_T error stays at the tolerance's level.  benchmarks/contact_steps.py measures the
cost."""

import math

import numpy as np
import pytest

import tmafm

from conftest import INPUTS

#: benchmarks/period_cost.py's tilted_hertz_3: two Hertz contacts per drive period.
TILTED = {"model": {"n_modes": 3, "convention": "paper"}, "scene": {"alpha2": 7e-4, "theta": 0.2},
          "initial": {"a0": [2e-4, 0.0, 0.0]}}
PERIODS = 20


def run(method, rtol, atol):
    return tmafm.run(INPUTS / "fig2_n4.nml", **TILTED,
                     solver={"method": method, "rtol": rtol, "atol": atol, "tau_end": PERIODS * math.pi},
                     output={"sample_dtau": 0.05})


@pytest.fixture(scope="module")
def reference():
    return run("flight_exact", 1e-13, 1e-18)


@pytest.mark.parametrize("rtol,atol,per_contact", [(1e-7, 1e-10, 0.25), (1e-10, 1e-14, 1.5)])
def test_contact_exits_are_crossed_without_rejections(reference, rtol, atol, per_contact):
    """The kink of the force at V_T = 0 used to cost about one rejected step per contact at
    rtol 1e-7 and four at 1e-10 (a step aimed by the linear estimate of the exit crossed it
    far, or ended near it with a long step)."""
    result = run("flight_exact", rtol, atol)
    c = result.counters
    contacts = c["phase_switches"] / 2
    assert contacts >= 2 * PERIODS - 1
    assert c["phase_switches"] == reference.counters["phase_switches"]
    # Every switch is still located where the reference has it: a V_T error e moves a switch
    # by e / |V_T'|, and |V_T'| ~ 1e-3 at these switches.
    tolerance = atol + rtol * np.max(np.abs(reference.vt))
    np.testing.assert_allclose(result.switches, reference.switches, rtol=0, atol=10 * tolerance / 1e-4)
    assert c["rejected_steps"] <= per_contact * contacts, c
    # The error stays at the tolerance's level: atol + rtol x the tip's motion per step,
    # a few times that over the run.
    assert np.max(np.abs(result.vt - reference.vt)) <= 10 * tolerance


def test_pi_controller_stops_the_reject_cycle_of_dop853(reference):
    """dop853 out of contact runs at the stability limit of the highest mode: the classical
    controller rejected about one step in five there (27 per period at rtol 1e-7)."""
    result = run("dop853", 1e-7, 1e-10)
    c = result.counters
    assert c["phase_switches"] == reference.counters["phase_switches"]
    assert c["rejected_steps"] <= 0.1 * c["steps"], c
    tolerance = 1e-10 + 1e-7 * np.max(np.abs(reference.vt))
    assert np.max(np.abs(result.vt - reference.vt)) <= 10 * tolerance

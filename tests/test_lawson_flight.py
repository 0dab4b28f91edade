"""flight_exact with a force in flight (issue 29, item 5; fortran/src/integrators/tmafm_lawson.f90):
the flight is the exact free modal flow plus the force's response, integrated by the Lawson form
of dop853.  Checked against dop853 at a tight tolerance on a van der Waals scene, a biased tip and
a DLVO scene (trajectory and per-period observables), for its order (error against mean step),
and against the force-free exact flight when the force is vanishingly small."""

import math

import numpy as np
import pytest

import tmafm

#: The van der Waals scene of benchmarks/longrange_flight.py: tapping_polystyrene (N = 3) with the
#: attraction of H = 1e-19 J, at Z = 0.5 nm: from rest the tip taps within a few periods (26
#: switches by tau = 30), the attraction acting in every flight.
VDW = dict(model={"contact_law": "dmt_vdw"},
           physical={"hamaker": 1.0e-19, "intermolecular_distance": 0.165e-9, "tip_sample_distance": 0.5e-9})
SCENES = {
    "vdw": ("tapping_polystyrene", VDW),
    "biased_tip": ("biased_tip", {}),
    "dlvo": ("dlvo_water", {}),
}
TAU_END = 30.0


def _run(name, method, rtol, atol, **extra):
    source, groups = SCENES[name]
    groups = {k: dict(v) for k, v in groups.items()}
    for key, value in extra.items():
        groups[key] = {**groups.get(key, {}), **value}
    solver = {"method": method, "rtol": rtol, "atol": atol, "tau_end": TAU_END}
    return tmafm.run(tmafm.Config(source, **{**groups, "solver": solver, "output": {"sample_dtau": 0.01}}))


def _within(switches):
    """The switches located before tau_end (an adaptive run's last step may locate one past it;
    flight_exact's scan stops at tau_end)."""
    return np.asarray(switches)[np.asarray(switches) <= TAU_END]


@pytest.mark.parametrize("name", list(SCENES))
def test_flight_exact_follows_dop853_on_a_scene_with_a_force_in_flight(name):
    reference = _run(name, "dop853", 1e-12, 1e-16)
    # dop853's own error at rtol 1e-10 bounds its error at 1e-12 many times over, and
    # flight_exact's at 1e-8 bounds its error at 1e-10 (the measured errors, not a guess).
    reference_error = np.max(np.abs(_run(name, "dop853", 1e-10, 1e-14).vt - reference.vt))
    tight = _run(name, "flight_exact", 1e-10, 1e-14)
    method_error = np.max(np.abs(_run(name, "flight_exact", 1e-8, 1e-12).vt - tight.vt))
    difference = np.max(np.abs(tight.vt - reference.vt))
    assert difference <= 10 * max(reference_error, method_error), (name, difference, reference_error,
                                                                    method_error)
    # The switches are the same ones (a scene without contact has none; a last step may locate
    # one past tau_end).
    assert len(_within(tight.switches)) == len(_within(reference.switches))
    if name == "vdw":
        assert len(_within(reference.switches)) > 10
    # The force acts in flight: the exact flight without it is another trajectory.
    scale = np.max(np.abs(reference.vt))
    assert difference < 1e-6 * scale


def test_flight_exact_integrates_the_flight_not_the_force_free_solution():
    """The vdW scene's trajectory differs from its DMT twin by far more than the tolerance: the
    Lawson flight carries the attraction."""
    vdw = _run("vdw", "flight_exact", 1e-10, 1e-14)
    dmt = tmafm.run(tmafm.Config("tapping_polystyrene", physical={"tip_sample_distance": 0.5e-9},
                                 solver={"method": "flight_exact", "rtol": 1e-10, "atol": 1e-14,
                                         "tau_end": TAU_END}, output={"sample_dtau": 0.01}))
    assert np.max(np.abs(vdw.vt - dmt.vt)) > 1e3 * 1e-10 * np.max(np.abs(dmt.vt))
    # Out of contact its steps are many (the force is integrated), not one per flight.
    assert vdw.counters["steps"] - vdw.counters["contact_steps"] > 5 * dmt.counters["phase_switches"]


def test_observables_per_period_agree_with_dop853():
    """Amplitude, phase, the extremes of the gap and the force, and the energy per period
    under flight_exact and under dop853, within the two methods' own errors (each measured
    against the same method at a 100x looser tolerance)."""
    source, groups = SCENES["vdw"]
    names = ("amplitude", "phase", "min_gap", "max_gap", "peak_force", "min_force", "drive_work")

    def per_period(method, rtol):
        obs = tmafm.observe(tmafm.Config(source, **groups, solver={"method": method, "rtol": rtol,
                                                                     "atol": rtol * 1e-4}),
                            max_periods=12, stop_at_steady=False)
        return {k: np.asarray(obs.per_period[k], dtype=float) for k in names}

    reference, reference_loose = per_period("dop853", 1e-12), per_period("dop853", 1e-10)
    tight, loose = per_period("flight_exact", 1e-10), per_period("flight_exact", 1e-8)
    for k in names:
        bound = 10 * max(np.max(np.abs(reference_loose[k] - reference[k])), np.max(np.abs(loose[k] - tight[k])))
        # A floor of 1e-13 of the value's scale: an observable both methods give to round-off.
        bound = max(bound, 1e-13 * np.max(np.abs(reference[k])))
        assert np.max(np.abs(tight[k] - reference[k])) <= bound, (k, tight[k] - reference[k], bound)


def test_order_of_the_lawson_flight_is_at_least_five():
    """Error against mean step on the biased tip's flight (no contact: every step is a Lawson
    step): the slope of log(error) against log(mean step) over rtol 1e-6 to 1e-9 is >= 5 (8 for
    the DOP853 tableau with error per step held at the tolerance: about 7)."""
    reference = _run("biased_tip", "dop853", 1e-13, 1e-17)
    scale = np.max(np.abs(reference.vt))
    steps, errors = [], []
    for rtol in (1e-6, 1e-7, 1e-8, 1e-9):
        run = _run("biased_tip", "flight_exact", rtol, rtol * 1e-3)
        assert run.counters["contact_steps"] == 0
        steps.append(TAU_END / run.counters["steps"])
        errors.append(np.max(np.abs(run.vt - reference.vt)) / scale)
    # The finest error stays far above the reference's (dop853 at 1e-13: about 1e-13).
    assert min(errors) > 100 * 1e-13
    slope = np.polyfit(np.log(steps), np.log(errors), 1)[0]
    assert slope >= 5, (slope, steps, errors)


def test_a_vanishing_force_reproduces_the_exact_flight():
    """A force at a distance of strength 1e-290 (in &scene units) turns the Lawson flight on and
    acts on nothing: the trajectory is flight_exact's without it to round-off in a free run (the
    Lawson step of a zero force is the closed-form flow; each step rounds the state once more, a
    few ulp of its condition number), and in a run with contacts within the contact pair's own
    error (the located entries agree to round-off; the contacts are then dop853's)."""
    base = "fig2_n3"
    for delta_hat, contacts in ((5e-3, False), (None, True)):
        scene = {} if delta_hat is None else {"delta_hat": delta_hat}
        solver = {"method": "flight_exact", "rtol": 1e-10, "atol": 1e-14, "tau_end": TAU_END}
        exact = tmafm.run(tmafm.Config(base, scene=scene, solver=solver))
        lawson = tmafm.run(tmafm.Config(base, scene={**scene, "electrostatic_strength": 1e-290}, solver=solver))
        # The Lawson path ran: one step per flight for the exact flight, many for the Lawson one.
        assert lawson.counters["steps"] > exact.counters["steps"]
        assert (len(exact.switches) > 0) == contacts
        scale = np.max(np.abs(exact.vt))
        difference = np.max(np.abs(lawson.vt - exact.vt)) / scale
        if contacts:
            looser = tmafm.run(tmafm.Config(base, scene=scene, solver={**solver, "rtol": 1e-8, "atol": 1e-12}))
            assert len(_within(lawson.switches)) == len(_within(exact.switches))
            assert difference <= 10 * np.max(np.abs(looser.vt - exact.vt)) / scale
        else:
            steps = lawson.counters["steps"]
            assert difference <= 64 * math.ulp(1.0) * steps, (difference, steps)

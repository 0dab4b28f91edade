"""The steady-state test follows the method (tmafm_steady_state): rk4_paper's jitter level,
the reasons a run is not steady, the one steady phase, and the observed runs' default method
(docs/observables.md, "Steady state"; docs/model-notes.md, finding 15)."""

import math
import warnings

import numpy as np
import pytest

import tmafm
from tmafm import analysis, sweeps
from tmafm.observe import observe_states, observed_config, steady_harmonic, steady_test

#: The packaged inputs the README's observe example and the figures use, all rk4_paper.
RK4_INPUTS = ("fig3", "fig2_n1", "fig2_n2", "fig2_n3", "fig2_n4", "physical_polystyrene")


@pytest.mark.parametrize("name", RK4_INPUTS)
def test_rk4_paper_inputs_reach_the_located_runs_period(name):
    """Each packaged rk4_paper input finds its steady period within 100 periods, the period a
    flight_exact run of the same scene finds (period 1 for all six), and stops there with its
    Poincare points within the method's measured jitter (benchmarks/steady_jitter.json:
    at most 1.1e-2 of the orbit's size), not at the looser bound."""
    assert tmafm.Config(name).to_dict()["solver"]["method"] == "rk4_paper"
    paper = tmafm.observe(name, max_periods=100, observables=())
    exact = tmafm.observe(name, max_periods=100, observables=(), solver={"method": "flight_exact"})
    assert exact.steady and exact.period == 1
    assert paper.steady and paper.period == exact.period and paper.periods < 100
    assert paper.unsteady_reason == "" and paper.evidence["reason"] == "steady"
    assert paper.evidence["closest"] <= 1.1e-2
    # The floor came from the jitter level, far above steady_tol: the point of the change.
    assert paper.evidence["jitter"] > 100 * paper.evidence["tol"]
    # The orbit it stopped on is the located one's, to rk4_paper's first-order error.
    size = np.abs(exact.final_state).max()
    assert np.abs(paper.final_state - exact.final_state).max() < 0.1 * size


def _orbit_with_noise(rng, count, level):
    """A period-1 sequence of 4-component points of size 1 with uniform noise of `level`."""
    base = np.array([1.0, -0.5, 0.25, 0.8])
    return base + rng.uniform(-level, level, (count, 4))


def _first_steady(points, floor):
    """The number of points at which an observed run would stop (the core's test on the
    points so far, as finish_period calls it), or None."""
    return next((m for m in range(2, len(points) + 1)
                 if steady_test(points[:m], 8, 1e-6, 3, floor=floor)["period"] == 1), None)


def test_jitter_floor_accepts_jitter_but_not_drift_or_a_shrinking_transient():
    """Jitter below the floor is steady; a drift above it, or a transient whose steps still
    shrink (within the floor), is not, and the reason says which."""
    rng = np.random.default_rng(7)
    floor = 1e-3
    noise = _orbit_with_noise(rng, 60, floor / 4)
    assert _first_steady(noise, floor) is not None
    assert steady_test(noise, 8, 1e-6, 3)["period"] == 0           # without the floor: jitter
    # A drift of 2 floors per period on top of the same jitter: never steady.
    drift = noise + 2 * floor * np.arange(60)[:, None]
    assert _first_steady(drift, floor) is None
    test = steady_test(drift, 8, 1e-6, 3, floor=floor)
    assert test["period"] == 0 and test["reason"] == "no_repeat" and test["closest"] > floor
    # A transient 0.8^j of 1e-2: its steps (0.2 of it) fall below the floor from j = 12 on,
    # but they keep shrinking, which jitter does not: not steady while that shows.
    transient = noise[0] + 1e-2 * 0.8 ** np.arange(60)[:, None]
    for m in range(12, 60):
        test = steady_test(transient[:m], 8, 1e-6, 3, floor=floor)
        assert test["period"] == 0 and test["reason"] == "settling", m
    # With the jitter on top, it stops once the transient's steps are below the jitter's
    # (0.2 * 1e-2 * 0.8^j < 2.5e-4 from j = 10 on), not before.
    stop = _first_steady(transient + noise - noise[0], floor)
    assert stop is not None and stop > 10


def test_real_rk4_points_with_a_drift_above_their_jitter_are_not_steady():
    """fig3's rk4_paper Poincare points (90 periods) are steady at their own jitter level; the
    same points with a drift of 3 jitter levels per period are not."""
    obs = tmafm.observe("fig3", max_periods=90, stop_at_steady=False, observables=())
    points = obs.poincare
    size = np.abs(points[-20:]).max()
    level = obs.evidence["jitter"] * size           # the core's level, absolute
    assert obs.steady and obs.period == 1
    assert steady_test(points, 8, 1e-6, 3, floor=level)["period"] == 1
    drift = points + 3 * level * np.arange(len(points))[:, None]
    test = steady_test(drift, 8, 1e-6, 3, floor=level)
    assert test["period"] == 0 and test["reason"] == "no_repeat"


def test_steady_harmonic_across_the_wrap():
    """Phases 179 and -179 degrees (equal amplitudes) average to 180, not to 0 (the mean of the
    numbers); 170 and -150 to -170 with amplitude cos(20 deg); closed forms."""
    amplitude, phase = steady_harmonic([2.0, 2.0], [179.0, -179.0])
    assert abs(abs(phase) - 180.0) < 1e-12
    assert amplitude == pytest.approx(2 * math.cos(math.radians(1.0)), rel=1e-14)
    amplitude, phase = steady_harmonic([1.0, 1.0], [170.0, -150.0])
    assert phase == pytest.approx(-170.0, abs=1e-12)
    assert amplitude == pytest.approx(math.cos(math.radians(20.0)), rel=1e-14)


def test_one_steady_phase_on_a_period_2_run():
    """fig6 in `consistent` is period-2 (flight_exact): its steady phase is the phase of the
    mean of the two periods' first harmonics (numpy, from the per-period phases), and
    Observation.steady_values, observe_states, a sweep and tmafm.analysis.lockin all give that
    one value."""
    overrides = {"model": {"convention": "consistent"}, "solver": {"method": "flight_exact"}}
    obs = tmafm.observe("fig6", max_periods=200, **overrides)
    assert obs.period == 2
    amp = obs.per_period["amplitude"][-2:]
    phase = np.radians(obs.per_period["phase"][-2:])
    expected = math.degrees(math.atan2(np.mean(amp * np.sin(phase)), np.mean(amp * np.cos(phase))))
    expected_amp = math.hypot(np.mean(amp * np.sin(phase)), np.mean(amp * np.cos(phase)))
    steady = obs.steady_values()
    assert steady["phase"] == pytest.approx(expected, abs=1e-9)
    assert steady["amplitude"] == pytest.approx(expected_amp, rel=1e-12)
    # The mean of the two numbers is not it (the definition before: arithmetic mean).
    assert abs(np.mean(obs.per_period["phase"][-2:]) - expected) > 1e-3
    config = tmafm.Config("fig6", **overrides)
    n = config.n_modes
    state = np.concatenate([config.to_dict()["initial"]["a0"][:n], np.zeros(n)])
    states = observe_states(config, state[None, :], max_periods=200)
    assert states.period[0] == 2
    assert states.steady["phase"][0] == pytest.approx(steady["phase"], abs=1e-12)
    ds = sweeps.sweep(config, {"scene.delta_hat": [config.scene["delta_hat"]]}, max_periods=200)
    assert float(ds["phase"].values.ravel()[0]) == pytest.approx(steady["phase"], abs=1e-12)
    # tmafm.analysis reads the same two periods through the core's steady harmonic.
    period = 2 * math.pi / config.scene["omega"]
    result = tmafm.run(config, solver={"tau_end": obs.periods * period},
                       output={"sample_dtau": period / 100})
    lock = analysis.lockin(result, since=(obs.periods - 2) * period)
    assert lock["periods"] == 2
    assert math.degrees(lock["phase"]) == pytest.approx(steady["phase"], abs=1e-9)


def test_an_unsteady_run_says_why_and_warns():
    """fig6 with flight_exact at rtol 1e-7 never repeats within 1e-6 (its points wander by
    about 5e-6 of the orbit's size, whatever rtol); a run of 2 periods cannot confirm one."""
    with pytest.warns(tmafm.UnsteadyWarning, match="no repeat within tol after 40 periods"):
        obs = tmafm.observe("fig6", max_periods=40, observables=(),
                            solver={"method": "flight_exact"})
    assert not obs.steady and obs.period == 0
    assert obs.unsteady_reason.startswith("no repeat within tol after 40 periods")
    assert obs.evidence["reason"] == "no_repeat" and obs.evidence["closest"] > 1e-6
    with pytest.warns(tmafm.UnsteadyWarning, match="too few periods"):
        short = tmafm.observe("fig3", max_periods=2, observables=())
    assert short.evidence["reason"] == "short" and "too few periods" in short.unsteady_reason
    assert issubclass(tmafm.UnsteadyWarning, tmafm.TmafmWarning)
    # A run not asked to stop at a steady state does not warn.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        tmafm.observe("fig3", max_periods=3, stop_at_steady=False, observables=())
    config = tmafm.Config("fig3")
    n = config.n_modes
    out = observe_states(config, np.zeros((1, 2 * n)), max_periods=2)
    assert out.period[0] == 0 and out.reason[0] == 1


def test_observed_runs_default_to_flight_exact():
    """An input naming no &solver method is observed with flight_exact; one that names it
    (every packaged input: rk4_paper) keeps it."""
    groups = tmafm.Config("fig3").to_dict()
    del groups["solver"]["method"]
    assert observed_config(groups).to_dict()["solver"]["method"] == "flight_exact"
    kept = observed_config("fig3").to_dict()["solver"]["method"]
    assert kept == "rk4_paper"
    named = observed_config(groups, solver={"method": "dop853"})
    assert named.to_dict()["solver"]["method"] == "dop853"
    obs = tmafm.observe(groups, max_periods=60, observables=())
    assert obs.config.to_dict()["solver"]["method"] == "flight_exact" and obs.period == 1


def test_minimal_period_is_the_cores():
    """The sweeps' minimal period of an orbit: a period-2 orbit whose points coincide within
    tol is period 1; two distinct points stay period 2."""
    point = np.array([1.0, 2.0, -1.0])
    same = np.stack([point, point + 1e-9])
    assert sweeps.minimal_period(same, 1e-6) == 1
    distinct = np.stack([point, point + 0.1])
    assert sweeps.minimal_period(distinct, 1e-6) == 2


def test_rk4_paper_basin_labels_one_attractor_at_its_jitter():
    """A basin map of the Fig. 3 scene with rk4_paper: every run reaches the one period-1
    attractor, labelled once; the labels' tolerance is the method's jitter level (rk4_paper's
    orbits differ by up to 1.3e-3 of their size between runs, above the default tol 1e-3)."""
    config = tmafm.Config("fig3", solver={"method": "rk4_paper"})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", tmafm.UnsteadyWarning)
        ds = sweeps.basin(config, a1=np.linspace(-5e-4, 5e-4, 6), adot1=np.linspace(-1e-3, 1e-3, 6),
                          workers=1, max_periods=100)
    assert np.all(ds["period"].values == 1) and np.all(ds["attractor"].values == 0)
    scale = float(np.abs(ds["attractor_orbit_0"].values).max())
    assert ds["attractor"].attrs["tolerance"] > 1e-2 * scale


def test_a_sweep_warns_once_for_all_its_unsteady_points():
    """A sweep reports its unsteady runs in one UnsteadyWarning (how many, and the first
    reason), not one per point; the dataset's period is 0 at each of them."""
    pytest.importorskip("xarray")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        base = tmafm.Config("fig2_n4", solver={"method": "flight_exact"})
        ds = tmafm.sweep(base, {"scene.delta_hat": [0.0, 1e-4, 2e-4]}, max_periods=2)
    unsteady = [w for w in caught if issubclass(w.category, tmafm.UnsteadyWarning)]
    assert len(unsteady) == 1, [str(w.message) for w in unsteady]
    assert "3 of 3 runs ended without a steady state" in str(unsteady[0].message)
    assert "too few periods" in str(unsteady[0].message)
    assert (ds["period"].values == 0).all()

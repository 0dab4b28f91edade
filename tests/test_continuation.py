"""tmafm.continuation: the stroboscopic map's monodromy matrix against finite differences,
periodic orbits and their multipliers against brute-force runs, folds and period doublings
against sweeps, reproducibility, and typed errors (docs/continuation.md)."""

from pathlib import Path

import numpy as np
import pytest

import tmafm
from tmafm import continuation as cont

BISTABLE = str(Path(__file__).resolve().parents[1] / "inputs" / "sweeps" / "bistable_n2.nml")


def _settled(model, periods=80, rtol=1e-9):
    """A state near the attractor reached from rest: the map iterated `periods` times."""
    y = np.zeros(2 * model.n_modes)
    for _ in range(periods):
        y = cont.periodic_map(model, y, 1, rtol).y
    return y


# --- The monodromy matrix equals the finite-difference Jacobian of the map -----------------

@pytest.mark.parametrize("name, overrides", [
    ("hertz", {"scene": {"delta_hat": 0.0005, "alpha4": 0.0}}),
    ("dmt", {"scene": {"delta_hat": 0.0005, "alpha4": 0.0}, "model": {"contact_law": "dmt"}}),
    ("damped", {"scene": {"delta_hat": 0.0005, "alpha4": 0.4}}),
    ("damped_dmt", {"scene": {"delta_hat": 0.0005, "alpha4": 0.4}, "model": {"contact_law": "dmt"}}),
    # a liquid: per-mode added mass and damping, so the damping block is not alpha3 M^-1
    ("damped_liquid", {"scene": {"delta_hat": 0.0005, "alpha4": 0.4, "medium_mass": 0.02,
                                 "medium_reynolds": 200.0}}),
])
def test_monodromy_equals_finite_differences(name, overrides):
    """Central differences of P with step h = 1e-5 of the state's size: truncation error
    O(h^2) ~ 1e-10 and the map's tolerance rtol/h ~ 1e-8 relative, against the 1e-6 asked."""
    model = tmafm.Model(BISTABLE, **overrides)
    y = _settled(model)
    out = cont.periodic_map(model, y, 1, 1e-13)
    assert out.stats["contacts"] == 1  # a tapping orbit: one contact begun, with its switches
    assert out.stats["gap_min"] < 0 < out.stats["gap_max"]
    h = 1e-5 * np.max(np.abs(y))
    fd = np.empty_like(out.monodromy)
    for j in range(len(y)):
        e = np.zeros_like(y)
        e[j] = h
        fd[:, j] = (cont.periodic_map(model, y + e, 1, 1e-13).y
                    - cont.periodic_map(model, y - e, 1, 1e-13).y) / (2 * h)
    error = np.max(np.abs(out.monodromy - fd)) / np.max(np.abs(out.monodromy))
    assert error <= 1e-6, (name, error)


def test_free_orbit_multipliers_are_exp_of_the_free_system():
    """An orbit that never touches (bistable_n2 far from the sample): its monodromy matrix is
    exp(A T), so its multipliers are exp(lambda_k T) with lambda_k the eigenvalues of the free
    system A = [0 I; -M^-1 Lambda, -alpha3 M^-1], built here from the model's M and Lambda."""
    model = tmafm.Model(BISTABLE, scene={"delta_hat": 0.01})
    orbit = cont.periodic_orbit(model, np.zeros(4))
    assert orbit.stats["contacts"] == 0 and orbit.stable
    n = model.n_modes
    inv = np.linalg.inv(model.mass)
    a = np.block([[np.zeros((n, n)), np.eye(n)],
                  [-inv @ np.diag(model.eigen), -model.scene["alpha3"] * inv]])
    period = 2 * np.pi / model.scene["omega"]
    expected = np.exp(np.linalg.eigvals(a) * period)
    got = orbit.multipliers
    for mu in expected:
        assert np.min(np.abs(got - mu)) <= 1e-12 * max(1.0, abs(mu))


# --- Periodic orbits against brute-force runs -----------------------------------------------

def _brute_force(base, key_overrides, y_start, periods=300, rtol=1e-12):
    """The state at the last period boundary of a long flight_exact run from y_start."""
    n = len(y_start) // 2
    obs = tmafm.observe(base, max_periods=periods, stop_at_steady=False, steady_tol=1e-12,
                        solver={"method": "flight_exact", "rtol": rtol, "atol": 1e-16},
                        initial={"a0": list(y_start[:n]), "adot0": list(y_start[n:])},
                        **key_overrides)
    return obs.final_state, obs.poincare


def _coarse_sweep():
    grid = np.linspace(8e-3, 0.0, 41)
    return grid, tmafm.approach(BISTABLE, delta_hat=grid, workers=1)


@pytest.fixture(scope="module")
def bistable_sweep():
    return _coarse_sweep()


def test_bistable_approach_fold_brackets_the_sweep_jump(bistable_sweep):
    """From the free branch towards the sample: grazing, then the fold where the approach
    sweep jumps, within one grid step; the stable points equal brute-force steady states."""
    grid, sweep = bistable_sweep
    step = grid[0] - grid[1]
    jump = np.flatnonzero(sweep["jump"].sel(direction="approach").values)
    assert len(jump) == 1
    before, after = grid[jump[0] - 1], grid[jump[0]]
    # From the approach sweep's state before the jump: the free branch (a run from rest at
    # the same offset lands on the tapping branch).
    y0 = sweep["final_state"].sel(direction="approach").values[jump[0] - 1]
    ds = tmafm.continuation(BISTABLE, "scene.delta_hat", before, after, y0=y0, ds=0.05,
                            ds_max=0.1, max_points=60)
    labels = list(ds["label"].values)
    assert "grazing" in labels and "fold" in labels
    fold = float(ds["scene.delta_hat"].values[labels.index("fold")])
    assert after - step <= fold <= before + step
    # The fold: one multiplier at +1 to the location's tolerance.
    k = labels.index("fold")
    mu = ds["multiplier_re"].values[k] + 1j * ds["multiplier_im"].values[k]
    assert np.min(np.abs(mu - 1)) < 1e-5
    # Grazing: the orbit's minimum gap through zero (relative to the stroke).
    g = labels.index("grazing")
    assert abs(ds["min_gap"].values[g]) < 1e-5 * ds["amplitude"].values[g]
    # Stable points against long brute-force runs started off the orbit (1e-3 of its size).
    stable = np.flatnonzero(ds["stable"].values & (ds["label"].values == ""))
    for i in stable[:: max(1, len(stable) // 2)][:2]:
        y = ds["state"].values[i, 0]
        value = float(ds["scene.delta_hat"].values[i])
        final, _ = _brute_force(BISTABLE, {"scene": {"delta_hat": value}},
                                y * (1 + 1e-3), periods=200)
        assert np.max(np.abs(final - y)) <= 1e-8 * np.max(np.abs(y))


def test_bistable_retract_fold_on_the_period_two_branch(bistable_sweep):
    """Back from the sample the retract sweep runs period-2 motions and jumps at the fold of
    the period-2 branch: the fold lies within one grid step of the jump."""
    grid, sweep = bistable_sweep
    step = grid[0] - grid[1]
    retract = sweep.sel(direction="retract")
    jump = np.flatnonzero(retract["jump"].values)
    assert len(jump) == 1
    # Retract runs the grid backwards: a jump flagged at i lies between grid[i + 1] and grid[i].
    low, high = grid[jump[0] + 1], grid[jump[0]]
    two = np.flatnonzero((retract["period"].values == 2) & (grid < low))
    start = grid[two[0]]
    ds = tmafm.continuation(BISTABLE, "scene.delta_hat", start, high + step, period=2,
                            y0=retract["final_state"].values[two[0]], ds=0.05, ds_max=0.2,
                            max_points=100, switch=False)
    labels = list(ds["label"].values)
    assert "fold" in labels
    fold = float(ds["scene.delta_hat"].values[labels.index("fold")])
    assert low - step <= fold <= high + step
    assert ds["stable"].values[0]


def test_period_doubling_matches_the_bifurcation_diagram():
    """Fig. 4's scene in alpha2: the period-1 branch doubles; brute-force runs are period-1
    just below the doubling and period-2 above it, on the period-2 branch born there."""
    config = tmafm.Config(str(Path(BISTABLE).parents[1] / "fig4a.nml"))
    ds = tmafm.continuation(config, "scene.alpha2", 1.05e-3, 1.5e-3, ds=0.1, ds_max=0.2,
                            max_points=60, max_period=2, settle=300)
    labels = ds["label"].values
    pd = np.flatnonzero((labels == "period_doubling") & (ds["period"].values == 1))
    assert len(pd) == 1
    value = float(ds["scene.alpha2"].values[pd[0]])
    mu = ds["multiplier_re"].values[pd[0]] + 1j * ds["multiplier_im"].values[pd[0]]
    assert np.min(np.abs(mu + 1)) < 1e-6
    assert 1.05e-3 < value < 1.5e-3
    # The period-2 branch born there reaches alpha2 = 1.5e-3: its orbit there, refined by Newton
    # at exactly 1.5e-3, is the attractor brute force reaches from the period-1 orbit.
    two = np.flatnonzero(ds["period"].values == 2)
    assert len(two) > 0
    last = two[np.argmax(ds["scene.alpha2"].values[two])]
    model = tmafm.Model(config, scene={"alpha2": 1.5e-3})
    orbit = cont.periodic_orbit(model, ds["state"].values[last, :2], period=2)
    assert orbit.stable
    start = ds["state"].values[pd[0], 0]
    _, poincare = _brute_force(config, {"scene": {"alpha2": 1.5e-3}}, start, periods=150,
                               rtol=1e-11)
    scale = np.max(np.abs(orbit.states))
    for row in poincare[-2:]:
        assert np.min(np.max(np.abs(orbit.states - row), axis=1)) <= 1e-7 * scale
    # and below the doubling (the branch's start, its multipliers within 0.9: 250 periods
    # shrink the 1e-3 start error below 1e-12), brute force reaches the period-1 orbit.
    assert ds["stable"].values[0] and ds["period"].values[0] == 1
    below = ds["state"].values[0, 0]
    _, poincare = _brute_force(config, {"scene": {"alpha2": 1.05e-3}}, below * 1.001, periods=250,
                               rtol=1e-11)
    assert np.max(np.abs(poincare[-1] - below)) <= 1e-7 * scale


# --- Reproducibility --------------------------------------------------------------------

def test_branch_through_a_fold_is_reproducible_and_independent_of_workers():
    """A branch through the approach fold and back, twice in this process and once with each
    branch in its own process: the Datasets are identical to the bit."""
    kwargs = dict(ds=0.05, ds_max=0.05, max_points=24, switch=False)
    y0 = tmafm.continuation.periodic_orbit(
        tmafm.Model(BISTABLE, scene={"delta_hat": 1.995e-3}), np.zeros(4)).states[0]
    runs = [tmafm.continuation(BISTABLE, "scene.delta_hat", 1.995e-3, 1.975e-3, y0=[y0, y0 * 1.01],
                               workers=w, **kwargs) for w in (1, 1, 2)]
    assert "fold" in list(runs[0]["label"].values)
    assert runs[0].identical(runs[1])
    assert runs[0].identical(runs[2])


# --- Bad arguments raise typed exceptions ------------------------------------------------

@pytest.mark.parametrize("call, error", [
    (lambda: tmafm.continuation(BISTABLE, "scene.nope", 0.0, 1e-3), tmafm.InputError),
    (lambda: tmafm.continuation(BISTABLE, "scene.delta_hat", 1e-3, 1e-3), tmafm.InputError),
    (lambda: tmafm.continuation(BISTABLE, "scene.delta_hat", "a", 1e-3), tmafm.InputTypeError),
    (lambda: tmafm.continuation(BISTABLE, "scene.delta_hat", 0.0, 1e-3, period=0),
     tmafm.InputTypeError),
    (lambda: tmafm.continuation(BISTABLE, "scene.delta_hat", 0.0, 1e-3, y0=[1.0, 2.0]),
     tmafm.InputError),
    (lambda: tmafm.continuation(BISTABLE, "scene.delta_hat", 0.0, 1e-3, workers="x"),
     tmafm.InputTypeError),
    (lambda: tmafm.continuation(BISTABLE, "scene.alpha2", 0.0, -1.0), tmafm.InputError),
    (lambda: tmafm.continuation(BISTABLE, "scene.delta_hat", 0.0, 1e-3, rtol=-1),
     tmafm.InputError),
    (lambda: cont.periodic_map(tmafm.Model(BISTABLE), np.zeros(4), 0), tmafm.InputTypeError),
    (lambda: cont.periodic_map(tmafm.Model(BISTABLE), np.zeros(3)), tmafm.InputError),
    (lambda: cont.periodic_map(tmafm.Model(BISTABLE), [np.nan] * 4), tmafm.InputError),
    (lambda: cont.periodic_orbit(tmafm.Model(BISTABLE), np.zeros(4), period=2.5),
     tmafm.InputTypeError),
])
def test_bad_arguments_raise_typed_errors(call, error):
    with pytest.raises(error):
        call()


def test_si_observables_of_a_physical_input():
    """A physical key (&physical drive_amplitude) is continued like any other, and the length
    observables come in SI-derived units too: times the gap d of the input (5 um = 5000 nm)."""
    base = tmafm.Config("physical_polystyrene")
    f = base.to_dict()["physical"]["drive_amplitude"]
    gap = base.to_dict()["physical"]["gap"]
    ds = tmafm.continuation(base, "physical.drive_amplitude", f, 1.02 * f, max_points=3,
                            switch=False, settle=150)
    assert ds["min_gap_si"].attrs["units"] == "nm"
    np.testing.assert_allclose(ds["min_gap_si"].values, ds["min_gap"].values * gap * 1e9,
                               rtol=1e-14)
    assert np.all(np.diff(ds["physical.drive_amplitude"].values) > 0)


def test_the_si_lengths_take_each_points_own_gap():
    """Continued along the distance Z, each point's SI lengths use its own gap d = g0 + Z/cos(theta)
    (the base input's Z is 25 nm here): the largest and smallest gap at Z = 12 nm equal a long
    run's located ones there (tmafm.observe) to 1e-6 of the stroke (the base's d was 1e-3 off)."""
    ds = tmafm.continuation("tapping_polystyrene", "physical.tip_sample_distance", 12e-9, 11e-9)
    v = tmafm.observe("tapping_polystyrene", max_periods=4000, steady_tol=1e-9,
                      physical={"tip_sample_distance": 12e-9}).steady_values(physical=True)
    stroke = v["max_gap"] - v["min_gap"]
    assert float(ds["max_gap_si"][0]) == pytest.approx(v["max_gap"], abs=1e-6 * stroke)
    assert float(ds["min_gap_si"][0]) == pytest.approx(v["min_gap"], abs=1e-6 * stroke)

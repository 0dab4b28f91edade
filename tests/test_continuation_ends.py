"""tmafm.continuation (issue 28): every branch end has a reason, non-smooth points are crossed
(the tapping_polystyrene S-curve in one call, its folds against 0.005 nm warm-started sweeps;
Fig. 4's period-1 branch past a change of its contact sequence), restarts from a Dataset point
(direction at a fold, the period-2 switch at a doubling), and the refusals
(docs/continuation.md, sections 5-6)."""

import math
import warnings
from pathlib import Path

import numpy as np
import pytest

import tmafm
from tmafm import continuation as cont
from tmafm.continuation import plots

INPUTS = Path(__file__).resolve().parents[1] / "inputs"
BISTABLE = str(INPUTS / "sweeps" / "bistable_n2.nml")
FIG4 = str(INPUTS / "fig4a.nml")
KEY_Z = "physical.tip_sample_distance"
#: The fine sweeps' step (m) and half width around each fold.
FINE_STEP, FINE_HALF = 0.005e-9, 0.03e-9


def _tapping():
    return tmafm.Config("tapping_polystyrene", physical={"drive_frequency": 301e3})


@pytest.fixture(scope="module")
def s_curve():
    with warnings.catch_warnings():
        warnings.simplefilter("error", tmafm.ContinuationWarning)
        return cont.continuation(_tapping(), KEY_Z, 30e-9, 14e-9, max_points=400, switch=False)


def _fine_sweep(ds, fold_index, direction):
    """A warm-started sweep in FINE_STEP steps through the fold from the continued stable orbit
    nearest it on its stable side (approach: above it, retract: below it); the two Z values
    the amplitude jumps between (the largest amplitude step by far)."""
    z = ds[KEY_Z].values
    fold = z[fold_index]
    sign = 1.0 if direction == "approach" else -1.0
    stable = ds["stable"].values & (ds["label"].values == "")
    candidates = [i for i in range(len(z)) if stable[i] and sign * (z[i] - fold) >= FINE_HALF
                  and ds["contacts"].values[i] == 1]
    first = min(candidates, key=lambda i: abs(z[i] - fold))
    state = ds["state"].values[first, 0]
    n = len(state) // 2
    grid = z[first] - sign * FINE_STEP * np.arange(0, int(round(abs(z[first] - fold) / FINE_STEP))
                                                   + int(FINE_HALF / FINE_STEP) + 1)
    base = tmafm.Config(_tapping(), initial={"a0": list(state[:n]), "adot0": list(state[n:])})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", tmafm.UnsteadyWarning)
        out = tmafm.approach(base, z=grid, retract=False, max_periods=6000, workers=1)
    amplitude = out.sel(direction="approach")["amplitude"].values
    steps = np.abs(np.diff(amplitude))
    k = int(np.argmax(steps))
    assert steps[k] > 20 * np.max(np.delete(steps, k))
    return sorted((grid[k], grid[k + 1]))


def test_s_curve_in_one_call_through_grazing_and_both_folds(s_curve):
    """tapping_polystyrene driven at 301 kHz, continued in Z from 30 nm to 14 nm in one call:
    the free orbit grazes the sample, the branch is posed again past the grazing, turns at the
    lower fold (where an approach jumps), runs back up unstable to the upper fold (where a
    retract jumps) and down to 14 nm; the branch ends at stop, with no warning.  Each fold lies
    within one step of where a 0.005 nm warm-started sweep jumps."""
    ds = s_curve
    labels = list(ds["label"].values)
    assert labels.count("grazing") == 1 and labels.count("fold") == 2
    assert ds["end_reason"].values[-1] == "stop" and ds[KEY_Z].values[-1] <= 14e-9
    z = ds[KEY_Z].values
    g = labels.index("grazing")
    # The grazing orbit, the last free one, is located to the smallest step (ds_min = 1e-4 ds
    # of the scaled arclength, 1e-4 x 0.02 x 16 nm in Z; the free orbit's smallest gap moves
    # with Z one to one): it touches no more than that far away.
    assert 0 <= ds["min_gap_si"].values[g] <= 1e-4 * 0.02 * 16.0
    assert 19.2e-9 < z[g] < 19.4e-9
    folds = sorted(i for i, lab in enumerate(labels) if lab == "fold")
    lower, upper = sorted(folds, key=lambda i: z[i])
    assert z[lower] < z[g] < z[upper]
    for index, direction in ((lower, "approach"), (upper, "retract")):
        low, high = _fine_sweep(ds, index, direction)
        assert low - FINE_STEP <= z[index] <= high + FINE_STEP, (direction, z[index], low, high)
        mu = ds["multiplier_re"].values[index] + 1j * ds["multiplier_im"].values[index]
        assert np.min(np.abs(mu - 1)) < 1e-6


def test_grazing_reports_stability_on_either_side(s_curve):
    """At the grazing point the multipliers jump: just before it (the free orbit) they are the
    free system's, exp(lambda_k T), computed here from the model's matrices; just after it
    (the first orbit in contact past it) the largest is another one, and the Dataset states
    both."""
    ds = s_curve
    g = int(np.flatnonzero(ds["label"].values == "grazing")[0])
    model = tmafm.Model(_tapping(), physical={"tip_sample_distance": float(ds[KEY_Z].values[g])})
    n = model.n_modes
    inv = np.linalg.inv(model.mass)
    a = np.block([[np.zeros((n, n)), np.eye(n)],
                  [-inv @ np.diag(model.eigen), -model.scene["alpha3"] * inv]])
    free = np.max(np.abs(np.exp(np.linalg.eigvals(a) * 2 * np.pi / model.scene["omega"])))
    before = float(ds["max_multiplier_before"].values[g])
    after = float(ds["max_multiplier_after"].values[g])
    assert abs(before - free) <= 1e-9
    assert abs(after - before) > 1e-2
    # docs/continuation.md section 9: just past grazing unstable, the first orbit the branch
    # goes on with (past the point) stable.
    assert after > 1 and ds["stable"].values[g + 1] and ds["contacts"].values[g + 1] == 1
    assert math.isnan(ds["max_multiplier_before"].values[0])


@pytest.fixture(scope="module")
def fig4_end():
    with warnings.catch_warnings():
        warnings.simplefilter("error", tmafm.ContinuationWarning)
        return cont.continuation(FIG4, "scene.alpha2", 5e-4, 2e-3, switch=False, max_points=200)


def test_fig4_period_one_branch_reaches_its_end_past_a_non_smooth_point(fig4_end):
    """Fig. 4's period-1 branch in alpha2 reaches 2e-3: at alpha2 = 1.9632e-3 its contact
    sequence changes (the corrector fails there, the orbit at the predicted point has another
    number of contacts), the point is labelled and the branch posed again past it.  The
    multipliers on either side agree with orbits solved by Newton alone (periodic_orbit)
    1e-7 before it and 1e-6 after it."""
    ds = fig4_end
    labels = list(ds["label"].values)
    assert labels.count("contact_sequence") == 1
    assert ds["end_reason"].values[-1] == "stop" and ds["scene.alpha2"].values[-1] >= 2e-3
    k = labels.index("contact_sequence")
    value = float(ds["scene.alpha2"].values[k])
    assert 1.963e-3 < value < 1.9634e-3
    y = ds["state"].values[k, 0]
    before = cont.periodic_orbit(tmafm.Model(FIG4, scene={"alpha2": value - 1e-7}), y)
    assert abs(np.max(np.abs(before.multipliers)) - ds["max_multiplier_before"].values[k]) < 1e-3
    # Past it, Newton alone from the point's orbit reaches the orbit the branch went on with.
    nxt = k + 1
    after = cont.periodic_orbit(tmafm.Model(FIG4, scene={"alpha2": float(
        ds["scene.alpha2"].values[nxt])}), y, max_iter=60)
    np.testing.assert_allclose(np.abs(after.multipliers), ds["multiplier_abs"].values[nxt],
                               rtol=1e-6)
    # docs/continuation.md section 8: "the largest |mu| jumps from 1.27 to 1.86, a real
    # multiplier below -1 on both sides"
    assert round(float(ds["max_multiplier_before"].values[k]), 2) == 1.27
    assert round(float(ds["max_multiplier_after"].values[k]), 2) == 1.86
    for i in (k, nxt):
        assert ds["multiplier_re"].values[i, 0] < -1 and ds["multiplier_im"].values[i, 0] == 0


def test_an_early_end_warns_and_says_why():
    """A branch cut by max_points ends with end_reason 'max_points' and a ContinuationWarning
    naming it; the corrector's diagnostics are there for every point."""
    with pytest.warns(tmafm.ContinuationWarning, match="max_points"):
        ds = cont.continuation(BISTABLE, "scene.delta_hat", 8e-3, 0.0, max_points=4, switch=False)
    assert list(ds["end_reason"].values) == ["", "", "", "max_points"]
    assert ds["label"].values[-1] == "end"
    assert np.all(ds["newton_iterations"].values[1:] >= 1)
    assert np.all(ds["step"].values[1:] > 0)


@pytest.fixture(scope="module")
def bistable():
    with warnings.catch_warnings():
        warnings.simplefilter("error", tmafm.ContinuationWarning)
        return cont.continuation(BISTABLE, "scene.delta_hat", 8e-3, 0.0, max_points=400)


def test_bistable_diagram_each_branch_once_each_end_with_a_reason(bistable):
    """The whole bistable_n2 diagram: one period-2 branch (born at the first doubling, meeting
    its parent at the second), every branch ending at stop or where it rejoins its parent."""
    ds = bistable
    assert set(np.unique(ds["branch"].values[ds["period"].values == 2])) == {1000}
    ends = ds["end_reason"].values[ds["end_reason"].values != ""]
    assert sorted(ends) == ["rejoined", "stop"]
    assert list(ds["label"].values).count("period_doubling") == 2


def test_restart_at_a_fold_in_either_direction(bistable):
    """From the approach fold: direction 1 goes on the way the branch went (onto the unstable
    side), -1 back along the stable side; both start with the fold's orbit."""
    ds = bistable
    k = int(np.flatnonzero(ds["label"].values == "fold")[0])
    value = float(ds["scene.delta_hat"].values[k])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", tmafm.ContinuationWarning)
        runs = {d: cont.continuation(BISTABLE, "scene.delta_hat", None,
                                     5e-3 if d > 0 else 1.9e-3, y0=ds.isel(point=k),
                                     direction=d, max_points=3, switch=False)
                for d in (1, -1)}
    for d, run in runs.items():
        assert run["scene.delta_hat"].values[0] == value
        np.testing.assert_allclose(run["state"].values[0, 0], ds["state"].values[k, 0],
                                   rtol=0, atol=1e-8 * np.max(np.abs(ds["state"].values[k, 0])))
    assert not runs[1]["stable"].values[2] and runs[-1]["stable"].values[2]


def test_restart_at_a_doubling_switches_to_the_period_two_branch(bistable):
    """From the first period doubling with period = 2: the doubled branch born there, whose
    fold is the full diagram's period-2 fold to 1e-6 relative; period = 2 from a period-1
    start state is refused (the orbit found is period 1 run twice)."""
    ds = bistable
    k = int(np.flatnonzero(ds["label"].values == "period_doubling")[0])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", tmafm.ContinuationWarning)
        two = cont.continuation(BISTABLE, "scene.delta_hat", None, 4.5e-3, y0=ds.isel(point=k),
                                period=2, max_points=80, switch=False)
    assert np.all(two["period"].values == 2)
    state = two["state"].values
    assert np.all(np.max(np.abs(state[:, 0] - state[:, 1]), axis=1) > 0)
    fold = two["scene.delta_hat"].values[two["label"].values == "fold"]
    full = ds["scene.delta_hat"].values[(ds["label"].values == "fold") & (ds["period"].values == 2)]
    assert len(fold) == 1 and len(full) == 1
    assert abs(fold[0] - full[0]) <= 1e-6 * full[0]
    with pytest.raises(tmafm.InputError, match="period = 2"):
        cont.continuation(BISTABLE, "scene.delta_hat", 6e-3, 5e-3, y0=ds["state"].values[0, 0],
                          period=2, max_points=3)


@pytest.mark.parametrize("kwargs, error", [
    ({"direction": 0}, tmafm.InputTypeError),
    ({"direction": "up"}, tmafm.InputTypeError),
    ({"cross": "yes"}, tmafm.InputTypeError),
])
def test_bad_new_arguments(kwargs, error):
    with pytest.raises(error):
        cont.continuation(BISTABLE, "scene.delta_hat", 6e-3, 5e-3, max_points=2, **kwargs)


def test_bad_restarts(bistable):
    ds = bistable
    k = int(np.flatnonzero(ds["label"].values == "fold")[0])
    with pytest.raises(tmafm.InputError, match="period = 2"):
        cont.continuation(BISTABLE, "scene.delta_hat", None, 5e-3, y0=ds.isel(point=k), period=2)
    with pytest.raises(tmafm.InputError, match="start"):
        cont.continuation(BISTABLE, "scene.delta_hat", 1e-3, 5e-3, y0=ds.isel(point=k))
    with pytest.raises(tmafm.InputError, match="key"):
        cont.continuation(BISTABLE, "scene.alpha2", None, 5e-3, y0=ds.isel(point=k))
    with pytest.raises(tmafm.InputError, match="one point"):
        cont.continuation(BISTABLE, "scene.delta_hat", None, 5e-3, y0=ds.isel(point=[k, k + 1]))


def test_bistable_grazing_stability_either_side_by_iterating_the_map(bistable):
    """Section 7's grazing row, checked by iterating the map from a perturbed orbit (not by the
    monodromy matrix): 1e-11 past the grazing point in delta_hat the orbit in contact is
    unstable (a perturbation of 1e-9 of its size grows over 40 periods), 1e-8 past it stable
    (it shrinks at about the 0.76 of the next points); before it, free, stable."""
    ds = bistable
    g = int(np.flatnonzero(ds["label"].values == "grazing")[0])
    value = float(ds["scene.delta_hat"].values[g])
    y = ds["state"].values[g, 0]
    rates = {}
    for offset in (-1e-11, -1e-8, 1e-8):
        model = tmafm.Model(BISTABLE, scene={"delta_hat": value + offset})
        orbit = cont.periodic_orbit(model, y, rtol=1e-12, tol=1e-12)
        x = orbit.states[0] + 1e-9 * np.max(np.abs(orbit.states[0])) * np.array([1, 0.3, -0.2, 0.5])
        distance = []
        for _ in range(40):
            x = cont.periodic_map(model, x, 1, 1e-12).y
            distance.append(np.max(np.abs(x - orbit.states[0])))
        rates[offset] = (distance[-1] / distance[9]) ** (1 / 30)
    assert rates[-1e-11] > 1.0
    assert rates[-1e-8] < 0.8 and rates[1e-8] < 0.8
    assert ds["max_multiplier_before"].values[g] < 1 < ds["max_multiplier_after"].values[g]


def test_two_start_states_on_one_branch_trace_it_once():
    """Two start states that Newton takes to the same orbit: the branch is traced once; the
    second start keeps its first point, end_reason 'duplicate' naming the branch, and no
    warning (it is not an early end)."""
    model = tmafm.Model(BISTABLE, scene={"delta_hat": 6e-3})
    y = cont.periodic_orbit(model, np.zeros(4)).states[0]
    with warnings.catch_warnings():
        warnings.simplefilter("error", tmafm.ContinuationWarning)
        ds = cont.continuation(BISTABLE, "scene.delta_hat", 6e-3, 5e-3, y0=[y, y * 1.001],
                               max_points=40, switch=False, workers=1)
    second = ds.where(ds["branch"] == 1, drop=True)
    assert second.sizes["point"] == 1
    assert second["end_reason"].values[0] == "duplicate"
    assert "branch 0" in str(second["end_detail"].values[0])
    assert ds.where(ds["branch"] == 0, drop=True)["end_reason"].values[-1] == "stop"


def test_a_crossing_beyond_ds_is_not_found_and_the_end_says_so():
    """docs/continuation.md section 9: Fig. 4's branch from alpha2 = 1.9e-3 to 2e-3 (so ds is
    2e-6 in alpha2) cannot be posed again past its contact-sequence change (the orbit past it
    is out of Newton's reach within ds): it ends there, 'contact_sequence', with a warning."""
    with pytest.warns(tmafm.ContinuationWarning, match="contact_sequence"):
        ds = cont.continuation(FIG4, "scene.alpha2", 1.9e-3, 2e-3, switch=False, max_points=100)
    assert ds["end_reason"].values[-1] == "contact_sequence"
    assert 1.963e-3 < ds["scene.alpha2"].values[-1] < 1.9634e-3


def test_plot_branch_over_an_si_approach(s_curve):
    """plot_branch draws a branch continued in physical.tip_sample_distance over an SI
    approach (its axis z in m), the key with its unit, the SI lengths as the sweep's nm, one
    legend entry per branch."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", tmafm.UnsteadyWarning)
        sweep = tmafm.approach(_tapping(), z=[30e-9, 25e-9], retract=False, max_periods=50,
                               workers=1)
    fig, ax = plt.subplots()
    plots.plot_branch(s_curve, None, "min_gap_si", sweep=sweep, ax=ax)
    assert ax.get_xlabel() == "physical.tip_sample_distance [m]"
    assert ax.get_ylabel() == "min_gap_si [nm]"
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "branch 0 (period 1)" in labels and "brute force (min_gap)" in labels
    plt.close(fig)


def test_the_unstable_orbit_is_one_call_away(s_curve):
    """orbit_run: a run (the input's own solver, flight_exact at rtol 1e-9) from an unstable
    orbit of the S-curve's middle branch over one period comes back to its section state to
    1e-6 of the orbit's size (the run's tolerance times |mu| ~ 1.01 over one period); its
    smallest V_T is the orbit's min_gap to the same accuracy."""
    ds = s_curve
    middle = np.flatnonzero(~ds["stable"].values & (ds["label"].values == ""))
    k = int(middle[len(middle) // 2])
    assert ds["multiplier_abs"].values[k, 0] > 1
    result = cont.orbit_run(_tapping(), ds.isel(point=k))
    y = ds["state"].values[k, 0]
    n = len(y) // 2
    end = np.concatenate([result.a[-1], result.adot[-1]])
    assert np.max(np.abs(end - y)) <= 1e-6 * np.max(np.abs(y))
    assert abs(np.min(result.vt) - ds["min_gap"].values[k]) <= 1e-3 * ds["amplitude"].values[k]
    assert n == 3

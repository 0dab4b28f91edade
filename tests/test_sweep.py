"""tmafm.sweep and friends: grids, validation before any run, Dask = local, NetCDF, hysteresis,
attractor labels, the sweep-file command line."""

import subprocess
import sys

import numpy as np
import pytest

import tmafm
from tmafm import sweeps

xr = pytest.importorskip("xarray")

# A small, quick grid on the Fig. 2 scene (N = 2 to keep it cheap).
BASE = {"model": {"n_modes": 2, "contact_law": "hertz", "convention": "paper"},
        "initial": {"a0": [0.0, 0.0]},
        "solver": {"method": "flight_exact", "rtol": 1e-8, "tau_end": 10.0}}
QUICK = dict(max_periods=12, steady_tol=1e-5)
# The bistable scene of docs/sweeps.md (inputs/sweeps/bistable_n2.nml): N = 2, Omega = 3.8,
# above the first resonance.
BISTABLE = dict(BASE, scene={"omega": 3.8, "alpha2": 5e-4})


# --- Bad input: one clear error, and nothing runs ------------------------------------------

@pytest.fixture
def no_runs(monkeypatch):
    """Count every call into the core's observers; a sweep that validates first makes none."""
    from tmafm.sweeps import runs as observe_module  # the sweeps' calls into the core's observers
    calls = []

    def refuse(*args, **kwargs):
        calls.append(args)
        raise AssertionError("a run started before the sweep input was validated")

    monkeypatch.setattr(observe_module, "observe_batch", refuse)
    monkeypatch.setattr(observe_module, "observe_states", refuse)
    return calls


@pytest.mark.parametrize("axes, words", [
    ({"scene.delta_hatt": [0.1]}, ["scene.delta_hatt", "unknown key"]),
    ({"scenery.delta_hat": [0.1]}, ["scenery.delta_hat", "unknown group"]),
    ({"scene.delta_hat": []}, ["scene.delta_hat", "empty axis"]),
    ({"scene.omega": [2.0, 2.1], "scene.delta_hat": [0.1, 0.2, 5000.0]},
     ["delta_hat", "5000"]),
    ({"scene.alpha2": [1e-4, -1e-4]}, ["alpha2", "-0.0001"]),
    ({"model.n_modes": [2, 0.5]}, ["n_modes", "0.5"]),
])
def test_bad_sweep_input_fails_before_any_run(no_runs, axes, words):
    with pytest.raises(tmafm.InputError) as info:
        tmafm.sweep(BASE, axes, workers=1, **QUICK)
    message = str(info.value)
    assert "\n" not in message
    for word in words:
        assert word in message, message
    assert no_runs == []


def test_bad_continuation_and_basin_input_fail_before_any_run(no_runs):
    with pytest.raises(tmafm.InputError, match="delta_hat.*2000"):
        tmafm.approach(BASE, delta_hat=[0.5, 2000.0], **QUICK)
    with pytest.raises(tmafm.InputError, match="scene.omega.*empty axis"):
        tmafm.frequency_sweep(BASE, omega=[], **QUICK)
    with pytest.raises(tmafm.InputError, match="alpha2.*-1"):
        tmafm.approach(BASE, delta_hat=[0.5], curves={"scene.alpha2": [1e-3, -1.0]}, **QUICK)
    with pytest.raises(tmafm.InputError, match="a1.*empty axis"):
        tmafm.basin(BASE, a1=[], adot1=[0.0], **QUICK)
    with pytest.raises(tmafm.InputError, match="unknown key"):
        tmafm.bifurcation(BASE, "scene.omegaa", [1.0], **QUICK)
    assert no_runs == []


# --- Grids ---------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def grid():
    axes = {"scene.delta_hat": [0.0, 5e-4, 2e-3], "scene.alpha2": [5e-4, 1e-3]}
    return axes, tmafm.sweep(BASE, axes, workers=1, **QUICK)


def test_grid_dataset_matches_single_observations(grid):
    axes, ds = grid
    assert ds["amplitude"].dims == ("scene.delta_hat", "scene.alpha2")
    np.testing.assert_array_equal(ds["scene.delta_hat"].values, axes["scene.delta_hat"])
    for name in ("amplitude", "phase", "mean_deflection", "min_gap", "peak_force", "contact_time",
                 "contacts_per_period", "dissipated_energy", "period"):
        assert name in ds and "units" in ds[name].attrs or name == "period"
    # Every point is the observation of the base with that point's values.
    for i, delta in enumerate(axes["scene.delta_hat"]):
        for j, alpha2 in enumerate(axes["scene.alpha2"]):
            obs = tmafm.observe(tmafm.Config(BASE, scene={"delta_hat": delta, "alpha2": alpha2}),
                                **QUICK)
            steady = obs.steady_values()
            assert ds["amplitude"].values[i, j] == pytest.approx(steady["amplitude"], rel=1e-12)
            assert ds["period"].values[i, j] == obs.period
    # More drive, more amplitude, at every offset (a physical check that fails on a mixed grid).
    assert np.all(ds["amplitude"].isel({"scene.alpha2": 1}).values
                  > ds["amplitude"].isel({"scene.alpha2": 0}).values)


def test_local_threads_processes_and_dask_give_identical_datasets(grid):
    axes, local = grid
    two = tmafm.sweep(BASE, axes, workers=2, chunk=2, **QUICK)
    xr.testing.assert_identical(local, two)
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        on_dask = tmafm.sweep(BASE, axes, client=client, chunk=2, **QUICK)
        curves = dict(delta_hat=[4e-3, 2e-3, 1e-3], curves={"scene.alpha2": [4e-4, 5e-4]},
                      **QUICK)
        approach_on_dask = tmafm.approach(BISTABLE, client=client, **curves)
    xr.testing.assert_identical(local, on_dask)
    xr.testing.assert_identical(tmafm.approach(BISTABLE, workers=2, **curves), approach_on_dask)


def test_process_pool_gives_the_same_dataset(grid):
    axes, local = grid
    pooled = tmafm.sweep(BASE, axes, workers=2, backend="processes", chunk=3, **QUICK)
    xr.testing.assert_identical(local, pooled)


def test_netcdf_round_trip(grid, tmp_path):
    _, ds = grid
    path = sweeps.write_dataset(ds, tmp_path / "grid.nc")
    with xr.open_dataset(path) as back:
        xr.testing.assert_identical(ds, back.load())
    assert not list(tmp_path.glob(".*partial"))


def test_a_failed_run_is_recorded_and_the_others_kept():
    axes = {"solver.max_steps": [1_000_000, 40, 2_000_000]}
    ds = tmafm.sweep(BASE, axes, workers=2, chunk=3, **QUICK)
    assert ds["failed"].values.tolist() == [0, 1, 0]
    amplitude = ds["amplitude"].values
    assert np.isnan(amplitude[1]) and np.isfinite(amplitude[[0, 2]]).all()
    assert amplitude[0] == amplitude[2]  # the step budget does not change a run that fits in it
    assert ds.attrs["failures"] == 1 and "max_steps" in ds.attrs["first_failure"]
    assert "\n" not in ds.attrs["first_failure"]


def test_physical_base_gives_physical_variables():
    # (tests/test_sweep_units.py checks the values against Eq. (12)'s scales)
    ds = tmafm.sweep(tmafm.Config("physical_polystyrene", solver={"method": "flight_exact"}),
                     {"physical.drive_amplitude": [2e-9, 3e-9]}, workers=1, max_periods=4)
    assert ds["amplitude"].attrs["units"] == "nm" and "amplitude_nm" not in ds
    assert ds["amplitude"].values[1] > ds["amplitude"].values[0] > 1  # nm, not gap units


# --- Continuation: hysteresis --------------------------------------------------------------

def test_mark_jumps():
    flags = sweeps.mark_jumps(np.array([1.0, 1.01, 1.02, 0.3, 0.31]), 0.2)
    assert flags.tolist() == [False, False, False, True, False]
    # A steep but smooth branch is no jump; a step 3x its neighbours is.
    assert not sweeps.mark_jumps(np.arange(6.0)).any()
    assert sweeps.mark_jumps([0.0, 1.0, 2.0, 5.0, 6.0]).tolist() == [False, False, False, True,
                                                                     False]




@pytest.fixture(scope="module")
def hysteresis():
    deltas = np.linspace(8e-3, 1e-3, 15)
    return deltas, tmafm.approach(BISTABLE, delta_hat=deltas, workers=1, max_periods=200)


def test_approach_and_retract_show_two_branches_with_jumps_at_different_offsets(hysteresis):
    deltas, ds = hysteresis
    assert ds["direction"].values.tolist() == ["approach", "retract"]
    assert ds["amplitude"].dims == ("direction", "scene.delta_hat")
    amp = ds["amplitude"].values
    jump = ds["jump"].values.astype(bool)
    # Far from the sample both directions sit on the free oscillation, close to it on one branch.
    assert amp[0, 0] == pytest.approx(amp[1, 0], rel=1e-3)
    assert amp[0, -1] == pytest.approx(amp[1, -1], rel=1e-3)
    # Each direction jumps exactly once, the retract jump at a larger offset than the approach's.
    assert jump[0].sum() == 1 and jump[1].sum() == 1
    on_approach, on_retract = deltas[jump[0]][0], deltas[jump[1]][0]
    assert on_retract > on_approach
    # Between the jumps the two branches differ: retract stays in contact at a larger amplitude.
    between = (deltas > on_approach) & (deltas < on_retract)
    assert between.any()
    assert np.all(amp[1, between] > 1.5 * amp[0, between])
    assert np.all(ds["min_gap"].values[1, between] < 0) and np.all(
        ds["min_gap"].values[0, between] > 0)


def test_warm_start_carries_the_state(hysteresis):
    deltas, ds = hysteresis
    # The approach's first point starts from the base's rest state; every later point from the
    # previous final state, so a cold run at a point between the jumps lands on the free branch
    # while the retract (warm) run there is in contact.
    states = ds["final_state"].values
    assert states.shape == (2, deltas.size, 4)
    cold = tmafm.observe(tmafm.Config(BISTABLE, scene={"delta_hat": float(deltas[10])}),
                         max_periods=200)
    assert cold.steady_values()["amplitude"] == pytest.approx(
        ds["amplitude"].values[0, 10], rel=1e-3)
    assert ds["amplitude"].values[1, 10] > 1.5 * ds["amplitude"].values[0, 10]


# --- Bifurcation and basins -------------------------------------------------------------

# The Figs. 4-5 scene with a method that gives the observers dense output.
FIG4 = tmafm.Config("fig4a", solver={"method": "flight_exact", "rtol": 1e-8})
FIG5 = tmafm.Config("fig5a", solver={"method": "flight_exact", "rtol": 1e-8})


def test_label_attractors_up_to_cyclic_shift():
    p1 = np.array([[1.0, 0.0]])
    p2 = np.array([[1.0, 0.5], [2.0, -0.5]])
    alternating = np.array([[1.0, 0.0], [1.0 + 1e-9, 0.0]])  # a period-1 point called period 2
    labels, known = sweeps.label_attractors(
        [p1, p2, p2[::-1].copy(), p1 + 1e-9, p1 + 0.1, np.zeros((1, 2)), p2 + 1e-9, alternating],
        [1, 2, 2, 1, 1, 0, 2, 2], tol=1e-6)
    assert labels.tolist() == [0, 1, 1, 0, 2, -1, 1, 0]
    assert len(known) == 3
    assert not sweeps.same_orbit(p2, np.array([[1.0, 0.5], [2.0, -0.4]]), 1e-6)


def test_basin_tells_the_two_branches_of_the_bistable_scene_apart():
    scene = dict(BISTABLE, scene=dict(BISTABLE["scene"], delta_hat=3e-3))
    ds = tmafm.basin(scene, a1=[-3e-3, 0.0, 1e-3], adot1=[-5e-3, 0.0], workers=2,
                     max_periods=300, steady_tol=1e-4, tol=1e-2, observables=["amplitude"])
    labels = ds["attractor"].values.ravel()
    amplitude = ds["amplitude"].values.ravel()
    assert ds.attrs["attractors"] == 2 and set(labels.tolist()) == {0, 1}
    assert np.all(ds["attractor_period"].values == 1)
    # Same label <=> same steady amplitude: the free oscillation (~2.0e-3) or tapping (~4.1e-3).
    for i in range(labels.size):
        for j in range(labels.size):
            same = abs(amplitude[i] - amplitude[j]) < 1e-3 * amplitude.max()
            assert (labels[i] == labels[j]) == same
    assert amplitude[labels == labels[0]].min() > 1.5 * amplitude[labels != labels[0]].max()


def test_basin_of_the_papers_fig4_scene_has_one_attractor():
    # docs/reproduction.md: a1(0) = 0, 3e-4, 7e-4 all reach one period-1 attractor (the paper's
    # period-2 motions do not reproduce); the classifier may call a point period-2 while its
    # transient still alternates, which label_attractors reduces to the minimal period.
    ds = tmafm.basin(FIG4, a1=[0.0, 3e-4, 7e-4], adot1=[0.0], workers=2, max_periods=100)
    assert ds["attractor"].values.ravel().tolist() == [0, 0, 0]
    assert ds.attrs["attractors"] == 1
    assert np.all(ds["attractor_period"].values == 1)
    obs = tmafm.observe(FIG4, initial={"a0": [3e-4, 0.0, 0.0]}, max_periods=100)
    orbit = ds["attractor_orbit_0"].values
    assert np.max(np.abs(orbit[0] - obs.poincare[-1])) < 1e-3 * np.max(np.abs(orbit))


def test_bifurcation_points_sample_the_orbit():
    ds = tmafm.bifurcation(FIG5, "scene.alpha2", [5e-4, 1e-3], periods_kept=8, workers=1,
                           max_periods=100, stop_at_steady=False)
    assert ds["vt"].dims == ("scene.alpha2", "kept")
    vt = ds["vt"].values[0]
    # Period 1 (docs/reproduction.md): the kept section points are one point.
    assert np.ptp(vt) < 1e-6 * np.abs(vt).max()
    # Each value is its own run: the section point moves with the drive amplitude.
    assert abs(ds["vt"].values[1, -1] - vt[-1]) > 1e-3 * np.abs(vt).max()
    # V_T at the section is p^T a + delta_hat (the drive term vanishes at the period boundary).
    config = FIG5
    obs = tmafm.observe(config, max_periods=100, stop_at_steady=False)
    a_last = obs.poincare[-1, :config.n_modes]
    expected = config.model().contact(0.0, a_last).vt
    assert vt[-1] == pytest.approx(expected, rel=1e-12, abs=1e-15)


# --- Sweep files and the command line ------------------------------------------------------

def test_sweep_file_command_line(tmp_path):
    spec = tmp_path / "grid.nml"
    spec.write_text("&sweep\n  kind = 'grid', base = 'fig2_n1', key = 'scene.delta_hat'\n"
                    "  start = 0.0, stop = 2e-3, count = 3, max_periods = 8\n"
                    "  method = 'flight_exact'\n/\n")
    out = tmp_path / "grid.nc"
    done = subprocess.run([sys.executable, "-m", "tmafm.sweeps", str(spec), "-o", str(out),
                           "--workers", "1"], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    with xr.open_dataset(out) as ds:
        assert ds["amplitude"].dims == ("scene.delta_hat",)
        np.testing.assert_allclose(ds["scene.delta_hat"].values, [0.0, 1e-3, 2e-3])
        direct = tmafm.sweep(tmafm.Config("fig2_n1", solver={"method": "flight_exact"}),
                             {"scene.delta_hat": [0.0, 1e-3, 2e-3]}, workers=1, max_periods=8)
        np.testing.assert_array_equal(ds["amplitude"].values, direct["amplitude"].values)
    assert out.with_suffix(".png").stat().st_size > 1000


@pytest.mark.parametrize("text, words", [
    ("&sweep kind = 'grid', base = 'fig2_n1', colour = 3 /\n", ["colour", "unknown key"]),
    ("&sweep kind = 'spiral', base = 'fig2_n1' /\n", ["kind", "spiral"]),
    ("&sweep kind = 'grid', base = 'fig2_n1', key = 'scene.delta_hat', start = 0, stop = 1, "
     "count = 0 /\n", ["count", "0"]),
    ("&sweep kind = 'grid', base = 'fig2_n1', key = 'scene.xi0', start = 0.5, stop = 2, "
     "count = 2 /\n", ["xi0", "2"]),
])
def test_bad_sweep_file_is_one_line_and_writes_nothing(tmp_path, text, words):
    spec = tmp_path / "bad.nml"
    spec.write_text(text)
    done = subprocess.run([sys.executable, "-m", "tmafm.sweeps", str(spec)], capture_output=True,
                          text=True, timeout=300, cwd=tmp_path)
    assert done.returncode == 2
    message = done.stderr.strip()
    assert message.count("\n") == 0 and message.startswith("tmafm.sweeps: error:")
    for word in words:
        assert word in message, message
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.nml"]


def test_progress_bar_counts_every_run(capsys):
    tmafm.sweep(BASE, {"scene.delta_hat": [0.0, 1e-3, 2e-3]}, workers=1, chunk=1, progress=True,
                **QUICK)
    err = capsys.readouterr().err
    assert "3/3" in err and "sweep" in err


def test_continuation_dataset_round_trips_through_netcdf(hysteresis, tmp_path):
    _, ds = hysteresis
    path = sweeps.write_dataset(ds, tmp_path / "approach.nc")
    with xr.open_dataset(path) as back:
        xr.testing.assert_identical(ds, back.load())
        assert back["direction"].values.tolist() == ["approach", "retract"]


# --- Basin maps stopped at known attractors; selected observables ---------------------------

BISTABLE_BASIN = dict(BISTABLE, scene=dict(BISTABLE["scene"], delta_hat=3e-3))


@pytest.mark.parametrize("scene, axes, options", [
    # Two attractors (the free oscillation and tapping): docs/sweeps.md.
    (BISTABLE_BASIN, (np.linspace(-4e-3, 2e-3, 7), np.linspace(-8e-3, 8e-3, 7)),
     dict(max_periods=300, steady_tol=1e-4, tol=1e-2)),
    # The paper's Fig. 4 scene at the benchmark's settings: one attractor.
    (FIG4, (np.linspace(-1e-3, 1e-3, 6), np.linspace(-2e-3, 2e-3, 6)), dict(max_periods=100)),
])
def test_basin_labels_with_known_attractor_stops_equal_full_runs(scene, axes, options):
    full = tmafm.basin(scene, a1=axes[0], adot1=axes[1], workers=2, known_attractors=False,
                       **options)
    fast = tmafm.basin(scene, a1=axes[0], adot1=axes[1], workers=2, coarse=3, chunk=8,
                       **options)
    assert full.attrs["attractors"] == fast.attrs["attractors"]
    np.testing.assert_array_equal(fast["attractor"].values, full["attractor"].values)
    np.testing.assert_array_equal(fast["attractor_period"].values,
                                  full["attractor_period"].values)
    # The first pass (every 3rd point) begins with no attractor known: its first chunk runs
    # to its own steady state.  Most other points stop early; those that do not are the same
    # runs as without the stops.
    first = np.zeros(full["attractor"].shape, dtype=bool)
    first[::3, ::3] = True
    stopped = fast["stopped_known"].values.astype(bool)
    assert not stopped[first].ravel()[:8].any() and stopped[~first].mean() > 0.5
    np.testing.assert_array_equal(fast["periods"].values[~stopped],
                                  full["periods"].values[~stopped])
    assert np.all(fast["periods"].values[stopped] < full["periods"].values[stopped])
    assert fast["periods"].sum() < 0.8 * full["periods"].sum()
    if scene is BISTABLE_BASIN:
        assert full.attrs["attractors"] == 2


def test_basin_computes_only_the_observables_asked_for():
    ds = tmafm.basin(FIG4, a1=[0.0, 3e-4], adot1=[0.0], workers=1, max_periods=100)
    assert "amplitude" not in ds and "peak_force" not in ds and "contact_time" in ds
    ds = tmafm.basin(FIG4, a1=[0.0, 3e-4], adot1=[0.0], workers=1, max_periods=100,
                     observables=["lockin"])
    obs = tmafm.observe(FIG4, initial={"a0": [3e-4, 0.0, 0.0]}, max_periods=100)
    assert ds["amplitude"].values[1, 0] == pytest.approx(obs.steady_values()["amplitude"],
                                                         rel=1e-12)
    assert ds.attrs["observe_observables"] == "lockin"


def test_sweep_observables_keeps_the_asked_variables_and_continuation_keeps_lockin():
    ds = tmafm.sweep(BASE, {"scene.delta_hat": [0.0, 1e-3]}, workers=1,
                     observables=["peak_force"], **QUICK)
    full = tmafm.sweep(BASE, {"scene.delta_hat": [0.0, 1e-3]}, workers=1, **QUICK)
    assert "peak_force" in ds and "amplitude" not in ds and "dissipated_energy" not in ds
    np.testing.assert_array_equal(ds["peak_force"].values, full["peak_force"].values)
    curve = tmafm.approach(BASE, delta_hat=[2e-3, 1e-3], retract=False, workers=1,
                           observables=(), **QUICK)
    assert "amplitude" in curve and "phase" in curve and "peak_force" not in curve
    with pytest.raises(tmafm.InputError, match="unknown name"):
        tmafm.sweep(BASE, {"scene.delta_hat": [0.0]}, workers=1, observables=["nope"], **QUICK)


def test_basin_backends_give_the_same_labels():
    axes = dict(a1=np.linspace(-1e-3, 1e-3, 4), adot1=np.linspace(-2e-3, 2e-3, 3))
    local = tmafm.basin(FIG4, workers=2, coarse=2, chunk=4, max_periods=100, **axes)
    pooled = tmafm.basin(FIG4, workers=2, coarse=2, chunk=4, max_periods=100,
                         backend="processes", **axes)
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        on_dask = tmafm.basin(FIG4, client=client, coarse=2, chunk=4, max_periods=100, **axes)
    for other in (pooled, on_dask):
        np.testing.assert_array_equal(other["attractor"].values, local["attractor"].values)
        assert other.attrs["attractors"] == local.attrs["attractors"] == 1
        assert other["stopped_known"].values.sum() > 0

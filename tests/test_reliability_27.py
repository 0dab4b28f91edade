"""Issue 27, "nothing silent, nothing lost": each test is one item that failed before.

F1 a calibration whose modes' coupling is far below round-off stopped the program inside
LAPACK (DGEBAL's XERBLA, exit 0); F2 a sweep file on a full disk crashed in h5py and left its
temporary; F3 the sweep command checked its targets after the sweep; F5 and F8 inputs refused
only after a run (or never); F9 and F13 raw exceptions and silent infinities of the results;
F12 the sweep command's warnings and start-up Ctrl-C; a failed sweep point without a warning;
and the paper cuts (inputs.names, --help, the [test] extra)."""

import ast
import math
import os
import signal
import subprocess
import sys
import textwrap
import time
import warnings

import numpy as np
import pytest

import tmafm
from tmafm.observe import steady_harmonic
from tmafm.sweeps import points, runs

from conftest import INPUTS, REPO

TAPPING = (INPUTS / "tapping_polystyrene.nml").read_text()
BISTABLE = INPUTS / "sweeps" / "bistable_n2.nml"


def _python(code: str, *args, cwd=None, timeout=300):
    """Run `code` in a child interpreter (a crash there must not take the test run with it)."""
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code), *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, timeout=timeout)


def _one_error_line(proc, *words):
    lines = proc.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("tmafm: error: "), proc.stderr
    for word in words:
        assert word in lines[0], lines[0]
    return lines[0]


# --- F1: no LAPACK call stops the program -----------------------------------------------------

def _tapping(tmp_path, old, new, name="t.nml"):
    assert old in TAPPING
    text = TAPPING.replace(old, new).replace("tau_end = 100.0", "tau_end = 2.0")
    path = tmp_path / name
    path.write_text(text)
    return path


def test_a_tip_mass_ratio_below_round_off_is_calibrated_as_no_tip_mass(tmp_path):
    """tip_mass_ratio = 1e-100 made the modes' coupling 1e-99: Newton's iteration on the first
    eigenvalue, started at dgeev's (exact there to the last bits), overflowed to NaN, and the
    next dgeev's DGEBAL printed a line and stopped the program with exit 0 (from Python it
    killed the interpreter).  Now the eigenvalue stays dgeev's, and the calibrated scene is the
    one of no tip mass: a tip mass ratio of 1e-100 changes M by less than its round-off."""
    tiny = _tapping(tmp_path, "tip_mass_ratio = 0.01", "tip_mass_ratio = 1e-100", "tiny.nml")
    none = _tapping(tmp_path, "tip_mass_ratio = 0.01", "tip_mass_ratio = 0.0", "none.nml")
    proc = _python("""
        import sys, tmafm
        a, b = tmafm.Config(sys.argv[1]).scene, tmafm.Config(sys.argv[2]).scene
        print(repr({k: (a[k], b[k]) for k in ("alpha1", "alpha2", "alpha3", "omega")}))
    """, tiny, none)
    assert proc.returncode == 0 and "DGEBAL" not in proc.stdout + proc.stderr, proc
    values = ast.literal_eval(proc.stdout)
    assert values["alpha1"] == (1e-100, 0.0)
    # The eigenvalue is dgeev's instead of Newton's: the same to a few ulps of its modulus,
    # amplified by the damping search's regula falsi (its stop, 1e-14 in log Q).
    for key in ("alpha2", "alpha3", "omega"):
        assert math.isclose(*values[key], rel_tol=1e-12), (key, values[key])
    done = subprocess.run([tmafm.executable(), "-q", tiny.name, "-o", "tiny.dat"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and done.stderr == "" and done.stdout == "", done
    assert (tmp_path / "tiny.dat").is_file()


@pytest.mark.parametrize("position", ["1e-85", "1e-300"])
def test_a_tip_at_the_clamp_is_refused_naming_tip_position(tmp_path, position):
    """tip_position = 1e-85 gave the calibrated beam an E1 I = k L^3 p^T Lambda^-1 p below the
    smallest normal number (p ~ (x0/L)^2): m was 0, the scene NaN, and DGEBAL stopped the
    program (exit 0, a LAPACK line on stdout).  Now one line names tip_position and its value,
    exit 2, no output file."""
    path = _tapping(tmp_path, "tip_position = 125.0e-6", f"tip_position = {position}")
    proc = subprocess.run([tmafm.executable(), "-q", path.name, "-o", "t.dat"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and proc.stdout == "", proc
    _one_error_line(proc, f"&physical tip_position = {position}", "E1 I", "the tip sits at the clamp")
    assert not (tmp_path / "t.dat").exists()
    child = _python("""
        import sys, tmafm
        try:
            tmafm.Config(sys.argv[1])
        except tmafm.InputError as exc:
            print(type(exc).__name__, exc)
    """, path)
    assert child.returncode == 0 and child.stdout.startswith("InputError "), child
    assert f"tip_position = {position}" in child.stdout and len(child.stdout.splitlines()) == 1


# --- F2: a full disk --------------------------------------------------------------------------

def test_write_dataset_on_a_full_disk_is_a_typed_error_and_leaves_nothing(small_tmpfs):
    """A 64 KiB tmpfs and a 240 kB dataset: h5py wrote into the temporary, crashed on ENOSPC
    (segfault) and left `.d.nc.partial-*`.  Now the file is made in memory, and its write
    fails with InputFileError; the previous file stays as it was, and nothing else is there."""
    (small_tmpfs / "d.nc").write_text("previous\n")
    proc = _python("""
        import sys
        import numpy as np, xarray as xr
        import tmafm, tmafm.sweeps
        ds = xr.Dataset({"x": ("n", np.arange(30000.0))}, attrs={"tmafm_kind": "sweep"})
        try:
            tmafm.sweeps.write_dataset(ds, sys.argv[1])
        except tmafm.InputFileError as exc:
            print(type(exc).__name__, isinstance(exc, OSError), exc)
    """, small_tmpfs / "d.nc")
    assert proc.returncode == 0, proc
    assert proc.stdout.startswith("InputFileError True ") and "No space left" in proc.stdout, proc
    assert sorted(p.name for p in small_tmpfs.iterdir()) == ["d.nc"]
    assert (small_tmpfs / "d.nc").read_text() == "previous\n"


def test_write_dataset_still_writes_what_read_dataset_reads(tmp_path):
    """The in-memory NetCDF file is the same dataset, read back."""
    xr = pytest.importorskip("xarray")
    ds = xr.Dataset({"period": ("n", np.arange(5, dtype=np.int32)), "x": ("n", np.linspace(0, 1, 5))},
                    attrs={"tmafm_kind": "sweep"})
    path = tmafm.sweeps.write_dataset(ds, tmp_path / "d.nc")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.nc"]
    back = tmafm.sweeps.read_dataset(path)
    assert back.identical(ds)


# --- F3, F12: the sweep command ---------------------------------------------------------------

def _sweep_file(folder, extra="values = 1e-3, 2e-3"):
    (folder / "bistable_n2.nml").write_bytes(BISTABLE.read_bytes())
    path = folder / "sweep.nml"
    path.write_text(f"&sweep kind = 'grid', base = 'bistable_n2.nml', key = 'scene.delta_hat', "
                    f"max_periods = 2, {extra} /\n")
    return path


@pytest.fixture
def nothing_runs(monkeypatch):
    """Fail the test if a grid point is built or observed."""
    def built(*args, **kwargs):
        raise AssertionError("a grid point was built or run")
    monkeypatch.setattr(points, "_config", built)
    monkeypatch.setattr(runs, "observe_batch", built)


@pytest.mark.parametrize("args, words", [
    (["-o", "{tmp}/missing/out.nc"], "No such file or directory"),
    (["-o", "{tmp}/out.dat"], "must end in .nc"),
    (["-o", "{tmp}/out.nc", "--plot", "{tmp}/missing/p.png"], "No such file or directory"),
    (["-o", "{tmp}/out.nc", "--plot", "{tmp}/p.xyz"], "matplotlib writes"),
    (["-o", "{tmp}/out.nc", "--plot", "{tmp}/plot"], "matplotlib writes"),
], ids=["missing_folder", "not_nc", "plot_missing_folder", "plot_unknown_format", "plot_no_suffix"])
def test_the_sweep_command_checks_its_targets_before_any_work(tmp_path, capsys, nothing_runs,
                                                              args, words):
    """The folder of -o and of --plot, and both names' extensions, were checked only after the
    whole sweep (and --plot p.xyz wrote a PNG under that name)."""
    path = _sweep_file(tmp_path)
    before = sorted(p.name for p in tmp_path.iterdir())
    code = tmafm.sweeps.main([str(path), *[a.format(tmp=tmp_path) for a in args]])
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    assert code == 2 and len(lines) == 1, (code, lines)
    assert lines[0].startswith("tmafm.sweeps: error: ") and words in lines[0], lines
    assert captured.out == "" and sorted(p.name for p in tmp_path.iterdir()) == before


def test_the_sweep_command_says_wrote_only_once_both_files_are_there(tmp_path, small_tmpfs, capsys):
    """The plot's write failed (a full disk) after the NetCDF file was written: the command
    removed the NetCDF file, but had already printed `wrote OUT.nc`."""
    path = _sweep_file(tmp_path)
    filler = small_tmpfs / "filler"
    fd = os.open(filler, os.O_WRONLY | os.O_CREAT, 0o644)
    try:  # fill the tmpfs, then free two pages: room for an empty temporary, not for a plot
        while True:
            os.write(fd, b"\0" * 4096)
    except OSError:
        pass
    finally:
        os.close(fd)
    os.truncate(filler, filler.stat().st_size - 8192)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        code = tmafm.sweeps.main([str(path), "-o", str(tmp_path / "out.nc"), "--plot",
                                  str(small_tmpfs / "p.png"), "--workers", "1"])
    captured = capsys.readouterr()
    assert code == 2, captured
    assert "wrote" not in captured.out, captured.out
    assert "No space left" in captured.err and len(captured.err.splitlines()) == 1, captured.err
    assert not (tmp_path / "out.nc").exists()
    assert sorted(p.name for p in small_tmpfs.iterdir()) == ["filler"]


def test_the_sweep_commands_warnings_are_one_line_each(tmp_path):
    """max_periods = 2 ends every run unsteady: Python printed the UnsteadyWarning on two lines,
    the second the source line that warned."""
    path = _sweep_file(tmp_path)
    proc = subprocess.run([sys.executable, "-m", "tmafm.sweeps", str(path), "-o", "out.nc",
                           "--no-plot", "--workers", "1"], cwd=tmp_path, capture_output=True,
                          text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stderr.splitlines()
    assert len(lines) == 1, lines
    assert lines[0].startswith("tmafm.sweeps: warning: UnsteadyWarning: ") \
        and "2 of 2 runs ended without a steady state" in lines[0], lines
    assert proc.stdout.splitlines() == ["wrote out.nc"]


def test_ctrl_c_while_the_sweep_command_starts_is_one_line_and_exit_130(tmp_path):
    """SIGINT while `python -m tmafm.sweeps` imported the package gave a 23-line traceback and
    death by SIGINT.  The signal is sent once numpy is being loaded (the package's first
    import), so it comes during the start-up, before the command's main."""
    path = _sweep_file(tmp_path)
    proc = subprocess.Popen([sys.executable, "-m", "tmafm.sweeps", str(path), "-o", "out.nc",
                             "--no-plot", "--workers", "1"], cwd=tmp_path,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    maps = f"/proc/{proc.pid}/maps"
    deadline = time.monotonic() + 60
    try:
        while time.monotonic() < deadline and proc.poll() is None:
            try:
                with open(maps) as handle:
                    if "numpy" in handle.read():
                        break
            except OSError:
                pass
            time.sleep(0.001)
        assert proc.poll() is None, "the command ended before numpy was loaded"
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 130, (proc.returncode, err)
    assert err.splitlines() == ["tmafm.sweeps: interrupted"], err
    assert out == "" and not (tmp_path / "out.nc").exists()


# --- a failed sweep point warns ---------------------------------------------------------------

def test_a_failed_sweep_point_warns_once_with_the_count_and_the_first_reason():
    """A point whose run fails became NaN with only ds.attrs['failures'] to say so; unsteady
    points warned.  dtau = 1 blows the paper's RK4 up (its stability limit is far below)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ds = tmafm.sweep("fig2_n4", {"solver.dtau": [2e-3, 1.0]}, max_periods=3, workers=1)
    failed = [w for w in caught if issubclass(w.category, tmafm.FailedRunWarning)]
    assert ds.attrs["failures"] == 1 and ds["failed"].values.tolist() == [0, 1]
    assert np.isnan(ds["amplitude"].values[1]) and np.isfinite(ds["amplitude"].values[0])
    assert len(failed) == 1, [str(w.message) for w in caught]
    message = str(failed[0].message)
    assert "1 of 2 runs failed" in message and ds.attrs["first_failure"] in message
    assert "\n" not in message


# --- F5, F8: refused before any run -----------------------------------------------------------

def test_a_viscoelastic_sample_with_a_fixed_step_method_is_refused_before_the_search(tmp_path):
    """n_modes = 0, an SLS sample and rk4_event: the automatic-N search ran (~7 s, with its
    progress lines) before the method was refused.  Now the input check refuses it: one line,
    and no search line before it."""
    path = tmp_path / "sls.nml"
    path.write_text("&model n_modes = 0 /\n&scene sls_relaxation_time = 1, sls_modulus_ratio = 0.5 /\n"
                    "&solver method = 'rk4_event', tau_end = 5 /\n")
    proc = subprocess.run([tmafm.executable(), path.name, "-o", "s.dat"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2, proc
    _one_error_line(proc, "&solver method = 'rk4_event'", "&scene sls_relaxation_time = 1",
                    "dopri5")
    with pytest.raises(tmafm.InputError, match="sls_relaxation_time") as info:
        tmafm.Config(path)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("value", ["1e-20", "1e-300"])
def test_a_physical_relaxation_time_below_the_scene_floor_is_refused_at_input(tmp_path, value):
    """&physical sample_relaxation_time = 1e-20 gave &scene sls_relaxation_time below its
    floor 1e-12 (read_scene's rule, not the key's range): accepted, and the run then failed
    with exit 5.  Now the derived value is held to the &scene key's rule, naming the key
    written."""
    text = (INPUTS / "sls_polystyrene.nml").read_text()
    old = "sample_relaxation_time = 3.0e-6"
    assert old in text
    path = tmp_path / "sls.nml"
    path.write_text(text.replace(old, f"sample_relaxation_time = {value}"))
    proc = subprocess.run([tmafm.executable(), "-q", path.name, "-o", "s.dat"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2, proc
    _one_error_line(proc, f"&physical sample_relaxation_time = {value}", "sls_relaxation_time",
                    "1.0E-012")
    assert not (tmp_path / "s.dat").exists()


# --- F9, F13: typed errors and warnings in the results ----------------------------------------

def test_force_distance_of_an_undriven_run_is_a_typed_error():
    """drive_frequency = 0: 2 pi/omega raised a raw ZeroDivisionError."""
    result = tmafm.run("tapping_polystyrene", physical={"drive_frequency": 0.0},
                       solver={"tau_end": 2.0})
    assert result.scene["omega"] == 0
    with pytest.raises(tmafm.InputError, match="omega = 0.0"):
        result.force_distance()


def test_a_zero_free_amplitude_gives_a_nan_setpoint_and_a_warning():
    """A curve at free_amplitude = 0 had setpoint = amplitude/0 = inf, silently."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ds = tmafm.approach("tapping_polystyrene", z=[15e-9], retract=False,
                            curves={"physical.free_amplitude": [0.0, 20e-9]}, max_periods=3,
                            workers=1, stop_at_steady=False)
    said = [str(w.message) for w in caught if issubclass(w.category, tmafm.TmafmWarning)
            and "free_amplitude = 0" in str(w.message)]
    assert len(said) == 1 and "NaN" in said[0], [str(w.message) for w in caught]
    setpoint = ds["setpoint"].sel({"physical.free_amplitude": 0.0}).values
    assert np.isnan(setpoint).all()
    other = ds.sel({"physical.free_amplitude": 20e-9})
    assert np.allclose(other["setpoint"].values, other["amplitude"].values / 20.0, rtol=1e-15)
    assert np.isfinite(other["setpoint"].values).all()


# --- paper cuts --------------------------------------------------------------------------------

def test_inputs_names_lists_every_run_input_the_bimodal_example_included():
    names = tmafm.inputs.names()
    assert "bimodal/tapping" in names and "fig2_n4" in names
    assert not any(n.startswith("sweeps/") for n in names)
    assert tmafm.Config("bimodal/tapping").n_modes == 4


def test_the_help_names_every_option_on_its_usage_line():
    proc = subprocess.run([tmafm.executable(), "--help"], capture_output=True, text=True, timeout=60)
    usage = proc.stdout.splitlines()[0]
    assert proc.returncode == 0 and usage.startswith("usage: tmafm INPUT.nml")
    for option in ("-o FILE", "-q", "--timings"):
        assert option in usage, usage


def test_the_test_extra_installs_what_the_tests_build_with():
    """tests/testcore.py builds the test-only extension with meson and ninja: `pip install
    '.[test]'` then pytest failed without them."""
    tomllib = pytest.importorskip("tomllib")
    extra = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["optional-dependencies"]["test"]
    names = {e.split(">")[0].split("=")[0].split("[")[0].strip() for e in extra}
    testcore = (REPO / "tests" / "testcore.py").read_text()
    for tool in ("meson", "ninja"):
        assert f'_tool("{tool}")' in testcore and tool in names, (tool, extra)


# --- the steady test of dop853 ----------------------------------------------------------------

def _free_orbit(method, **solver):
    """tapping_polystyrene 25 nm from the sample (A0 = 20 nm: the tip never touches it)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", tmafm.UnsteadyWarning)
        return tmafm.observe("tapping_polystyrene", max_periods=2500, steady_tol=1e-8,
                             solver={"method": method, **solver}, observables=())


def test_dop853_finds_the_period_of_a_free_high_q_orbit_as_dopri5_does():
    """dop853's steps were set by the third mode (Q3 ~ 7000) past h omega_3 ~ 4.4: its velocity
    at the period boundary jittered by 1.2e-9 and no period repeated within 1e-8 in 6000
    periods, where dopri5 and flight_exact find period 1 after 1731.  Now dop853 steps at most
    h omega_N = 4 (tmafm_method_adaptive dop853_mode_reach) and finds it within 10 % of the
    periods dopri5 needs."""
    reference = _free_orbit("dopri5")
    assert reference.period == 1
    for solver in ({}, {"atol": 1e-16}):
        found = _free_orbit("dop853", **solver)
        assert found.period == 1, (solver, found.evidence)
        assert abs(len(found.poincare) - len(reference.poincare)) <= 0.1 * (len(reference.poincare) - 1)
    # The same orbit: each last point is still approaching it, by steps of at most 1e-8 of its
    # size shrinking by rho = exp(-pi/Q) a period (Q = 400), so it lies within 1e-8/(1 - rho)
    # of the orbit; the two within twice that.
    size = np.abs(reference.poincare[-1]).max()
    reach = 1e-8 / (1 - math.exp(-math.pi / 400)) * size
    assert np.abs(found.poincare[-1] - reference.poincare[-1]).max() <= 2 * reach


def _dopri5_stability(z):
    """dopri5's stability function R(z): the series of its Butcher tableau, 1, 1, 1/2, 1/6, 1/24,
    1/120, 1/600 (b^T A^k 1 of Dormand and Prince's 5th-order weights, computed here)."""
    a = np.zeros((6, 6))
    a[1, :1] = [1 / 5]
    a[2, :2] = [3 / 40, 9 / 40]
    a[3, :3] = [44 / 45, -56 / 15, 32 / 9]
    a[4, :4] = [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729]
    a[5, :5] = [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656]
    b = np.array([35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84])
    return 1 + z * b @ np.linalg.solve(np.eye(6) - z * a, np.ones(6))


def test_dopri5_with_four_modes_at_the_defaults_finds_the_period_flight_exact_finds():
    """dopri5 holds the imaginary axis only up to h omega = 0.997 (|R(iy)| <= 1); with N = 4 at
    the defaults on the free tapping_polystyrene orbit its error control chose h omega_4 ~ 1.13,
    where a mode needs zeta > 1.2e-4 not to be amplified by the method, and mode 4 (zeta 3.7e-5)
    was: no period in 6000.  Its step is now capped at h omega_N = 0.9
    (tmafm_method_adaptive dopri5_mode_reach), inside the interval."""
    # The cap's premise, from the method's stability function: inside at 0.9, outside at 1.
    assert abs(_dopri5_stability(0.9j)) < 1 < abs(_dopri5_stability(1.0j))
    defaults = {"rtol": 1e-7, "atol": 1e-10}

    def orbit(method):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", tmafm.UnsteadyWarning)
            return tmafm.observe("tapping_polystyrene", max_periods=2500, model={"n_modes": 4},
                                 solver={"method": method, **defaults}, observables=())
    exact, found = orbit("flight_exact"), orbit("dopri5")
    assert exact.period == found.period == 1, found.evidence
    assert abs(len(found.poincare) - len(exact.poincare)) <= 0.1 * (len(exact.poincare) - 1)
    # Every step inside the cap: 200 tau of the same run take at least 200 omega_4/0.9 steps.
    config = tmafm.Config("tapping_polystyrene", model={"n_modes": 4},
                          solver={"method": "dopri5", "tau_end": 200.0, **defaults})
    omega_n = float(np.asarray(config.model()._f.beta)[3]) ** 2
    assert config.run().counters["steps"] >= 200 * omega_n / 0.9


def test_dop853_on_fig3_at_the_defaults_finds_period_one():
    """fig3 with dop853 at rtol 1e-7 fell into a two-period cycle of its step pattern (points
    4.7e-6 of the orbit apart) and had no period in 300 periods; flight_exact finds period 1
    after 24 (docs/observables.md)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", tmafm.UnsteadyWarning)
        dop = tmafm.observe("fig3", solver={"method": "dop853"}, max_periods=300)
        exact = tmafm.observe("fig3", solver={"method": "flight_exact"}, max_periods=100)
    assert dop.period == exact.period == 1
    assert len(dop.poincare) == len(exact.poincare) == 25


# --- F4: a zero drive under flight_exact ------------------------------------------------------

def _cpu_of(call):
    start = time.process_time()
    value = call()
    return time.process_time() - start, value


def test_a_zero_drive_under_flight_exact_costs_what_a_small_one_does():
    """alpha2 = 0 (free_amplitude = 0) left every mode exactly at rest: the extrema scans of a
    channel of size 0 cleared no interval and halved each to its 2 000 000 points, 2.2-3 s of
    CPU a drive period.  Now they cost what alpha2 = 1e-12 does (a thousandth of a second), and
    the located extremes of a mode at rest are exactly 0."""
    def observe(alpha2):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", tmafm.UnsteadyWarning)
            return tmafm.observe("fig2_n4", max_periods=3, solver={"method": "flight_exact"},
                                 scene={"alpha2": alpha2, "delta_hat": 1e-3})
    small_cpu, _ = _cpu_of(lambda: observe(1e-12))
    zero_cpu, zero = _cpu_of(lambda: observe(0.0))
    assert zero_cpu <= 20 * small_cpu + 0.2, (zero_cpu, small_cpu)
    values = zero.steady_values()
    assert (values["modal_max_free"] == 0).all() and (values["modal_min_free"] == 0).all()
    assert values["min_gap"] == values["max_gap"] == 1e-3
    cpu, _ = _cpu_of(lambda: tmafm.observe("tapping_polystyrene", max_periods=3,
                                           physical={"free_amplitude": 0.0}))
    assert cpu <= 20 * small_cpu + 0.2, cpu


# --- F10: an observed run beyond the largest tau_end ------------------------------------------

def test_an_observed_run_past_the_largest_tau_end_is_refused_at_once():
    """frequency_sweep('sweeps/vdw_attractive', omega=[1e-300]) ran 100 periods of 6e300 and
    did not return in 60 s.  Now an observed run whose max_periods drive periods end past the
    largest &solver tau_end (1e7) is an InputError naming omega, before any step."""
    proc = _python("""
        import tmafm
        try:
            tmafm.frequency_sweep("sweeps/vdw_attractive", omega=[1e-300], workers=1)
        except tmafm.InputError as exc:
            print(type(exc).__name__, exc)
    """, timeout=60)
    assert proc.returncode == 0 and proc.stdout.startswith("InputError "), proc
    assert "&scene omega = 1.0E-300" in proc.stdout and "1.0E+007" in proc.stdout
    assert len(proc.stdout.splitlines()) == 1
    with pytest.raises(tmafm.InputError, match="max_periods = 10 drive periods"):
        tmafm.observe("fig3", max_periods=10, scene={"omega": 1e-6})


# --- F15: the automatic-N search has a cost bound ---------------------------------------------

def test_the_automatic_n_search_stops_at_its_work_budget(tmp_path):
    """The search had no bound but mode_horizon: extreme scenes ran 21-45 s, and over 208 s
    (stopped at N = 20).  Now its comparison runs share a budget of steps times modes
    (tmafm_settings search_work_budget, 4e8: the Fig. 2 scene at mode_tol = 1e-12 spends 1.2e8
    in 19.8 s); past it the search stops with one line naming n_modes = 0 and what to change.
    The default budget is reached only after about a minute, so the test gives a small one
    through the test-only core (the same routine the executable calls)."""
    from testcore import core
    path = tmp_path / "auto.nml"
    path.write_text("&model n_modes = 0, mode_horizon = 20, mode_tol = 1e-12 /\n"
                    "&solver tau_end = 1, method = 'dopri5' /\n")
    n, ierr, errmsg = core.choose_with_budget(str(path), 2e5)
    message = errmsg.decode().strip() if isinstance(errmsg, bytes) else str(errmsg).strip()
    assert ierr == 5 and n == 0, (ierr, message)
    assert message.startswith("&model n_modes = 0: the search for N stopped at N = "), message
    for words in ("spent their budget of 2.0E+005 steps times modes", "give n_modes",
                  "mode_tol (now 1.0E-012)", "mode_horizon = 2.0E+001"):
        assert words in message, message
    # A budget the search does not reach changes nothing: the Fig. 2 scene's N at mode_tol 1e-2.
    path.write_text("&model n_modes = 0 /\n&solver tau_end = 1 /\n")
    n, ierr, errmsg = core.choose_with_budget(str(path), 4e8)
    assert ierr == 0 and n == tmafm.Config(path).n_modes == 3


# --- F6/F7: refusals through the calibration and the drive name the keys written -------------

@pytest.mark.parametrize("old, new, words", [
    # tip_position = 1e-20 named `length` (alpha4's list held no calibration key)
    ("tip_position = 125.0e-6", "tip_position = 1e-20",
     ["&physical tip_position = 1e-20 gives alpha4", "spring_constant, resonance_frequency, tip_position",
      "(line "]),
    # m = E1 I t0^2/L^4 overflowed at f0 = 1e-300: named `length`
    ("resonance_frequency = 300.0e3", "resonance_frequency = 1e-300",
     ["&physical resonance_frequency = 1e-300: gives the calibrated beam", "(line 17)"]),
    ("spring_constant = 40.0", "spring_constant = 1e-300",
     ["&physical spring_constant = 1e-300: gives the calibrated beam", "(line 16)"]),
    # the second tone: the key and the number as written, with the line (it named
    # drive_angular_frequency_2 = 0.0E+000 and 6.283185307179586E+003, without a line)
    ("tip_sample_distance = 25.0e-9 ", "tip_sample_distance = 25.0e-9, drive_frequency_2 = 0.0, "
     "drive_amplitude_2 = 1e-9 ", ["&physical drive_frequency_2 = 0.0: a second tone", "(line 33)"]),
    ("tip_sample_distance = 25.0e-9 ", "tip_sample_distance = 25.0e-9, drive_frequency_2 = 1e3, "
     "free_amplitude_2 = 1e-5 ", ["&physical drive_frequency_2 = 1e3: not commensurate with drive_frequency "
                                  "= 3.0E+005", "nearest 1/64: drive_frequency_2 = 4.6875E+003", "(line 33)"]),
    # free_amplitude_2 = 0.1 m named tip_sample_distance (a tie of keys whose default 0 is 'off')
    ("tip_sample_distance = 25.0e-9 ", "tip_sample_distance = 25.0e-9, drive_frequency_2 = 1.9e6, "
     "free_amplitude_2 = 0.1 ", ["&physical free_amplitude_2 = 0.1 gives alpha2_2"]),
], ids=["tip_position", "resonance_frequency", "spring_constant", "tone_2_zero", "tone_2_ratio",
        "free_amplitude_2"])
def test_a_refusal_through_the_calibration_or_the_drive_names_the_key_written(tmp_path, old, new, words):
    path = _tapping(tmp_path, old, new)
    proc = subprocess.run([tmafm.executable(), "-q", path.name, "-o", "t.dat"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2, proc
    _one_error_line(proc, *words)
    assert not (tmp_path / "t.dat").exists()
    with pytest.raises(tmafm.InputError) as info:
        tmafm.Config(path)
    assert words[0] in str(info.value) and "\n" not in str(info.value)


# --- steady values without a steady period ----------------------------------------------------

def test_steady_values_without_a_period_average_the_closest_repeats_lag():
    """With no period found, steady_values() was the last period alone, whose
    dissipated_viscoelastic can be negative on a double-tap orbit that alternates.  Now it is the
    mean over the last q periods, q the lag of the closest repeat (here 2: fig2_n4 after 8
    periods, still far from steady), in Python and in the core's steady values (sweeps) alike."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", tmafm.UnsteadyWarning)
        obs = tmafm.observe("fig2_n4", max_periods=8, solver={"method": "flight_exact"})
        ds = tmafm.sweep("fig2_n4", {"solver.method": ["flight_exact"]}, max_periods=8, workers=1)
    assert obs.period == 0 and obs.evidence["closest_lag"] == 2
    values = obs.steady_values()
    rows = obs.per_period
    for name in ("dissipated_energy", "contact_time", "min_gap", "peak_force"):
        assert values[name] == pytest.approx(np.mean(rows[name][-2:]), rel=1e-15, abs=0), name
        assert rows[name][-1] != rows[name][-2]           # one period alone is another number
    amplitude, phase = steady_harmonic(rows["amplitude"][-2:], rows["phase"][-2:])
    assert values["amplitude"] == pytest.approx(amplitude, rel=1e-14)
    assert values["phase"] == pytest.approx(phase, abs=1e-12)
    for name in ("amplitude", "phase", "dissipated_energy", "contact_time"):
        assert float(ds[name].values.ravel()[0]) == pytest.approx(values[name], rel=1e-14, abs=1e-14), name


def test_continuum_resonance_frequency_is_zero_exactly_when_the_tip_mass_is_inside_the_beam():
    """It was echoed as 0.0 with the tip inside the beam, undocumented: docs/model.md and
    output-format.md now say so; at the free end it is the continuum's frequency, below the
    N-mode model's undamped one."""
    at_end = tmafm.Config("tapping_polystyrene").derived
    inside = tmafm.Config("tapping_polystyrene", physical={"tip_position": 100e-6}).derived
    assert inside["continuum_resonance_frequency"] == 0.0
    assert 0 < at_end["continuum_resonance_frequency"] < at_end["undamped_resonance_frequency"]
    for doc in ("model.md", "output-format.md"):
        assert "0 when the tip" in (REPO / "docs" / doc).read_text().replace("\n  ", " ") \
            or "echoed as 0" in (REPO / "docs" / doc).read_text()


def test_a_sweep_dataset_holds_the_indentation():
    """Only the approach plot computed the indentation; the dataset had min_gap alone."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", tmafm.TmafmWarning)
        ds = tmafm.approach("tapping_polystyrene", z=[25e-9, 0.0], retract=False, max_periods=3,
                            workers=1, stop_at_steady=False)
    gap, indentation = ds["min_gap"].values, ds["indentation"].values
    assert np.array_equal(indentation, np.maximum(-gap, 0.0))
    assert indentation[..., 0].item() == 0 and indentation[..., 1].item() > 0   # free, then tapping
    assert ds["indentation"].attrs["units"] == ds["min_gap"].attrs["units"] == "nm"


def test_a_smooth_crossover_is_not_marked_as_a_jump_but_hysteresis_is():
    """Jump markers appeared where approach and retract coincide: a steep single-valued change
    on a coarse grid looks like a jump in each direction alone."""
    from types import SimpleNamespace

    from tmafm.sweeps import curves

    x = np.linspace(0, 1, 11)
    smooth = np.tanh((x - 0.52) / 0.01)                   # one steep step, the same both ways
    flat = np.zeros_like(x)

    def flags(approach, retract):
        data = {"amplitude": SimpleNamespace(values=np.array([approach, retract])),
                "phase": SimpleNamespace(values=np.array([flat, flat]))}
        return curves._jump_flags(data, (2, x.size), True, 0.2)

    assert curves.mark_jumps(smooth).any()                 # each direction alone would mark it
    assert not flags(smooth, smooth).any()
    # Hysteresis: the approach jumps up at x = 0.6, the retract down at x = 0.3.
    up = np.where(x >= 0.6 - 1e-12, 1.0, 0.0)
    down = np.where(x >= 0.3 - 1e-12, 1.0, 0.0)
    marked = flags(up, down)
    assert marked[0].nonzero()[0].tolist() == [6] and marked[1].nonzero()[0].tolist() == [2]


# --- a calibrated cantilever needs what a user knows ------------------------------------------

def test_a_calibrated_cantilever_needs_no_tip_position_and_no_tip_mass_ratio(tmp_path):
    """A cantilever given with its own length and no tip_position was refused (the default
    x0 = 300e-6 m lies past L = 125e-6 m), and spring_constant without tip_mass_ratio was
    refused.  Now the tip sits at the free end and the tip mass is 0 unless given: the same
    scene as writing tip_position = length and tip_mass_ratio = 0."""
    lines = [line for line in TAPPING.splitlines()
             if not line.strip().startswith(("tip_position", "tip_mass_ratio"))]
    short = tmp_path / "short.nml"
    short.write_text("\n".join(lines) + "\n")
    explicit = TAPPING.replace("tip_mass_ratio = 0.01", "tip_mass_ratio = 0.0")
    full = tmp_path / "full.nml"
    full.write_text(explicit)
    a, b = tmafm.Config(short), tmafm.Config(full)
    assert a.scene == b.scene and a.scene["xi0"] == 1.0 and a.scene["alpha1"] == 0.0
    # The packaged input, which gives both, is unchanged by the defaults.
    assert tmafm.Config("tapping_polystyrene").scene["alpha1"] == 0.01

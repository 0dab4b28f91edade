"""The output window (issue 27, paper cut): ``&output sample_from`` (a time) or
``last_periods`` (the last N drive periods) keep only those samples of a run, in the written
file and in the arrays Python gets; the run itself, its counters and switches, and the
observables (``tmafm.observe``, ``analysis.observation``) are the whole run's."""

import math

import numpy as np
import pytest

import tmafm
from tmafm import analysis

from conftest import INPUTS

TAPPING = (INPUTS / "tapping_polystyrene.nml").read_text()
ARRAYS = ("tau", "vt", "vtdot", "contact", "a", "adot")


def _case(tmp_path, name, method, window="", tau_end=100.0):
    """tapping_polystyrene (sample_dtau 0.01) with `method`, `tau_end` and `window` (text in
    &output); returns its path."""
    text = TAPPING.replace("method = 'flight_exact'", f"method = '{method}'")
    text = text.replace("tau_end = 100.0", f"tau_end = {tau_end}")
    text = text.replace("file = 'tapping_polystyrene.dat',", f"{window} file = 'out.dat',")
    path = tmp_path / name
    path.write_text(text)
    return path


def _rows(path):
    return np.loadtxt(path, comments="#", ndmin=2)


@pytest.mark.parametrize("method", ["rk4_paper", "rk4_event", "dopri5", "dop853", "flight_exact"])
@pytest.mark.parametrize("window", ["sample_from = 37.505,", "last_periods = 8,"])
def test_the_written_file_holds_the_run_s_own_samples_of_the_window(run_exe, tmp_path, method, window):
    """The window's rows are the full run's last rows (the sample grid k sample_dtau and the
    drive phase carried as the run carries it): the same bits for the stepping methods; for
    flight_exact, whose flight samples are a recurrence anchored at a flight's first sample
    (tmafm_flight: a window's first flight starts its anchors elsewhere), to the bound of that
    recurrence's rounding."""
    # The fixed steps are dear: a shorter run, its window inside it.
    tau_end, start = (20.0, 7.505) if method.startswith("rk4") else (100.0, 37.505)
    window = window.replace("37.505", str(start))
    full_case = _case(tmp_path, "full.nml", method, tau_end=tau_end)
    win_case = _case(tmp_path, "win.nml", method, window, tau_end=tau_end)
    for case, out in ((full_case, "full.dat"), (win_case, "win.dat")):
        proc = run_exe("-q", case.name, "-o", out)
        assert proc.returncode == 0 and proc.stderr == "", proc.stderr
    full, win = _rows(tmp_path / "full.dat"), _rows(tmp_path / "win.dat")
    tau_end = full[-1, 0]
    if window.startswith("sample_from"):
        assert win[0, 0] >= start > win[0, 0] - 0.01
    else:
        period = 2 * math.pi / tmafm.Config(str(win_case)).scene["omega"]
        assert win[0, 0] >= tau_end - 8 * period > win[0, 0] - 0.01
    assert win.shape[0] < full.shape[0] and win[-1, 0] == tau_end
    tail = full[-win.shape[0]:]
    if method == "flight_exact":
        # Each run's flight samples equal direct evaluation to 1e-13 of the state's size
        # (tests/test_sampling.py), so two runs agree to twice that: the dimensionless columns
        # (V_T, its rate, a, adot) against the state's size, the SI series against their own.
        n_state = 4 + 2 * tmafm.Config(str(win_case)).n_modes  # tau, vt, vtdot, contact, a, adot
        state = np.abs(full[:, 1:n_state]).max()
        si = np.abs(full[:, n_state:]).max(axis=0)
        assert np.all(np.abs(tail[:, 1:n_state] - win[:, 1:n_state]) <= 2e-13 * state)
        assert np.all(np.abs(tail[:, n_state:] - win[:, n_state:]) <= 2e-13 * si)
        np.testing.assert_array_equal(tail[:, 3], win[:, 3])  # the contact flags
        np.testing.assert_array_equal(tail[:, 0], win[:, 0])  # the sample times
    else:
        np.testing.assert_array_equal(tail, win)
    # The header records the window as the input gave it; the file is a valid input again.
    header = (tmp_path / "win.dat").read_text().split("# columns")[0]
    assert window.split(",")[0].split("=")[0].strip() in header
    again = run_exe("-q", "win.dat", "-o", "again.dat")
    assert again.returncode == 0, again.stderr
    np.testing.assert_array_equal(_rows(tmp_path / "again.dat"), win)


@pytest.mark.parametrize("method", ["dopri5", "dop853"])
def test_python_returns_the_window_and_the_whole_run_s_counters(method):
    full = tmafm.run("tapping_polystyrene", solver={"method": method})
    config = tmafm.Config("tapping_polystyrene", solver={"method": method}, output={"last_periods": 8})
    win = config.run()
    assert config.n_samples == win.tau.size < full.tau.size
    assert (win.tau.size, full.tau.size) == (1458, 10001)  # README, the output window
    n = win.tau.size
    for name in ARRAYS:
        np.testing.assert_array_equal(getattr(full, name)[-n:], getattr(win, name))
    # The integration is the whole run's: the same steps, the same phase changes.  The
    # right-hand sides count the work done: dop853's dense output costs 3 more per step that
    # has a sample to give, and the window has fewer (dopri5's costs none).
    rhs = "rhs_evaluations"
    assert {k: v for k, v in win.counters.items() if k != rhs} == \
        {k: v for k, v in full.counters.items() if k != rhs}
    if method == "dopri5":
        assert win.counters[rhs] == full.counters[rhs]
    else:
        assert win.counters[rhs] < full.counters[rhs]
        assert (full.counters[rhs] - win.counters[rhs]) % 3 == 0
    np.testing.assert_array_equal(win.switches, full.switches)
    # The last tap of a physical run is inside the window.
    d_full, f_full = full.force_distance()
    d_win, f_win = win.force_distance()
    np.testing.assert_array_equal(d_full, d_win)
    np.testing.assert_array_equal(f_full, f_win)


def test_a_saved_window_loads_back(tmp_path):
    win = tmafm.run("tapping_polystyrene", solver={"tau_end": 20.0}, output={"sample_from": 12.0})
    assert win.tau[0] == 12.0
    path = win.save(tmp_path / "win.npz")
    back = tmafm.load(path)
    for name in ARRAYS:
        np.testing.assert_array_equal(getattr(back, name), getattr(win, name))


def test_the_observables_are_the_whole_run_s():
    """An observed run keeps no samples: a window in its input changes nothing."""
    plain = tmafm.observe("tapping_polystyrene", max_periods=40, stop_at_steady=False)
    windowed = tmafm.observe(tmafm.Config("tapping_polystyrene", output={"last_periods": 3}),
                             max_periods=40, stop_at_steady=False)
    assert plain.periods == windowed.periods == 40
    for name, values in plain.per_period.items():
        np.testing.assert_array_equal(values, windowed.per_period[name], err_msg=name)


def test_the_analysis_of_a_window_is_the_run_s_over_the_window():
    """A window starting inside a period: its Poincare sections are the run's period
    boundaries in it, and the per-period measures from a time are those of the full run."""
    omega = tmafm.Config("fig2_n4").scene["omega"]
    period = 2 * math.pi / omega
    common = dict(solver={"tau_end": 40 * period})
    full = tmafm.run("fig2_n4", **common, output={"sample_dtau": period / 64})
    win = tmafm.run("fig2_n4", **common, output={"sample_dtau": period / 64, "sample_from": 20.3 * period})
    assert win.tau[0] / period == pytest.approx(20.3125, rel=1e-12, abs=0)
    times_full, sections_full = analysis.poincare_sections(full)
    times_win, sections_win = analysis.poincare_sections(win)
    assert times_win.size == 20 and times_win[0] == pytest.approx(21 * period, rel=1e-12, abs=0)
    np.testing.assert_array_equal(times_full[-20:], times_win)
    np.testing.assert_array_equal(sections_full[-20:], sections_win)
    since = 21 * period
    assert analysis.per_period(full, since) == analysis.per_period(win) == analysis.per_period(win, since)
    assert analysis.lockin(full, since) == analysis.lockin(win)
    np.testing.assert_array_equal(analysis.harmonics(full, since), analysis.harmonics(win))
    assert analysis.vt_max(full, win.tau[0]) == analysis.vt_max(win)
    with pytest.raises(tmafm.InputError, match="since = 1: must lie within the run's samples"):
        analysis.lockin(win, 1.0)


@pytest.mark.parametrize("output, words", [
    ({"last_periods": 2, "sample_from": 3}, "last_periods = 2: cannot be given with sample_from = 3"),
    ({"last_periods": 80}, "last_periods = 80: is 1.45795867"),
    ({"last_periods": -1}, "last_periods = -1: must be in 1..1000000000"),
    ({"last_periods": 2.0}, "last_periods = 2.0: must be an integer"),
    ({"sample_from": 100.005}, "sample_from = 100.005: must be finite, >= 0.0E+000 and <= 1.0E+002"),
    ({"sample_from": float("nan")}, "sample_from = nan"),
])
def test_a_bad_window_is_one_line_naming_the_key(output, words):
    with pytest.raises(tmafm.InputError) as error:
        tmafm.Config("tapping_polystyrene", output=output)
    assert words in str(error.value) and "\n" not in str(error.value)


def test_a_window_of_periods_needs_a_drive_and_a_sample(run_exe, tmp_path):
    (tmp_path / "z.nml").write_text("&model n_modes = 2 /\n&scene omega = 0 /\n&solver tau_end = 5 /\n"
                                    "&output last_periods = 1 /\n")
    proc = run_exe("-q", "z.nml", "-o", "z.dat")
    assert proc.returncode == 2 and not (tmp_path / "z.dat").exists()
    assert proc.stderr == ("tmafm: error: z.nml: &output last_periods = 1: needs a drive period, and "
                           "&scene omega is 0: give sample_from (line 4)\n")
    # sample_from after the last sample (tau_end 5.005 with sample_dtau 0.01: the last is 5.0).
    (tmp_path / "e.nml").write_text("&model n_modes = 2 /\n&solver tau_end = 5.005 /\n"
                                    "&output sample_from = 5.004 /\n")
    proc = run_exe("-q", "e.nml", "-o", "e.dat")
    assert proc.returncode == 2 and not (tmp_path / "e.dat").exists()
    assert proc.stderr.startswith("tmafm: error: e.nml: &output sample_from = 5.004: keeps no sample: "
                                  "the last one is at tau = 5.0")


def test_a_window_lets_a_run_past_the_sample_limit_keep_its_end():
    """The limits on samples and memory count the kept samples: a run of 1e8 samples (over the
    5e7 limit) keeping its last 2 periods is accepted, and the same without a window is not."""
    long = dict(solver={"tau_end": 1.0e4, "method": "dopri5"}, output={"sample_dtau": 1.0e-4})
    with pytest.raises(tmafm.InputError, match="more than 50000000"):
        tmafm.Config("tapping_polystyrene", **long)
    config = tmafm.Config("tapping_polystyrene", solver=long["solver"],
                          output={**long["output"], "last_periods": 2})
    period = 2 * math.pi / config.scene["omega"]
    assert config.n_samples == math.floor(2 * period / 1.0e-4) + 1

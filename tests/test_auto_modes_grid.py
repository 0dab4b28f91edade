"""The automatic N (&model n_modes = 0) does not depend on the output grid.

It compared V_T(N) and V_T(N+1) at the output samples (sample_dtau, or mode_horizon/100 if
finer), so a coarse grid hid part of the difference: on Fig. 2 at mode_tol = 1.65e-3 it chose
N = 4 with sample_dtau = 0.1 (N = 4 against 5: 1.62E-003) and N = 5 with 0.001 (1.72E-003).
The search now samples its runs on a grid of its own (at least 16 points per period of the
fastest free mode of N+1) and locates max|V_T(N) - V_T(N+1)| and the range of V_T(N+1) between
the grid points on the cubic Hermite interpolant of V_T and its rate (docs/model-notes.md,
item 14).  Here: the same N and the same differences for any sample_dtau, from the executable
and from Python; each reported difference against an independent dense computation from two
fixed-N runs; the header states the comparison, each N's value and mode_tol.
"""

import re

import numpy as np
import pytest

import tmafm
from conftest import INPUTS, write_nml

#: (base input, overrides, mode_tol): Fig. 2 (Hertz, printed equations), where main's search
#: chose N = 4 or 5 by sample_dtau, and Fig. 7's DMT scene with the errata corrected, where it
#: chose N = 3 (sample_dtau 0.1: N = 3 against 4 gave 3.65E-003) or 4 (0.001: 4.43E-003).
SCENES = {
    "fig2": (INPUTS / "fig2_n4.nml", {}, 1.65e-3),
    "dmt_consistent": (INPUTS / "fig7_dmt.nml", {"model": {"convention": "consistent"}}, 4e-3),
}
#: The search's points per period of the fastest mode (tmafm_settings comparison_points).
COMPARISON_POINTS = 16
#: A cubic Hermite interpolant's error at K points per period of a sinusoid, relative to its
#: amplitude: (2 pi/K)^4/384, the bound on how far a located value may sit from the signal's.
HERMITE_ERROR = (2 * np.pi / COMPARISON_POINTS) ** 4 / 384
#: The header prints 6 significant digits: half a unit of the last one, relatively.
PRINT_ROUNDING = 5e-6


def auto_input(path, scene, sample_dtau, output="auto.dat"):
    base, overrides, mode_tol = SCENES[scene]
    groups = {g: dict(v) for g, v in overrides.items()}
    groups.setdefault("model", {}).update(n_modes=0, mode_tol=mode_tol)
    # A short, cheap run after the search: only the search is under test.
    return write_nml(path, base=base, **groups, initial={"a0": [0.0]},
                     solver={"method": "dopri5", "tau_end": 0.2},
                     output={"sample_dtau": sample_dtau, "file": output})


def search_line(text):
    """The header's (or resolved text's) line recording the search, without its '#' prefix."""
    lines = [line.lstrip("# ").strip() for line in text.splitlines() if "chosen n_modes" in line]
    assert len(lines) == 1, lines
    return lines[0]


def differences(line):
    return {int(n): float(v) for n, v in re.findall(r"N=(\d+): ([0-9.E+-]+)", line)}


@pytest.mark.parametrize("scene", SCENES)
def test_executable_chooses_the_same_n_for_any_sample_dtau(tmp_path, run_exe, scene):
    lines = {}
    for dtau in (0.1, 0.001):
        path = auto_input(tmp_path / f"auto_{dtau}.nml", scene, dtau, output=f"auto_{dtau}.dat")
        proc = run_exe(path, "-q")
        assert proc.returncode == 0, proc.stderr
        lines[dtau] = search_line((tmp_path / f"auto_{dtau}.dat").read_text())
    # The comparison runs do not depend on sample_dtau at all: the same line, bit for bit.
    assert lines[0.1] == lines[0.001], lines
    line = lines[0.1]
    chosen = int(re.search(r"chosen n_modes = (\d+)", line)[1])
    values = differences(line)
    mode_tol = SCENES[scene][2]
    # The rule, read off the evidence: the first N within mode_tol, every N before it not.
    assert values[chosen] <= mode_tol and all(values[n] > mode_tol for n in range(1, chosen))
    assert sorted(values) == list(range(1, chosen + 1))
    # The header states the comparison: the quantity, each N's value and mode_tol.
    assert "max over tau in [0, mode_horizon] of |V_T(N) - V_T(N+1)|/range(V_T(N+1))" in line
    assert f"located on a grid of >= {COMPARISON_POINTS} points per period of mode N+1" in line
    assert float(re.search(r"\(mode_tol = ([^)]+)\)$", line)[1]) == mode_tol, line


@pytest.mark.parametrize("scene", SCENES)
def test_python_chooses_the_same_n_for_any_sample_dtau(tmp_path, scene):
    configs = [tmafm.Config(auto_input(tmp_path / f"auto_{dtau}.nml", scene, dtau))
               for dtau in (0.1, 0.001)]
    assert configs[0].n_modes == configs[1].n_modes
    searches = [config.mode_search for config in configs]
    assert searches[0]["differences"] == searches[1]["differences"]
    assert searches[0]["n_modes"] == configs[0].n_modes
    assert searches[0]["mode_tol"] == SCENES[scene][2]
    assert searches[0]["mode_horizon"] == 20.0
    assert searches[0]["quantity"].startswith("max over tau in [0, mode_horizon] of |V_T(N)")


def test_python_reports_what_the_header_states(tmp_path, run_exe):
    path = auto_input(tmp_path / "auto.nml", "fig2", 0.1)
    proc = run_exe(path, "-q")
    assert proc.returncode == 0, proc.stderr
    header = search_line((tmp_path / "auto.dat").read_text())
    result = tmafm.run(path)
    assert search_line(result.resolved_text) == header
    search = result.mode_search
    assert search["n_modes"] == result.n_modes == 5
    printed = differences(header)
    assert set(search["differences"]) == set(printed)
    for n, value in search["differences"].items():
        assert float(f"{value:.5E}") == printed[n]  # the core's value, to the 6 digits printed
    # A saved result keeps the evidence in its resolved input; read back, it reports it.
    result.save(tmp_path / "auto.npz")
    loaded = tmafm.load(tmp_path / "auto.npz").mode_search
    assert loaded["differences"] == printed and loaded["n_modes"] == 5
    # A fixed N reports no search.
    assert tmafm.run("fig2_n4", solver={"tau_end": 0.1}).mode_search is None


def dense_pair(n, horizon, h):
    """The fixed-N runs N and N+1 of Fig. 2 sampled at spacing h, at the search's tolerances."""
    return [tmafm.run(INPUTS / "fig2_n4.nml", model={"n_modes": m}, initial={"a0": [0.0] * m},
                      solver={"method": "dopri5", "rtol": 1e-10, "atol": 1e-16, "tau_end": horizon},
                      output={"sample_dtau": h}) for m in (n, n + 1)]


def sampled_max_bounds(values, rates, h):
    """max|values| on the grid, and how far the signal's max may lie above it: h^2/8 max|f''|,
    with f'' from the rates' differences (doubled: they underestimate its peaks)."""
    curvature = 2 * np.max(np.abs(np.diff(rates))) / h
    return np.max(np.abs(values)), h * h / 8 * curvature


@pytest.mark.parametrize("n", [1, 4])
def test_reported_difference_equals_a_dense_computation(tmp_path, run_exe, n):
    """N = 1 against 2 (largest in contact) and 4 against 5 (in free flight, the one that
    decides at mode_tol = 1.65e-3): the header's value against max|dV_T| and the range of V_T
    taken from 131073 samples of two fixed-N runs, with the bounds of a sampled maximum."""
    path = auto_input(tmp_path / "auto.nml", "fig2", 0.1)
    proc = run_exe(path, "-q")
    assert proc.returncode == 0, proc.stderr
    reported = differences(search_line((tmp_path / "auto.dat").read_text()))[n]
    horizon = 20.0
    h = horizon / 2**17
    lower, upper = dense_pair(n, horizon, h)
    sup, sup_slack = sampled_max_bounds(upper.vt - lower.vt, upper.vtdot - lower.vtdot, h)
    _, extreme_slack = sampled_max_bounds(upper.vt, upper.vtdot, h)
    span, span_slack = upper.vt.max() - upper.vt.min(), 2 * extreme_slack
    low_bound = sup / (span + span_slack)
    high_bound = (sup + sup_slack) / span
    assert high_bound / low_bound - 1 < 1e-3  # the dense computation is itself sharp
    slack = PRINT_ROUNDING + HERMITE_ERROR
    assert low_bound * (1 - slack) <= reported <= high_bound * (1 + slack), \
        (reported, low_bound, high_bound)


def test_comparison_runs_ignore_a_fine_output_grid():
    """The comparison runs once took the output's sample_dtau, and an input with a fine grid and
    a long mode_horizon was refused for their sample count (test_input_strict had the case);
    they now sample their own grid, and the same input runs."""
    config = tmafm.Config({"model": {"n_modes": 0, "mode_horizon": 100, "mode_tol": 0.5},
                           "solver": {"tau_end": 1e-2}, "output": {"sample_dtau": 1e-6}})
    assert config.n_modes == 1 and config.n_samples == 10001

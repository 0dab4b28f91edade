"""The automatic-N search (&model n_modes = 0) is bounded before it starts and reports its
progress: `&model n_modes = 0, mode_horizon = 1e4, mode_tol = 1e-12 / &solver tau_end = 1 /`
ran silently for hours (up to 30 comparison runs of tau = 1e4 at rtol 1e-10; the search over
mode_horizon = 20 already takes ~14 s CPU when no N agrees), and a Python call could not be
interrupted.  mode_horizon is now at most 100 (the worst case ~90 s) (fortran/src/config/tmafm_config.f90,
max_mode_horizon), and the executable writes one line per comparison on stderr (not with -q).
"""

import re
import subprocess
import sys

import pytest

import tmafm

HOPELESS = "&model n_modes = 0, mode_horizon = 1e4, mode_tol = 1e-12 /\n&solver tau_end = 1 /\n"


def test_executable_refuses_a_long_search_at_once(tmp_path, exe):
    (tmp_path / "auto.nml").write_text(HOPELESS)
    proc = subprocess.run([exe, "auto.nml", "-o", "out.dat"], cwd=tmp_path, capture_output=True,
                          text=True, timeout=60)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.splitlines()
    assert len(lines) == 1, lines
    assert "&model mode_horizon = 1e4" in lines[0] and "<= 1.0E+002" in lines[0], lines[0]
    assert "n_modes = 0" in lines[0], lines[0]
    assert not (tmp_path / "out.dat").exists()


def test_python_refuses_a_long_search_at_once():
    """In a child process with a timeout: before the bound, the call ran for hours."""
    code = ("import tmafm\n"
            "try:\n"
            "    tmafm.run({'model': {'n_modes': 0, 'mode_horizon': 1e4, 'mode_tol': 1e-12},\n"
            "               'solver': {'tau_end': 1.0}})\n"
            "except tmafm.InputError as error:\n"
            "    print('InputError:', error)\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith("InputError:") and "mode_horizon" in proc.stdout, proc.stdout


@pytest.mark.parametrize("horizon", [100, 100.0000000001, float("inf"), 0, -1])
def test_mode_horizon_bounds(horizon):
    config = {"model": {"n_modes": 4, "mode_horizon": horizon}}
    if 0 < horizon <= 100:
        assert tmafm.Config(config).to_dict()["model"]["mode_horizon"] == horizon
    else:
        with pytest.raises(tmafm.InputError, match="mode_horizon"):
            tmafm.Config(config)


def test_search_writes_one_progress_line_per_comparison(tmp_path, run_exe):
    (tmp_path / "auto.nml").write_text("&model n_modes = 0, mode_horizon = 2, mode_tol = 5e-3 /\n"
                                       "&solver tau_end = 0.2 /\n&output file = 'a.dat' /\n")
    proc = run_exe("auto.nml")
    assert proc.returncode == 0, proc.stderr
    lines = [line for line in proc.stderr.splitlines() if line.startswith("tmafm: choosing N:")]
    header = next(line for line in (tmp_path / "a.dat").read_text().splitlines() if "chosen n_modes" in line)
    differences = re.findall(r"N=(\d+): ([0-9.E+-]+)", header)
    assert len(differences) >= 2
    assert len(lines) == len(differences), (lines, header)
    for line, (n, value) in zip(lines, differences):
        assert f"N = {n} against {int(n) + 1} over mode_horizon = 2.0E+000" in line, line
        assert f"max|dV_T|/range = {value} (mode_tol = 5.0E-003)" in line, line
    # The comparison lines come before the run's own progress.
    assert proc.stderr.index("choosing N") < proc.stderr.index("% tau =")
    quiet = run_exe("auto.nml", "-q", "-o", "b.dat")
    assert quiet.returncode == 0 and quiet.stderr == "", quiet.stderr

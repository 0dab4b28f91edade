"""The sweeps check everything before they build or run anything (docs/sweeps.md, "Checked
before anything runs"): the extras they need, where the runs go (client, workers, progress,
chunk, backend), the keys and values, and the memory the grid would hold.  Before, the sweep
command without matplotlib wrote the .nc and then died with a traceback (exit 1); an oversized
`count` gave a MemoryError traceback; a sweep without xarray ran every point and then raised a
bare ModuleNotFoundError; and a bad `client` was found (a bare AttributeError) only after the
whole grid had been built and validated (348 s and 2.5 GB for 10**6 points)."""

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import tmafm
from tmafm import sweeps
from tmafm.sweeps import points, runs

from conftest import INPUTS

pytest.importorskip("xarray")

BISTABLE = INPUTS / "sweeps" / "bistable_n2.nml"


@pytest.fixture
def nothing_runs(monkeypatch):
    """Fail the test if a grid point is built or observed (points._config, the core's batch)."""
    def built(*args, **kwargs):
        raise AssertionError("a grid point was built or run")
    monkeypatch.setattr(points, "_config", built)
    monkeypatch.setattr(runs, "observe_batch", built)
    monkeypatch.setattr(runs, "observe_states", built)


@pytest.fixture
def little_memory(monkeypatch):
    """1 GB available: a grid of 10**6 points (16 GB by the estimate) is then too large, and
    the test needs no absurd grid (which main's code would build until memory ran out)."""
    monkeypatch.setattr(points, "_available_memory", lambda: 10**9)


def _sweep_file(folder: Path, extra: str = "values = 1e-3, 2e-3") -> Path:
    (folder / "bistable_n2.nml").write_bytes(BISTABLE.read_bytes())
    path = folder / "sweep.nml"
    path.write_text(f"&sweep kind = 'grid', base = 'bistable_n2.nml', key = 'scene.delta_hat', "
                    f"max_periods = 2, {extra} /\n")
    return path


def _main(capsys, *args):
    code = sweeps.main([str(a) for a in args])
    err = capsys.readouterr().err
    return code, err.splitlines()


@pytest.mark.parametrize("missing, words, args", [
    ("matplotlib", "matplotlib", []),
    ("xarray", "xarray", ["--no-plot"]),
    ("h5netcdf", "NetCDF writer", ["--no-plot"]),
    ("tqdm", "tqdm", ["--no-plot", "--progress"]),
])
def test_the_sweep_command_checks_its_extras_before_any_work(tmp_path, monkeypatch, capsys,
                                                             nothing_runs, missing, words, args):
    path = _sweep_file(tmp_path)
    monkeypatch.setitem(sys.modules, missing, None)  # `import missing` raises ImportError
    if missing == "h5netcdf":
        monkeypatch.setitem(sys.modules, "netCDF4", None)
    before = sorted(p.name for p in tmp_path.iterdir())
    code, lines = _main(capsys, path, "-o", tmp_path / "out.nc", *args)
    assert code == 2 and len(lines) == 1, (code, lines)
    assert lines[0].startswith("tmafm.sweeps: error: ") and words in lines[0], lines
    assert "pip install 'tmafm[sweep]'" in lines[0] or "tmafm[plot]" in lines[0], lines
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # nothing written


@pytest.mark.parametrize("extra, words, little", [
    ("start = 0, stop = 1e-3, count = 1000000000000", "count = 1000000000000", False),
    ("start = 0, stop = 1e-3, count = 1000, key2 = 'scene.alpha2', start2 = 1e-4, "
     "stop2 = 5e-4, count2 = 1000", "count = 1000, count2 = 1000", True),
], ids=["one_axis", "two_axes"])
def test_an_oversized_grid_is_one_line_naming_the_key(tmp_path, capsys, request, nothing_runs,
                                                      extra, words, little):
    """count = 10**12 raised MemoryError in np.linspace (a traceback, exit 1)."""
    if little:
        request.getfixturevalue("little_memory")
    path = _sweep_file(tmp_path, extra)
    code, lines = _main(capsys, path, "-o", tmp_path / "out.nc")
    assert code == 2 and len(lines) == 1, (code, lines)
    assert words in lines[0] and "in memory, more than the" in lines[0], lines
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bistable_n2.nml", "sweep.nml"]


def test_an_oversized_grid_from_python_is_refused_before_it_is_built(little_memory,
                                                                     nothing_runs):
    axis = np.linspace(0, 1e-3, 1000)
    with pytest.raises(tmafm.InputError, match=r"scene.delta_hat \(1000 values\) x "
                                               r"scene.alpha2 \(1000 values\): 1000000 points"):
        tmafm.sweep(BISTABLE, {"scene.delta_hat": axis, "scene.alpha2": axis})
    with pytest.raises(tmafm.InputError, match="1000000 points"):
        tmafm.basin(BISTABLE, axis, axis)
    with pytest.raises(tmafm.InputError, match="1000000 points"):
        tmafm.approach(BISTABLE, axis, curves={"scene.alpha2": axis[:500]})


@pytest.mark.parametrize("call", [
    lambda **kw: tmafm.sweep(BISTABLE, {"scene.delta_hat": [1e-3, 2e-3]}, **kw),
    lambda **kw: tmafm.approach(BISTABLE, [2e-3, 1e-3], **kw),
    lambda **kw: tmafm.bifurcation(BISTABLE, "scene.delta_hat", [1e-3, 2e-3], **kw),
    lambda **kw: tmafm.basin(BISTABLE, [0.0, 1e-4], [0.0], **kw),
], ids=["sweep", "approach", "bifurcation", "basin"])
@pytest.mark.parametrize("keyword, value, error", [
    ("client", "tcp://127.0.0.1:8786", tmafm.InputTypeError),
    ("client", 42, tmafm.InputTypeError),
    ("workers", 0, tmafm.InputTypeError),
    ("workers", 10**400, tmafm.InputTypeError),
    ("progress", "yes", tmafm.InputTypeError),
    ("progress", np.array([1, 2]), tmafm.InputTypeError),
    ("max_periods", "many", tmafm.InputTypeError),
    ("steady_tol", 10**400, tmafm.InputError),
])
def test_a_bad_argument_is_a_typed_error_before_the_grid_is_built(nothing_runs, call, keyword,
                                                                  value, error):
    with pytest.raises(error) as info:
        call(**{keyword: value})
    assert isinstance(info.value, tmafm.TmafmError)
    assert keyword in str(info.value) and "\n" not in str(info.value)
    if error is tmafm.InputTypeError:
        assert isinstance(info.value, TypeError)


def test_a_sweep_without_xarray_is_a_typed_error_before_any_point(monkeypatch, nothing_runs):
    """Before, every point ran and then `import xarray` raised a bare ModuleNotFoundError."""
    monkeypatch.setitem(sys.modules, "xarray", None)
    for call in (lambda: tmafm.sweep(BISTABLE, {"scene.delta_hat": [1e-3]}),
                 lambda: tmafm.approach(BISTABLE, [1e-3]),
                 lambda: tmafm.frequency_sweep(BISTABLE, [3.8]),
                 lambda: tmafm.bifurcation(BISTABLE, "scene.delta_hat", [1e-3]),
                 lambda: tmafm.basin(BISTABLE, [0.0], [0.0])):
        with pytest.raises(tmafm.errors.MissingExtraError, match=r"tmafm\[sweep\]") as info:
            call()
        assert isinstance(info.value, (tmafm.TmafmError, ImportError))


def test_the_sweep_command_writes_its_files_when_all_is_well(tmp_path, capsys):
    """The NetCDF file and the plot are made in memory, then written: both appear, and the
    NetCDF file reads back as the sweep (a check that the new order changed nothing)."""
    path = _sweep_file(tmp_path)
    code, lines = _main(capsys, path, "-o", tmp_path / "out.nc", "--workers", "1")
    assert code == 0, lines
    assert (tmp_path / "out.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    ds = sweeps.read_dataset(tmp_path / "out.nc")
    assert ds.attrs["tmafm_kind"] == "sweep" and ds["scene.delta_hat"].values.tolist() == [1e-3, 2e-3]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bistable_n2.nml", "out.nc", "out.png",
                                                          "sweep.nml"]


#: Measures, in a fresh process, the resident memory a sweep of `points` fig2_n4 points holds
#: per point (its peak over the call, less the memory before it).
MEASURE = textwrap.dedent("""
    import json, sys
    import numpy as np
    import tmafm, tmafm.sweeps as sweeps
    def status(field):
        with open("/proc/self/status") as f:
            return next(int(line.split()[1]) * 1024 for line in f if line.startswith(field))
    points = int(sys.argv[1])
    base = tmafm.Config("fig2_n4", solver={"tau_end": 1.0})
    sweeps.sweep(base, {"scene.delta_hat": [0.1, 0.2]}, max_periods=1, workers=1)  # warm
    before = status("VmRSS:")
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")  # the peak (VmHWM) starts again from the resident memory now
    ds = sweeps.sweep(base, {"scene.delta_hat": np.linspace(0, 0.5, points)}, max_periods=1,
                      workers=1)
    print(json.dumps({"per_point": (status("VmHWM:") - before) / points}))
""")


def test_the_memory_a_sweep_holds_per_point_is_below_the_estimate():
    """BYTES_PER_POINT, the estimate of the size check, is above what a grid sweep holds:
    8.3 kB per point for fig2_n4 (N = 4), the peak resident memory over the call less the memory
    before it; ``pytest -s tests/test_sweep_limits.py -k memory`` prints it."""
    proc = subprocess.run([sys.executable, "-c", MEASURE, "1500"], capture_output=True,
                          text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    per_point = json.loads(proc.stdout.splitlines()[-1])["per_point"]
    print(f"\nsweep memory per point: {per_point:.0f} bytes (estimate {sweeps.BYTES_PER_POINT})")
    assert 0 < per_point < sweeps.BYTES_PER_POINT, per_point


def test_a_bifurcation_over_n_modes_keeps_each_points_own_state():
    """Over model.n_modes the points have different N: the kept section points were put in an
    array of the base's 2N columns (a raw ValueError, "could not broadcast ... (2,6) into
    (2,8)"), found by tests/test_api_entry_points.py.  Each point's a1 and a1' are now its own,
    as tmafm.observe of that point gives them."""
    ds = tmafm.bifurcation("fig2_n4", "model.n_modes", [0, 2, 4], max_periods=3, periods_kept=2,
                           workers=1)
    for i, n_modes in enumerate([0, 2, 4]):
        groups = points._base_dict(tmafm.Config("fig2_n4"))  # its &initial values are zeros
        groups["model"]["n_modes"] = n_modes
        groups.pop("initial")
        config = tmafm.Config(groups)
        n = config.n_modes
        assert n == (n_modes or 3)
        obs = tmafm.observe(config, max_periods=3, stop_at_steady=False, observables=())
        assert np.array_equal(ds["a1"].values[i], obs.poincare[-2:, 0])
        assert np.array_equal(ds["adot1"].values[i], obs.poincare[-2:, n])

"""Every fenced ```python block of README.md and docs/*.md runs here, and what the text says
it gives is checked on the run.

BLOCKS lists each block, keyed by (file, the block's first line):
- `setup`: the names the block takes as given (`c1`, `tau`, an `out.npz` to read), run first
  in the block's namespace;
- `subs`: literal (old, new) substitutions that shrink a long study (sizes only: the block's
  own code runs), each of which must occur in the block; no block needs one today;
- `check`: what the docs say the block gives, asserted on the run (the values each name took,
  in order: `seen["ds"][0]` is the first dataset a block made);
- `skip`: why the block is not meant to run (a sketch with `...` for its arguments).
A block missing from BLOCKS, or an entry whose block is gone, fails
test_every_block_is_listed; a code line in an indented (unfenced) block fails
test_no_unfenced_python.  Each block runs in its own temporary folder outside the checkout,
with nothing of the checkout in reach (no `inputs/` link, no checkout folder on sys.path) and
tmafm imported from the installed wheel: the docs' examples run as they do after
`pip install tmafm` (packaged names such as "fig2_n4" and "sweeps/bistable_n2").
"""

from __future__ import annotations

import ast
import contextlib
import io
import os
import re
import subprocess
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
import pytest

import tmafm
from tmafm.observe import CF_UNITS, UNITS

REPO = Path(__file__).resolve().parent.parent
DOCS = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
FENCE = re.compile(r"^```(\S*)[^\n]*\n(.*?)^```[ \t]*$", re.M | re.S)


def fenced_blocks(path: Path):
    """(language, first line number, text) of each fenced block of a markdown file."""
    text = path.read_text()
    for m in FENCE.finditer(text):
        yield m.group(1), text.count("\n", 0, m.start(2)) + 1, m.group(2)


def python_blocks():
    """(file relative to the repository, line, text) of every ```python block."""
    return [(str(path.relative_to(REPO)), line, body) for path in DOCS
            for lang, line, body in fenced_blocks(path) if lang == "python"]


@dataclass(frozen=True)
class Block:
    setup: str = ""
    subs: tuple = ()
    check: Callable | None = None
    skip: str = ""


# ----------------------------------------------------------------------------- the checks
def _check_readme_run(ns, seen, out):
    r, c, m = ns["r"], ns["c"], ns["m"]
    first, path_run, dict_run, consistent = seen["r"]
    n = 4
    # "numpy arrays; a and adot are samples x N"
    for name in ("tau", "vt", "vtdot", "contact"):
        assert isinstance(getattr(r, name), np.ndarray) and getattr(r, name).shape == r.tau.shape
    assert r.a.shape == r.adot.shape == (r.tau.size, n)
    # a packaged name and the path of the same file give the same run
    np.testing.assert_array_equal(first.vt, path_run.vt)
    # "... or a dict of groups": N = 3, tau_end = 50 (the last sample k * sample_dtau <= 50)
    assert dict_run.a.shape[1] == 3 and abs(dict_run.tau[-1] - 50) < 1e-9
    # "+ overrides"; "the fully resolved input"
    assert consistent.resolved["model"]["convention"] == "consistent"
    assert first.resolved["model"]["convention"] == "paper"
    assert not np.array_equal(first.vt, consistent.vt)
    assert set(r.counters) == {"steps", "contact_steps", "rejected_steps", "rhs_evaluations",
                               "phase_switches"}
    assert r.counters["phase_switches"] == len(r.switches) > 0
    # "the executable's .npz layout": the saved run reads back to the last bit
    r2 = ns["r2"]
    for name in ("tau", "vt", "vtdot", "contact", "a", "adot", "switches"):
        np.testing.assert_array_equal(getattr(r2, name), getattr(r, name))
    # a Config held in memory, written and read back
    assert tmafm.Config("resolved.nml").to_dict() == c.to_dict()
    assert c.to_dict()["solver"]["tau_end"] == 10
    # the model: "(M, C, K, F) of Eq. (15)", dy/dtau of length 2N
    mass, damping, stiffness, force = m.matrices(ns["tau"], ns["a"], ns["in_contact"])
    assert mass.shape == damping.shape == stiffness.shape == (n, n) and force.shape == (n,)
    assert m.derivative(ns["tau"], ns["y"], ns["in_contact"]).shape == (2 * n,)
    assert np.isclose(m.contact(ns["tau"], ns["a"]).vt,
                      m.tip @ ns["a"] + r.scene["alpha2"] * np.sin(r.scene["omega"] * ns["tau"])
                      + r.scene["delta_hat"])


def _check_readme_observe(ns, seen, out):
    o, obs = ns["o"], ns["obs"]
    n = 4
    # "stops at steady state": fig3 (Fig. 2's scene, N = 4, the paper's rk4_paper) has a
    # period-1 steady state (docs/reproduction.md, Fig. 3), so the run finds it and stops.
    assert o.period >= 1, "tmafm.observe('fig3', max_periods=100) found no period"
    assert o.periods < 100
    assert o.per_period["amplitude"].shape == (o.periods,)
    assert o.poincare.shape == (o.periods + 1, 2 * n)
    np.testing.assert_array_equal(o.final_state, o.poincare[-1])
    assert "contact_time" in o.steady_values()
    # the batch: one Observation per input, each as observe gives it
    assert len(obs) == 3
    for config, ob in zip((ns["c1"], ns["c2"], ns["c3"]), obs):
        alone = tmafm.observe(config)
        assert ob.period == alone.period == 1
        np.testing.assert_array_equal(ob.poincare, alone.poincare)


def _check_observe_example(ns, seen, out):
    o, f = ns["o"], ns["f"]
    # "1 and 28: period 1 found after 28 periods" (the input's rk4_paper)
    assert (o.period, o.periods) == (1, 28)
    # flight_exact: "1 and 24"
    assert (f.period, f.periods) == (1, 24)
    # "contact fraction: 0.2312"
    fraction = f.steady_values()["contact_time"] / (2 * np.pi / 2.0)
    assert f"{fraction:.4f}" == "0.2312"


def _check_bimodal_example(ns, seen, out):
    tap, free = ns["tap"], ns["free"]
    # "[-95.0942, 89.4918]", "[-70.3145, 111.1355]", "0.6224", "3.0"
    assert [round(v, 4) for v in (free["tone1_phase"], free["tone2_phase"])] == [-95.0942, 89.4918]
    assert [round(v, 4) for v in (tap["tone1_phase"], tap["tone2_phase"])] == [-70.3145, 111.1355]
    assert round(tap["tone2_amplitude"] / free["tone2_amplitude"], 4) == 0.6224
    assert tap["contacts_per_period"] == 3.0
    # "tone 1 7.0985e-4", "tone 2 4.047e-5"; tapping "6.2272e-4"
    assert f"{free['tone1_amplitude']:.4e}" == "7.0985e-04" and f"{free['tone2_amplitude']:.3e}" == "4.047e-05"
    assert f"{tap['tone1_amplitude']:.4e}" == "6.2272e-04"


def _check_npz_read(ns, seen, out):
    n = 4
    assert ns["a"].shape == (ns["tau"].size, n) and ns["vt"].shape == ns["tau"].shape
    text = out.getvalue()
    assert text.lstrip().startswith("&model") and "tau_end" in text
    # "the input that made it": it reads back as that input
    Path("again.nml").write_text(text)
    made = tmafm.Config("run.nml", output={"file": "out.npz"})   # -o out.npz, as resolved
    assert tmafm.Config("again.nml").to_dict() == made.to_dict()


def _check_quick_start(ns, seen, out):
    ds = ns["ds"]
    # "This prints `...`": the line the README quotes
    quoted = re.search(r"This prints `([^`]*)`", (REPO / "README.md").read_text()).group(1)
    assert out.getvalue().strip() == quoted
    # Z in m, the observables in nm, degree, nN, pW; the setpoint A/A0 with A0 = 20 nm
    assert ds["z"].attrs["units"] == "m" and ds.attrs["free_amplitude"] == pytest.approx(20.0)
    units = {"amplitude": "nm", "phase": "degree", "peak_force": "nN", "min_gap": "nm",
             "tip_sample_power": "pW", "setpoint": "1"}
    for name, unit in units.items():
        assert ds[name].attrs["units"] == unit, name
    for name in ds.coords:
        if ds[name].dtype.kind in "fi":
            assert "units" in ds[name].attrs, name
    # "A0 = 20 nm": far from the sample the amplitude is the free amplitude (the core's linear
    # response gives the drive), within the steady test's Q/pi * steady_tol
    far = ds.sel(direction="approach").sel(z=25e-9, method="nearest")
    assert float(far.amplitude) == pytest.approx(20.0, rel=400 / np.pi * 1e-8 * 2)
    assert int(ds["failed"].sum()) == 0 and int((ds["period"] == 0).sum()) == 0
    assert Path("approach.png").stat().st_size > 10_000


STEADY = ("amplitude", "phase", "mean_deflection", "min_gap", "peak_force", "contact_time",
          "contacts_per_period", "dissipated_energy", "drive_work", "virial",
          "contact_normal_work", "harmonic_amplitude", "harmonic_phase")


def _check_grid(ns, seen, out):
    ds = ns["ds"]
    # "one dimension per key, named as the key, with the values as its coordinate", first key
    # slowest
    assert ds["amplitude"].dims == ("scene.delta_hat", "scene.alpha2")
    np.testing.assert_array_equal(ds["scene.delta_hat"].values, np.linspace(0, 2e-3, 21))
    for name in STEADY:
        assert name in ds and ds[name].attrs["units"] == CF_UNITS.get(UNITS[name], UNITS[name])
    # every coordinate has its units (the swept keys are dimensionless: "1")
    for name in ds.coords:
        assert ds[name].attrs["units"] == "1", name
    assert ds["harmonic_amplitude"].dims[-1] == "harmonic"
    for name in ("period", "steady", "periods", "failed"):
        assert name in ds
    assert int(ds.attrs["failures"]) == 0
    back = tmafm.sweeps.read_dataset("grid.nc")
    np.testing.assert_array_equal(back["amplitude"].values, ds["amplitude"].values)


def _check_approach_and_frequency(ns, seen, out):
    summarize = tmafm.sweeps.summarize
    approach, frequency = seen["ds"]
    assert approach["jump"].dims == ("direction", "scene.alpha2", "scene.delta_hat")
    # docs/sweeps.md, the table of `--summarize approach.nc` (its sweep file is this grid)
    table = {(4e-4, "approach"): ("1.4e-3", None), (4e-4, "retract"): ("3.4e-3", "4.09e-3"),
             (5e-4, "approach"): ("1.8e-3", None), (5e-4, "retract"): ("4.2e-3", "5.05e-3")}
    jumps = summarize(approach)["jumps"]
    assert len(jumps) == 4
    for j in jumps:
        at, amplitude = table[(j["scene.alpha2"], j["direction"])]
        assert [f"{x:.1e}".replace("e-03", "e-3") for x in j["at"]] == [at]
        if amplitude:
            assert f"{j['amplitude_max']:.2e}".replace("e-03", "e-3") == amplitude
    # "the free oscillation: amplitude 2.0e-3, phase −166°, no contact"; "the phase
    # (−166° → −44° at α2 = 5e-4)"; "tapping ... amplitude up to 5.1e-3"
    curve = approach.sel({"scene.alpha2": 5e-4, "direction": "approach"})
    free = curve.sel({"scene.delta_hat": 8e-3}, method="nearest")
    assert f"{float(free.amplitude):.1e}" == "2.0e-03" and round(float(free.phase)) == -166
    assert float(free.contacts_per_period) == 0
    hop = int(np.flatnonzero(curve["jump"].values)[0])
    assert [round(float(curve.phase[k])) for k in (hop - 1, hop)] == [-166, -44]
    retract = approach.sel({"scene.alpha2": 5e-4, "direction": "retract"})
    assert f"{float(retract.amplitude.max()):.1e}" == "5.1e-03"
    # "Retracting, the tapping branch lasts to δ̂ = 4e-3 ... then falls back to 2.0e-3"
    at = {x: retract.sel({"scene.delta_hat": x}, method="nearest") for x in (4e-3, 4.2e-3)}
    assert float(at[4e-3].contacts_per_period) > 0
    assert f"{float(at[4.2e-3].amplitude):.1e}" == "2.0e-03"
    # the frequency sweep: up, climbs to 4.70e-3 and drops at 4.05; down, jumps at 3.55
    by_direction = {j["direction"]: j for j in summarize(frequency)["jumps"]}
    assert [round(x, 2) for x in by_direction["up"]["at"]] == [4.05]
    assert f"{by_direction['up']['amplitude_max']:.2e}" == "4.70e-03"
    assert [round(x, 2) for x in by_direction["down"]["at"]] == [3.55]


def _check_bifurcation(ns, seen, out):
    ds = ns["ds"]
    summary = tmafm.sweeps.summarize(ds)
    alpha2 = ds["scene.alpha2"].values
    period = ds["period"].values
    # "period-1 up to α2 = 1.1e-3 ... from 1.125e-3 to 1.325e-3 no period ... from 1.35e-3
    # period 2"; "From 1.175e-3 the section values of V_T split by more than 1e-6"
    assert np.all(period[alpha2 < 1.1125e-3] == 1)
    assert np.all(period[(alpha2 > 1.1125e-3) & (alpha2 < 1.3375e-3)] == 0)
    assert np.all(period[alpha2 > 1.3375e-3] == 2)
    assert round(min(summary["split_1e-6_at"]), 6) == 1.175e-3
    assert ds["vt"].dims[-1] == "kept" and ds.sizes["kept"] == 64
    assert {"a1", "adot1", "tip", "vt"} <= set(ds.data_vars)


def _check_basin(ns, seen, out):
    ds = ns["ds"]
    summary = tmafm.sweeps.summarize(ds)
    # "one attractor over the whole 41 × 41 map: 1680 points reach it"; "all 1680 points
    # period-1, attractor_period 1"; "One point fails: a1(0) = 0, a1'(0) = −5e-4, switch chatter"
    assert summary["attractors"] == 1
    assert summary["points_per_label"] == {"-1": 1, "0": 1680}
    labels = ds["attractor"].values
    assert np.all(ds["period"].values[labels == 0] == 1)
    assert np.all(ds["attractor_period"].values[labels == 0] == 1)
    failed = np.argwhere(ds["failed"].values.astype(bool))
    assert len(failed) == 1
    i, j = failed[0]
    assert ds["a1"].values[i] == 0 and np.isclose(ds["adot1"].values[j], -5e-4)
    assert "switch chatter" in ds.attrs["first_failure"]


def _check_continuation(ns, seen, out):
    ds = ns["ds"]
    one = ds.where(ds["period"] == 1, drop=True)
    labels = list(one["label"].values)
    assert "grazing" in labels and labels.count("fold") == 2
    assert (ds["period"] == 2).any()
    assert ns["orbit"].stable and ns["orbit"].stats["contacts"] == 2
    # "one period-2 branch"; every end has a reason, none early; section 7's grazing row:
    # "max |mu| 0.7594 before, 1.129 just after"
    assert set(ds["branch"].values[ds["period"].values == 2]) == {1000}
    assert sorted(r for r in ds["end_reason"].values if r) == ["rejoined", "stop"]
    g = labels.index("grazing")
    assert round(float(one["max_multiplier_before"].values[g]), 4) == 0.7594
    assert round(float(one["max_multiplier_after"].values[g]), 3) == 1.129


def _check_s_curve(ns, seen, out):
    # "grazing ... between 19.2 and 19.4 nm ... both folds ... end_reason stop"
    ds = ns["ds"]
    labels = list(ds["label"].values)
    assert labels.count("grazing") == 1 and labels.count("fold") == 2
    z = ds["physical.tip_sample_distance"].values
    assert 19.2e-9 < z[labels.index("grazing")] < 19.4e-9
    assert [r for r in ds["end_reason"].values if r] == ["stop"] and z[-1] <= 14e-9


def _check_time_domain(ns, seen, out):
    """The run continues the point's orbit: its first sample is the final state, and the
    spectrum's largest bin past 0 is the drive's (bin 4 over 4 periods)."""
    r, state, n = ns["r"], ns["state"], ns["n"]
    assert np.array_equal(r.a[0], state[:n])
    assert set(ns["series"]) == {"t_s", "distance_m", "deflection_m", "normal_force_N", "friction_force_N"}
    assert int(np.argmax(ns["spectrum"][1:])) + 1 == 4


def _check_z_schedule(ns, seen, out):
    # docs/instrument.md: one value per drive period; 10 nm nearer, the tip taps and the
    # amplitude falls below the far one.
    steps = ns["steps"]
    amplitude = steps.values["amplitude"]
    assert amplitude.shape == (800,) and steps.units["amplitude"] == "nm"
    assert amplitude[-1] < amplitude[399] and steps.values["peak_force"][-1] > 0


def _check_thermal(ns, seen, out):
    """docs/model.md section 21: the spectrum of inputs/thermal_air.nml peaks within the
    resonance's width (f0/Q = 3.5 kHz) of f0 = 70 kHz, in m^2/Hz of the order k_B T/(k f0/Q)."""
    assert abs(ns["peak"] - 70e3) < 3.5e3
    assert ns["dof"] > 40
    level = 1.380649e-23 * 298.15 / 2.0 / (70e3 / 20)
    assert 0.1 * level < ns["S"].max() < 10 * level


def _check_fm_approach(ns, seen, out):
    # docs/instrument.md, FM-AFM: the Δf the text quotes (tests/test_fm.py checks them against
    # the Sader-Jarvis integral)
    assert np.allclose(ns["fm"].df.values, [-0.648, -1.67, -9.57], rtol=2e-3, atol=0)


def _check_scan_line(ns, seen, out):
    # docs/instrument.md, AM imaging: the Dataset's layout and units, and the 5 nm step: on the
    # trace the last pixel (x > 375 nm, the softer material) is about 5 nm above the first.
    ds = ns["ds"]
    assert ds["height"].dims == ("direction", "x") and list(ds["direction"].values) == ["trace", "retrace"]
    for name, unit in (("height", "nm"), ("amplitude_error", "nm"), ("phase", "deg"), ("peak_force", "nN")):
        assert ds[name].attrs["units"] == unit, name
    assert 4.5 < float(ds["height"].values[0, -1] - ds["height"].values[0, 0]) < 5.5
    assert Path("scan.png").stat().st_size > 10_000


BLOCKS = {
    ("docs/instrument.md", "from tmafm.instrument import fm_approach"): Block(check=_check_fm_approach),
    ("docs/instrument.md", "import numpy as np, tmafm"): Block(check=_check_z_schedule),
    ("docs/instrument.md", "import tmafm.instrument"): Block(
        setup="import matplotlib; matplotlib.use('Agg')",
        subs=(("pixels=256, line_rate=2.0", "pixels=4, line_rate=50.0"),), check=_check_scan_line),
    ("docs/model.md", "import numpy as np, tmafm"): Block(check=_check_thermal),
    ("docs/continuation.md", "import tmafm"): Block(check=_check_continuation),
    ("docs/continuation.md", 'base = tmafm.Config("tapping_polystyrene", physical={"drive_frequency": '
                             '301e3})'): Block(check=_check_s_curve),
    ("README.md", "import tmafm"): Block(
        setup="import numpy as np\n"
              "tau, in_contact = 1.0, False\n"
              "a = np.array([2e-4, 1e-5, -1e-6, 1e-7]); adot = np.array([1e-4, 0, 0, 0])\n"
              "y = np.concatenate([a, adot])",
        check=_check_readme_run),
    ("README.md", "import numpy as np, tmafm"): Block(check=_check_quick_start),
    ("README.md", 'ds = tmafm.sweep(base, {"scene.delta_hat": np.linspace(0, 2e-3, 21)}, '
                  'workers=2)  # xarray'): Block(
        skip="a sketch of the sweep API: `...` stands for the arrays; docs/sweeps.md runs "
             "each call in full"),
    ("README.md", 'ds = tmafm.instrument.scan_line("tapping_polystyrene", topography="step", ...)  '
                  '# height, phase, ...'): Block(
        skip="a sketch of the instrument's API: `...` stands for the settings; docs/instrument.md "
             "runs each call in full"),
    ("README.md", 'o = tmafm.observe("fig3", max_periods=100)        # no trajectory kept; '
                  'stops at steady state'): Block(
        setup='c1, c2, c3 = (tmafm.Config(name, solver={"method": "flight_exact"})\n'
              '              for name in ("fig2_n1", "fig2_n2", "fig2_n3"))',
        check=_check_readme_observe),
    ("docs/observables.md", "import tmafm"): Block(check=_check_observe_example),
    ("docs/observables.md", "import tmafm  # two tones"): Block(check=_check_bimodal_example),
    ("docs/output-format.md", "import numpy as np"): Block(
        setup="c = tmafm.Config('fig2_n4', solver={'tau_end': 1.0}, output={'format': 'npy'})\n"
              "c.write('run.nml')\n"
              "subprocess.run([tmafm.executable(), '-q', 'run.nml', '-o', 'out.npz'], check=True)",
        check=_check_npz_read),
    ("docs/sweeps.md", "import numpy as np, tmafm"): Block(
        setup="import matplotlib; matplotlib.use('Agg')", check=_check_grid),
    ("docs/sweeps.md", 'ds = tmafm.approach("sweeps/bistable_n2", '
                       'delta_hat=np.linspace(8e-3, 0, 41),'): Block(
        setup="import numpy as np, tmafm", check=_check_approach_and_frequency),
    ("docs/sweeps.md", "import numpy as np, tmafm  # the force, trajectory and spectrum at one Z "
                       "of a curve"): Block(check=_check_time_domain),
    ("docs/sweeps.md", 'fig5 = tmafm.Config("fig5a", solver={"method": "flight_exact", '
                       '"rtol": 1e-8})'): Block(
        setup="import numpy as np, tmafm", check=_check_bifurcation),
    ("docs/sweeps.md", 'fig4 = tmafm.Config("fig4a", solver={"method": "flight_exact", '
                       '"rtol": 1e-8})'): Block(
        setup="import numpy as np, tmafm", check=_check_basin),
}


def _key(path, body):
    return path, body.splitlines()[0].strip()


def test_every_block_is_listed():
    """Every ```python block is run or explicitly skipped, and every entry has its block."""
    found = {_key(path, body) for path, _, body in python_blocks()}
    assert sorted(found - set(BLOCKS)) == [], "python blocks not in BLOCKS"
    assert sorted(set(BLOCKS) - found) == [], "BLOCKS entries whose block is gone"
    assert len(found) == len(python_blocks()), "two blocks share a first line"
    for block in BLOCKS.values():
        assert bool(block.skip) != bool(block.check), "a block either runs with a check or skips"


def test_no_unfenced_python():
    """Code in an indented (unfenced) block is never run: examples go in ```python fences."""
    code = re.compile(r"^(?: {4}|\t)(?:import |from \S+ import |\w+ = tmafm\.|tmafm\.)", re.M)
    for path in DOCS:
        text = FENCE.sub("", path.read_text())
        hits = [line for line in text.splitlines() if code.match(line)]
        assert hits == [], f"{path.name}: indented code outside a fence: {hits}"


def _run(source: str, ns: dict, filename: str, seen: dict) -> None:
    """Run `source` statement by statement in `ns`, noting each new value a name takes."""
    for statement in ast.parse(source).body:
        before = {k: id(v) for k, v in ns.items()}
        exec(compile(ast.Module([statement], []), filename, "exec"), ns)
        for name, value in ns.items():
            if not name.startswith("__") and before.get(name) != id(value):
                seen.setdefault(name, []).append(value)


def _inside(path, folder: Path) -> bool:
    try:
        Path(path).resolve().relative_to(folder)
    except (ValueError, OSError):
        return False
    return True


def _outside_the_checkout(folder: Path) -> None:
    """The block's folder is outside the checkout, tmafm (and its extension and inputs) comes
    from the installed wheel, and no folder of the checkout that holds a tmafm package is on
    sys.path: what runs is what `pip install` gives."""
    import importlib.util
    import sys
    assert not _inside(folder, REPO), f"{folder} is inside the checkout {REPO}"
    for module in (tmafm, tmafm.inputs):
        assert not _inside(module.__file__, REPO), f"{module.__name__} imported from the checkout"
    assert not _inside(tmafm.inputs.folder(), REPO)
    assert not _inside(importlib.util.find_spec("tmafm._fwrap").origin, REPO)
    for entry in sys.path:
        root = Path(entry or ".").resolve()
        assert not (_inside(root, REPO) and (root / "tmafm").is_dir()), \
            f"sys.path entry {entry!r} holds the checkout's tmafm"


def test_examples_run_outside_the_checkout(tmp_path, monkeypatch):
    """The check itself: from a folder outside the checkout, the packaged names the docs use
    resolve inside the installed package, sweep files included."""
    _outside_the_checkout(tmp_path)
    monkeypatch.chdir(tmp_path)
    for name in ("fig2_n4", "sweeps/bistable_n2", "sweeps/approach"):
        path = tmafm.inputs.path(name)
        assert path.is_file() and not _inside(path, REPO)
        assert path.read_bytes() == (REPO / "inputs" / f"{name}.nml").read_bytes()
    assert tmafm.inputs.sweep_names() == sorted(
        f"sweeps/{p.stem}" for p in (REPO / "inputs" / "sweeps").glob("*.nml"))
    assert tmafm.Config("sweeps/bistable_n2").n_modes == 2
    from tmafm.sweeps import read_sweep_file
    spec = read_sweep_file("sweeps/approach.nml")
    assert Path(spec["base"]).is_file() and not _inside(spec["base"], REPO)


@pytest.mark.parametrize("path,line,body", python_blocks(),
                         ids=[f"{p}:{n}" for p, n, _ in python_blocks()])
def test_block_runs_and_gives_what_the_docs_say(path, line, body, tmp_path, monkeypatch):
    block = BLOCKS.get(_key(path, body))
    if block is None:
        pytest.fail(f"{path}:{line}: not in BLOCKS (test_every_block_is_listed)")
    if block.skip:
        pytest.skip(f"{path}:{line}: {block.skip}")
    source = body
    for old, new in block.subs:
        assert old in source, f"{path}:{line}: substitution {old!r} no longer applies"
        source = source.replace(old, new)
    _outside_the_checkout(tmp_path)
    monkeypatch.chdir(tmp_path)
    ns = {"__name__": "__docs__", "tmafm": tmafm, "subprocess": subprocess, "os": os}
    seen: dict = {}
    _run(block.setup, ns, f"{path}:{line} (setup)", {})
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        _run(source, ns, f"{path}:{line}", seen)
    block.check(ns, seen, out)

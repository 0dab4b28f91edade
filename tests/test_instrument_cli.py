"""The instrument in the executable (docs/instrument.md, "In the executable"): &scan runs the
AM scan line and &fm the FM approach; their tables equal what tmafm.instrument gives for the
same settings (the same core, so equal to the printed digits: 17 significant digits read back
exactly); bad &scan and &fm input is refused in one line, with exit 2 and no output file; the
resolved text reads back to the same input."""

import numpy as np
import pytest

import tmafm
from tmafm.instrument import MATERIAL_KEYS, fm_approach, scan_line

from conftest import INPUTS, write_nml

INPUT_ERROR = 2
AM_SCAN = INPUTS / "am_scan.nml"
FM_APPROACH = INPUTS / "fm_approach.nml"


def read_table(path):
    """The table's columns by name, and the header's lines (without '# ')."""
    header = [line[2:] for line in path.read_text().splitlines() if line.startswith("# ")]
    names = next(line for line in header if line.startswith("columns: ")).split()[1:]
    units = next(line for line in header if line.startswith("units: ")).split()[1:]
    data = np.loadtxt(path, ndmin=2)
    assert data.shape[1] == len(names) == len(units)
    return {name: data[:, k] for k, name in enumerate(names)}, dict(zip(names, units)), header


def note(header, prefix, name):
    """The value of a header note '<prefix>: <name> = <value> <unit>'."""
    line = next(line for line in header if line.startswith(f"{prefix}: {name} = "))
    return float(line.split(" = ")[1].split()[0])


def test_am_scan_equals_scan_line(tmp_path, run_exe):
    proc = run_exe(AM_SCAN, "-o", tmp_path / "scan.dat")
    assert proc.returncode == 0, proc.stderr
    assert "tmafm: scan: 4 pixels, trace and retrace" in proc.stderr
    table, units, header = read_table(tmp_path / "scan.dat")
    # inputs/am_scan.nml's &scan, as Python's keywords (its comment says so too).
    ds = scan_line(AM_SCAN, scan_length=40e-9, pixels=4, line_rate=375.0, setpoint_ratio=0.8,
                   lockin_bandwidth=10e3, feedback_bandwidth=1e3, topography="step", step_height=2e-9,
                   step_position=20e-9, material_b={"youngs_modulus_sample": 0.3e9}, material_boundary=30e-9)
    assert list(table) == ["direction", "x", *ds.data_vars]
    for p, direction in enumerate(["trace", "retrace"]):
        rows = table["direction"] == p
        assert rows.sum() == 4
        np.testing.assert_array_equal(table["x"][rows], ds["x"].values)
        for name in ds.data_vars:
            assert units[name] == ds[name].attrs["units"]
            np.testing.assert_array_equal(table[name][rows], ds[name].sel(direction=direction).values,
                                          err_msg=name)
    for name, unit in (("free_amplitude", "nm"), ("slope", None), ("integral_gain", "1_per_s"),
                       ("engaged_height", "nm"), ("periods_per_pixel", None)):
        assert note(header, "engage", name) == ds.attrs[f"{name}_{unit}" if unit else name], name
    # The scene: the step under the tip, and the second material on the last pixel only.
    # (pixel means of 2e-9 m in nm: rounding of the sums, far below 1e-12 nm)
    np.testing.assert_allclose(table["topography"][:4], [0, 0, 2, 2], rtol=0, atol=1e-12)
    assert table["material"][3] == 1 and not table["material"][:3].any()


def test_a_noisy_am_scan_equals_scan_line(tmp_path, run_exe):
    # &solver thermal_noise = 1 in the executable's &scan: the same seeded realisation as
    # scan_line's (each period's seed from noise_seed), so the same table to the printed digits.
    noise = {"thermal_noise": 1, "noise_seed": 11, "method": "dop853"}
    path = write_nml(tmp_path / "noisy.nml", AM_SCAN, solver=noise, model={"n_modes": 1})
    proc = run_exe(path, "-o", tmp_path / "scan.dat")
    assert proc.returncode == 0, proc.stderr
    table, _, header = read_table(tmp_path / "scan.dat")
    ds = scan_line(AM_SCAN, solver=noise, model={"n_modes": 1}, scan_length=40e-9, pixels=4, line_rate=375.0,
                   setpoint_ratio=0.8, lockin_bandwidth=10e3, feedback_bandwidth=1e3, topography="step",
                   step_height=2e-9, step_position=20e-9, material_b={"youngs_modulus_sample": 0.3e9},
                   material_boundary=30e-9)
    for p, direction in enumerate(["trace", "retrace"]):
        rows = table["direction"] == p
        for name in ("height", "phase", "amplitude", "peak_force"):
            np.testing.assert_array_equal(table[name][rows], ds[name].sel(direction=direction).values,
                                          err_msg=name)
    assert note(header, "engage", "free_amplitude") == ds.attrs["free_amplitude_nm"]
    assert note(header, "engage", "ringup_periods") == ds.attrs["ringup_periods"]


def test_fm_approach_equals_fm_approach(tmp_path, run_exe):
    proc = run_exe(FM_APPROACH, "-o", tmp_path / "fm.dat")
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr.count("tmafm: fm: Z point") == 3
    table, units, header = read_table(tmp_path / "fm.dat")
    fm = fm_approach(FM_APPROACH, z=np.linspace(10e-9, 6e-9, 3), amplitude=5e-9, pll_bandwidth=10e3,
                     amplitude_bandwidth=10e3, settle_periods=150, average_periods=10)
    np.testing.assert_array_equal(table["z"], fm["z"].values)
    for name, unit, _ in tmafm.instrument.FM_COLUMNS:
        assert units[name] == unit
        if name != "z":
            np.testing.assert_array_equal(table[name], fm[name].values, err_msg=name)
    assert note(header, "reference", "f0") == fm.attrs["f0_Hz"]
    assert note(header, "reference", "phase_setpoint") == fm.attrs["phase_setpoint_deg"]
    assert note(header, "reference", "response_time") == fm.attrs["response_time_s"]


def test_fm_npy_format(tmp_path, run_exe):
    """&output format = 'npy': one array per column, the resolved input and the notes."""
    path = write_nml(tmp_path / "fm.nml", base=FM_APPROACH, fm={"z_points": 1, "z_end": 10e-9},
                     output={"file": "fm.npz", "format": "npy"})
    proc = run_exe(path)
    assert proc.returncode == 0, proc.stderr
    with np.load(tmp_path / "fm.npz") as data:
        assert data["df"].shape == (1,) and data["z"][0] == 10.0
        assert "&fm" in data["resolved.npy" if "resolved.npy" in data else "resolved"].item().decode()
        assert "reference: f0 = " in data["notes"].item().decode()


def test_b_keys_are_python_material_keys():
    keys = tmafm._namelist.KEY_TYPES["scan"]
    assert [k[2:] for k in keys if k.startswith("b_")] == list(MATERIAL_KEYS)


SCAN = {"scan_length": 40e-9, "pixels": 4, "line_rate": 375.0, "setpoint_ratio": 0.8,
        "lockin_bandwidth": 10e3, "feedback_bandwidth": 1e3}

CASES = {
    # name: (groups patched into the base, the base, words the message holds)
    "scan_pixels_zero": ({"scan": {"pixels": 0}}, AM_SCAN, ["&scan pixels = 0", "1..100000"]),
    "scan_ratio_one": ({"scan": {"setpoint_ratio": 1.0}}, AM_SCAN, ["setpoint_ratio = 1.0", "< 1.0"]),
    "scan_lockin_too_fast": ({"scan": {"lockin_bandwidth": 2e5}}, AM_SCAN,
                             ["lockin_bandwidth = 2.0E+005", "half the drive frequency"]),
    "scan_two_setpoints": ({"scan": {"setpoint": 10e-9}}, AM_SCAN, ["setpoint = 1.0E-008", "exactly one"]),
    "scan_too_fast_line": ({"scan": {"line_rate": 1e5}}, AM_SCAN,
                           ["line_rate = 1.0E+005", "less than one drive period per pixel"]),
    "scan_bad_topography": ({"scan": {"topography": "cone"}}, AM_SCAN, ["topography = 'cone'", "'sphere'"]),
    "scan_unknown_key": ({"scan": {"pixel": 4}}, AM_SCAN, ["&scan pixel = 4", "unknown key"]),
    "scan_b_out_of_range": ({"scan": {"b_poisson_ratio_sample": 0.7}}, AM_SCAN,
                            ["b_poisson_ratio_sample = 0.7", "<= 5.0E-001"]),
    "scan_b_rule_across_keys": ({"scan": {"b_sample_modulus_relaxed": 2e9}}, AM_SCAN,
                                ["the second material (&scan b_ keys)", "sample_modulus_relaxed = 2000000000.0"]),
    "scan_step_past_line": ({"scan": {"step_position": 50e-9}}, AM_SCAN,
                            ["step_position = 5.0E-008", "scan_length"]),
    "fm_amplitude_negative": ({"fm": {"amplitude": -5e-9}}, FM_APPROACH, ["&fm amplitude = -5e-09"]),
    "fm_pll_too_fast": ({"fm": {"pll_bandwidth": 50e3}}, FM_APPROACH,
                        ["pll_bandwidth = 5.0E+004", "f0/10"]),
    "fm_unknown_key": ({"fm": {"z_step": 1e-9}}, FM_APPROACH, ["&fm z_step", "unknown key"]),
    "fm_no_z_end": ({"fm": {"z_points": 3, "z_end": None}}, FM_APPROACH, ["z_points = 3", "needs z_end"]),
    "fm_average_zero": ({"fm": {"average_periods": 0}}, FM_APPROACH, ["average_periods = 0", "1..10000000"]),
    "both_groups": ({"scan": SCAN}, FM_APPROACH, ["&scan or &fm, not both"]),
}


def patched(tmp_path, groups, base):
    """base patched by groups (a None value drops the key)."""
    path = write_nml(tmp_path / "bad.nml", base=base, output={"file": "bad.dat"},
                     **{g: {k: v for k, v in values.items() if v is not None} for g, values in groups.items()})
    drop = [(g, k) for g, values in groups.items() for k, v in values.items() if v is None]
    if drop:
        lines = path.read_text().splitlines()
        path.write_text("\n".join(line for line in lines
                                  if not any(line.strip().startswith(f"{k} =") for _, k in drop)) + "\n")
    return path


@pytest.mark.parametrize("name", sorted(CASES))
def test_bad_instrument_input_is_refused(tmp_path, run_exe, name):
    groups, base, words = CASES[name]
    proc = run_exe(patched(tmp_path, groups, base))
    assert proc.returncode == INPUT_ERROR, proc.stderr
    assert proc.stderr.count("\n") == 1 and proc.stderr.startswith("tmafm: error: "), proc.stderr
    for word in words:
        assert word in proc.stderr, (word, proc.stderr)
    assert not (tmp_path / "bad.dat").exists()
    assert [p.name for p in tmp_path.iterdir()] == ["bad.nml"]


def test_instrument_needs_physical(tmp_path, run_exe):
    for group, values in (("scan", SCAN), ("fm", {"amplitude": 5e-9, "z_start": 10e-9})):
        path = write_nml(tmp_path / "bad.nml", base=INPUTS / "fig2_n4.nml", output={"file": "bad.dat"},
                         **{group: values})
        proc = run_exe(path)
        assert proc.returncode == INPUT_ERROR and proc.stderr.count("\n") == 1
        assert f"&{group} needs the scene in SI units (&physical)" in proc.stderr
        assert not (tmp_path / "bad.dat").exists()
        with pytest.raises(tmafm.InputError, match="SI units"):
            tmafm.Config("fig2_n4", **{group: values})


@pytest.mark.parametrize("base", [AM_SCAN, FM_APPROACH])
def test_resolved_text_round_trips(tmp_path, base):
    text = tmafm.Config(base).text
    group = "&scan" if base == AM_SCAN else "&fm"
    assert group in text
    (tmp_path / "again.nml").write_text(text)
    assert tmafm.Config(tmp_path / "again.nml").text == text


def test_python_overrides_take_the_groups():
    config = tmafm.Config("tapping_polystyrene", scan={**SCAN, "b_adhesion_energy": 0.05})
    text = config.text
    assert "&scan" in text and "b_adhesion_energy = 5.0E-002" in text and "b_hamaker" not in text
    assert "&fm" not in text
    with pytest.raises(tmafm.InputError, match="pixels = 0"):
        tmafm.Config("tapping_polystyrene", scan={**SCAN, "pixels": 0})


@pytest.mark.parametrize("group", ["scan", "fm"])
def test_a_run_or_observe_of_an_instrument_input_is_refused_not_silently_a_trajectory(group):
    # An input with &scan or &fm asks for that measurement; tmafm.run and tmafm.observe would
    # leave the group out, so they refuse it in one line naming the group.
    config = tmafm.Config(f"{'am_scan' if group == 'scan' else 'fm_approach'}")
    with pytest.raises(tmafm.InputError, match=rf"&{group}: .*not a trajectory"):
        tmafm.run(config)
    with pytest.raises(tmafm.InputError, match=rf"&{group}: .*not an observed run"):
        tmafm.observe(config, max_periods=2)

"""Units of the sweeps' datasets: a &physical scene's observables in SI-derived units with a
`units` attribute pint reads, every coordinate with its units, the dissipated power, physical
bifurcation variables; the plots' labels and their fixed defects; the packaged sweep files."""

import math
import warnings

import numpy as np
import pytest

import tmafm
from tmafm.observe import physical_scales
from tmafm import sweeps  # noqa: F401 (tmafm.sweeps below)
from tmafm.sweeps import plots

xr = pytest.importorskip("xarray")

PHYSICAL = tmafm.Config("physical_polystyrene", solver={"method": "flight_exact"})
QUICK = dict(max_periods=6, stop_at_steady=False)


def _independent_scales(config):
    """Eq. (10)-(12)'s scales from the &physical input itself (not from the core): gap d,
    t0 = sqrt(m L^4/(E1 I)), E1 I/L^2, E1 I d^2/L^3."""
    phys = config.to_dict()["physical"]
    ei = phys["youngs_modulus_tip"] * phys["width"] * phys["thickness"] ** 3 / 12
    m = phys["density"] * phys["width"] * phys["thickness"]
    length = phys["length"]
    # the gap: given, or tip_length + Z/cos(tilt) from the tip-sample distance Z
    d = phys["gap"] if "gap" in phys else \
        phys["tip_length"] + phys["tip_sample_distance"] / math.cos(phys["tilt"])
    return {"length": d, "time": math.sqrt(m * length ** 4 / ei), "force": ei / length ** 2,
            "energy": ei * d ** 2 / length ** 3}


@pytest.fixture(scope="module")
def physical_grid():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", tmafm.UnsteadyWarning)
        return tmafm.sweep(PHYSICAL, {"physical.drive_amplitude": [2e-9, 3e-9]}, workers=1,
                           **QUICK)


def test_physical_scales_are_the_inputs_eq12():
    scales = physical_scales(PHYSICAL)
    for name, value in _independent_scales(PHYSICAL).items():
        assert scales[name] == pytest.approx(value, rel=1e-12), name
    assert physical_scales("fig2_n4") is None


def test_a_physical_scene_gives_si_values_with_units(physical_grid):
    ds = physical_grid
    expected = {"amplitude": "nm", "phase": "degree", "mean_deflection": "nm", "min_gap": "nm",
                "peak_force": "nN", "contact_time": "us", "dissipated_energy": "aJ",
                "virial": "aJ", "harmonic_amplitude": "nm", "harmonic_phase": "degree",
                "dissipated_power": "pW", "tip_sample_power": "pW", "contacts_per_period": "1"}
    for name, unit in expected.items():
        assert ds[name].attrs["units"] == unit, name
    # No unit hides in a name any more.
    assert not [name for name in ds.data_vars if name.endswith(("_nm", "_nN", "_aJ", "_us"))]
    # The values: each point's model values (observe, run alone) times the scales computed
    # here from the input (Eq. 12), not the core's.
    for k, f in enumerate([2e-9, 3e-9]):
        config = tmafm.Config(PHYSICAL, physical={"drive_amplitude": f})
        s = _independent_scales(config)
        model = tmafm.observe(config, **QUICK).steady_values()
        point = ds.isel({"physical.drive_amplitude": k})
        assert float(point.amplitude) == pytest.approx(model["amplitude"] * s["length"] * 1e9,
                                                       rel=1e-12)
        assert float(point.peak_force) == pytest.approx(model["peak_force"] * s["force"] * 1e9,
                                                        rel=1e-12)
        assert float(point.phase) == pytest.approx(model["phase"], rel=1e-12)
        np.testing.assert_allclose(point.harmonic_amplitude.values,
                                   model["harmonic_amplitude"] * s["length"] * 1e9, rtol=1e-12)
        # the dissipated power: the energy per period over the drive period 2 pi/omega (s)
        omega = config.to_dict()["physical"]["drive_angular_frequency"]
        power = model["dissipated_energy"] * s["energy"] / (2 * math.pi / omega)
        assert float(point.dissipated_power) * 1e-12 == pytest.approx(power, rel=1e-9)
        contact = (model["dissipated_contact_damping"] + model["dissipated_friction"]) \
            * s["energy"] / (2 * math.pi / omega)
        assert float(point.tip_sample_power) * 1e-12 == pytest.approx(contact, rel=1e-9)


def test_every_coordinate_has_units_pint_reads(physical_grid):
    pint = pytest.importorskip("pint")
    ureg = pint.UnitRegistry()
    ds = physical_grid
    assert ds["physical.drive_amplitude"].attrs["units"] == "m"
    assert ds["harmonic"].values.tolist() == [1, 2, 3]
    for name, var in ds.variables.items():
        if var.dtype.kind in "fi":
            unit = var.attrs["units"]
            assert ureg.Quantity(1.0, "" if unit == "1" else unit).dimensionality is not None
    assert ureg.Quantity(float(ds.amplitude[0]), ds.amplitude.attrs["units"]).to("m").magnitude \
        == pytest.approx(float(ds.amplitude[0]) * 1e-9)


def test_a_dimensionless_scene_keeps_model_units():
    ds = tmafm.sweep("fig2_n4", {"scene.delta_hat": [0.0, 1e-3]}, workers=1, max_periods=4,
                     stop_at_steady=False, observables=["lockin"])
    assert ds.amplitude.attrs["units"] == "d" and ds.phase.attrs["units"] == "degree"
    assert ds["scene.delta_hat"].attrs["units"] == "1"
    assert "dissipated_power" not in ds


def test_physical_bifurcation_variables_are_in_nm():
    ds = tmafm.bifurcation(PHYSICAL, "physical.drive_amplitude", [2e-9, 2.5e-9], max_periods=4,
                           periods_kept=3, workers=1)
    d = _independent_scales(PHYSICAL)
    groups = PHYSICAL.to_dict()
    dimensionless = {"model": groups["model"], "scene": PHYSICAL.scene, "solver": groups["solver"]}
    plain = tmafm.bifurcation(dimensionless, "scene.alpha2",
        [2e-9 / d["length"], 2.5e-9 / d["length"]], max_periods=4, periods_kept=3, workers=1)
    for name in ("a1", "tip", "vt"):
        assert ds[name].attrs["units"] == "nm"
        np.testing.assert_allclose(ds[name].values, plain[name].values * d["length"] * 1e9,
                                   rtol=1e-9, atol=1e-9 * float(abs(ds[name]).max()))
    assert ds["adot1"].attrs["units"] == "mm/s"
    np.testing.assert_allclose(ds["adot1"].values,
                               plain["adot1"].values * d["length"] / d["time"] * 1e3, rtol=1e-9,
                               atol=1e-9 * float(abs(ds["adot1"]).max()))
    assert ds["kept"].attrs["units"] == "1" and plain["vt"].attrs["units"] == "1"


def test_plot_labels_are_physical(physical_grid):
    ds = physical_grid
    assert plots._label(ds, "amplitude") == "amplitude A [nm]"
    assert plots._label(ds, "peak_force") == "peak force [nN]"
    assert plots._label(ds, "phase") == "phase [deg]"
    values, label = plots._shown(ds, "physical.drive_amplitude")
    assert label == "physical.drive_amplitude [nm]"
    np.testing.assert_allclose(values, [2.0, 3.0])
    assert plots._curve_label(ds, "physical.drive_amplitude", 2e-9) == \
        ", physical.drive_amplitude = 2 nm"


def _figure(monkeypatch):
    """The figure a plot function draws (its save replaced by keeping it)."""
    kept = []
    monkeypatch.setattr(plots, "_save", lambda fig, path: kept.append(fig) or path)
    return kept


def test_titles_name_the_input_not_its_path(monkeypatch, tmp_path):
    kept = _figure(monkeypatch)
    ds = tmafm.bifurcation(tmafm.inputs.path("fig5a"), "scene.alpha2", [4e-4, 5e-4],
                           max_periods=4, periods_kept=2, workers=1)
    assert "/" in ds.attrs["base"]
    plots.plot_bifurcation(ds, tmp_path / "b.png")
    title = kept[0].axes[0].get_title()
    assert title == "bifurcation diagram: fig5a.nml"


def test_basin_period_has_a_discrete_colour_bar(monkeypatch, tmp_path):
    kept = _figure(monkeypatch)
    ds = tmafm.basin("sweeps/bistable_n2", a1=[-1e-3, 0.0], adot1=[0.0, 1e-3], max_periods=8,
                     known_attractors=False)
    ds["period"].values[:] = [[0, 1], [2, 1]]   # three integer values to show
    plots.plot_basin(ds, tmp_path / "m.png")
    fig = kept[0]
    bar = fig.axes[-1]                           # the period panel's colour bar
    labels = [t.get_text() for t in bar.get_yticklabels()]
    assert labels == ["none", "1", "2"]
    image = fig.axes[1].images[0]
    assert image.cmap.N == 3                     # one colour per value found, no gradient


# --- Curves in physical terms (the &physical keys tip_sample_distance, drive_frequency) ------

def _accurate(name):
    return tmafm.Config(name, model={"convention": "consistent"},
                        solver={"method": "flight_exact", "rtol": 1e-10, "atol": 1e-14})


def test_approach_in_z_is_the_dimensionless_delta_hat_sweep():
    """approach(z=) on an SI base gives, in nm, nN, degree and aJ, the numbers of the same curve
    run as a delta_hat sweep of the matching dimensionless scene: the scene at Z = 0 (gap d0 =
    tip_length), delta_hat = Z/(d0 cos(tilt)), converted with the scales of Eq. (12) computed
    here from the input.  The model is invariant under the choice of length unit, so the two
    agree to the integration's error (rtol 1e-10), far inside 1e-7."""
    base = _accurate("physical_polystyrene")
    z = np.array([3e-9, 2e-9, 1e-9, 0.5e-9])
    keywords = dict(max_periods=30, stop_at_steady=False, workers=1)
    ds = tmafm.approach(base, z=z, **keywords)
    assert ds["z"].attrs["units"] == "m" and ds.attrs["input_key"] == "physical.tip_sample_distance"
    np.testing.assert_array_equal(ds["z"].values, z)
    for name, unit in (("amplitude", "nm"), ("phase", "degree"), ("peak_force", "nN"),
                       ("min_gap", "nm"), ("dissipated_energy", "aJ"), ("dissipated_power", "pW")):
        assert ds[name].attrs["units"] == unit, name
    at_zero = tmafm.Config(base, physical={"tip_sample_distance": 0.0})
    groups = at_zero.to_dict()
    s = _independent_scales(at_zero)
    d0, tilt = s["length"], groups["physical"]["tilt"]
    scene = dict(at_zero.scene)
    plain = tmafm.approach({"model": groups["model"], "solver": groups["solver"], "scene": scene},
                           delta_hat=z / (d0 * math.cos(tilt)), **keywords)
    for name, factor in (("amplitude", d0 * 1e9), ("min_gap", d0 * 1e9),
                         ("peak_force", s["force"] * 1e9), ("dissipated_energy", s["energy"] * 1e18)):
        np.testing.assert_allclose(ds[name].values, plain[name].values * factor, rtol=1e-7,
                                   err_msg=name)
    np.testing.assert_allclose(ds["phase"].values, plain["phase"].values, rtol=0, atol=1e-5)
    np.testing.assert_array_equal(ds["jump"].values, plain["jump"].values)


def test_frequency_sweep_in_hz_is_the_omega_sweep():
    base = _accurate("physical_polystyrene")
    t0 = _independent_scales(base)["time"]
    omega = np.array([1.8, 2.0, 2.2])
    keywords = dict(max_periods=12, stop_at_steady=False, workers=1)
    ds = tmafm.frequency_sweep(base, frequency=omega / (2 * math.pi * t0), **keywords)
    assert ds["frequency"].attrs["units"] == "Hz"
    groups = base.to_dict()
    plain = tmafm.frequency_sweep({"model": groups["model"], "solver": groups["solver"],
                                   "scene": base.scene}, omega=omega, **keywords)
    d = _independent_scales(base)["length"]
    np.testing.assert_allclose(ds["amplitude"].values, plain["amplitude"].values * d * 1e9,
                               rtol=1e-7)


def test_a_scene_key_on_a_physical_base_is_named():
    with pytest.raises(tmafm.InputError, match=r"scene.delta_hat.*&physical.*approach\(base, z="):
        tmafm.approach("physical_polystyrene", delta_hat=[1e-3, 0.0])
    with pytest.raises(tmafm.InputError, match="give either delta_hat= .* or z="):
        tmafm.approach("physical_polystyrene", delta_hat=[1e-3], z=[1e-9])


def test_a_sweep_file_on_a_physical_base_sweeps_z(tmp_path):
    path = tmp_path / "z.nml"
    path.write_text("&sweep\n    kind = 'approach', base = 'physical_polystyrene'\n"
                    "    start = 2.0e-9, stop = 0.0, count = 3\n"
                    "    max_periods = 4, stop_at_steady = .false., method = 'flight_exact'\n/\n")
    ds = tmafm.sweeps.run_sweep_file(path, workers=1)
    assert ds.attrs["input_key"] == "physical.tip_sample_distance"
    np.testing.assert_allclose(ds["z"].values, [2e-9, 1e-9, 0.0])
    assert ds["amplitude"].attrs["units"] == "nm"

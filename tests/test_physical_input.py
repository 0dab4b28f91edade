"""The physical input in practitioner terms (issue 20; docs/model.md section 12): the cantilever by
its calibration (spring_constant, resonance_frequency, quality_factor, tip_mass_ratio), the drive
by drive_frequency and free_amplitude, the tip-sample distance Z; the refused combinations; and
the default convention 'consistent' that makes an SI scene's forces the physical ones.

Every check is against an independent computation: numpy's eigenvalues of the model's own
matrices, a free decay integrated by dop853, Hertz's law from the materials."""

import math
import subprocess

import numpy as np
import pytest

import tmafm
from tmafm import executable

#: A standard tapping cantilever (k = 40 N/m, f0 = 300 kHz, Q = 400), a silicon tip of R = 10 nm.
CANTILEVER = {"length": 225e-6, "width": 38e-6, "tip_position": 225e-6, "spring_constant": 40.0,
              "resonance_frequency": 300e3, "quality_factor": 400.0, "tip_mass_ratio": 0.05,
              "tip_radius": 10e-9, "tip_length": 10e-6, "tip_sample_distance": 20e-9}


def _companion_eigenvalues(model):
    """Eigenvalues of the free phase M a'' + C a' + K a = 0 (the model's matrices), by numpy."""
    n = model.n_modes
    mass, damping, stiffness, _ = model.matrices(0.0, np.zeros(n), False)
    inv = np.linalg.inv(mass)
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-inv @ stiffness, -inv @ damping]])
    return np.linalg.eigvals(a), (mass, damping, stiffness)


def _first_mode(model):
    values, _ = _companion_eigenvalues(model)
    return values[np.argmin(np.where(values.imag >= 0, abs(values), np.inf))]


def _settled_observation(config):
    """observe() run until every free transient has decayed below e^-21 (the slowest eigenvalue
    of the model's free phase, numpy), so the last period is the steady free response."""
    values, _ = _companion_eigenvalues(config.model())
    period = 2 * math.pi / config.scene["omega"]
    n_periods = math.ceil(21 / min(-values.real) / period) + 2
    return tmafm.observe(config, max_periods=n_periods, stop_at_steady=False)


@pytest.mark.parametrize("n_modes", [3, 6])
@pytest.mark.parametrize("convention", ["paper", "consistent"])
def test_a_calibrated_cantilever_has_its_k_f0_and_q_in_the_model_matrices(n_modes, convention):
    config = tmafm.Config({"model": {"n_modes": n_modes, "convention": convention},
                           "physical": CANTILEVER})
    model = config.model()
    derived = config.derived
    # The scales from the derived beam: t0 = sqrt(m L^4/(E1 I)).
    L = CANTILEVER["length"]
    t0 = math.sqrt(derived["mass_per_length"] * L ** 4 / derived["rigidity"])
    lam = _first_mode(model)
    assert abs(lam) / (2 * math.pi * t0) == pytest.approx(300e3, rel=1e-9)
    assert abs(lam) / (2 * abs(lam.real)) == pytest.approx(400.0, rel=1e-9)
    # Static tip stiffness: F = k w_T, with K a = (F L^3/(E1 I d)) p and w_T = d p^T a.
    _, _, stiffness, _ = model.matrices(0.0, np.zeros(n_modes), False)
    p = model.tip
    compliance = p @ np.linalg.solve(stiffness, p)
    assert derived["rigidity"] / (L ** 3 * compliance) == pytest.approx(40.0, rel=1e-9)
    # The tip mass is the ratio's (alpha1 the ratio itself), the damping the model's alpha3.
    assert derived["tip_mass"] / (derived["mass_per_length"] * L) == pytest.approx(0.05, rel=1e-12)
    assert config.scene["alpha1"] == 0.05
    assert config.scene["alpha3"] == pytest.approx(derived["beam_damping"] * t0 / derived["mass_per_length"],
                                                   rel=1e-12)
    # The model's own values, as the header prints them, and the continuum 3 E1 I/L^3 (x0 = L).
    assert derived["spring_constant"] == pytest.approx(40.0, rel=1e-12)
    assert derived["resonance_frequency"] == pytest.approx(300e3, rel=1e-12)
    assert derived["quality_factor"] == pytest.approx(400.0, rel=1e-12)
    assert derived["continuum_spring_constant"] == pytest.approx(3 * derived["rigidity"] / L ** 3, rel=1e-14)


def test_the_free_decay_of_a_calibrated_cantilever_gives_its_q():
    """Mode 1 alone (a = Re(v e^(lambda tau)), its complex eigenvector from numpy) decays freely,
    integrated by dop853: sampled every damped period T = 2 pi/Im(lambda), a(kT) = e^(-sigma k T)
    a(0); sigma fitted from the run gives Q = |lambda|/(2 sigma)."""
    base = {"model": {"n_modes": 4}, "physical": {**CANTILEVER, "tip_sample_distance": 1e-6,
                                                  "drive_amplitude": 0.0}}
    model = tmafm.Model(base)
    values, (mass, damping, stiffness) = _companion_eigenvalues(model)
    lam = _first_mode(model)
    # Mode 1's vector: the null vector of lambda^2 M + lambda C + K.
    _, _, vh = np.linalg.svd(lam ** 2 * mass + lam * damping + stiffness)
    v = vh[-1].conj()
    v *= 1e-4 / np.abs(v).max()
    period = 2 * math.pi / lam.imag
    count = 20
    result = tmafm.run(base, initial={"a0": list(v.real), "adot0": list((lam * v).real)},
                       solver={"method": "dop853", "rtol": 1e-12, "atol": 1e-18,
                               "tau_end": count * period * (1 + 1e-12)},
                       output={"sample_dtau": period})
    a = result.a
    assert a.shape[0] == count + 1
    ratio = a[-1] @ a[0] / (a[0] @ a[0])
    # a(kT) is parallel to a(0): the damped frequency is Im(lambda).
    np.testing.assert_allclose(a[-1], ratio * a[0], rtol=0, atol=1e-9 * abs(a[-1]).max())
    sigma = -math.log(ratio) / (count * period)
    q = math.hypot(sigma, lam.imag) / (2 * sigma)
    assert q == pytest.approx(400.0, rel=1e-6)


def test_a_scene_given_by_its_free_amplitude_reaches_it_far_from_the_sample():
    """Q = 30 so that the start's transient dies (e^(-sigma tau) < 1e-9 for the slowest
    eigenvalue) within the run; the
    last period's amplitude observable (V_T's first harmonic, located) is the free amplitude."""
    physical = {**CANTILEVER, "quality_factor": 30.0, "tip_sample_distance": 1e-6,
                "drive_frequency": 290e3, "free_amplitude": 20e-9}
    config = tmafm.Config({"model": {"n_modes": 3}, "physical": physical,
                           "solver": {"method": "flight_exact", "rtol": 1e-12, "atol": 1e-16}})
    obs = _settled_observation(config)
    assert obs.per_period["min_gap"][-1] > 0  # never in contact
    d = config.derived["gap"]
    assert obs.per_period["amplitude"][-1] * d == pytest.approx(20e-9, rel=1e-6)
    assert config.derived["free_amplitude"] == pytest.approx(20e-9, rel=1e-12)
    # The drive in Hz: Omega = 2 pi f t0.
    assert config.scene["omega"] == pytest.approx(2 * math.pi * 290e3 * config.derived["time_scale"],
                                                  rel=1e-14)


def test_the_tip_sample_distance_sets_the_gap_and_an_override_replaces_the_base_gap(tmp_path):
    config = tmafm.Config("physical_polystyrene", physical={"tip_sample_distance": 3e-9})
    tilt = math.pi / 12
    assert config.derived["gap"] == pytest.approx(5e-6 + 3e-9 / math.cos(tilt), rel=1e-15)
    assert config.derived["static_offset"] == 3e-9
    assert config.scene["delta_hat"] == pytest.approx(3e-9 / (config.derived["gap"] * math.cos(tilt)),
                                                      rel=1e-14)
    # The resolved text gives Z, not the gap, and reads back to the same scene.
    again = tmafm.Config(config.write(tmp_path / "resolved.nml"))
    assert again.scene == config.scene
    assert "tip_sample_distance = " in again.text and "    gap = " not in again.text


#: Refused combinations: (&physical entries, the two keys the one-line message names).
REFUSED = [
    ({"spring_constant": 40, "resonance_frequency": 3e5, "quality_factor": 400,
      "tip_mass_ratio": 0.05, "thickness": 3e-6}, ("spring_constant", "thickness")),
    ({"spring_constant": 40, "resonance_frequency": 3e5, "quality_factor": 400,
      "tip_mass_ratio": 0.05, "density": 2330}, ("spring_constant", "density")),
    ({"spring_constant": 40, "resonance_frequency": 3e5, "quality_factor": 400,
      "tip_mass_ratio": 0.05, "tip_mass": 1e-12}, ("spring_constant", "tip_mass")),
    ({"spring_constant": 40, "resonance_frequency": 3e5, "quality_factor": 400,
      "tip_mass_ratio": 0.05, "beam_damping": 1e-3}, ("spring_constant", "beam_damping")),
    ({"spring_constant": 40, "resonance_frequency": 3e5, "tip_mass_ratio": 0.05},
     ("spring_constant", "quality_factor")),
    ({"resonance_frequency": 3e5}, ("resonance_frequency", "spring_constant")),
    ({"drive_frequency": 3e5, "drive_angular_frequency": 1e6}, ("drive_frequency", "drive_angular_frequency")),
    ({"free_amplitude": 2e-8, "drive_amplitude": 1e-9}, ("free_amplitude", "drive_amplitude")),
    ({"tip_sample_distance": 1e-8, "gap": 5e-6}, ("tip_sample_distance", "gap")),
    ({"tip_sample_distance": 1e-8, "static_offset": 0.0}, ("tip_sample_distance", "static_offset")),
]


def _nml(physical: dict, n_modes: int = 4) -> str:
    entries = ", ".join(f"{k} = {v!r}" for k, v in physical.items())
    return f"&model n_modes = {n_modes} /\n&physical {entries} /\n&solver tau_end = 1 /\n"


@pytest.mark.parametrize("physical, names", REFUSED, ids=[" ".join(n) for _, n in REFUSED])
def test_an_over_determined_input_is_refused_in_one_line_naming_both_keys(tmp_path, physical, names):
    path = tmp_path / "bad.nml"
    path.write_text(_nml(physical))
    done = subprocess.run([executable(), "-q", str(path), "-o", str(tmp_path / "out.dat")],
                          capture_output=True, text=True)
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and all(name in lines[0] for name in names), done.stderr
    # Refused for giving both (or one without the other), not as an unknown key.
    assert ("not both" in lines[0] or "needs" in lines[0]) and "unknown key" not in lines[0]
    assert not (tmp_path / "out.dat").exists()
    with pytest.raises(tmafm.InputError, match=names[1]) as info:
        tmafm.Config(path)
    assert names[0] in str(info.value) and "\n" not in str(info.value)
    assert "unknown key" not in str(info.value)


@pytest.mark.parametrize("key", ["spring_constant", "free_amplitude"])
def test_an_exact_conversion_needs_a_fixed_n(key):
    """The calibration and the free amplitude are exact for the N that runs: n_modes = 0 is
    refused with them."""
    physical = dict(CANTILEVER) if key == "spring_constant" else {"free_amplitude": 1e-8}
    with pytest.raises(tmafm.InputError, match=f"{key}.*needs a fixed &model n_modes"):
        tmafm.Config({"model": {"n_modes": 0}, "physical": physical})


def test_physical_polystyrene_peak_force_is_hertz_at_its_own_indentation():
    """The packaged SI scene, default convention: the located peak force (N) is
    (4/3) E* sqrt(R) delta^(3/2) at the located indentation delta = -min_gap.  The normal
    indentation is -v_T sin(theta1), theta1 = pi/2 - tilt + arctan(slope): with the tilt set to
    0, sin(theta1) = 1 - O(slope^2) ~ 1e-9, so -min_gap is delta to that.  Under 'paper' (the
    printed E4) the ratio is 2."""
    config = tmafm.Config("physical_polystyrene", physical={"tilt": 0.0},
                          solver={"method": "dop853", "rtol": 1e-10, "atol": 1e-14})
    assert config.to_dict()["model"]["convention"] == "consistent"
    obs = tmafm.observe(config, max_periods=4, stop_at_steady=False)
    phys = config.to_dict()["physical"]
    e_star = 1 / ((1 - phys["poisson_ratio_tip"] ** 2) / phys["youngs_modulus_tip"]
                  + (1 - phys["poisson_ratio_sample"] ** 2) / phys["youngs_modulus_sample"])
    delta = -obs.physical["min_gap"][-1] * 1e-9
    assert delta > 0
    hertz = 4 / 3 * e_star * math.sqrt(phys["tip_radius"]) * delta ** 1.5
    assert obs.physical["peak_force"][-1] * 1e-9 == pytest.approx(hertz, rel=1e-6)
    # 'paper' (the printed E4): twice Hertz's force at its own indentation.
    paper = tmafm.observe(tmafm.Config(config, model={"convention": "paper", "errata": "convention"}),
                          max_periods=4,
                          stop_at_steady=False)
    delta = -paper.physical["min_gap"][-1] * 1e-9
    hertz = 4 / 3 * e_star * math.sqrt(phys["tip_radius"]) * delta ** 1.5
    assert paper.physical["peak_force"][-1] * 1e-9 == pytest.approx(2 * hertz, rel=1e-6)
    # The packaged scene as it is (tilt pi/12): the same law to within the tilt's effect,
    # |sin(theta1)/cos(tilt) - 1| <= tan(tilt) |slope|, slope = (d/L) s.a bounded by the run's
    # modal extrema in contact.
    config = tmafm.Config("physical_polystyrene", solver={"method": "dop853", "rtol": 1e-10,
                                                          "atol": 1e-14})
    obs = tmafm.observe(config, max_periods=4, stop_at_steady=False)
    tilt = config.scene["theta"]
    slope = (1 / config.scene["l_over_d"]) * abs(config.model().slope) @ np.maximum(
        abs(obs.per_period["modal_max_contact"][-1]), abs(obs.per_period["modal_min_contact"][-1]))
    delta = -obs.physical["min_gap"][-1] * 1e-9 * math.cos(tilt)
    hertz = 4 / 3 * e_star * math.sqrt(phys["tip_radius"]) * delta ** 1.5
    bound = 1.5 * math.tan(tilt) * slope * 1.01 + 1e-6
    assert abs(obs.physical["peak_force"][-1] * 1e-9 / hertz - 1) <= bound


def _contact_forces(model, result):
    """(kappa5 f_c, kappa6 h) of the model at each sample in contact (0 elsewhere)."""
    kappa5, kappa6 = model.kappas
    normal, friction = np.zeros(result.tau.size), np.zeros(result.tau.size)
    for k in np.flatnonzero(result.contact == 1):
        state = model.contact(result.tau[k], result.a[k])
        normal[k], friction[k] = kappa5 * state.normal, kappa6 * state.friction
    return normal, friction


def test_the_si_series_are_the_dimensionless_ones_times_the_scales(tmp_path):
    config = tmafm.Config("physical_polystyrene", solver={"method": "dop853", "tau_end": 8.0},
                          output={"sample_dtau": 0.005})
    result = config.run()
    scales = config.derived
    model = config.model()
    normal, friction = _contact_forces(model, result)
    assert result.contact.any() and friction.any()
    expected = {"t_s": result.tau * scales["time_scale"], "distance_m": result.vt * scales["length_scale"],
                "deflection_m": result.a @ model.tip * scales["length_scale"],
                "normal_force_N": normal * scales["force_scale"],
                "friction_force_N": friction * scales["force_scale"]}
    assert list(result.physical) == list(tmafm.SERIES_UNITS) == list(expected)
    for name, value in expected.items():
        np.testing.assert_allclose(result.physical[name], value, rtol=1e-13,
                                   atol=1e-13 * abs(value).max(), err_msg=name)
    # The executable writes the same series as five more columns (text) and arrays (npy).
    path = tmp_path / "p.nml"
    config.write(path)
    subprocess.run([executable(), "-q", str(path), "-o", str(tmp_path / "p.dat")], check=True)
    header = [line for line in (tmp_path / "p.dat").read_text().splitlines() if line.startswith("#")]
    n = config.n_modes
    columns = header[-1].split()[2:]
    assert columns[4 + 2 * n:] == list(tmafm.SERIES_UNITS)
    table = np.loadtxt(tmp_path / "p.dat")
    for k, name in enumerate(tmafm.SERIES_UNITS):
        np.testing.assert_array_equal(table[:, 4 + 2 * n + k], result.physical[name])
    assert any(line.startswith("# ! derived: force_scale = ") for line in header)
    tmafm.Config(config, output={"format": "npy"}).write(tmp_path / "npy.nml")
    subprocess.run([executable(), "-q", str(tmp_path / "npy.nml"), "-o", str(tmp_path / "p.npz")],
                   check=True)
    with np.load(tmp_path / "p.npz") as data:
        for name in tmafm.SERIES_UNITS:
            np.testing.assert_array_equal(data[name], result.physical[name])
    loaded = tmafm.load(tmp_path / "p.npz")
    assert loaded.derived == config.derived
    for name in tmafm.SERIES_UNITS:
        np.testing.assert_array_equal(loaded.physical[name], result.physical[name])
    # Result.save writes them too, and load reads them back.
    result.save(tmp_path / "saved.npz")
    again = tmafm.load(tmp_path / "saved.npz")
    np.testing.assert_array_equal(again.physical["normal_force_N"], result.physical["normal_force_N"])


def test_force_against_distance_is_the_last_period_of_the_series():
    result = tmafm.run("physical_polystyrene", solver={"method": "dop853", "tau_end": 20.0},
                       output={"sample_dtau": 0.01})
    distance, force = result.force_distance()
    period = 2 * math.pi / result.scene["omega"]
    last = result.tau >= result.tau[-1] - period * (1 + 1e-12)
    assert last.sum() == distance.size == force.size and last.sum() >= period / 0.01
    np.testing.assert_array_equal(distance, result.physical["distance_m"][last])
    np.testing.assert_array_equal(force, result.physical["normal_force_N"][last])
    # Force only where the tip is at or below the surface.
    assert np.all(force[distance > 0] == 0) and force.max() > 0
    # A dimensionless scene has no SI series and no force-distance curve.
    plain = tmafm.run("fig2_n4", solver={"tau_end": 1.0})
    assert plain.physical is None and plain.derived is None
    with pytest.raises(tmafm.InputError, match="no SI series"):
        plain.force_distance()


def test_a_dimensionless_scene_writes_no_si_column(tmp_path):
    path = tmp_path / "f.nml"
    tmafm.Config("fig2_n4", solver={"tau_end": 1.0}).write(path)
    subprocess.run([executable(), "-q", str(path), "-o", str(tmp_path / "f.dat")], check=True)
    text = (tmp_path / "f.dat").read_text()
    assert "! derived:" not in text
    columns = [line for line in text.splitlines() if line.startswith("# columns:")][0].split()[2:]
    assert columns[-1] == "adot_4" and len(columns) == 12


def test_calibration_overrides_replace_the_base_geometry():
    """Overrides of the calibration on a geometry base drop the base's thickness, density,
    tip_mass and beam_damping (given in the same input, they are refused)."""
    calibration = {"spring_constant": 40.0, "resonance_frequency": 300e3, "quality_factor": 400.0,
                   "tip_mass_ratio": 0.05, "drive_frequency": 299e3}
    config = tmafm.Config("physical_polystyrene", physical=calibration)
    derived = config.derived
    assert derived["spring_constant"] == pytest.approx(40.0, rel=1e-12)
    assert derived["resonance_frequency"] == pytest.approx(300e3, rel=1e-12)
    written = config.to_dict()["physical"]
    assert not {"thickness", "density", "tip_mass", "beam_damping", "drive_angular_frequency"} & set(written)
    # The geometry overridden back on the calibrated Config drops the calibration in turn.
    geometry = tmafm.Config(config, physical={"thickness": 3e-6, "density": 2330.0, "tip_mass": 3.1455e-12,
                                              "beam_damping": 6.028930253369996e-3})
    assert geometry.derived["rigidity"] == pytest.approx(130e9 * 30e-6 * (3e-6) ** 3 / 12, rel=1e-14)
    assert "spring_constant" not in geometry.to_dict()["physical"]


def test_the_continuum_resonance_is_the_root_of_the_tip_mass_beam_equation():
    """The echoed continuum frequency: beta^2/(2 pi t0), beta the first root of
    1 + cos b cosh b + alpha1 b (cos b sinh b - sin b cosh b) = 0 (scipy's brentq, unscaled);
    the N-mode model's undamped frequency approaches it from above (docs/model.md section 4)."""
    optimize = pytest.importorskip("scipy.optimize")
    alpha1 = CANTILEVER["tip_mass_ratio"]
    beta = optimize.brentq(lambda b: 1 + math.cos(b) * math.cosh(b)
                           + alpha1 * b * (math.cos(b) * math.sinh(b) - math.sin(b) * math.cosh(b)),
                           1.0, 1.8751, xtol=1e-15, rtol=1e-15)
    for n in (4, 12):
        derived = tmafm.Config({"model": {"n_modes": n}, "physical": CANTILEVER}).derived
        continuum = beta ** 2 / (2 * math.pi * derived["time_scale"])
        assert derived["continuum_resonance_frequency"] == pytest.approx(continuum, rel=1e-13)
        gap = derived["undamped_resonance_frequency"] / continuum - 1
        assert 0 < gap < (1e-4 if n == 4 else 1e-6)


def test_the_largest_tip_mass_ratio_is_taken_as_given():
    """alpha1 is the ratio itself, not M/(m L) recomputed (which rounds past the bound 1e3)."""
    config = tmafm.Config({"model": {"n_modes": 3}, "physical": {**CANTILEVER, "tip_mass_ratio": 1e3}})
    assert config.scene["alpha1"] == 1e3
    assert config.derived["resonance_frequency"] == pytest.approx(300e3, rel=1e-12)


def test_in_a_liquid_the_derived_resonance_and_q_are_those_of_the_model_that_runs():
    """The header's f0 and Q of a scene in water are the model's own first eigenvalue, with each
    mode's added mass and fluid damping (model.matrices, numpy), not the beam's in air (which
    gave Q = 22.6 here against the model's 2.86)."""
    water = {"medium_density": 997.0, "medium_viscosity": 8.9e-4}
    config = tmafm.Config("physical_polystyrene", physical=water, model={"n_modes": 2})
    lam = _first_mode(tmafm.Model(config))
    t0 = config.derived["time_scale"]
    assert config.derived["resonance_frequency"] == pytest.approx(abs(lam) / (2 * math.pi * t0), rel=1e-9)
    assert config.derived["quality_factor"] == pytest.approx(abs(lam) / (2 * abs(lam.real)), rel=1e-9)
    air = tmafm.Config("physical_polystyrene", model={"n_modes": 2})
    assert config.derived["quality_factor"] < air.derived["quality_factor"]


WATER = {"medium_density": 997.0, "medium_viscosity": 8.9e-4}
# A standard tapping lever (125 x 30 um, k = 40 N/m) as calibrated in water by its thermal peak.
IN_WATER = {**CANTILEVER, **WATER, "length": 125e-6, "width": 30e-6, "tip_position": 125e-6,
            "tip_mass_ratio": 0.01, "resonance_frequency": 120e3, "quality_factor": 8.0}


@pytest.mark.parametrize("n_modes", [2, 4])
def test_a_cantilever_calibrated_in_water_has_its_k_f0_and_q_there(n_modes):
    """k, f0 and Q measured in water (the thermal peak there): the loaded model's first
    eigenvalue (numpy, from the matrices with each mode's added mass and fluid damping) has that
    f0 and Q, and its static tip stiffness is k, all to 1e-9."""
    physical = IN_WATER
    config = tmafm.Config({"model": {"n_modes": n_modes}, "physical": physical})
    model = tmafm.Model(config)
    derived = config.derived
    L = IN_WATER["length"]
    t0 = math.sqrt(derived["mass_per_length"] * L ** 4 / derived["rigidity"])
    assert config.scene["medium_mass"] > 0 and config.scene["medium_reynolds"] > 0
    lam = _first_mode(model)
    assert abs(lam) / (2 * math.pi * t0) == pytest.approx(120e3, rel=1e-9)
    assert abs(lam) / (2 * abs(lam.real)) == pytest.approx(8.0, rel=1e-9)
    _, _, stiffness, _ = model.matrices(0.0, np.zeros(n_modes), False)
    compliance = model.tip @ np.linalg.solve(stiffness, model.tip)
    assert derived["rigidity"] / (L ** 3 * compliance) == pytest.approx(40.0, rel=1e-9)
    # The same cantilever in air would ring higher and longer: the liquid loads it.
    air = {k: v for k, v in physical.items() if not k.startswith("medium_")}
    dry = tmafm.Config({"model": {"n_modes": n_modes}, "physical": air})
    assert derived["mass_per_length"] < dry.derived["mass_per_length"]


def test_a_free_amplitude_in_water_is_reached_far_from_the_sample():
    """The free amplitude in the liquid (the base drives the liquid's added mass and damping
    too): the last period's amplitude observable of a long flight_exact run is A0 to 1e-6."""
    physical = {**IN_WATER, "drive_frequency": 115e3, "free_amplitude": 5e-9, "tip_sample_distance": 1e-6}
    config = tmafm.Config({"model": {"n_modes": 3}, "physical": physical,
                           "solver": {"method": "flight_exact", "rtol": 1e-12, "atol": 1e-16}})
    obs = _settled_observation(config)
    assert obs.per_period["min_gap"][-1] > 0
    d = config.derived["gap"]
    assert obs.per_period["amplitude"][-1] * d == pytest.approx(5e-9, rel=1e-6)
    assert config.derived["free_amplitude"] == pytest.approx(5e-9, rel=1e-12)


def test_the_derived_free_amplitude_in_a_liquid_is_the_one_that_runs():
    """A liquid scene given by its drive amplitude: the header's free amplitude is the run's."""
    physical = {**WATER, "drive_amplitude": 1e-9, "drive_frequency": 30e3, "tip_sample_distance": 1e-6}
    config = tmafm.Config({"model": {"n_modes": 2}, "physical": physical,
                           "solver": {"method": "flight_exact", "rtol": 1e-12, "atol": 1e-16}},
                          )
    obs = _settled_observation(config)
    run = obs.per_period["amplitude"][-1] * config.derived["gap"]
    assert config.derived["free_amplitude"] == pytest.approx(run, rel=1e-6)


@pytest.mark.parametrize("change, key", [({"quality_factor": 500.0}, "quality_factor"),
                                         ({"resonance_frequency": 250e3}, "resonance_frequency"),
                                         ({"resonance_frequency": 5e6, "quality_factor": 0.6},
                                          "resonance_frequency")])
def test_a_calibration_the_liquid_cannot_meet_is_refused_naming_its_key(change, key):
    """Q above what the liquid alone allows, or f0 above what any beam of that k reaches in it."""
    physical = {**IN_WATER, **change}
    with pytest.raises(tmafm.InputError, match=f"&physical {key} = ") as info:
        tmafm.Config({"model": {"n_modes": 2}, "physical": physical})
    assert "\n" not in str(info.value)

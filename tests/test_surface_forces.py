"""The forces at a distance (docs/model.md §17): the electrostatic force of a biased tip (sphere +
cone, Hudlet et al. 1998) and the electrical double layer (DLVO with 'dmt_vdw').

Oracles, each independent of the code under test:
- the closed forms, written here again in SI from their references (not from the core's units);
- their limits: the sphere-plane force -pi eps0 V^2 R/s at s << R and the cone's
  -pi eps0 V^2 k^2 (ln(H/s) - 1) at s >> R, approached at the first order the expansions predict;
- the textbook Debye length of a 1:1 electrolyte, 0.304 nm/sqrt(I/M) in water at 25 C;
- the small-amplitude frequency shift of a free cantilever near a surface, -f0/(2k) dF/dz, from a
  ring-down of the full beam.
The composed dynamics (these forces with every other part, against a numpy peer) and the
Jacobian's partials are in tests/test_compose.py and tests/test_continuation_physics.py.
"""

import math
import subprocess

import numpy as np
import pytest

import tmafm

EPS0 = 8.8541878188e-12
BASE = "tapping_polystyrene"
DOP853 = {"method": "dop853"}
#: tapping_polystyrene's tip and adhesion energy (the contact's force scale 1.5 pi gamma R).
RADIUS, GAMMA, A0 = 10e-9, 0.035, 0.165e-9


def hudlet(s, voltage, radius, half_angle, height):
    """Hudlet et al., Eur. Phys. J. B 2, 5 (1998): the sphere-capped cone over a plane (N)."""
    b = radius * (1 - math.sin(half_angle))
    k2 = 1 / math.log(math.tan(half_angle / 2)) ** 2
    apex = radius**2 * (1 - math.sin(half_angle)) / (s * (s + b))
    cone = k2 * (math.log(height / (s + b)) - 1 + radius * math.cos(half_angle) ** 2 / math.sin(half_angle) / (s + b))
    return -math.pi * EPS0 * voltage**2 * (apex + cone)


def debye_length(permittivity, ionic_strength, temperature=298.15):
    """lambda_D of a 1:1 electrolyte (m), ionic strength in mol/m^3."""
    kb, e, na = 1.380649e-23, 1.602176634e-19, 6.02214076e23
    return math.sqrt(permittivity * EPS0 * kb * temperature / (2 * na * e**2 * ionic_strength))


def _force(model, vt, radius=RADIUS, gamma=GAMMA):
    """The normal force (N) and the separation (m) the core gives at tip gap vt (a_1 alone)."""
    n = model.n_modes
    a = np.zeros(n)
    v0 = model.contact(0.0, a).vt
    a[0] = (vt - v0) / model.tip[0]
    state = model.contact(0.0, a)
    d = model.config.derived["length_scale"]
    a0 = model.config.to_namelist()["physical"].get("intermolecular_distance", A0)
    return state.normal * 1.5 * math.pi * gamma * radius, a0 + d * state.vt * math.sin(state.theta1), state


BIASED = {"tip_bias": 2.5, "contact_potential": 0.4, "cone_half_angle": 0.3, "tip_length": 12e-6}


@pytest.mark.parametrize("separation", [0.3e-9, 1e-9, 10e-9, 100e-9, 1e-6])
def test_electrostatic_force_is_hudlets_sphere_and_cone(separation):
    model = tmafm.Model(BASE, physical=BIASED, solver=DOP853)
    d = model.config.derived["length_scale"]
    # V_T sin(theta1) = s - a0: sin(theta1) from the state at the guess, then once more.
    vt = (separation - A0) / d
    for _ in range(3):
        force, s, state = _force(model, vt)
        vt *= (separation - A0) / (s - A0)
    force, s, _ = _force(model, vt)
    expected = hudlet(s, 2.5 - 0.4, RADIUS, 0.3, 12e-6)
    assert force == pytest.approx(expected, rel=1e-12, abs=0)


def test_in_contact_the_electrostatic_force_is_its_value_at_the_contact_separation():
    plain = tmafm.Model(BASE, physical={k: BIASED[k] for k in ("cone_half_angle", "tip_length")}, solver=DOP853)
    biased = tmafm.Model(BASE, physical=BIASED, solver=DOP853)
    for vt in (-1e-5, -1e-4):
        added = _force(biased, vt)[0] - _force(plain, vt)[0]
        assert added == pytest.approx(hudlet(A0, 2.1, RADIUS, 0.3, 12e-6), rel=1e-12, abs=0)
    # Under Hertz (no adhesion jump) the force is continuous at the switch: V_T = 0 from above
    # equals the contact's value.
    hertz = tmafm.Model(BASE, physical=BIASED, model={"contact_law": "hertz"}, solver=DOP853)
    assert _force(hertz, 1e-18)[0] == pytest.approx(_force(hertz, -1e-18)[0], rel=1e-9, abs=0)


def test_the_electrostatic_force_tends_to_the_sphere_plane_and_to_the_cone():
    """Near the apex F/F_sphere = 1 + C1 s + O(s^2), C1 = -1/b + k^2 (ln(H/b) - 1 + c/b)/R, with
    F_sphere = -pi eps0 V^2 R/s; far from it F/F_cone = 1 + O(R/s), F_cone = -pi eps0 V^2 k^2
    (ln(H/s) - 1).  A micron-size apex and a0 = 1e-15 m put the contact separation 1e-9 of the
    apex's size away, where the sphere-plane form holds to ~1e-9."""
    radius, angle, height, volts = 1e-6, 0.3, 12e-6, 1.0
    physical = {"tip_bias": volts, "cone_half_angle": angle, "tip_length": height, "tip_radius": radius,
                "intermolecular_distance": 1e-15, "hamaker": 1e-25}
    # Hertz, and a gap just below 0: in contact the force is the electrostatic one at a0 alone.
    model = tmafm.Model(BASE, physical=physical, model={"contact_law": "hertz"}, solver=DOP853)
    b = radius * (1 - math.sin(angle))
    k2 = 1 / math.log(math.tan(angle / 2)) ** 2
    c1 = -1 / b + k2 * (math.log(height / b) - 1 + radius * math.cos(angle) ** 2 / math.sin(angle) / b) / radius
    at_contact = _force(model, -1e-16, radius=radius)[0]
    sphere = -math.pi * EPS0 * volts**2 * radius / 1e-15
    assert at_contact / sphere - 1 == pytest.approx(c1 * 1e-15, rel=1e-5, abs=0)
    assert abs(at_contact / sphere - 1) < 1e-9
    d = model.config.derived["length_scale"]
    errors = []
    for s in (2e-9, 2e-8):
        force, sep, _ = _force(model, s / d, radius=radius)
        sphere = -math.pi * EPS0 * volts**2 * radius / sep
        errors.append((force / sphere - 1) / sep)
    # First order: the error over s is C1, to O(s/b).
    assert errors == pytest.approx([c1, c1], rel=50 * 2e-8 / b, abs=0)
    # The cone far from a small apex (R = 1 nm, H = 12 um): F/F_cone - 1 = (c - b)/(s (ln(H/s) - 1))
    # + O((R/s)^2), c = R cos^2(theta0)/sin(theta0), b = R (1 - sin(theta0)).
    small = 1e-9
    physical.update(tip_radius=small, intermolecular_distance=0.165e-9, hamaker=3e-20)
    model = tmafm.Model(BASE, physical=physical, solver=DOP853)
    d = model.config.derived["length_scale"]
    first_order = small * (math.cos(angle) ** 2 / math.sin(angle) - (1 - math.sin(angle)))
    for s in (1e-7, 1e-6):
        force, sep, _ = _force(model, s / d, radius=small)
        logarithm = math.log(height / sep) - 1
        cone = -math.pi * EPS0 * volts**2 * k2 * logarithm
        assert (force / cone - 1) * sep * logarithm == pytest.approx(first_order, rel=20 * small / sep, abs=0), s
    assert abs(force / cone - 1) < 2e-3


WATER = {"medium_density": 997.0, "medium_viscosity": 0.89e-3, "medium_permittivity": 78.4, "quality_factor": 5.0,
         "resonance_frequency": 100e3, "drive_frequency": 100e3}


def test_the_debye_length_of_an_electrolyte_is_the_textbook_one():
    # 0.304 nm/sqrt(I in mol/L) for a 1:1 electrolyte in water at 25 C (Israelachvili, Eq. 14.36).
    for ionic in (1.0, 10.0, 100.0):
        model = tmafm.Model(BASE, physical={**WATER, "ionic_strength": ionic, "tip_surface_potential": -0.03,
                                            "sample_surface_potential": -0.05}, solver=DOP853)
        d = model.config.derived["length_scale"]
        debye = model.scene["double_layer_range"] * d
        assert debye == pytest.approx(0.304e-9 / math.sqrt(ionic / 1000), rel=2e-3, abs=0)
        assert debye == pytest.approx(debye_length(78.4, ionic), rel=1e-13, abs=0)


@pytest.mark.parametrize("law", ["hertz", "dmt_vdw"])
def test_the_double_layer_and_dlvo_are_the_closed_forms_at_three_debye_lengths(law):
    """F = 4 pi R eps_r eps0 psi_t psi_s/lambda_D exp(-s/lambda_D) (Butt 1991), and under 'dmt_vdw'
    minus the sphere-plane van der Waals force H R/(6 s^2): DLVO."""
    hamaker = 3e-21
    physical = {**WATER, "ionic_strength": 10.0, "tip_surface_potential": -0.03, "sample_surface_potential": -0.05,
                "hamaker": hamaker}
    model = tmafm.Model(BASE, physical=physical, model={"contact_law": law}, solver=DOP853)
    lam = debye_length(78.4, 10.0)
    d = model.config.derived["length_scale"]
    for multiple in (1, 2, 3):
        vt = multiple * lam / d
        for _ in range(3):
            force, s, _ = _force(model, vt)
            vt *= multiple * lam / s
        force, s, _ = _force(model, vt)
        expected = 4 * math.pi * RADIUS * 78.4 * EPS0 * 0.03 * 0.05 / lam * math.exp(-s / lam)
        if law == "dmt_vdw":
            expected -= hamaker * RADIUS / (6 * s**2)
        assert force == pytest.approx(expected, rel=1e-12, abs=0), multiple


def test_off_is_free_and_bit_for_bit_the_scene_without_the_keys():
    plain = tmafm.run(BASE, solver={"tau_end": 20.0})
    zero = tmafm.run(BASE, physical={"tip_bias": 0.0, "tip_surface_potential": 0.0, "cone_half_angle": 0.5,
                                     "medium_permittivity": 3.0}, solver={"tau_end": 20.0})
    assert np.array_equal(plain.vt, zero.vt)
    assert np.array_equal(plain.a, zero.a)


def _ring_down_frequency(bias):
    """The frequency (Hz) of a free ring-down at tip_bias, from upward zero crossings of V_T
    (each located by a cubic through the 4 samples around it; 50 samples per period)."""
    physical = dict(spring_constant=2.0, resonance_frequency=70e3, quality_factor=1e4, drive_amplitude=0.0,
                    drive_frequency=70e3, tip_sample_distance=10e-9, tilt=0.0, tip_mass_ratio=200.0,
                    tip_bias=bias)
    config = tmafm.Config(BASE, physical=physical, solver={"method": "dop853", "tau_end": 1.0})
    period = 2 * math.pi / config.scene["omega"]
    result = tmafm.run(BASE, physical=physical, initial={"a0": [1e-6, 0.0, 0.0]},
                       solver={"method": "dop853", "rtol": 1e-11, "atol": 1e-20, "tau_end": 120 * period},
                       output={"sample_dtau": period / 50})
    tau, vt = result.tau, result.vt - np.mean(result.vt[-2500:])
    crossings = []
    for i in np.flatnonzero((vt[:-1] < 0) & (vt[1:] >= 0))[5:]:
        window = slice(i - 1, i + 3)
        roots = np.roots(np.polyfit(tau[window] - tau[i], vt[window], 3))
        roots = roots[np.isreal(roots)].real
        crossings.append(tau[i] + roots[np.argmin(np.abs(roots))])
    fitted = np.polyfit(np.arange(len(crossings)), crossings, 1)[0]
    return 70e3 * period / fitted, config


def test_a_free_cantilevers_frequency_shift_is_minus_f0_over_2k_times_the_force_gradient():
    """Delta f = -f0/(2k) dF/dz for a small oscillation at the rest separation (the static
    deflection F/k included).  What separates the full beam from this formula: its second order
    in F'/k (F'/k = 0.17 % here: 4e-4 of Delta f), the beam's own mass (tip_mass_ratio 200:
    < 1e-3) and the N = 3 Galerkin stiffness at the tip (0.14 %, derived continuum_spring_constant):
    together < 0.5 % of Delta f."""
    f_free, _ = _ring_down_frequency(0.0)
    f_biased, config = _ring_down_frequency(1.0)
    assert f_free == pytest.approx(70e3, rel=1e-7, abs=0)
    separation = A0 + 10e-9
    for _ in range(60):
        separation = A0 + 10e-9 + hudlet(separation, 1.0, RADIUS, math.pi / 9, 15e-6) / 2.0
    h = 1e-13
    gradient = (hudlet(separation + h, 1.0, RADIUS, math.pi / 9, 15e-6)
                - hudlet(separation - h, 1.0, RADIUS, math.pi / 9, 15e-6)) / (2 * h)
    expected = -70e3 / (2 * 2.0) * gradient
    assert expected < -50
    assert f_biased - f_free == pytest.approx(expected, rel=5e-3, abs=0)


@pytest.mark.parametrize("physical, message", [
    ({"debye_length": 1e-9, "ionic_strength": 1.0}, "ionic_strength = 1.0: give the Debye length once"),
    ({"tip_surface_potential": -0.03, "debye_length": 1e-9}, "tip_surface_potential = -0.03: needs sample"),
    ({"sample_surface_potential": 0.02, "debye_length": 1e-9}, "sample_surface_potential = 0.02: needs tip"),
    ({"tip_surface_potential": -0.03, "sample_surface_potential": 0.02}, "needs a Debye length"),
    ({"cone_half_angle": 1.6}, "cone_half_angle = 1.6"),
    ({"medium_permittivity": 0.5}, "medium_permittivity = 0.5"),
    ({"temperature": 0.0}, "temperature = 0.0"),
])
def test_inconsistent_double_layer_and_geometry_keys_are_refused_in_one_line(physical, message):
    with pytest.raises(tmafm.InputError, match=message) as err:
        tmafm.Config(BASE, physical=physical, solver=DOP853)
    assert "\n" not in str(err.value)


def test_the_executable_refuses_with_a_nonzero_exit_and_writes_nothing(tmp_path):
    text = (tmafm.inputs.path(BASE)).read_text().replace("tip_sample_distance = 25.0e-9",
                                                          "tip_sample_distance = 25.0e-9\n    tip_bias = 3.0"
                                                          "\n    cone_half_angle = 1.6")
    source = tmp_path / "biased.nml"
    source.write_text(text)
    done = subprocess.run(["tmafm", "-q", str(source), "-o", str(tmp_path / "out.dat")], capture_output=True,
                          text=True, check=False)
    assert done.returncode != 0
    assert "cone_half_angle" in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "out.dat").exists()


def test_model_md_quotes_the_study_and_the_study_reproduces():
    """docs/model.md §17 quotes studies/results/surface_forces.json (written by
    `python studies/surface_forces_example.py`); its examples are recomputed here and agree with
    the JSON to the runs' steady tolerance (1e-8 of the orbit)."""
    import json
    import sys
    from pathlib import Path

    repo = Path(__file__).resolve().parents[1]
    data = json.loads((repo / "studies" / "results" / "surface_forces.json").read_text())
    text = (repo / "docs" / "model.md").read_text()
    section = text[text.index("## 17. Forces at a distance"):]
    kelvin = data["kelvin_parabola"]
    for k in (0, 1, 2):
        assert f"{kelvin['phase_deg'][k]:.4f}°".replace("-", "−") in section
    assert f"vertex is at {kelvin['vertex_V']:.4f} V" in section
    ring = data["ring_down"]
    assert f"falls by {-ring['shift_Hz']:.3f} Hz" in section
    assert f"−f0/(2k) dF/dz = {ring['formula_Hz']:.3f} Hz".replace("= -", "= −") in section
    assert f"{ring['shift_Hz'] / ring['formula_Hz'] - 1:.1e}".replace("e-04", " × 10⁻⁴") in section
    for ionic, row in data["dlvo_water"].items():
        line = (f"| {ionic} | {row['debye_length_nm']:.2f} | {row['amplitude']:.3f} | {row['phase']:.2f} | "
                f"{row['peak_force']:.3f} | {row['min_force']:.3f} |").replace("-", "−")
        assert line in section, line
    sys.path.insert(0, str(repo / "studies"))
    import surface_forces_example as study

    again = study.kelvin_parabola()
    assert again["vertex_V"] == pytest.approx(kelvin["vertex_V"], abs=1e-6)
    assert again["phase_deg"] == pytest.approx(kelvin["phase_deg"], abs=1e-5)
    for ionic, row in study.dlvo().items():
        assert row == pytest.approx(data["dlvo_water"][ionic], rel=1e-6, abs=1e-6)

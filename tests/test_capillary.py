"""The capillary meniscus (docs/model.md §19): a water neck that forms when the tip touches the
sample, holds it in flight and breaks at a rupture gap D on the way out, pulling with
F(g) = -F0 (1 - g/D), F0 = 4 pi R gamma_w cos(theta_w), at the normal gap g (-F0 in contact).

Oracles, each independent of the code under test:
- the Kelvin radius from scipy's physical constants and water's molar mass and density;
- the force law evaluated here in SI, at the contact angle of each sample from Model.contact,
  against the core's SI force column;
- the energy per tap: the stated law integrated from contact to rupture by quadrature;
- the three integrators against each other (dop853, dopri5, flight_exact), each to its tolerance;
- the composed peer (studies/composed_peer.py, tests/test_compose.py): the meniscus written again
  in numpy, its rupture a solve_ivp event of its own, alone and with tones, an SLS sample and vdW.
"""

import math

import numpy as np
import pytest
from scipy import constants
from scipy.integrate import quad

import tmafm
from tmafm import analysis

BASE = "tapping_polystyrene"
#: tapping_polystyrene's tip radius (m) and work of adhesion (J/m^2), and water's surface tension.
RADIUS, WORK, WATER = 10e-9, 0.035, 0.072
#: Water's molar volume at 25 C from its molar mass and density (CRC): 18.015 g/mol, 997.05 kg/m^3.
MOLAR_VOLUME = 18.015e-3 / 997.05
TIGHT = {"rtol": 1e-11, "atol": 1e-15}


def kelvin_rupture(humidity, angle=0.0, temperature=298.15, molar_volume=MOLAR_VOLUME):
    """2 r_K cos(theta_w), r_K = gamma_w V_m/(R T ln(1/RH))."""
    return 2 * math.cos(angle) * WATER * molar_volume / (constants.R * temperature * math.log(1 / humidity))


def core_rupture(humidity):
    """The same with the core's stated V_m = 1.8069e-5 m^3/mol (docs/model.md §19), for the checks
    tighter than the 4e-5 between it and CRC's density."""
    return kelvin_rupture(humidity, molar_volume=1.8069e-5)


def pull(angle=0.0):
    """F0 = 4 pi R gamma_w cos(theta_w) (N)."""
    return 4 * math.pi * RADIUS * WATER * math.cos(angle)


def humid(method="dop853", z=12e-9, **physical):
    return {"physical": {"tip_sample_distance": z, **physical}, "solver": {"method": method, **TIGHT}}


def test_the_scene_groups_are_the_meniscus_in_the_contact_units():
    """c_C = F0/(1.5 pi gamma R) and D/d with D the Kelvin gap; a given D replaces it; the contact
    angle enters both through cos(theta_w)."""
    cfg = tmafm.Config(BASE, **humid(relative_humidity=0.5))
    scene = cfg.scene
    assert scene["capillary_strength"] == pytest.approx(pull() / (1.5 * math.pi * WORK * RADIUS), rel=1e-12, abs=0)
    d = cfg.derived["gap"]
    # The molar volume from CRC's density agrees with the core's 1.8069e-5 to 1e-4.
    assert scene["capillary_range"] * d == pytest.approx(kelvin_rupture(0.5), rel=1e-4, abs=0)
    assert scene["capillary_range"] * d == pytest.approx(core_rupture(0.5), rel=1e-12, abs=0)
    assert kelvin_rupture(0.5) == pytest.approx(1.514e-9, rel=1e-3)
    given = tmafm.Config(BASE, physical={"meniscus_rupture_distance": 3e-9, "water_contact_angle": 0.5})
    assert given.scene["capillary_range"] * given.derived["gap"] == pytest.approx(3e-9, rel=1e-12, abs=0)
    assert given.scene["capillary_strength"] == pytest.approx(pull(0.5) / (1.5 * math.pi * WORK * RADIUS),
                                                              rel=1e-12, abs=0)
    assert tmafm.Config(BASE).scene["capillary_strength"] == 0


@pytest.mark.parametrize("method", ["dop853", "dopri5", "flight_exact"])
def test_the_energy_per_tap_is_the_law_integrated_from_contact_to_rupture(method):
    """dissipated_adhesion per tap at steady state equals the quadrature of -F(g) from 0 to D, to
    the runs' accuracy (rtol 1e-11: 1e-8 relative allowed), one tap per period, three switches
    (contact, exit into the held flight, rupture)."""
    obs = tmafm.observe(BASE, max_periods=3000, **humid(method, relative_humidity=0.5))
    assert obs.steady and obs.period == 1
    v = obs.steady_values(physical=True)
    assert v["contacts_per_period"] == 1
    rupture = core_rupture(0.5)
    law, _ = quad(lambda g: pull() * (1 - g / rupture), 0, rupture, epsabs=0, epsrel=1e-13)
    assert v["dissipated_adhesion"] * 1e-18 == pytest.approx(law, rel=1e-8, abs=0)
    # The most attractive force is in contact: the meniscus's F0 plus DMT's 2 pi gamma R.
    assert v["min_force"] * 1e-9 == pytest.approx(-(pull() + 2 * math.pi * WORK * RADIUS), rel=1e-9, abs=0)


def test_a_given_rupture_distance_and_contact_angle_set_the_loss():
    """D = 3 nm given, theta_w = 0.5 rad: the loss per tap is F0 cos(theta_w) D/2 by quadrature."""
    obs = tmafm.observe(BASE, max_periods=3000,
                        **humid(meniscus_rupture_distance=3e-9, water_contact_angle=0.5))
    assert obs.steady
    v = obs.steady_values(physical=True)
    law, _ = quad(lambda g: pull(0.5) * (1 - g / 3e-9), 0, 3e-9, epsabs=0, epsrel=1e-13)
    assert v["dissipated_adhesion"] * 1e-18 / v["contacts_per_period"] == pytest.approx(law, rel=1e-8, abs=0)


def test_the_force_in_flight_is_the_law_at_each_samples_normal_gap():
    """The core's SI force column on the samples where the meniscus holds the tip in flight (a
    nonzero force out of contact): -F0 (1 - g/D) with g = d V_T sin(theta1), theta1 from
    Model.contact, to 1e-12 of F0; the held samples reach to within a sample of the rupture gap,
    and none lies past it; dry flight (past the rupture) has no force."""
    run = tmafm.run(BASE, physical={"tip_sample_distance": 12e-9, "relative_humidity": 0.5},
                    solver={"method": "dop853", "tau_end": 400.0, **TIGHT}, output={"sample_dtau": 0.002})
    model = tmafm.Model(run.config)
    last = run.tau > 300
    force, distance = run.physical["normal_force_N"], run.physical["distance_m"]
    flight = last & (run.contact == 0)
    held = flight & (force != 0)
    assert held.sum() > 100 and (flight & (force == 0)).sum() > 1000
    gaps = np.array([distance[k] * math.sin(model.contact(run.tau[k], run.a[k]).theta1)
                     for k in np.flatnonzero(held)])
    rupture = core_rupture(0.5)
    assert np.max(np.abs(force[held] + pull() * (1 - gaps / rupture))) < 1e-9 * pull()
    assert gaps.max() <= rupture * (1 + 1e-9)
    assert gaps.max() > 0.9 * rupture


def test_the_methods_agree_on_the_held_orbit():
    """Phase and amplitude of the steady orbit at RH = 0.5 under flight_exact and dopri5 agree
    with dop853's to the runs' tolerance (rtol 1e-11: 1e-7 relative and 1e-6 deg allowed)."""
    values = {m: tmafm.observe(BASE, max_periods=3000, **humid(m, relative_humidity=0.5)).steady_values()
              for m in ("dop853", "dopri5", "flight_exact")}
    for method in ("dopri5", "flight_exact"):
        assert values[method]["amplitude"] == pytest.approx(values["dop853"]["amplitude"], rel=1e-7, abs=0)
        assert values[method]["phase"] == pytest.approx(values["dop853"]["phase"], abs=1e-6)


def test_the_meniscus_composes_with_a_viscoelastic_sample_and_vdw():
    """With a viscoelastic sample and dmt_vdw the meniscus still takes F0 D/2 per tap (its loss
    does not depend on the other parts), and the energy balance of the steady period closes."""
    obs = tmafm.observe(BASE, max_periods=6000, steady_tol=1e-10, model={"contact_law": "dmt_vdw"},
                        **humid(relative_humidity=0.4, hamaker=1e-19, intermolecular_distance=0.3e-9,
                                sample_relaxation_time=1e-7, sample_modulus_relaxed=0.6e9))
    assert obs.steady
    v = obs.steady_values(physical=True)
    rupture = core_rupture(0.4)
    taps = v["contacts_per_period"]
    assert taps >= 1
    assert v["dissipated_adhesion"] / taps == pytest.approx(pull() * rupture / 2 * 1e18, rel=1e-8, abs=0)
    assert v["dissipated_viscoelastic"] > 0
    losses = sum(v[k] for k in ("dissipated_beam", "dissipated_contact_damping", "dissipated_friction",
                                "dissipated_viscoelastic", "dissipated_adhesion"))
    assert v["dissipated_energy"] == pytest.approx(losses, rel=1e-12)
    # Over a steady period (to 1e-10 of the orbit) the modal energy returns: the drive's and the
    # normal force's remaining work (the sample's delayed part) feed the losses.
    assert v["drive_work"] + v["contact_normal_work"] == pytest.approx(losses, rel=1e-6)


@pytest.mark.parametrize("overrides, words", [
    ({"solver": {"method": "rk4_paper"}}, ["&physical relative_humidity = ", "rk4_paper", "flight_exact"]),
    ({"model": {"contact_law": "jkr"}}, ["&physical relative_humidity = ", "jkr"]),
    ({"physical": {"meniscus_rupture_distance": 2e-9}}, ["meniscus_rupture_distance", "not both"]),
])
def test_what_the_meniscus_refuses_is_one_line_naming_the_keys(overrides, words):
    physical = {"relative_humidity": 0.5, **overrides.pop("physical", {})}
    with pytest.raises(tmafm.TmafmError) as info:
        tmafm.Config(BASE, physical=physical, **overrides)
    message = str(info.value)
    assert "\n" not in message
    for word in words:
        assert word in message


def test_a_meniscus_in_a_liquid_and_the_energy_flow_of_its_samples_are_refused():
    with pytest.raises(tmafm.TmafmError, match="liquid"):
        tmafm.Config(BASE, physical={"relative_humidity": 0.5, "medium_density": 1000.0,
                                     "medium_viscosity": 1e-3})
    run = tmafm.run(BASE, physical={"relative_humidity": 0.5}, solver={"tau_end": 2.0})
    with pytest.raises(tmafm.InputError, match="dissipated_adhesion"):
        analysis.energy_flow(run)


def test_the_humidity_study_holds_and_model_md_quotes_it():
    """studies/adhesion_phase_contrast.py's humidity rows: every loss per tap is F0 D/2 at its
    humidity (the closed form here), docs/model.md §19 quotes the table, and the RH = 0.5 point
    recomputed here agrees with the JSON to the runs' steady tolerance."""
    import json
    import sys
    from pathlib import Path

    repo = Path(__file__).resolve().parents[1]
    data = json.loads((repo / "studies" / "results" / "adhesion_phase_contrast.json").read_text())
    text = (repo / "docs" / "model.md").read_text()
    section = text[text.index("## 19. The capillary meniscus"):]
    for humidity, row in zip(data["humidities"], data["humid"], strict=True):
        closed = pull() * core_rupture(humidity) / 2 * 1e18 if humidity > 0 else 0.0
        assert row["adhesion_loss_per_tap_aJ"] == pytest.approx(closed, rel=1e-6, abs=1e-12)
        line = (f"| {humidity * 100:g} | {row['phase_deg']:.2f} | {row['amplitude_nm']:.3f} | "
                f"{row['adhesion_loss_per_tap_aJ']:.4f} | {row['tip_sample_loss_per_period_aJ']:.3f} |"
                ).replace("-", "−")
        assert line in section, line
    sys.path.insert(0, str(repo / "studies"))
    import adhesion_phase_contrast as study

    k = data["humidities"].index(0.5)
    again = study.steady("dmt", 0.035, 0.5)
    assert again["phase_deg"] == pytest.approx(data["humid"][k]["phase_deg"], abs=1e-4)
    assert again["adhesion_loss_per_tap_aJ"] == pytest.approx(data["humid"][k]["adhesion_loss_per_tap_aJ"],
                                                              rel=1e-6)


def test_the_humid_air_example_states_its_numbers():
    """inputs/humid_air.nml (and docs/model.md §19) state F0 = 9.05 nN, D = 1.51 nm and
    F0 D/2 = 6.85 aJ: the closed forms here, and its run's loss per tap."""
    from pathlib import Path

    repo = Path(__file__).resolve().parents[1]
    text = (repo / "inputs" / "humid_air.nml").read_text()
    rupture = core_rupture(0.5)
    assert f"F0 = 4 pi R gamma_w cos(theta_w) = {pull() * 1e9:.2f} nN" in text
    assert f"D = 2 r_K cos(theta_w) = {rupture * 1e9:.2f} nm" in text
    assert f"each tap loses F0 D/2 = {pull() * rupture / 2 * 1e18:.2f} aJ" in text
    assert f"at RH = 0.5, 25 °C, D = {rupture * 1e9:.2f} nm" in (repo / "docs" / "model.md").read_text()
    obs = tmafm.observe("humid_air", max_periods=3000)
    assert obs.steady
    v = obs.steady_values(physical=True)
    assert f"{v['dissipated_adhesion'] / v['contacts_per_period']:.2f}" == f"{pull() * rupture / 2 * 1e18:.2f}"


def test_the_monodromy_matrix_of_a_held_orbit_is_the_maps_derivative(monodromy_fd):
    """On humid_air's periodic orbit (contact, a flight the meniscus holds, its rupture, a free
    flight): the monodromy matrix equals central differences of the stroboscopic map, whose error
    falls as h^2 (1e-4 -> 1e-5: at least 50x) to below 1e-7 of |M|; the flag (the map state's last
    component) has a zero row and column; Newton converges in a few iterations."""
    from tmafm.continuation.shooting import map_size, periodic_orbit

    model = tmafm.Model("humid_air")
    m = map_size(model)
    assert m == 2 * 3 + 1
    obs = tmafm.observe("humid_air", max_periods=3000)
    guess = np.zeros(m)
    guess[:6] = np.asarray(obs.final_state)[:6]
    orbit = periodic_orbit(model, guess, rtol=1e-11)
    assert orbit.iterations <= 5 and orbit.stable
    x0 = orbit.states[0]
    monodromy, errors = monodromy_fd(model, x0, 6)
    assert np.all(monodromy[-1] == 0) and np.all(monodromy[:, -1] == 0)
    assert errors[0] / errors[1] > 50 and errors[1] < 1e-7, errors


def test_continuation_follows_the_held_orbit_as_observe_finds_it():
    """tmafm.continuation along Z (12 -> 8 nm) on humid_air: at three points the continued orbit's
    largest and smallest gap equal a long run's located ones at steady state (tmafm.observe) to
    1e-6 of the stroke."""
    ds = tmafm.continuation("humid_air", "physical.tip_sample_distance", 12e-9, 8e-9)
    z = ds["physical.tip_sample_distance"].values
    assert z[0] == 12e-9 and z[-1] <= 8e-9 * (1 + 1e-12)
    assert bool(ds["stable"].all())
    for k in (0, len(z) // 2, len(z) - 1):
        v = tmafm.observe("humid_air", max_periods=4000, steady_tol=1e-9,
                          physical={"tip_sample_distance": float(z[k])}).steady_values(physical=True)
        stroke = v["max_gap"] - v["min_gap"]
        assert float(ds["max_gap_si"][k]) == pytest.approx(v["max_gap"], abs=1e-6 * stroke)
        assert float(ds["min_gap_si"][k]) == pytest.approx(v["min_gap"], abs=1e-6 * stroke)

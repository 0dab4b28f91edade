"""The JKR law (docs/model.md §18): an adhesive neck made at contact and broken at the JKR pull-off,
past the undeformed surface, so each tap that goes past pull-off loses the area of the hysteresis
loop.

Oracles, each independent of the code under test:
- the JKR closed form in SI (Johnson, Kendall and Roberts 1971), its contact radius solved here by
  bracketing on the stable branch, not by the core's Newton iteration in its own units;
- the hysteresis loop's area, integrated here by quadrature along the branch;
- the composed peer (studies/composed_peer.py), whose JKR radius is the largest real root of the
  quartic by numpy's companion matrix and whose pull-off is a solve_ivp event of its own
  (tests/test_compose.py runs it against the core).
"""

import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq

import tmafm

BASE = "tapping_polystyrene"
JKR = {"model": {"contact_law": "jkr"}, "solver": {"method": "dop853"}}
#: tapping_polystyrene's tip and sample (SI).
RADIUS, WORK = 10e-9, 0.035
E_STAR = 1 / ((1 - 0.27**2) / 130e9 + (1 - 0.3**2) / 1.2e9)


def jkr_radius(delta):
    """a on the stable branch at normal indentation delta (m): delta = a^2/R - sqrt(2 pi w a/E*)."""
    a_c = (math.pi * WORK * RADIUS**2 / (8 * E_STAR)) ** (1 / 3)

    def gap(a):
        return a * a / RADIUS - math.sqrt(2 * math.pi * WORK * a / E_STAR) - delta

    high = 2 * a_c
    while gap(high) < 0:
        high *= 2
    return brentq(gap, a_c, high, xtol=1e-30, rtol=1e-15, maxiter=500)


def jkr_force(a):
    """F = 4 E* a^3/(3 R) - sqrt(8 pi w E* a^3) (N)."""
    return 4 * E_STAR * a**3 / (3 * RADIUS) - math.sqrt(8 * math.pi * WORK * E_STAR * a**3)


def pull_off_indentation():
    """delta_c = -(3/4) (pi^2 w^2 R/E*^2)^(1/3)."""
    return -0.75 * (math.pi**2 * WORK**2 * RADIUS / E_STAR**2) ** (1 / 3)


def _neck_force(model, vt):
    """The core's normal force (N), normal indentation (m) and contact radius at gap vt, with the
    neck held (phase 'in contact' whatever the sign of vt)."""
    n = model.n_modes
    a = np.zeros(n)
    v0 = model.contact(0.0, a).vt
    a[0] = (vt - v0) / model.tip[0]
    _, _, state = model.trajectory_energy_flow([0.0], a[None, :], np.zeros((1, n)), [1])
    theta1, radius, normal = state[0, 0], state[0, 1], state[0, 2]
    d = model.config.derived["length_scale"]
    return normal * 1.5 * math.pi * WORK * RADIUS, -vt * math.sin(theta1) * d, radius


def test_the_neck_force_is_the_jkr_closed_form_on_both_branches():
    model = tmafm.Model(BASE, **JKR)
    d = model.config.derived["length_scale"]
    delta_c = pull_off_indentation()
    # Loading (delta > 0) and the neck stretched above the surface, down to just above pull-off.
    for target in (2e-9, 0.5e-9, 1e-12, 0.0, 0.3 * delta_c, 0.9 * delta_c, 0.999 * delta_c):
        vt = -target / d
        for _ in range(3):
            force, delta, _ = _neck_force(model, vt)
            vt = vt * (target / delta) if delta else vt
        force, delta, _ = _neck_force(model, vt)
        expected = jkr_force(jkr_radius(delta))
        assert force == pytest.approx(expected, rel=1e-9, abs=1e-9 * abs(jkr_force(jkr_radius(0.0)))), target
    # The force where the neck forms (-(4/3) pi w R) and where it breaks (-(5/6) pi w R).
    assert _neck_force(model, 0.0)[0] == pytest.approx(-4 / 3 * math.pi * WORK * RADIUS, rel=1e-12, abs=0)
    at_pull_off = jkr_force((math.pi * WORK * RADIUS**2 / (8 * E_STAR)) ** (1 / 3))
    assert at_pull_off == pytest.approx(-5 / 6 * math.pi * WORK * RADIUS, rel=1e-12, abs=0)
    # Without the neck (in flight) nothing acts, whatever the gap: the approach branch is 0 until contact.
    n = model.n_modes
    a = np.zeros(n)
    a[0] = 1e-4 / model.tip[0]
    _, _, state = model.trajectory_energy_flow([0.0], a[None, :], np.zeros((1, n)), [0])
    assert state[0, 2] == 0


def hysteresis_energy():
    """-integral of F d(delta) from delta_c to 0 along the branch (J), by quadrature in a."""
    a_c = (math.pi * WORK * RADIUS**2 / (8 * E_STAR)) ** (1 / 3)
    a_0 = jkr_radius(0.0)

    def integrand(a):
        return jkr_force(a) * (2 * a / RADIUS - 0.5 * math.sqrt(2 * math.pi * WORK / (E_STAR * a)))

    value, error = quad(integrand, a_c, a_0, epsabs=0, epsrel=1e-13, limit=200)
    return -value


def test_each_tap_loses_the_area_of_the_jkr_hysteresis_loop():
    """Over a steady tapping orbit the neck's channel (dissipated_adhesion) is, per contact, the
    loop's area, whatever else the tap does; the energy balance closes with it."""
    energy = hysteresis_energy()
    # The closed form 1.5 pi (9 pi/8)^(2/3) e (w^5 R^4/E*^2)^(1/3), e = 0.648641... the antiderivative's
    # value (docs/model.md §18): 7.0922 (w^5 R^4/E*^2)^(1/3).
    assert energy == pytest.approx(7.0922 * (WORK**5 * RADIUS**4 / E_STAR**2) ** (1 / 3), rel=1e-5, abs=0)
    obs = tmafm.observe(BASE, max_periods=6000, steady_tol=1e-8, physical={"tip_sample_distance": 12e-9},
                        model={"contact_law": "jkr"}, solver={"method": "dop853", "rtol": 1e-11, "atol": 1e-16})
    assert obs.steady, obs.unsteady_reason
    p = obs.physical
    orbit = slice(len(p["drive_work"]) - obs.period, None)
    contacts = float(np.sum(p["contacts_per_period"][orbit]))
    assert contacts >= 1
    per_tap = float(np.sum(p["dissipated_adhesion"][orbit])) * 1e-18 / contacts
    assert per_tap == pytest.approx(energy, rel=1e-6, abs=0)
    balance = float(np.sum(p["drive_work"][orbit] + p["contact_normal_work"][orbit] - p["dissipated_energy"][orbit]))
    assert abs(balance) <= 1e-6 * float(np.sum(p["drive_work"][orbit]))
    # The phase contrast's source: the neck's loss is a share of what the tip-sample contact takes.
    assert 0 < float(np.sum(p["dissipated_adhesion"][orbit])) < float(np.sum(p["dissipated_energy"][orbit]))


def test_the_neck_breaks_above_the_surface_and_the_samples_say_so():
    """A run's contact flags are the neck's phase: samples with the neck stretched (V_T > 0) are in
    contact, and every contact ends at the pull-off gap -D_c beta/sin(theta1), not at V_T = 0."""
    result = tmafm.run(BASE, physical={"tip_sample_distance": 12e-9}, model={"contact_law": "jkr"},
                       solver={"method": "dop853", "rtol": 1e-10, "atol": 1e-15, "tau_end": 400.0},
                       output={"sample_dtau": 0.002})
    stretched = (result.contact == 1) & (result.vt > 0)
    assert stretched.any()
    scene = tmafm.Config(BASE, physical={"tip_sample_distance": 12e-9}, **JKR).scene
    # sin(theta1) = cos(theta + atan|t|) with the scaled slope |t| ~ 1e-4 here: the pull-off gap is
    # 3^(-1/3) beta/cos(theta) to 1e-3, and the samples (0.002 tau apart) come within 10 % of it.
    pull_off = 3 ** (-1 / 3) * scene["beta"] / math.cos(scene["theta"])
    assert 0.9 * pull_off <= np.max(result.vt[stretched]) <= 1.001 * pull_off
    # Out of contact nothing is below the surface.
    assert np.all(result.vt[result.contact == 0] > 0)


@pytest.mark.parametrize("overrides, message", [
    ({"solver": {"method": "rk4_paper"}}, "rk4_paper.*jkr"),
    ({"solver": {"method": "rk4_event"}}, "rk4_event.*jkr"),
    ({"solver": {"method": "dop853"}, "physical": {"sample_relaxation_time": 1e-6}},
     "sample_relaxation_time.*viscoelastic sample is not modelled under"),
])
def test_what_the_jkr_law_does_not_support_is_refused_in_one_line(overrides, message):
    with pytest.raises(tmafm.InputError, match=message) as err:
        tmafm.Config(BASE, model={"contact_law": "jkr"}, **overrides)
    assert "\n" not in str(err.value)


def test_the_monodromy_matrix_through_the_pull_off_is_the_maps_derivative(monodromy_fd):
    """On the JKR orbit at Z = 12 nm (a neck that holds across the period boundary, flag 1, and
    breaks at the pull-off, where f ~ sqrt(D - D_c)): the monodromy matrix equals central
    differences of the stroboscopic map, whose error falls as h^2 (1e-4 -> 1e-5: at least 50x) to
    below 1e-8 of |M|; the flag has a zero row and column; Newton converges in a few steps."""
    from tmafm.continuation.shooting import map_size, periodic_orbit

    config = tmafm.Config(BASE, physical={"tip_sample_distance": 12e-9}, **JKR)
    model = tmafm.Model(config)
    m = map_size(model)
    assert m == 2 * 3 + 1
    guess = np.zeros(m)
    guess[:6] = np.asarray(tmafm.observe(config, max_periods=3000).final_state)[:6]
    orbit = periodic_orbit(model, guess, rtol=1e-11)
    assert orbit.iterations <= 5 and orbit.stable and orbit.states[0][-1] == 1
    x0 = orbit.states[0]
    monodromy, errors = monodromy_fd(model, x0, 6)
    assert np.all(monodromy[-1] == 0) and np.all(monodromy[:, -1] == 0)
    assert errors[0] / errors[1] > 50 and errors[1] < 1e-8, errors


def test_continuation_follows_the_jkr_orbit_as_observe_finds_it():
    """tmafm.continuation along Z (12 -> 8 nm) with the JKR neck: at three points the continued
    orbit's largest and smallest gap equal a long run's located ones (tmafm.observe) to 1e-6 of
    the stroke; a JKR scene with a force at a distance is refused in one line."""
    base = tmafm.Config(BASE, **JKR)
    ds = tmafm.continuation(base, "physical.tip_sample_distance", 12e-9, 8e-9)
    z = ds["physical.tip_sample_distance"].values
    assert bool(ds["stable"].all()) and z[-1] <= 8e-9 * (1 + 1e-12)
    for k in (0, len(z) // 2, len(z) - 1):
        v = tmafm.observe(base, max_periods=4000, steady_tol=1e-9,
                          physical={"tip_sample_distance": float(z[k])}).steady_values(physical=True)
        stroke = v["max_gap"] - v["min_gap"]
        assert float(ds["max_gap_si"][k]) == pytest.approx(v["max_gap"], abs=1e-6 * stroke)
        assert float(ds["min_gap_si"][k]) == pytest.approx(v["min_gap"], abs=1e-6 * stroke)
    with pytest.raises(tmafm.TmafmError, match="jkr.*force at a distance") as err:
        tmafm.continuation(tmafm.Config(BASE, physical={"tip_bias": 1.0}, **JKR),
                           "physical.tip_sample_distance", 12e-9, 11e-9, max_points=2)
    assert "\n" not in str(err.value)


def test_the_phase_contrast_study_holds_and_model_md_quotes_it():
    """studies/adhesion_phase_contrast.py's JSON: every loss per tap is the loop's area at its w (an
    independent closed form), docs/model.md §18 quotes the table, and the w = 0.035 J/m^2 points
    recomputed here agree with the JSON to the runs' steady tolerance."""
    import json
    import sys
    from pathlib import Path

    repo = Path(__file__).resolve().parents[1]
    data = json.loads((repo / "studies" / "results" / "adhesion_phase_contrast.json").read_text())
    text = (repo / "docs" / "model.md").read_text()
    section = text[text.index("## 18. JKR adhesion"):]
    for k, work in enumerate(data["works_J_per_m2"]):
        jkr, dmt = data["jkr"][k], data["dmt"][k]
        closed = 7.092195971863954 * (work**5 * RADIUS**4 / E_STAR**2) ** (1 / 3) * 1e18
        assert jkr["adhesion_loss_per_tap_aJ"] == pytest.approx(closed, rel=1e-6, abs=0)
        assert dmt["adhesion_loss_per_tap_aJ"] == 0
        row = (f"| {work * 1e3:g} | {jkr['phase_deg']:.2f} | {dmt['phase_deg']:.2f} | "
               f"{jkr['phase_deg'] - dmt['phase_deg']:.2f} | {jkr['adhesion_loss_per_tap_aJ']:.4f} |").replace("-", "−")
        assert row in section, row
    sys.path.insert(0, str(repo / "studies"))
    import adhesion_phase_contrast as study

    k = data["works_J_per_m2"].index(0.035)
    for law in ("jkr", "dmt"):
        again = study.steady(law, 0.035)
        assert again["phase_deg"] == pytest.approx(data[law][k]["phase_deg"], abs=1e-4)
        assert again["adhesion_loss_per_tap_aJ"] == pytest.approx(data[law][k]["adhesion_loss_per_tap_aJ"],
                                                                   rel=1e-6, abs=1e-12)


def test_a_run_restarted_on_a_stretched_neck_reproduces_the_contact_state():
    """A run restarted from a sample where the neck holds above the surface (V_T > 0), with
    &initial in_contact = 1 and the drive's phase at that time, has the original's contact flags at
    every later sample and its V_T to the runs' accuracy; started by V_T's sign (in flight) it does
    not."""
    base = {"model": {"contact_law": "jkr"}, "scene": {"alpha2": 2e-3}}
    solver = {"method": "dop853", "rtol": 1e-11, "atol": 1e-16}
    whole = tmafm.run("fig2_n4", **base, solver={**solver, "tau_end": 40.0}, output={"sample_dtau": 0.002})
    omega = tmafm.Config("fig2_n4", **base, solver=solver).scene["omega"]
    stretched = np.flatnonzero((whole.contact == 1) & (whole.vt > 0) & (whole.tau > 15) & (whole.tau < 25))
    assert stretched.size > 10
    k = stretched[stretched.size // 2]
    restart = whole.tau[k]

    def rerun(contact):
        return tmafm.run("fig2_n4", model=base["model"],
                         scene={**base["scene"], "drive_phase": math.remainder(omega * restart, 2 * math.pi)},
                         initial={"a0": list(whole.a[k]), "adot0": list(whole.adot[k]), "in_contact": contact},
                         solver={**solver, "tau_end": 40.0 - restart}, output={"sample_dtau": 0.002})

    held = rerun(1)
    m = min(held.vt.size, whole.vt.size - k)
    assert m > 5000
    assert np.array_equal(held.contact[:m], whole.contact[k:k + m])
    # rtol 1e-11: the restarted V_T is the original's to 1e-9 of its range.
    assert np.max(np.abs(held.vt[:m] - whole.vt[k:k + m])) <= 1e-9 * np.ptp(whole.vt)
    by_sign = rerun(-1)
    assert not np.array_equal(by_sign.contact[:m], whole.contact[k:k + m])


@pytest.mark.parametrize("initial, message", [
    ({"a0": [0.0] * 4, "in_contact": 1}, r"in_contact = 1: the start state has V_T = .*past where contact ends"),
    ({"a0": [-0.01, 0.0, 0.0, 0.0], "in_contact": 0}, r"in_contact = 0: the start state has V_T = .* < 0"),
])
def test_an_initial_phase_the_start_state_contradicts_is_refused_in_one_line(initial, message):
    with pytest.raises(tmafm.InputError, match=message) as err:
        tmafm.run("fig2_n4", model={"contact_law": "jkr"}, scene={"delta_hat": 1e-3}, initial=initial,
                  solver={"method": "dop853", "tau_end": 1.0})
    assert "\n" not in str(err.value)


def test_the_fixed_step_methods_take_the_phase_from_the_sign_and_refuse_another():
    # V_T = 0 rising at the start: in flight by the sign rule.
    with pytest.raises(tmafm.InputError,
                       match=r"in_contact = 1: &solver method = 'rk4_paper' takes the start's phase"):
        tmafm.run("fig2_n4", scene={"delta_hat": 0.0}, initial={"a0": [0.0] * 4, "in_contact": 1},
                  solver={"tau_end": 1.0})
    # The phase they would take anyway is accepted.
    tmafm.run("fig2_n4", scene={"delta_hat": 1e-3}, initial={"a0": [0.0] * 4, "in_contact": 0},
              solver={"tau_end": 1.0})

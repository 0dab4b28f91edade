"""contact_law = 'dmt_vdw' (docs/model.md §6a, docs/vdw.md): the van der Waals force out of
contact against its closed form -H R/(6 s^2), in SI and in the scene's groups; continuity into
the DMT adhesion at contact; the right-hand side in flight against the brackets written out
here; a work-energy balance over a no-loss period; the two branches of the attractive regime
and the hysteresis of a warm-started approach and retract; and the input errors."""

import math
from pathlib import Path

import numpy as np
import pytest

import tmafm
from tmafm.observe import observe_states

INPUTS = Path(__file__).resolve().parents[1] / "inputs"
SCENE_FILE = INPUTS / "sweeps" / "vdw_attractive.nml"

H, A0_SI = 1e-19, 0.165e-9


def _physical(**changes):
    """The SI scene of inputs/sweeps/vdw_attractive.nml (its comments say where each comes from)."""
    length, width, thickness, rho, e1 = 125e-6, 37.5e-6, 4e-6, 2330.0, 130e9
    m = rho * width * thickness
    rigidity = e1 * width * thickness**3 / 12
    beta1 = 1.8751040687119611
    w1 = beta1**2 * math.sqrt(rigidity / (m * length**4))
    phys = dict(length=length, width=width, thickness=thickness, density=rho, youngs_modulus_tip=e1,
                poisson_ratio_tip=0.27, youngs_modulus_sample=130e9, poisson_ratio_sample=0.27,
                tip_radius=10e-9, adhesion_energy=H / (12 * math.pi * A0_SI**2), tilt=0.0, gap=10e-6,
                tip_length=10e-6, static_offset=0.0, tip_position=length, tip_mass=0.0,
                beam_damping=m * w1 / 400, contact_damping=0.0, drive_amplitude=16e-12,
                drive_angular_frequency=w1, hamaker=H, intermolecular_distance=A0_SI)
    phys.update(changes)
    return phys


def _scene_model(n_modes=1, law="dmt_vdw", **scene):
    return tmafm.Model({"model": {"n_modes": n_modes, "contact_law": law, "convention": "consistent"},
                        "scene": scene, "solver": {"method": "dopri5"}})


def _sin_theta1(model, a, theta):
    """sin(theta1) by E7 (consistent): theta1 = pi/2 - theta + atan((d/L) s.a)."""
    slope = float(np.dot(model.slope, a)) / model.scene["l_over_d"]
    return math.sin(math.pi / 2 - theta + math.atan(slope))


def test_si_force_is_minus_h_r_over_6_s_squared():
    """The normal force out of contact, in newtons, from the run's own groups and scales, equals
    -H R/(6 s^2) at the normal separation s = a0 + d V_T sin(theta1), on a tilted beam."""
    theta, d, radius = 0.3, 10e-6, 10e-9
    phys = _physical(tilt=theta, static_offset=5e-6 * math.cos(theta), tip_length=5e-6)
    model = tmafm.Model({"model": {"n_modes": 2, "contact_law": "dmt_vdw", "convention": "consistent"},
                         "physical": phys, "solver": {"method": "dopri5"}})
    kappa5, _ = model.kappas
    # Force unit of the brackets: E1 I/L^2 (tmafm_units).
    force_unit = phys["youngs_modulus_tip"] * phys["width"] * phys["thickness"]**3 / 12 / phys["length"]**2
    delta_hat = model.scene["delta_hat"]
    for target in (0.2e-9, 0.5e-9, 2e-9, 10e-9, 100e-9):
        # A bent beam: mode 2 gives a slope; mode 1 puts V_T near the separation asked.
        a = np.array([0.0, 3e-4])
        vt = (target - A0_SI) / (d * _sin_theta1(model, a, theta))
        a[0] = (vt - delta_hat - model.tip[1] * a[1]) / model.tip[0]
        state = model.contact(0.0, a)
        # V_T = p.a + delta_hat (0.5 here) carries delta_hat's rounding: 1e-14 of it, not of V_T.
        assert state.vt == pytest.approx(vt, rel=1e-12, abs=1e-14 * abs(delta_hat))
        separation = A0_SI + d * state.vt * _sin_theta1(model, a, theta)
        assert separation == pytest.approx(target, rel=0.05)
        force = kappa5 * state.normal * force_unit
        assert force == pytest.approx(-H * radius / (6 * separation**2), rel=1e-10)
        assert state.friction == 0 and state.radius == 0


def test_dimensionless_force_continuity_and_contact_branch():
    """f_c = -c_H/(1 + V_T sin(theta1)/eps)^2 in flight, A^3 - c_H in contact, equal at V_T = 0;
    P1, P2 are the normal force along the contact angle, with no friction in flight."""
    c_h, eps, beta, theta = 1.1, 2e-5, 1.128e-4, math.pi / 12
    model = _scene_model(n_modes=3, vdw_adhesion=c_h, vdw_range=eps, beta=beta, theta=theta,
                         delta_hat=0.0)
    kappa5, kappa6 = model.kappas
    bent = np.array([0.0, 2e-4, -1e-4])

    def state_at(vt):
        """The contact state at gap vt on the bent beam, and sin, cos of its contact angle."""
        a = bent.copy()
        a[0] = (vt - float(np.dot(model.tip, bent))) / model.tip[0]
        sin1 = _sin_theta1(model, a, theta)
        return model.contact(0.0, a), sin1, math.sqrt(1 - sin1**2)

    for vt in (1e-7, 1e-5, 3e-4, 1e-2):
        s, sin1, cos1 = state_at(vt)
        assert s.vt == pytest.approx(vt, rel=1e-9)
        expected = -c_h / (1 + s.vt * sin1 / eps)**2
        assert s.normal == pytest.approx(expected, rel=1e-12)
        assert s.transverse == pytest.approx(kappa5 * expected * sin1, rel=1e-12)
        assert s.axial == pytest.approx(-kappa5 * expected * cos1, rel=1e-12)
        assert s.friction == 0
    for vt in (-1e-6, -1e-4):
        s, sin1, cos1 = state_at(vt)
        radius = math.sqrt(-s.vt * sin1 / beta)
        assert s.normal == pytest.approx(radius**3 - c_h, rel=1e-12)
        friction = radius * (-s.vt * cos1)
        assert s.transverse == pytest.approx(kappa5 * (radius**3 - c_h) * sin1 + kappa6 * friction * cos1,
                                             rel=1e-12)
    # Continuity at the switch (s = a0): both sides tend to -c_H, the brackets too.
    above, below = state_at(1e-15)[0], state_at(-1e-15)[0]
    assert above.vt > 0 >= below.vt
    assert above.normal == pytest.approx(-c_h, rel=1e-9)
    assert below.normal == pytest.approx(-c_h, rel=1e-9)
    assert above.transverse == pytest.approx(below.transverse, rel=1e-9)
    assert above.axial == pytest.approx(below.axial, rel=1e-9)


@pytest.mark.parametrize("n_modes", [2, 6])
def test_flight_right_hand_side_carries_the_attraction(n_modes):
    """In flight, a'' under 'dmt_vdw' minus a'' under 'hertz' is M^-1 [(L/d) P1 p + (g0/d) P2 r
    + P2 G a] with the closed-form force (both kernels: N <= 4 and N > 4); in contact the two
    differ by the adhesion alone, and the contact damping acts in contact only."""
    c_h, eps, theta = 4 / 3, 3e-5, math.pi / 12
    scene = dict(vdw_adhesion=c_h, vdw_range=eps, theta=theta, delta_hat=2e-3, alpha4=0.4)
    vdw = _scene_model(n_modes, **scene)
    hertz = _scene_model(n_modes, law="hertz", **scene)
    kappa5, _ = vdw.kappas
    sc = vdw.scene
    rng = np.random.default_rng(3)
    a = rng.normal(scale=1e-5, size=n_modes)
    adot = rng.normal(scale=1e-3, size=n_modes)
    tau = 0.37
    vt = float(np.dot(vdw.tip, a)) + sc["alpha2"] * math.sin(sc["omega"] * tau) + sc["delta_hat"]
    assert vt > 0
    sin1 = _sin_theta1(vdw, a, theta)
    cos1 = math.sqrt(1 - sin1**2)
    f = -c_h / (1 + vt * sin1 / eps)**2
    p1, p2 = kappa5 * f * sin1, -kappa5 * f * cos1
    load = sc["l_over_d"] * p1 * vdw.tip + sc["g0_over_d"] * p2 * vdw.moment_shape + p2 * vdw.axial @ a
    expected = np.linalg.solve(vdw.mass, load)
    y = np.concatenate([a, adot])
    diff = vdw.derivative(tau, y, False)[n_modes:] - hertz.derivative(tau, y, False)[n_modes:]
    scale = np.max(np.abs(hertz.derivative(tau, y, False)))
    assert np.max(np.abs(diff - expected)) <= 1e-12 * scale
    assert np.max(np.abs(expected)) > 1e-6 * scale  # the attraction is not lost in round-off
    # The explicit M, C, K, F of Eq. (15) in flight carry the same force, and no contact damping.
    mass, damping, stiffness, force = vdw.matrices(tau, a, False)
    explicit = np.linalg.solve(mass, force - damping @ adot - stiffness @ a)
    assert np.max(np.abs(explicit - vdw.derivative(tau, y, False)[n_modes:])) <= 1e-12 * scale
    assert np.allclose(damping, sc["alpha3"] * np.eye(n_modes), rtol=0, atol=0)


def _drive_force(model, tau):
    sc = model.scene
    q, m = model.integral[:, None], model.mass_point[:, None]
    return (sc["alpha2"] * sc["omega"]**2 * (sc["alpha1"] * m + q) * np.sin(sc["omega"] * tau)[None, :]
            - sc["alpha2"] * sc["alpha3"] * sc["omega"] * q * np.cos(sc["omega"] * tau)[None, :])


@pytest.mark.parametrize("amplitude", [9.9e-4, 1.02e-3], ids=["flight_only", "with_contact"])
def test_work_energy_over_a_no_loss_period(amplitude):
    """No damping and no friction: over a period the modal energy changes by the drive's work
    plus the work of the tip-sample force, both integrated here from the closed forms (the
    attraction -c_H/(1 + V_T sin(theta1)/eps)^2, the Hertz force with the adhesion) on the
    run's samples; within the quadrature's and the method's error."""
    text = str(SCENE_FILE)
    config = tmafm.Config(text, scene={"alpha3": 0.0, "alpha6": 0.0, "delta_hat": 1e-3})
    model = tmafm.Model(config)
    sc = model.scene
    kappa5, _ = model.kappas
    period = 2 * math.pi / sc["omega"]
    a_start = (amplitude - 0.0) / model.tip[0]
    result = tmafm.run(config, initial={"a0": [a_start], "adot0": [0.0]},
                       solver={"rtol": 1e-12, "atol": 1e-18, "tau_end": period},
                       output={"sample_dtau": period / 8000})
    tau, a, adot = result.tau, result.a, result.adot
    assert tau[-1] == pytest.approx(period, rel=1e-3)
    touched = bool(np.any(result.vt <= 0))
    assert touched == (amplitude > 1e-3)
    vt = result.vt
    sin1 = np.sin(np.pi / 2 - sc["theta"] + np.arctan(a @ model.slope / sc["l_over_d"]))
    cos1 = np.sqrt(1 - sin1**2)
    c_h, eps = sc["vdw_adhesion"], sc["vdw_range"]
    flight = -c_h / (1 + np.maximum(vt, 0) * sin1 / eps)**2
    contact = np.sqrt(np.maximum(-vt, 0) * sin1 / sc["beta"])**3 - c_h
    f = np.where(vt <= 0, contact, flight)
    p1, p2 = kappa5 * f * sin1, -kappa5 * f * cos1
    tip_rate = adot @ model.tip
    axial_rate = np.einsum("ki,ij,kj->k", adot, np.atleast_2d(model.axial), a)
    power_force = sc["l_over_d"] * p1 * tip_rate + p2 * (sc["g0_over_d"] * (adot @ model.moment_shape)
                                                         + axial_rate)
    power_drive = np.einsum("ki,ik->k", adot, _drive_force(model, tau))
    mass, eigen = model.mass, model.eigen
    energy = 0.5 * np.einsum("ki,ij,kj->k", adot, np.atleast_2d(mass), adot) + 0.5 * (a**2) @ eigen

    def simpson(values, step):
        return step / 3 * (values[0] + values[-1] + 4 * values[1:-1:2].sum() + 2 * values[2:-1:2].sum())

    k = (len(tau) - 1) // 2 * 2
    h = tau[1] - tau[0]
    work = simpson(power_drive[:k + 1] + power_force[:k + 1], h)
    coarse = simpson(power_drive[:k + 1:2] + power_force[:k + 1:2], 2 * h)
    quad_error = abs(work - coarse)  # Simpson at h is far better than this difference
    change = energy[k] - energy[0]
    size = np.abs(power_drive).max() * period + np.abs(power_force).max() * period
    assert np.abs(power_force).max() * period > 1e-3 * abs(change)  # the force matters here
    assert abs(change - work) <= quad_error + 1e-8 * size, (change, work, quad_error, size)
    # Without the force the balance fails by far more than the tolerance.
    assert abs(change - simpson(power_drive[:k + 1], h)) > 10 * (quad_error + 1e-8 * size)


def test_documented_scene_is_eq12_of_its_si_values():
    """The groups of inputs/sweeps/vdw_attractive.nml are Eq. (12) of the SI values in its
    comments (vdw_adhesion = H/(9 pi gamma a0^2) = 4/3 there, vdw_range = a0/d)."""
    derived = tmafm.Model({"model": {"n_modes": 1, "contact_law": "dmt_vdw"}, "physical": _physical(),
                           "solver": {"method": "dopri5"}}).scene
    stored = tmafm.Model(str(SCENE_FILE)).scene
    for key, value in derived.items():
        if key == "delta_hat":
            continue
        assert stored[key] == pytest.approx(value, rel=1e-13, abs=1e-300), key
    assert derived["vdw_adhesion"] == pytest.approx(4 / 3, rel=1e-13)
    assert derived["vdw_range"] == pytest.approx(A0_SI / 10e-6, rel=1e-13)
    gamma = H / (12 * math.pi * A0_SI**2)
    assert derived["vdw_adhesion"] == pytest.approx(H / (9 * math.pi * gamma * A0_SI**2), rel=1e-13)


def _attractive(phase, min_gap):
    """The attractive branch: no contact (min V_T > 0) and a lag past 90 degrees."""
    return (min_gap > 0) & (phase < -90)


def test_two_branches_coexist_at_one_z():
    """At Z = 9.0e-4 d (inside the hysteresis window of docs/vdw.md) a start near a non-contact
    orbit (amplitude 8.9e-4 d, lag 116 degrees) settles on the attractive branch, and a start
    from rest (whose growing swing reaches the sample) on the repulsive one."""
    config = tmafm.Config(str(SCENE_FILE), scene={"delta_hat": 9.0e-4})
    model = tmafm.Model(config)
    p, omega, lag = model.tip[0], model.scene["omega"], math.radians(-116)
    states = np.array([[8.9e-4 * math.sin(lag) / p, 8.9e-4 * omega * math.cos(lag) / p], [0.0, 0.0]])
    obs = observe_states(config, states, max_periods=3000, observables=["lockin", "extrema"])
    assert not obs.failed.any()
    phase, gap, amp = obs.steady["phase"], obs.steady["min_gap"], obs.steady["amplitude"]
    assert (obs.period == 1).all(), obs.period
    assert _attractive(phase[0], gap[0]), (phase, gap)
    assert gap[1] < 0 and phase[1] > -90, (phase, gap)
    # Two distinct orbits: the repulsive one swings wider at the same Z.
    assert amp[1] > amp[0] + 1e-5


def test_approach_and_retract_jump_at_different_z():
    """Warm-started approach and retract on the documented scene: the approach leaves the
    attractive branch at a smaller Z than the retract returns to it."""
    base = tmafm.Config(str(SCENE_FILE))
    z = np.round(np.arange(1.01e-3, 8.55e-4, -1e-5), 12)
    ds = tmafm.approach(base, z, max_periods=3000, observables=["lockin", "extrema"], workers=1)
    branches = {}
    for direction in ("approach", "retract"):
        s = ds.sel(direction=direction).sortby("scene.delta_hat")
        attractive = _attractive(s.phase.values, s.min_gap.values)
        assert (s.steady.values == 1).all()
        # One switch along Z: attractive above it, repulsive below it.
        switches = np.flatnonzero(np.diff(attractive.astype(int)))
        assert len(switches) == 1 and attractive[-1] and not attractive[0], attractive
        branches[direction] = s["scene.delta_hat"].values[switches[0] + 1]
    # The attractive branch lasts to a lower Z on approach than it comes back on retract.
    assert branches["approach"] < branches["retract"] - 2.5e-5, branches


VDW_NEEDS = "must be > 0 with &model contact_law = 'dmt_vdw'"


@pytest.mark.parametrize("groups, key, reason", [
    ({"physical": _physical(hamaker=-1e-19)}, "&physical hamaker = -1e-19", "must be finite, >= 0"),
    ({"physical": _physical(intermolecular_distance=0.0)}, "&physical intermolecular_distance = 0",
     "must be finite, > 0"),
    ({"physical": _physical(hamaker=0.0)}, "&physical hamaker = 0", VDW_NEEDS),
    ({"scene": {"vdw_adhesion": 0.0}}, "&scene vdw_adhesion = 0", VDW_NEEDS),
    ({"scene": {"vdw_adhesion": -1.0}}, "&scene vdw_adhesion = -1", "must be finite, >= 0"),
    ({"scene": {"vdw_adhesion": 1.0, "vdw_range": 0.0}}, "&scene vdw_range = 0", "must be finite, > 0"),
])
def test_bad_vdw_inputs_give_one_line_errors_naming_the_key(groups, key, reason):
    groups = {"model": {"contact_law": "dmt_vdw", "n_modes": 1}} | groups
    groups["solver"] = {"method": "dopri5", "tau_end": 0.1} | groups.get("solver", {})
    with pytest.raises(tmafm.InputError) as info:
        tmafm.run(groups)
    message = str(info.value)
    assert key in message and reason in message and "\n" not in message, message


def test_hertz_and_dmt_ignore_the_vdw_keys():
    """The vdW groups change nothing under the other laws (the paper's scenes keep their bits)."""
    for law in ("hertz", "dmt"):
        runs = [tmafm.run({"model": {"n_modes": 2, "contact_law": law}, "scene": scene,
                           "solver": {"method": "dopri5", "tau_end": 5.0}})
                for scene in ({}, {"vdw_adhesion": 2.0, "vdw_range": 1e-3})]
        assert np.array_equal(runs[0].vt, runs[1].vt) and np.array_equal(runs[0].a, runs[1].a)


def _attractive_state(model, amplitude=8.9e-4, lag_deg=-116.0):
    """A state near the attractive orbit of the documented scene at Z ~ 9e-4 d."""
    p, omega, lag = model.tip[0], model.scene["omega"], math.radians(lag_deg)
    return [amplitude * math.sin(lag) / p, amplitude * omega * math.cos(lag) / p]


def test_every_method_but_the_exact_flight_integrates_the_attraction():
    """A contact-free stretch of the documented scene, where the attraction bends every swing:
    rk4_paper and rk4_event converge to dop853's answer at fourth order in dtau, dopri5 within
    its tolerance; and the attraction changes the answer by far more than these errors."""
    config = tmafm.Config(str(SCENE_FILE), scene={"delta_hat": 9.5e-4})
    model = tmafm.Model(config)
    start = _attractive_state(model)
    common = dict(initial={"a0": [start[0]], "adot0": [start[1]]}, output={"sample_dtau": 0.25})

    def final(**solver):
        result = tmafm.run(config, solver={"tau_end": 12.0} | solver, **common)
        assert not np.any(result.vt <= 0)
        return np.concatenate([result.a[-1], result.adot[-1]])

    reference = final(method="dop853", rtol=1e-13, atol=1e-20)
    scale = np.max(np.abs(reference))
    for method in ("rk4_paper", "rk4_event"):
        coarse = np.max(np.abs(final(method=method, dtau=8e-3) - reference))
        fine = np.max(np.abs(final(method=method, dtau=4e-3) - reference))
        assert 10 < coarse / fine < 24, (method, coarse, fine)
    assert np.max(np.abs(final(method="dopri5", rtol=1e-10, atol=1e-18) - reference)) < 1e-7 * scale
    hertz = tmafm.Config(str(SCENE_FILE), model={"contact_law": "hertz"}, scene={"delta_hat": 9.5e-4})
    free = tmafm.run(hertz, solver={"method": "dop853", "rtol": 1e-13, "atol": 1e-20, "tau_end": 12.0},
                     **common)
    assert np.max(np.abs(np.concatenate([free.a[-1], free.adot[-1]]) - reference)) > 1e-4 * scale


def test_observed_energy_and_virial_carry_the_attraction():
    """On the attractive branch (no contact) the observed contact_normal_work, virial and
    dissipation of a steady period equal the closed-form force integrated here over the next
    period of a dense run from the orbit's final state, and the drive's work plus the
    attraction's balances the dissipation."""
    # The orbit at the reference run's tolerance: an orbit of the file's rtol 1e-8 differs from
    # the rtol 1e-12 dynamics by ~1e-8 of its size, which moved the virial by 4e-6 of itself.
    config = tmafm.Config(str(SCENE_FILE), scene={"delta_hat": 9.0e-4}, solver={"rtol": 1e-12, "atol": 1e-20})
    model = tmafm.Model(config)
    sc = model.scene
    kappa5, _ = model.kappas
    obs = observe_states(config, np.array([_attractive_state(model)]), max_periods=3000,
                         steady_tol=1e-9)
    assert obs.period[0] == 1 and obs.steady["contact_time"][0] == 0
    final = obs.orbit[0, -1]
    period = 2 * math.pi / sc["omega"]
    tau0 = obs.periods[0] * period
    n = 8000
    result = tmafm.run(config, initial={"a0": [final[0]], "adot0": [final[1]]},
                       solver={"method": "dop853", "rtol": 1e-12, "atol": 1e-20, "tau_end": period},
                       output={"sample_dtau": period / n})
    assert len(result.tau) == n + 1
    a, adot, vt = result.a[:, 0], result.adot[:, 0], result.vt
    # The run restarts the clock at 0; the drive phase at the orbit's end is 0 too (whole periods).
    left = tau0 % period
    assert min(left, period - left) < 1e-9 * tau0
    # theta = 0 and one mode: theta1 = pi/2 + atan(t), t = (d/L) s a (E7).
    t = model.slope[0] * a / sc["l_over_d"]
    sin1 = 1 / np.sqrt(1 + t**2)
    cos1 = -t / np.sqrt(1 + t**2)
    f = -sc["vdw_adhesion"] / (1 + vt * sin1 / sc["vdw_range"])**2
    p1, p2 = kappa5 * f * sin1, -kappa5 * f * cos1
    power = (sc["l_over_d"] * p1 * model.tip[0] * adot
             + p2 * (sc["g0_over_d"] * model.moment_shape[0] * adot + model.axial[0, 0] * a * adot))
    weights = np.full(n + 1, 2.0)
    weights[1:-1:2] = 4.0
    weights[0] = weights[-1] = 1.0
    weights *= period / n / 3
    normal_work = weights @ power
    virial = weights @ (kappa5 * f * (vt - sc["delta_hat"])) / period
    beam = sc["alpha3"] * (weights @ adot**2)
    assert obs.steady["virial"][0] == pytest.approx(virial, rel=1e-6, abs=0)
    assert obs.steady["dissipated_beam"][0] == pytest.approx(beam, rel=1e-6)
    # The attraction's work on the modes over the closed orbit: not zero (the base moves under
    # it), and the observer's equals the closed form's to a millionth of the power's swing.
    swing = weights @ np.abs(power)
    assert abs(obs.steady["contact_normal_work"][0] - normal_work) < 1e-6 * swing
    assert abs(normal_work) > 1e-3 * swing
    # Steady: the modal energy returns, so drive + attraction = dissipation.
    assert obs.steady["drive_work"][0] + obs.steady["contact_normal_work"][0] == pytest.approx(
        obs.steady["dissipated_energy"][0], rel=1e-6)
    assert abs(virial) > 1e-3 * abs(kappa5 * sc["vdw_adhesion"] * sc["delta_hat"])


def test_docs_quote_the_study_json():
    """docs/vdw.md's numbers are those of studies/results/vdw_attractive.json (written by
    studies/vdw_attractive.py, the command the page gives)."""
    import json
    repo = Path(__file__).resolve().parents[1]
    data = json.loads((repo / "studies" / "results" / "vdw_attractive.json").read_text())
    text = (repo / "docs" / "vdw.md").read_text()

    def num(x, digits):
        return f"{x:.{digits}f}".replace("-", "\u2212")

    curves = data["n1_rtol1e-8"]
    app, ret = curves["approach"], curves["retract"]
    assert f"A0 = {num(data['free_amplitude_nm'], 2)} nm" in text
    assert f"free phase {num(data['free_phase_deg'], 2)}°" in text
    lo, hi = sorted(app["jump_between_nm"])
    assert f"| jump between | Z = {num(hi, 1)} and {num(lo, 1)} nm |" in text
    lo2, hi2 = sorted(ret["jump_between_nm"])
    assert f"| Z = {num(lo2, 1)} and {num(hi2, 1)} nm |" in text
    assert lo < lo2  # the approach jumps lower
    for key in ("n2_rtol1e-8", "n1_rtol1e-10"):
        for direction in ("approach", "retract"):
            assert sorted(data[key][direction]["jump_between_nm"]) == sorted(curves[direction]["jump_between_nm"])

    def at(curve, z):
        k = curve["z_nm"].index(z)
        return curve["amplitude_nm"][k], curve["phase_deg"][k], curve["min_gap_nm"][k]

    a, p, g = at(app, 9.0)
    assert f"A = {num(a, 2)} nm, φ = {num(p, 1)}°, min gap +{num(g, 3)} nm" in text
    a, p, g = at(ret, 9.0)
    assert f"A = {num(a, 2)} nm, φ = {num(p, 1)}°, min gap {num(g, 3)} nm" in text
    a_hi, p_hi, _ = at(app, hi)
    a_lo, p_lo, _ = at(app, lo)
    assert f"({num(a_hi, 2)} → {num(a_lo, 2)} nm) and the phase jumps from {num(p_hi, 1)}° to " \
           f"{num(p_lo, 1)}°" in text
    a_lo, p_lo, _ = at(ret, lo2)
    a_hi, p_hi, _ = at(ret, hi2)
    assert f"({num(a_lo, 2)} → {num(a_hi, 2)} nm) and the phase from {num(p_lo, 1)}° to {num(p_hi, 1)}°" in text
    a, p, _ = at(app, 11.0)
    assert f"({num(p, 1)}° at 11 nm" in text
    for curve in (app, ret):
        for branch, virial in zip(curve["branch"], curve["virial"]):
            assert branch in ("attractive", "repulsive")
            assert (virial > 0) == (branch == "attractive"), (branch, virial)
    v_app, v_ret = (c["virial"][c["z_nm"].index(9.0)] for c in (app, ret))
    assert v_app > 0 > v_ret
    assert f"+{v_app:.2e} against \u2212{-v_ret:.2e}" in text

"""The viscoelastic sample: a standard linear solid under the Hertz law (docs/model.md §14).

Oracles, each computed here and independent of the code under test:
- the limits T -> infinity and T -> 0 are the elastic laws at the instantaneous modulus (the
  scene itself) and at the relaxed one (beta r^(-2/3), alpha6 r^(-1/3): Eq. 12 at E*_inf);
- between taps the surface recovers as w exp(-r s/T), computed here from the exit's w and the
  flight's length, against the dashpot integrated numerically through the flight;
- over a steady period the drive's work equals the dissipations (the energy balance);
- switched off, the runs are today's, bit for bit, and the resolved text is today's.
"""

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import tmafm

REPO = Path(__file__).resolve().parent.parent
SCENE = "fig2_n4"
TIGHT = {"method": "flight_exact", "rtol": 1e-10, "atol": 1e-14}
RATIO = 0.4
TAU_END = 12.0


def _run(scene=None, solver=None, **extra):
    solver = {**TIGHT, "tau_end": TAU_END, **(solver or {})}
    return tmafm.run(SCENE, scene=scene or {}, solver=solver, output={"sample_dtau": 0.005}, **extra)


def _difference(run, reference):
    """max |V_T - V_T(reference)| over the run, relative to the reference's range of V_T."""
    return np.max(np.abs(run.vt - reference.vt)) / np.ptp(reference.vt)


def _relaxed_scene(ratio):
    """The elastic scene at the relaxed modulus E*_inf = ratio E*_0 (Eq. 12): beta ~ E*^(-2/3);
    the friction term kappa6 A (-V_T cos theta1) ~ alpha6 beta^(-1/2) is kept, so alpha6 ~ E*^(-1/3)."""
    scene = tmafm.Config(SCENE).scene
    return {"beta": scene["beta"] * ratio ** (-2.0 / 3), "alpha6": scene["alpha6"] * ratio ** (-1.0 / 3)}


@pytest.fixture(scope="module")
def elastic():
    """The scene's elastic run at TIGHT, and the same at 100 x the tolerances: their difference
    is the method's error on this run, the scale of the limit tests."""
    tight = _run()
    loose = _run(solver={"rtol": 1e-8, "atol": 1e-12})
    return tight, _difference(loose, tight)


def test_switched_off_is_todays_run_bit_for_bit():
    for method in ("rk4_paper", "dopri5", "flight_exact"):
        solver = {"method": method, "tau_end": 6.0}
        today = tmafm.run(SCENE, solver=solver)
        off = tmafm.run(SCENE, solver=solver, scene={"sls_relaxation_time": 0.0, "sls_modulus_ratio": 0.3})
        for name in ("tau", "vt", "vtdot", "a", "adot", "contact"):
            assert np.array_equal(getattr(today, name), getattr(off, name)), (method, name)
    # The resolved text of a scene without the sample is today's: the switches are left out.
    text = tmafm.Config(SCENE).text
    assert "sls_" not in text and "relax" not in text
    assert "sls_relaxation_time = 2.5E-001" in tmafm.Config(SCENE, scene={"sls_relaxation_time": 0.25}).text


def test_long_relaxation_time_is_the_instantaneous_elastic_law(elastic):
    reference, method_error = elastic
    frozen = _run(scene={"sls_relaxation_time": 1e9, "sls_modulus_ratio": RATIO})
    # w ~ X t_c/T: the law departs from the elastic one by ~1e-9 of the force.
    assert _difference(frozen, reference) <= 10 * method_error + 1e-8
    # The relaxed law is far from it: the comparison can tell the two moduli apart.
    relaxed = _run(scene=_relaxed_scene(RATIO))
    assert _difference(relaxed, reference) > 1e3 * (10 * method_error + 1e-8)


def test_short_relaxation_time_is_the_relaxed_elastic_law(elastic):
    _, method_error = elastic
    relaxed = _run(scene=_relaxed_scene(RATIO))
    gaps = [_difference(_run(scene={"sls_relaxation_time": t, "sls_modulus_ratio": RATIO}), relaxed)
            for t in (1e-3, 1e-4)]
    # First order in T (the dashpot lags X by ~T dX/dtau): ten times shorter, ten times closer.
    assert gaps[1] <= gaps[0] / 5
    assert gaps[1] <= 1e-2 + 10 * method_error
    instantaneous = _run()
    assert _difference(instantaneous, relaxed) > 20 * gaps[1]


def test_the_surface_recovers_in_closed_form_between_taps(tmp_path):
    from testcore import core
    relaxation, ratio = 1.0, 0.5
    path = tmp_path / "sls.nml"
    path.write_text(f"&model n_modes = 2, convention = 'consistent' /\n"
                    f"&scene sls_relaxation_time = {relaxation}, sls_modulus_ratio = {ratio} /\n"
                    f"&solver method = 'dopri5', rtol = 1e-11, atol = 1e-15, tau_end = 25 /\n")
    tau, w, entering, count, ierr, msg = core.sls_switches(str(path), 2, 1, 40)
    assert ierr == 0, msg
    assert count >= 10
    tau, w, entering = tau[:count], w[:count], entering[:count]
    assert entering[0] == 1 and w[0] == 0           # the sample is at rest before the first tap
    checked = 0
    for k in range(1, count - 1):
        if entering[k] == 0 and entering[k + 1] == 1:
            flight = tau[k + 1] - tau[k]
            closed = w[k] * math.exp(-ratio * flight / relaxation)
            # The pair holds w to rtol x max(|w|, 1) a step; a flight is a few hundred steps.
            assert abs(w[k + 1] - closed) <= 1e-8 * max(w[k], 1.0), (k, w[k + 1], closed)
            # The surface has not come back: the recovery is partial, the test has teeth.
            assert 0.05 * w[k] < w[k + 1] < 0.95 * w[k]
            checked += 1
    assert checked >= 4


def test_flight_exact_and_the_pairs_agree_with_the_sample():
    scene = {"sls_relaxation_time": 1.0, "sls_modulus_ratio": 0.5}
    runs = {m: _run(scene=scene, solver={"method": m, "rtol": 1e-11, "atol": 1e-15})
            for m in ("flight_exact", "dopri5", "dop853")}
    base = runs["flight_exact"]
    for method in ("dopri5", "dop853"):
        assert _difference(runs[method], base) <= 1e-6, method
    # The sample changes the run (else the agreement would say nothing).
    assert _difference(_run(), base) > 1e-3


@pytest.mark.parametrize("base, extra", [
    (SCENE, {}),
    ("fig7_dmt", {"model": {"convention": "consistent"}}),     # DMT: a period-2 orbit
])
def test_energy_balance_closes_with_the_viscoelastic_dissipation(base, extra):
    obs = tmafm.observe(base, scene={"sls_relaxation_time": 0.5, "sls_modulus_ratio": 0.3},
                        solver={"method": "flight_exact", "rtol": 1e-11, "atol": 1e-15},
                        max_periods=120, **extra)
    assert obs.period >= 1
    p = obs.per_period
    orbit = slice(len(p["drive_work"]) - obs.period, None)     # the steady orbit's periods

    def total(name):
        return float(np.sum(p[name][orbit]))

    drive = total("drive_work")
    balance = drive + total("contact_normal_work") - total("dissipated_energy")
    assert abs(balance) <= 1e-6 * drive
    parts = sum(total(name) for name in ("dissipated_beam", "dissipated_contact_damping",
                                         "dissipated_friction", "dissipated_viscoelastic"))
    assert parts == pytest.approx(total("dissipated_energy"), rel=1e-12)
    # The sample takes a real share of the drive's work, and takes it (never gives it).
    assert np.all(p["dissipated_viscoelastic"][orbit] > 1e-3 * drive / obs.period)
    # Without the viscoelastic part the balance would not close.
    assert abs(balance + total("dissipated_viscoelastic")) > 100 * abs(balance)
    # An elastic sample dissipates nothing viscoelastically.
    elastic = tmafm.observe(base, solver={"method": "flight_exact"}, max_periods=3, stop_at_steady=False,
                            **extra)
    assert np.all(elastic.per_period["dissipated_viscoelastic"] == 0)


@pytest.mark.parametrize("overrides, words", [
    ({"scene": {"sls_relaxation_time": -1.0}}, "&scene sls_relaxation_time = -1"),
    ({"scene": {"sls_relaxation_time": 1e-20}}, "&scene sls_relaxation_time = 1e-20"),
    ({"scene": {"sls_modulus_ratio": 0.0}}, "&scene sls_modulus_ratio = 0"),
    ({"scene": {"sls_modulus_ratio": 1.5}}, "&scene sls_modulus_ratio = 1.5"),
    ({"scene": {"sls_relaxation_time": 1.0}, "solver": {"method": "rk4_paper"}}, "rk4_paper"),
    ({"scene": {"sls_relaxation_time": 1.0}, "solver": {"method": "rk4_event"}}, "rk4_event"),
])
def test_bad_scene_inputs_give_one_line_errors_naming_key_and_value(overrides, words):
    with pytest.raises(tmafm.InputError) as err:
        tmafm.run(SCENE, **{**overrides, "solver": {"tau_end": 0.5, **overrides.get("solver", {})}})
    message = str(err.value)
    assert "\n" not in message and words.lower() in message.lower(), message


def test_bad_physical_inputs_give_one_line_errors(tmp_path):
    with pytest.raises(tmafm.InputError, match=r"&physical sample_modulus_relaxed = 2000000000\.0: "
                       r"must be 0 or <= youngs_modulus_sample") as err:
        tmafm.Config("physical_polystyrene", physical={"sample_modulus_relaxed": 2e9})
    assert "\n" not in str(err.value)
    with pytest.raises(tmafm.InputError, match=r"&physical sample_relaxation_time = -1"):
        tmafm.Config("physical_polystyrene", physical={"sample_relaxation_time": -1.0})
    # The executable: exit code, one line on stderr, no output file.
    path = tmp_path / "bad.nml"
    path.write_text("&scene sls_modulus_ratio = 2 /\n&solver tau_end = 1 /\n&output file = 'x.dat' /\n")
    done = subprocess.run([str(tmafm.executable()), "-q", str(path)], cwd=tmp_path, capture_output=True,
                          text=True)
    assert done.returncode != 0
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "sls_modulus_ratio = 2" in lines[0], done.stderr
    assert not (tmp_path / "x.dat").exists()


def test_physical_inputs_give_the_contact_sls_of_eq12():
    """The &physical conversion against the series compliance computed here: the tip's spring
    in series with the sample's SLS is an SLS with the sample's retardation time T2 E2/E2_inf."""
    phys = tmafm.Config("physical_polystyrene").to_dict()["physical"]
    e_relaxed, t2 = 0.4e9, 2e-6
    config = tmafm.Config("physical_polystyrene",
                          physical={"sample_modulus_relaxed": e_relaxed, "sample_relaxation_time": t2})
    tip = (1 - phys["poisson_ratio_tip"] ** 2) / phys["youngs_modulus_tip"]
    sample = 1 - phys["poisson_ratio_sample"] ** 2
    e0 = 1 / (tip + sample / phys["youngs_modulus_sample"])
    e_inf = 1 / (tip + sample / e_relaxed)
    ratio = e_inf / e0
    ei = phys["youngs_modulus_tip"] * phys["width"] * phys["thickness"] ** 3 / 12
    mass = phys["density"] * phys["width"] * phys["thickness"]
    time_unit = math.sqrt(mass * phys["length"] ** 4 / ei)
    retardation = t2 * phys["youngs_modulus_sample"] / e_relaxed
    assert config.scene["sls_modulus_ratio"] == pytest.approx(ratio, rel=1e-14)
    assert config.scene["sls_relaxation_time"] == pytest.approx(retardation * ratio / time_unit, rel=1e-14)
    # The contact's creep compliance J*(t) = 1/E*_0 + (1/E*_inf - 1/E*_0)(1 - exp(-t/T_eps)),
    # relaxing at T = T_eps E*_inf/E*_0: check the SLS identity psi(t) J(t) integrated = t, at
    # the relaxation function's own time (Laplace: psi_hat(s) J_hat(s) = 1/s^2).
    s = 1 / retardation
    relax = retardation * ratio
    psi_hat = e_inf / s + (e0 - e_inf) / (s + 1 / relax)
    j_hat = 1 / (e0 * s) + (1 / e_inf - 1 / e0) * (1 / s - 1 / (s + 1 / retardation))
    assert psi_hat * j_hat == pytest.approx(1 / s ** 2, rel=1e-12)


def test_docs_example_numbers_are_computed_by_the_study():
    done = subprocess.run([sys.executable, str(REPO / "studies" / "sls_example.py"), "--check"],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr


def test_the_viscoelastic_dissipation_is_the_loop_of_the_sample_force():
    """dissipated_viscoelastic against the loop of F over the normal indentation computed here:
    the dashpot w integrated along a finely sampled run of the same steady orbit (its ODE solved
    exactly over each sample interval, X_s held at the interval's mean), the force
    kappa5 max(X - (1 - r) w, 0) and delta_n = -V_T sin(theta1) from the model's contact state."""
    relaxation, ratio, periods = 0.5, 0.3, 24
    scene = {"sls_relaxation_time": relaxation, "sls_modulus_ratio": ratio}
    solver = {"method": "flight_exact", "rtol": 1e-11, "atol": 1e-15}
    period = 2 * math.pi / tmafm.Config(SCENE).scene["omega"]
    obs = tmafm.observe(SCENE, scene=scene, solver=solver, max_periods=periods, stop_at_steady=False)
    h = period / 4000
    config = tmafm.Config(SCENE, scene=scene, solver={**solver, "tau_end": periods * period},
                          output={"sample_dtau": h})
    run = config.run()
    model = config.model()
    _, _, state = model.trajectory_energy_flow(run.tau, run.a, run.adot, run.contact)
    hertz = state[:, 1] ** 3                                  # X = A^3 (zero out of contact)
    depth = np.maximum(-run.vt, 0.0) * np.sin(state[:, 0])     # delta_n
    w = np.zeros_like(hertz)
    for i in range(len(w) - 1):
        x = 0.5 * (hertz[i] + hertz[i + 1])
        guess = w[i]
        for _ in range(2):                                      # X_s = max(X, (1 - r) w) at the midpoint
            target = max(x, (1 - ratio) * 0.5 * (w[i] + guess))
            guess = target + (w[i] - target) * math.exp(-h / relaxation)
        w[i + 1] = guess
    delayed = np.maximum(hertz - (1 - ratio) * w, 0.0) - hertz   # f - X
    kappa5 = model.kappas[0]
    l_over_d = model.scene["l_over_d"]
    for k in (periods - 2, periods - 1):
        rows = slice(int(round(k * period / h)), int(round((k + 1) * period / h)) + 1)
        mid = 0.5 * (delayed[rows][1:] + delayed[rows][:-1])
        loop = l_over_d * kappa5 * np.sum(mid * np.diff(depth[rows]))
        got = obs.per_period["dissipated_viscoelastic"][k]
        assert loop > 0
        # Midpoint sums with 4000 samples a period, the kinks at the switches inside them:
        # measured 8.4e-6 of the loop at this h.
        assert got == pytest.approx(loop, rel=1e-4), (k, got, loop)


def test_the_si_normal_force_holds_the_samples_delayed_part():
    """Result.physical's normal_force_N of a viscoelastic sample is its force at the state
    (a, a', w): here the dashpot w is integrated again in numpy (Heun) from the run's own Hertz
    variable X = A^3 at the samples, dw/dtau = (max(X, (1 - r) w) - w)/T, and the force
    kappa5 (max(X - (1 - r) w, 0) - 4/3) (DMT) agrees within 10x the integration's own error
    (from the same at twice the step), far below the delayed part itself."""
    config = tmafm.Config("tapping_polystyrene",
                          physical={"sample_relaxation_time": 2e-7, "sample_modulus_relaxed": 0.4e9,
                                    "quality_factor": 10.0, "tip_sample_distance": 8e-9},
                          solver={"method": "flight_exact", "rtol": 1e-10, "atol": 1e-14, "tau_end": 40.0},
                          output={"sample_dtau": 5e-4})
    run = tmafm.run(config)
    model = tmafm.Model(config)
    s, kappa5, scale = model.scene, model.kappas[0], config.derived["force_scale"]
    period, ratio = s["sls_relaxation_time"], s["sls_modulus_ratio"]
    hertz = np.array([model.contact(t, a).radius ** 3 if c else 0.0
                      for t, a, c in zip(run.tau, run.a, run.contact)])

    def dashpot(x, dt):
        w = np.zeros_like(x)
        for k in range(x.size - 1):
            k1 = (max(x[k], (1 - ratio) * w[k]) - w[k]) / period
            guess = w[k] + dt * k1
            k2 = (max(x[k + 1], (1 - ratio) * guess) - guess) / period
            w[k + 1] = w[k] + dt * (k1 + k2) / 2
        return w

    def force(x, w):
        return np.where(x > 0, kappa5 * (np.maximum(x - (1 - ratio) * w, 0) - 4 / 3), 0.0) * scale

    fine = force(hertz, dashpot(hertz, 5e-4))
    coarse = force(hertz[::2], dashpot(hertz[::2], 1e-3))
    error = np.max(np.abs(fine[::2] - coarse))
    touching = run.contact == 1
    assert touching.sum() > 1000
    core = run.physical["normal_force_N"]
    assert np.max(np.abs(core - fine)[touching]) <= 10 * error
    elastic = force(hertz, np.zeros_like(hertz))
    assert np.max(np.abs(core - elastic)[touching]) > 1e3 * error

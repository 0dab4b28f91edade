"""Thermal noise (docs/model.md section 21): the Langevin force of &solver thermal_noise = 1.

Each statistical check compares an estimate with an independent closed form, within four of
its standard errors (estimated from the samples themselves: batch means or the spread over
bins), plus the zero-order hold's own deviation where it matters; the closed forms are
computed here with scipy from the model's M, C and K (tmafm.Model.matrices), not from the
package.
"""

from pathlib import Path

import f90nml
import numpy as np
import pytest
import scipy.linalg as sl

import tmafm
from tmafm import analysis

K_B = 1.380649e-23

#: A free cantilever in model units: no drive, the tip one gap above the sample.
FREE = {"scene": {"alpha2": 0.0, "delta_hat": 1.0, "thermal_energy": 1e-8},
        "solver": {"method": "dop853", "thermal_noise": 1, "noise_seed": 1}}

INPUTS = Path(__file__).resolve().parent.parent / "inputs"


def _input(name):
    """The groups of inputs/<name>.nml as a dict (the tests override their length)."""
    groups = {k: dict(v) for k, v in f90nml.read(str(INPUTS / f"{name}.nml")).items()}
    del groups["output"]
    return groups


#: A soft cantilever in air by its calibration (k = 2 N/m, f0 = 70 kHz, Q = 20), one mode,
#: 100 nm above the sample, undriven, at 298.15 K; and in water (f0 = 20 kHz, Q = 3).
AIR = _input("thermal_air")
WATER = _input("thermal_water")


def _merge(base, **groups):
    out = {k: dict(v) for k, v in base.items()}
    for group, keys in groups.items():
        out.setdefault(group, {}).update(keys)
    return out


def _free_matrices(config):
    """M, C, K of the free flight (dimensionless) and the tip vector p."""
    model = tmafm.Model(config)
    n = model.n_modes
    mass, damping, stiffness, _ = model.matrices(0.0, np.zeros(n), False)
    return mass, damping, stiffness, model.tip


def _batch_error(x, blocks=40):
    """The standard error of mean(x) by batch means over `blocks` consecutive blocks."""
    means = np.array([b.mean() for b in np.array_split(x, blocks)])
    return means.std(ddof=1) / np.sqrt(blocks)


def _system(mass, damping, stiffness):
    """y' = F y + G xi for y = (a, a')."""
    n = mass.shape[0]
    minv = np.linalg.inv(mass)
    f = np.block([[np.zeros((n, n)), np.eye(n)], [-minv @ stiffness, -minv @ damping]])
    g = np.vstack([np.zeros((n, n)), minv])
    return f, g


def _zoh_step(f, g, step):
    """(A, B) of one interval of a zero-order hold: y_{k+1} = A y_k + B xi_k."""
    m = f.shape[0]
    aug = np.zeros((m + g.shape[1], m + g.shape[1]))
    aug[:m, :m] = f * step
    aug[:m, m:] = g * step
    e = sl.expm(aug)
    return e[:m, :m], e[:m, m:]


def _zoh_covariance(f, g, damping, theta, step, intervals):
    """The covariance after `intervals` held intervals from a fixed state (the process the
    methods integrate): sum_j A^j B (2 theta C/step) B^T A^jT."""
    a, b = _zoh_step(f, g, step)
    q = b @ (2 * theta * damping / step) @ b.T
    sigma = np.zeros_like(a)
    for _ in range(intervals):
        sigma = a @ sigma @ a.T + q
    return sigma


def _ou_covariance(f, mass, stiffness, theta, s):
    """The white-noise (Ornstein-Uhlenbeck) transition covariance in closed form,
    Sigma_inf - Phi Sigma_inf Phi^T, Sigma_inf = blockdiag(theta K^-1, theta M^-1)."""
    inf = sl.block_diag(theta * np.linalg.inv(stiffness), theta * np.linalg.inv(mass))
    phi = sl.expm(f * s)
    return inf - phi @ inf @ phi.T


# --- equipartition -----------------------------------------------------------------------------

def test_each_mode_mean_square_deflection_is_kT_over_its_stiffness():
    """Two coupled Galerkin modes (alpha1 > 0): in the normal modes of (K, M) each mode's
    mean-square tip deflection is theta/k_n, k_n = v_n.K v_n/(p.v_n)^2, and the modal
    covariance is theta K^-1."""
    theta = 1e-8
    config = tmafm.Config(_merge(FREE, model={"n_modes": 2}, scene={"alpha3": 2.0},
                                 solver={"tau_end": 4000.0}, output={"sample_dtau": 0.5}))
    mass, damping, stiffness, tip = _free_matrices(config)
    assert np.count_nonzero(mass - np.diag(np.diag(mass))) > 0, "the modes should be mass-coupled"
    run = config.run()
    keep = run.tau >= 20.0
    a = run.a[keep]
    lam, vec = sl.eigh(stiffness, mass)          # vec^T M vec = I
    eta = a @ mass @ vec                         # normal coordinates
    for n in range(2):
        tip_part = (tip @ vec[:, n]) * eta[:, n]
        k_n = lam[n] / (tip @ vec[:, n]) ** 2
        ms = np.mean(tip_part ** 2)
        error = _batch_error(tip_part ** 2)
        assert abs(ms - theta / k_n) < 4 * error + 0.01 * theta / k_n, (n, ms * k_n / theta, error * k_n / theta)
    cov = a.T @ a / a.shape[0]
    expected = theta * np.linalg.inv(stiffness)
    for i in range(2):
        error = _batch_error(a[:, i] ** 2)
        assert abs(cov[i, i] - expected[i, i]) < 4 * error + 0.01 * expected[i, i]
    # The velocities: theta M^-1 (equipartition of the kinetic energy).
    adot = run.adot[keep]
    vexp = theta * np.linalg.inv(mass)
    for i in range(2):
        error = _batch_error(adot[:, i] ** 2)
        assert abs(np.mean(adot[:, i] ** 2) - vexp[i, i]) < 4 * error + 0.01 * vexp[i, i]


# --- the spectrum --------------------------------------------------------------------------------

def _lorentzian(f, k, f0, q, temperature):
    return 2 * K_B * temperature / (np.pi * k * q * f0) / ((1 - f**2 / f0**2) ** 2 + f**2 / (f0**2 * q**2))


def _oscillator(config):
    """(k at the tip in N/m, f0 in Hz, Q) of a one-mode model, from its M, C, K and SI scales."""
    mass, damping, stiffness, tip = _free_matrices(config)
    d = config.derived
    omega = np.sqrt(stiffness[0, 0] / mass[0, 0])
    f0 = omega / (2 * np.pi * d["time_scale"])
    q = np.sqrt(stiffness[0, 0] * mass[0, 0]) / damping[0, 0]
    k = d["energy_scale"] / d["length_scale"] ** 2 * stiffness[0, 0] / tip[0] ** 2
    return k, f0, q, omega


@pytest.mark.parametrize("base, periods, band", [(AIR, 2600, 3.0), (WATER, 1200, None)], ids=["air", "water"])
def test_the_deflection_spectrum_is_the_damped_oscillators_lorentzian(base, periods, band):
    """The Welch PSD of the tip deflection (m^2/Hz against Hz) over the resonance, divided by
    the Lorentzian of the model's own k, f0 and Q, averages to 1 within four standard errors,
    in the lower and the upper half of the band apart (a shifted f0 or a wrong Q tilts them),
    and the deflection's variance is k_B T/k."""
    config = tmafm.Config(base)
    k, f0, q, omega = _oscillator(config)
    if base is AIR:
        # The calibration is the one-mode model's own oscillator.
        assert k == pytest.approx(2.0, rel=1e-9, abs=0) and f0 == pytest.approx(70e3, rel=1e-9, abs=0)
        assert q == pytest.approx(20.0, rel=1e-9, abs=0)
    period = 2 * np.pi / omega
    run = tmafm.run(base, solver={"tau_end": periods * period}, output={"sample_dtau": period / 16})
    f, s, dof = analysis.deflection_psd(run, segments=24)
    assert f[1] < f0 / (8 * q), "the resolution must be well inside the resonance"
    width = band if band is not None else 0.7 * q
    lorentz = _lorentzian(f, k, f0, q, 298.15)
    for low, high in ((1 - width / q, 1.0), (1.0, 1 + width / q)):
        sel = (f > f0 * low) & (f < f0 * high)
        ratio = s[sel] / lorentz[sel]
        # Neighbouring bins of Hann segments are correlated: count half of them.
        error = ratio.std(ddof=1) / np.sqrt(sel.sum() / 2)
        assert abs(ratio.mean() - 1) < 4 * error + 0.01, (low, high, ratio.mean(), error)
        assert ratio.std(ddof=1) == pytest.approx(np.sqrt(2 / dof), rel=0.5, abs=0)
    # The deflection's variance against equipartition: about periods/(Q/pi) correlation times.
    variance = np.var(run.physical["deflection_m"])
    error = np.sqrt(2 * q / (np.pi * periods))
    assert abs(variance / (K_B * 298.15 / k) - 1) < 4 * error + 0.01


# --- the flight step in distribution ----------------------------------------------------------

@pytest.mark.parametrize("method", ["dop853", "flight_exact"])
def test_the_flight_transition_has_the_closed_form_mean_and_covariance(method):
    """Over s = 16 noise intervals the state's transition y(t) -> y(t + s) is Gaussian with mean
    Phi(s) y(t) and the zero-order hold's covariance (a sum over its intervals), which is the
    Ornstein-Uhlenbeck closed form Sigma_inf - Phi Sigma_inf Phi^T to O(Delta^2).  Residuals of
    disjoint windows of one run are independent: their mean is 0 and their covariance that."""
    theta, step, windows = 1e-8, 0.0625, 3000
    s = 16 * step
    config = tmafm.Config(_merge(FREE, model={"n_modes": 1},
                                 solver={"tau_end": windows * s, "noise_step": step, "rtol": 1e-10,
                                         "atol": 1e-16, "method": method},
                                 output={"sample_dtau": s}, initial={"a0": [1e-4]}))
    mass, damping, stiffness, _ = _free_matrices(config)
    f, g = _system(mass, damping, stiffness)
    phi = sl.expm(f * s)
    zoh = _zoh_covariance(f, g, damping, theta, step, 16)
    ou = _ou_covariance(f, mass, stiffness, theta, s)
    # The closed form is the Lyapunov integral int_0^s e^{Fu} G (2 theta C) G^T e^{F^T u} du.
    n = f.shape[0]
    van_loan = np.block([[-f, g @ (2 * theta * damping) @ g.T], [np.zeros((n, n)), f.T]]) * s
    e = sl.expm(van_loan)
    integral = e[n:, n:].T @ e[:n, n:]
    np.testing.assert_allclose(ou, integral, rtol=1e-9, atol=1e-9 * np.abs(ou).max())
    # The hold's deviation from white noise: O((omega Delta)^2), here below 0.5 %.
    assert np.abs(zoh - ou).max() < 5e-3 * np.abs(ou).max()
    run = config.run()
    y = np.column_stack([run.a, run.adot])
    residual = y[1:] - y[:-1] @ phi.T
    m = residual.shape[0]
    scale = np.sqrt(np.diag(zoh))
    assert np.all(np.abs(residual.mean(axis=0)) < 4 * scale / np.sqrt(m))
    cov = residual.T @ residual / m
    for i in range(2):
        assert abs(cov[i, i] / zoh[i, i] - 1) < 4 * np.sqrt(2 / m)
    corr, corr_expected = cov[0, 1] / np.sqrt(cov[0, 0] * cov[1, 1]), zoh[0, 1] / np.sqrt(zoh[0, 0] * zoh[1, 1])
    assert abs(corr - corr_expected) < 4 * (1 - corr_expected**2) / np.sqrt(m)


def test_flight_exact_steps_the_held_process_exactly():
    """flight_exact's flight is the closed form under each interval's held force, so between two
    grid points the state moves by the hold's exact transition, y_{k+1} = A y_k + B xi_k
    (A = e^{F Delta}, B = int_0^Delta e^{Fu} du G, from scipy): with two modes the 2N = 4
    components of y_{k+1} - A y_k are fixed by the N = 2 forces xi_k, and what is left off the
    range of B is round-off.  dop853 leaves its truncation error there.  The forces xi_k so
    recovered are independent N(0, 2 theta C/Delta), the fluctuation-dissipation amplitude."""
    theta, step, intervals = 1e-8, 0.125, 4000
    config = tmafm.Config(_merge(FREE, model={"n_modes": 2}, scene={"alpha3": 0.5},
                                 solver={"method": "flight_exact", "tau_end": intervals * step,
                                         "noise_step": step, "rtol": 1e-6, "atol": 1e-12},
                                 output={"sample_dtau": step}, initial={"a0": [1e-4, 0.0]}))
    mass, damping, stiffness, _ = _free_matrices(config)
    f, g = _system(mass, damping, stiffness)
    a, b = _zoh_step(f, g, step)
    exact = config.run()
    loose = tmafm.run(config, solver={"method": "dop853"})

    def split(run):
        y = np.column_stack([run.a, run.adot])
        jump = y[1:] - y[:-1] @ a.T
        xi, *_ = np.linalg.lstsq(b, jump.T, rcond=None)
        off = jump - (b @ xi).T
        return xi.T, np.abs(off).max() / np.abs(jump).max()

    xi, off = split(exact)
    _, off_loose = split(loose)
    # Round-off of a flight (a few ulps of the state, and of expm in A, B) against the pair's
    # truncation error at rtol 1e-6.
    assert off < 1e-11 and off_loose > 1e3 * off, (off, off_loose)
    variance = 2 * theta * np.diag(damping) / step
    m = xi.shape[0]
    for j in range(2):
        assert abs(np.mean(xi[:, j] ** 2) / variance[j] - 1) < 4 * np.sqrt(2 / m)
        lag = np.mean(xi[1:, j] * xi[:-1, j]) / variance[j]
        assert abs(lag) < 4 / np.sqrt(m)
    assert abs(np.mean(xi[:, 0] * xi[:, 1]) / np.sqrt(variance.prod())) < 4 / np.sqrt(m)


@pytest.mark.parametrize("scene", ["free", "tapping", "vdw"])
def test_flight_exact_integrates_the_same_noise_as_dop853(scene):
    """One seed, one realisation: flight_exact (exact flights, the contacts by its dop853 pair;
    with vdW the Lawson flight) and dop853 differ by their tolerances alone, here rtol 1e-11."""
    groups = {
        "free": _merge(FREE, model={"n_modes": 2}, solver={"tau_end": 40.0}),
        "tapping": {"model": {"n_modes": 2, "contact_law": "dmt", "convention": "consistent"},
                    "scene": {"delta_hat": 5e-4, "thermal_energy": 1e-11},
                    "solver": {"tau_end": 30.0, "thermal_noise": 1, "noise_seed": 5}},
        "vdw": _merge(AIR, model={"contact_law": "dmt_vdw"},
                      physical={"hamaker": 1e-19, "intermolecular_distance": 0.165e-9,
                                "tip_sample_distance": 2e-9, "drive_amplitude": 0.3e-9,
                                "youngs_modulus_sample": 1.2e9, "poisson_ratio_sample": 0.3},
                      solver={"tau_end": 60.0}),
    }[scene]
    tight = {"rtol": 1e-11, "atol": 1e-16}
    base = _merge(groups, solver=tight, output={"sample_dtau": 0.05})
    ref = tmafm.run(base, solver={"method": "dop853"})
    exact = tmafm.run(base, solver={"method": "flight_exact"})
    if scene != "free":
        assert ref.contact.any() and np.array_equal(ref.contact, exact.contact)
    size = np.abs(ref.a).max(axis=0)
    assert np.all(np.abs(exact.a - ref.a).max(axis=0) < 1e-7 * size)
    assert np.abs(exact.vt - ref.vt).max() < 1e-7 * np.abs(ref.vt).max()


#: The physics a study combines with noise: (input, overrides); Q lowered where the ring-up
#: would outlast the run.
COMPOSED = {
    "jkr": ("tapping_polystyrene", {"model": {"contact_law": "jkr"},
                                    "physical": {"tip_sample_distance": 12e-9, "quality_factor": 30.0}}),
    "meniscus": ("humid_air", {"physical": {"tip_sample_distance": 12e-9, "quality_factor": 30.0}}),
    "viscoelastic": ("sls_polystyrene", {}),
    "two_tones": ("bimodal/tapping", {"scene": {"thermal_energy": 1e-9}}),
    "water": ("thermal_water", {"physical": {"drive_amplitude": 2e-9, "tip_sample_distance": 8e-9}}),
    "double_layer": ("dlvo_water", {}),
}


@pytest.mark.parametrize("case", sorted(COMPOSED))
def test_flight_exact_with_noise_composes_with_the_physics(case):
    """JKR's neck, a meniscus, a viscoelastic sample, two tones, a liquid, a double layer: with
    noise, flight_exact (its flights cut on the grid, the switches above the surface by its pair)
    and dop853 integrate one realisation, to their tolerances, over 60 drive periods."""
    name, overrides = COMPOSED[case]
    config = tmafm.Config(name, **_merge(overrides, solver={"thermal_noise": 1, "noise_seed": 4,
                                                             "rtol": 1e-11, "atol": 1e-16}))
    period = 2 * np.pi / config.scene["omega"]
    runs = {m: tmafm.run(config, solver={"method": m, "tau_end": 60 * period}, output={"sample_dtau": period / 50})
            for m in ("dop853", "flight_exact")}
    ref, got = runs["dop853"], runs["flight_exact"]
    assert ref.contact.sum() > 60 and np.array_equal(ref.contact, got.contact)
    assert np.abs(got.a - ref.a).max() < 1e-7 * np.abs(ref.a).max()


def test_noisy_observables_are_the_same_on_flight_exact_and_dop853():
    """tmafm.observe with noise: flight_exact's closed-form lock-in, energies and located extrema
    under the held forces equal dop853's dense-output ones, period by period, in a tapping run
    (three modes, the DMT law with the paper's contact damping)."""
    base = {"model": {"n_modes": 3, "contact_law": "dmt", "convention": "consistent"},
            "scene": {"delta_hat": 5e-4, "thermal_energy": 1e-11, "alpha4": 1e-3},
            "solver": {"thermal_noise": 1, "noise_seed": 7, "rtol": 1e-11, "atol": 1e-16}}
    obs = {m: tmafm.observe(base, solver={"method": m}, max_periods=12, stop_at_steady=False)
           for m in ("dop853", "flight_exact")}
    quiet = tmafm.observe({"model": base["model"], "scene": {"delta_hat": 5e-4, "alpha4": 1e-3},
                           "solver": {"rtol": 1e-11, "atol": 1e-16}}, max_periods=12, stop_at_steady=False)
    assert obs["dop853"].per_period["peak_force"].min() > 0
    # The noise moves each column by far more than the tolerance below (1e-3 of its scale and up).
    for key in ("amplitude", "min_gap", "modal_max_free"):
        ref = obs["dop853"].per_period[key]
        assert np.abs(quiet.per_period[key] - ref).max() > 1e-4 * np.abs(ref).max()
    for key in ("amplitude", "phase", "mean_deflection", "min_gap", "max_gap", "peak_force",
                "dissipated_energy", "dissipated_contact_damping", "drive_work", "contact_time",
                "harmonic_amplitude", "modal_min_free", "modal_max_free"):
        ref = np.asarray(obs["dop853"].per_period[key], dtype=float)
        got = np.asarray(obs["flight_exact"].per_period[key], dtype=float)
        # rtol 1e-11 over 12 periods: a global error well below 1e-8 of the scale.
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-8 * np.abs(ref).max(), err_msg=key)


def test_the_period_stepper_steps_the_noise_of_flight_exact():
    """A Z schedule with noise: each period its own seed, the same realisation on flight_exact and
    dop853 (equal to tolerance), and not the noiseless schedule."""
    base = _merge(_input("tapping_polystyrene"), solver={"thermal_noise": 1, "noise_seed": 11,
                                                         "rtol": 1e-11, "atol": 1e-16})
    z = np.linspace(22e-9, 14e-9, 30)
    runs = {m: tmafm.instrument.z_schedule(base, z, solver={"method": m}) for m in ("dop853", "flight_exact")}
    quiet = tmafm.instrument.z_schedule(_merge(_input("tapping_polystyrene"),
                                               solver={"rtol": 1e-11, "atol": 1e-16}), z)
    ref, got = runs["dop853"].values["amplitude"], runs["flight_exact"].values["amplitude"]
    np.testing.assert_allclose(got, ref, rtol=1e-6, atol=0)
    assert np.abs(got - quiet.values["amplitude"]).max() > 1e-4


# --- the realisation ------------------------------------------------------------------------------

def test_a_seed_gives_the_same_force_on_every_method_and_run():
    base = _merge(FREE, model={"n_modes": 2}, solver={"tau_end": 40.0, "rtol": 1e-10, "atol": 1e-15},
                  output={"sample_dtau": 0.25})
    runs = {m: tmafm.run(base, solver={"method": m}) for m in ("dop853", "dopri5")}
    again = tmafm.run(base, solver={"method": "dop853"})
    np.testing.assert_array_equal(again.a, runs["dop853"].a)        # bit-identical
    np.testing.assert_array_equal(again.adot, runs["dop853"].adot)
    size = np.abs(runs["dop853"].a).max(axis=0)
    # The two pairs integrate one force: they differ by their errors (rtol 1e-10) alone.
    assert np.all(np.abs(runs["dopri5"].a - runs["dop853"].a).max(axis=0) < 1e-5 * size)
    other = tmafm.run(base, solver={"method": "dop853", "noise_seed": 2})
    assert np.all(np.abs(other.a - runs["dop853"].a).max(axis=0) > 0.1 * size)
    # A finer noise grid is another realisation (the grid is part of it), of the same size.
    finer = tmafm.run(base, solver={"method": "dop853", "noise_step": 0.004})
    assert np.all(np.abs(finer.a - runs["dop853"].a).max(axis=0) > 0.1 * size)


def test_noise_composes_with_contact_and_the_drive():
    """A tapping run with the noise on: contacts happen, the run is reproducible, and it
    differs from the run without noise by about the thermal amplitude."""
    base = {"model": {"n_modes": 2, "contact_law": "dmt", "convention": "consistent"},
            "scene": {"delta_hat": 5e-4},
            "solver": {"method": "dop853", "tau_end": 30.0}, "output": {"sample_dtau": 0.05}}
    quiet = tmafm.run(base)
    noise = {"scene": {"thermal_energy": 1e-11}, "solver": {"thermal_noise": 1, "noise_seed": 5}}
    noisy = tmafm.run(_merge(base, **noise))
    again = tmafm.run(_merge(base, **noise))
    np.testing.assert_array_equal(noisy.vt, again.vt)
    assert quiet.contact.any() and noisy.contact.any()
    thermal = np.sqrt(1e-11 * np.sum(tmafm.Model(tmafm.Config(base)).tip ** 2
                                     / tmafm.Model(tmafm.Config(base)).eigen))
    gap = np.abs(noisy.vt - quiet.vt).max()
    assert 0.1 * thermal < gap < 100 * thermal


# --- amplitude and phase at the drive; ensembles ------------------------------------------------

def test_amplitude_and_phase_noise_at_the_drive():
    """Driven at f0 to 1 nm, the per-period lock-in amplitude and phase (tmafm.observe) scatter
    by sqrt(k_B T/k) and sqrt(k_B T/k)/A: the thermal motion is narrow-band (Q = 20) and one
    period's lock-in passes it (its window |sinc|^2 is within 1 % of 1 over the resonance)."""
    drive = _merge(AIR, physical={"free_amplitude": 1e-9})
    del drive["physical"]["drive_amplitude"]
    obs = tmafm.observe(drive, max_periods=600, stop_at_steady=False)
    amplitude = obs.physical["amplitude"][60:]          # nm, after the transient (3 Q periods)
    phase = np.radians(obs.physical["phase"][60:])
    sigma = np.sqrt(K_B * 298.15 / 2.0) * 1e9
    # About (periods/(Q/pi)) independent values: the error of a standard deviation.
    error = np.sqrt(1 / (2 * amplitude.size / (20 / np.pi)))
    assert abs(amplitude.std() / sigma - 1) < 4 * error + 0.02
    assert abs(phase.std() * amplitude.mean() / sigma - 1) < 4 * error + 0.02


def test_an_ensemble_over_seeds_is_the_same_on_the_batch_and_on_dask():
    """A sweep over &solver noise_seed: the same numbers from the OpenMP batch (threads) and
    from Dask (the realisation depends on the seed only), different numbers per seed."""
    pytest.importorskip("xarray")
    distributed = pytest.importorskip("dask.distributed")
    drive = _merge(AIR, physical={"free_amplitude": 1e-9})
    del drive["physical"]["drive_amplitude"]
    seeds = [1, 2, 3, 4]
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")          # unsteady points (noise) warn once
        batch = tmafm.sweep(drive, {"solver.noise_seed": seeds}, max_periods=40, workers=2)
        with distributed.Client(processes=False, n_workers=1, threads_per_worker=2,
                                dashboard_address=None) as client:
            dask = tmafm.sweep(drive, {"solver.noise_seed": seeds}, max_periods=40, client=client, chunk=2)
    values = batch["amplitude"].values
    np.testing.assert_array_equal(values, dask["amplitude"].values)
    assert len(set(values.tolist())) == len(seeds)


# --- refusals ------------------------------------------------------------------------------------

@pytest.mark.parametrize("groups, words", [
    ({"solver": {"thermal_noise": 1, "method": "rk4_paper"}, "scene": {"thermal_energy": 1e-8}},
     "thermal_noise = 1: needs method 'dop853', 'dopri5' or 'flight_exact'"),
    ({"solver": {"thermal_noise": 1, "method": "rk4_event"}, "scene": {"thermal_energy": 1e-8}},
     "method = 'rk4_event'"),
    ({"solver": {"thermal_noise": 1, "method": "dop853"}}, "needs &scene thermal_energy > 0"),
    ({"scene": {"thermal_energy": 1e-8}}, "thermal_energy = 1.0E-008: acts only with &solver thermal_noise = 1"),
    ({"solver": {"noise_seed": 3}}, "noise_seed = 3: needs &solver thermal_noise = 1"),
    ({"solver": {"noise_step": 0.1}}, "noise_step = 1.0E-001: needs &solver thermal_noise = 1"),
    ({"solver": {"thermal_noise": 2}}, "thermal_noise = 2"),
    ({"solver": {"thermal_noise": 1, "method": "dop853", "noise_seed": -1}, "scene": {"thermal_energy": 1e-8}},
     "noise_seed = -1"),
    ({"solver": {"thermal_noise": 1, "method": "dop853", "noise_step": -0.1}, "scene": {"thermal_energy": 1e-8}},
     "noise_step = -0.1"),
    ({"solver": {"thermal_noise": 1, "method": "dop853", "noise_step": 1e-9, "max_steps": 1000},
      "scene": {"thermal_energy": 1e-8}}, "grid intervals, more than &solver max_steps = 1000"),
])
def test_bad_noise_input_is_refused_in_one_line(groups, words):
    with pytest.raises(tmafm.InputError) as info:
        tmafm.Config(groups)
    message = str(info.value)
    assert words in message and "\n" not in message, message


def test_a_negative_temperature_is_refused():
    with pytest.raises(tmafm.InputError, match="temperature = -1"):
        tmafm.Config(_merge(AIR, physical={"temperature": -1.0}))


def test_the_executable_refuses_noise_with_a_method_it_cannot_do(run_exe, tmp_path):
    (tmp_path / "in.nml").write_text("&scene thermal_energy = 1e-8 /\n&solver thermal_noise = 1 /\n")
    done = run_exe("in.nml")
    assert done.returncode != 0
    assert "thermal_noise = 1: needs method 'dop853', 'dopri5' or 'flight_exact'" in done.stderr


def test_the_holds_variance_deficit_is_the_one_the_docs_quote():
    """docs/model.md section 21: a held force on a grid of Delta = T/32 leaves a mode of
    Q >> 1 a variance low by (pi f Delta)^2/3 = 0.32 %, against the closed form of the hold."""
    mass, damping, stiffness = np.eye(1), np.array([[1e-3]]), np.eye(1)    # omega = 1, Q = 1000
    f, g = _system(mass, damping, stiffness)
    step = 2 * np.pi / 32
    a, b = _zoh_step(f, g, step)
    held = sl.solve_discrete_lyapunov(a, b @ (2 * damping / step) @ b.T)
    deficit = 1 - held[0, 0] / 1.0                   # theta K^-1 = 1
    assert deficit == pytest.approx((np.pi / 32) ** 2 / 3, rel=0.02, abs=0)
    text = (INPUTS.parent / "docs" / "model.md").read_text()
    assert f"{100 * (np.pi / 32) ** 2 / 3:.2f} % for the fastest mode" in text


def test_continuation_refuses_a_noisy_input():
    """Periodic orbits are the noiseless model's: a noisy base is refused, not run without it."""
    pytest.importorskip("xarray")
    with pytest.raises(tmafm.InputError, match="thermal_noise = 1: periodic orbits are the noiseless"):
        tmafm.continuation(FREE, "scene.delta_hat", 1.0, 0.9)

"""FM-AFM (fortran/src/instrument/tmafm_fm.f90, docs/instrument.md "FM-AFM"): the PLL and the
amplitude controller on the period stepper, checked against independent computations: the
force gradient in closed form, the Giessibl/Sader-Jarvis integral of the force law by
quadrature, and the energies of the observers."""

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import quad

import tmafm
from tmafm.instrument import fm_approach

pytest.importorskip("xarray")

#: The vdW scene: tapping_polystyrene's cantilever (k = 40 N/m, f0 = 300 kHz, Q = 400) untilted
#: (the tip moves along the sample's normal, so the force law is F(s) along the motion), with
#: the sphere-plane van der Waals attraction F = -H R/(6 s^2) out of contact (docs/model.md §6a);
#: s = a0 + Z + the tip's deflection.
VDW = {"model": {"n_modes": 1, "contact_law": "dmt_vdw"}, "physical": {"tilt": 0.0}}
HAMAKER, RADIUS, A0 = 3.592254119747249e-20, 10e-9, 0.165e-9
#: Fast loops (f0/30): the loop settles in ~100 periods; 150 settle them to the integrator's
#: accuracy (the trace's last periods agree to 1e-9 Hz, below).
LOOP = {"pll_bandwidth": 10e3, "amplitude_bandwidth": 10e3, "settle_periods": 150, "average_periods": 10}


def vdw_force(s):
    return -HAMAKER * RADIUS / (6 * s ** 2)


def sader_jarvis(config, center, amplitude):
    """Giessibl's Δf = -(f0/(pi k A)) ∫_{-1}^{1} F(z + A(1 + u)) u/sqrt(1 - u^2) du, z the closest
    approach (here z + A = center), with u = cos(theta); k and f0 the model's own (derived)."""
    derived = config.derived
    k, f0 = derived["spring_constant"], derived["resonance_frequency"]
    integral = quad(lambda th: vdw_force(center + amplitude * np.cos(th)) * np.cos(th), 0, np.pi,
                    epsabs=0, epsrel=1e-12)[0]
    return -f0 / (np.pi * k * amplitude) * integral


def center_of(data, i):
    """The tip's mean separation s (m): a0 + Z + its mean deflection (the loop's own)."""
    return A0 + float(data.z[i]) * 1e-9 + float(data.mean_deflection[i]) * 1e-9


@pytest.fixture(scope="module")
def vdw_config():
    return tmafm.Config("tapping_polystyrene", **VDW)


def test_far_from_the_sample_the_loop_rests_on_the_free_resonance(vdw_config):
    # The phase setpoint is the closed-form free response's phase at f0 (free_response); a run
    # started from that free steady state must keep it: Δf = 0, the free drive, A held.
    # With three modes and a base drive the setpoint is near, not at, -90 deg.
    data = fm_approach(vdw_config, z=[1e-6], amplitude=5e-9, **LOOP)
    assert abs(float(data.df[0])) <= 1e-4            # Hz, of f0 = 300 kHz
    assert float(data.drive_ratio[0]) == pytest.approx(1, rel=1e-6, abs=0)
    assert float(data.amplitude[0]) == pytest.approx(5, rel=1e-6, abs=0)
    assert abs(data.attrs["phase_setpoint_deg"] + 90) < 0.1
    three = fm_approach(tmafm.Config("tapping_polystyrene"), z=[1e-6], amplitude=5e-9,
                        **{**LOOP, "settle_periods": 5, "average_periods": 5})
    assert abs(float(three.df[0])) <= 1e-3
    assert three.attrs["phase_setpoint_deg"] != data.attrs["phase_setpoint_deg"]


def test_small_amplitude_gives_the_force_gradient(vdw_config):
    # Δf = -f0/(2k) dF/ds, dF/ds = H R/(3 s^3), for A << s.  The next term of the expansion
    # is (A^2/8) F''' = 1.5 (A/s)^2 of the first (F' ~ s^-3): the tolerance is twice it, plus
    # the loop's 2e-4 (the large-amplitude test's).
    amplitude = 0.1e-9
    data = fm_approach(vdw_config, z=[5e-9, 3e-9], amplitude=amplitude, **LOOP)
    derived = vdw_config.derived
    for i in range(2):
        s = center_of(data, i)
        expected = -derived["resonance_frequency"] / (2 * derived["spring_constant"]) \
            * HAMAKER * RADIUS / (3 * s ** 3)
        tolerance = 2 * 1.5 * (amplitude / s) ** 2 + 2e-4
        assert float(data.df[i]) == pytest.approx(expected, rel=tolerance, abs=0)
        assert float(data.min_gap[i]) > 0                      # never touches


def test_large_amplitude_gives_the_sader_jarvis_integral(vdw_config):
    # A = 5 nm down to 1 nm above the sample: far from the small-amplitude limit (there Δf is
    # 1.9 Hz, here 9.6 Hz); the integral holds for one mode to the harmonic approximation
    # (the motion's higher harmonics, 1e-4 here: measured 1e-4 at Z = 6 nm).
    data = fm_approach(vdw_config, z=[10e-9, 6e-9], amplitude=5e-9, **LOOP)
    for i in range(2):
        expected = sader_jarvis(vdw_config, center_of(data, i), 5e-9)
        assert float(data.df[i]) == pytest.approx(expected, rel=2e-4, abs=0)
        assert float(data.min_gap[i]) > 0
        assert float(data.df_spread[i]) < 1e-6 * abs(expected)   # settled
    # Three modes: the static k of the 3-mode model (with the higher modes' compliance) is
    # below mode 1's dynamic stiffness, so |Δf| is 2.6% below the integral with the static k.
    three = tmafm.Config("tapping_polystyrene", model={"n_modes": 3, "contact_law": "dmt_vdw"},
                         physical={"tilt": 0.0})
    data = fm_approach(three, z=[6e-9], amplitude=5e-9, **LOOP)
    ratio = float(data.df[0]) / sader_jarvis(three, center_of(data, 0), 5e-9)
    assert 0.97 < ratio < 0.98


@pytest.mark.parametrize("sample", ["contact_damping", "sls"])
def test_the_drive_rises_by_the_tip_sample_dissipation(sample):
    # Intermittent contact (A = 5 nm, Z = 4.5 nm: 0.5 nm into the sample) on a dissipative
    # sample.  Steady, the energy balances (drive work + the force's work on the modes =
    # dissipated energy); the drive's rise E_free (drive/drive_free - 1) is the tip-sample
    # dissipation (dissipated - the beam's) up to the terms it leaves out: the drive's work
    # scales as f^2, the beam's as f (first order in Δf/f0), and the force's work on the modes.
    physical = {"tilt": 0.0}
    if sample == "sls":
        physical.update(contact_damping=0.0, sample_relaxation_time=1e-6, sample_modulus_relaxed=0.3e9)
    config = tmafm.Config("tapping_polystyrene", model={"n_modes": 1, "contact_law": "dmt_vdw"},
                          physical=physical)
    data = fm_approach(config, z=[4.5e-9], amplitude=5e-9, **{**LOOP, "settle_periods": 300})
    free_work = data.attrs["free_drive_work_aJ"]
    assert float(data.min_gap[0]) < 0                            # it taps
    balance = data.drive_work + data.contact_normal_work - data.dissipated
    assert abs(float(balance[0])) <= 1e-6 * free_work
    tip_sample = float(data.dissipated_tip_sample[0])
    assert tip_sample > 0.005
    shift = abs(float(data.df[0])) / data.attrs["f0_Hz"]
    ratio = float(data.drive_ratio[0])
    tolerance = free_work * shift * (2 * ratio + 1) + abs(float(data.contact_normal_work[0]))
    assert abs(float(data.dissipation[0]) - tip_sample) <= tolerance
    assert float(data.amplitude[0]) == pytest.approx(5, rel=1e-6, abs=0)
    assert abs(float(data.phase_error[0])) < 1e-5


def test_the_loop_settles_at_its_bandwidth(vdw_config):
    # A step of Z from the free distance to 6 nm: the PLL's closed loop has both poles at
    # -2 pi B (the resonator's own pole tau_r = 2Q/omega0 = 0.42 ms is slow beside it), so Δf
    # is within 1% of its final value after 6/(2 pi B) (0.1 ms: 29 periods) and within 1e-6
    # after 150 periods.
    data = fm_approach(vdw_config, z=[6e-9], amplitude=5e-9, **LOOP)
    trace = data.trace_df[0].values
    final = float(data.df[0])
    periods = int(np.ceil(6 / (2 * np.pi * 10e3) * 300e3))
    assert abs(trace[periods] - final) < 0.01 * abs(final)
    assert abs(trace[-1] - final) < 1e-6 * abs(final)
    assert data.attrs["response_time_s"] == pytest.approx(2 * 400 / (2 * np.pi * 300e3), rel=1e-6, abs=0)


def test_a_liquid_low_q_composes():
    # In water (Q ~ 5: the resonator is faster than the loop, whose PI integrates only) the
    # loop holds A and the phase, far away at Δf = 0 and near the sample below 0.
    config = tmafm.Config("tapping_polystyrene", model={"n_modes": 1, "contact_law": "dmt_vdw"},
                          physical={"tilt": 0.0, "medium_density": 1000.0, "medium_viscosity": 1e-3,
                                    "quality_factor": 5.0, "resonance_frequency": 100e3,
                                    "drive_frequency": 100e3})
    data = fm_approach(config, z=[1e-6, 3e-9], amplitude=1e-9,
                       **{**LOOP, "pll_bandwidth": 2e3, "amplitude_bandwidth": 2e3, "settle_periods": 100})
    assert abs(float(data.df[0])) < 1e-3
    assert float(data.df[1]) < -1
    for i in range(2):
        assert float(data.amplitude[i]) == pytest.approx(1, rel=1e-5, abs=0)
        assert abs(float(data.phase_error[i])) < 1e-3
    expected = sader_jarvis(config, center_of(data, 1), 1e-9)
    assert float(data.df[1]) == pytest.approx(expected, rel=0.05, abs=0)


@pytest.mark.parametrize("keywords, message", [
    ({"amplitude": 0.0}, "amplitude = 0.0"),
    ({"amplitude": 2e-6}, "fm amplitude = 2.0E-006: must be > 0 and <= 1e-6"),
    ({"pll_bandwidth": 40e3}, "fm pll_bandwidth = 4.0E+004: must be > 0 and <= f0/10"),
    ({"amplitude_bandwidth": -1.0}, "fm amplitude_bandwidth = -1.0"),
    ({"settle_periods": -1}, "fm settle_periods = -1"),
    ({"average_periods": 0}, "fm average_periods = 0"),
    ({"free_distance": float("nan")}, "fm free_distance = nan"),
    ({"z": [float("inf")]}, "z[0] = inf"),
])
def test_bad_inputs_are_refused_in_one_line(vdw_config, keywords, message):
    arguments = {"z": [5e-9], "amplitude": 1e-9, **keywords}
    with pytest.raises(tmafm.InputError) as caught:
        fm_approach(vdw_config, **arguments)
    text = str(caught.value)
    assert message in text and "\n" not in text


def test_a_second_tone_and_a_dimensionless_scene_are_refused():
    with pytest.raises(tmafm.InputError, match="drive_amplitude_2 = .*one tone"):
        fm_approach(tmafm.Config("tapping_polystyrene", physical={"drive_amplitude_2": 1e-11,
                                                                  "drive_frequency_2": 1.8e6}),
                    z=[5e-9], amplitude=1e-9)
    with pytest.raises(tmafm.InputError, match="&physical"):
        fm_approach(tmafm.Config("fig3"), z=[5e-9], amplitude=1e-9)


def test_thermal_frequency_noise_of_the_pll():
    # Far from the sample, with thermal noise on (&solver thermal_noise = 1), the PLL's Δf
    # scatters by the thermal phase noise through the loop (docs/instrument.md, "With thermal
    # noise").  The phase relaxes with tau_r = 2Q/omega0 and its thermal drive has the
    # spectrum 2 sigma_phi^2 tau_r (sigma_phi = sqrt(k_B T/k)/A), the PLL's closed loop with both
    # poles at -2 pi B passes it to Δf with the noise bandwidth
    # B_n = ((2 tau w - 1)^2 + tau^2 w^2)/(8 tau^2 w), w = 2 pi B (5 pi B/4 for tau w >> 1):
    # Δf_rms^2 = k_B T f0 B_n/(pi k A^2 Q), the standard result (Albrecht et al. 1991) with
    # the loop's own noise bandwidth.  One mode, Q = 400, B = 1 kHz: 1.68 Hz at A = 5 nm.
    k_b, temperature, k, f0, q, amplitude, bandwidth = 1.380649e-23, 298.15, 40.0, 300e3, 400.0, 5e-9, 1e3
    config = tmafm.Config("tapping_polystyrene", model={"n_modes": 1},
                          solver={"thermal_noise": 1, "noise_seed": 1, "method": "dop853"})
    settle, average = 300, 10000
    data = fm_approach(config, z=[1e-6], amplitude=amplitude, pll_bandwidth=bandwidth,
                       amplitude_bandwidth=bandwidth, settle_periods=settle, average_periods=average)
    tau = data.attrs["response_time_s"]
    assert tau == pytest.approx(2 * q / (2 * np.pi * f0), rel=1e-6, abs=0)
    w = 2 * np.pi * bandwidth
    noise_bandwidth = ((2 * tau * w - 1) ** 2 + (tau * w) ** 2) / (8 * tau ** 2 * w)
    expected = np.sqrt(k_b * temperature * f0 * noise_bandwidth / (np.pi * k * amplitude ** 2 * q))
    df = data.trace_df.values[0, settle:]
    # The standard error of the standard deviation of a correlated series (Bartlett):
    # sqrt((1 + 2 sum rho_j^2)/(2 N)), rho the trace's autocorrelation (over 10/w's 480 periods).
    x = df - df.mean()
    rho = np.correlate(x, x, "full")[x.size - 1:x.size + 480] / (x @ x)
    error = np.sqrt((1 + 2 * np.sum(rho[1:] ** 2)) / (2 * x.size))
    # The per-period loop differs from the continuous one by its one-period delay, a phase lag
    # w T at the bandwidth (2%): twice it on top of four standard errors.
    assert df.std() == pytest.approx(expected, rel=4 * error + 2 * w / f0, abs=0)
    text = " ".join((Path(__file__).resolve().parent.parent / "docs" / "instrument.md").read_text().split())
    assert f"against the {expected:.2f} Hz of the formula" in text
    # The free reference (E_free, the dissipation channel's scale) is the noiseless one.
    quiet = fm_approach(tmafm.Config("tapping_polystyrene", model={"n_modes": 1}, solver={"method": "dop853"}),
                        z=[1e-6], amplitude=amplitude,
                        pll_bandwidth=bandwidth, amplitude_bandwidth=bandwidth, settle_periods=1, average_periods=1)
    assert data.attrs["free_drive_work_aJ"] == quiet.attrs["free_drive_work_aJ"]

"""AM imaging (fortran/src/instrument/tmafm_am_scan.f90, docs/instrument.md "AM imaging"): a scan
line with the Z feedback over a topography and two materials, checked against approach curves,
the topography given, and the designed closed-loop time constant."""

import math
from pathlib import Path
import warnings

import numpy as np
import pytest

import tmafm
from tmafm.instrument import scan_line, z_schedule

pytest.importorskip("xarray")

#: A fast scene: the standard tapping cantilever with Q = 50 (tau_c = 2Q/omega0 = 16 drive
#: periods), so that ring-up, approach and settling take hundreds of periods, not thousands.
FAST = {"quality_factor": 50.0}
#: A second material: a softer, more adhesive polymer than polystyrene.
SOFT = {"youngs_modulus_sample": 0.3e9, "adhesion_energy": 0.05}
PERIOD = 1 / 300e3
#: The common settings: lock-in 10 kHz, closed loop 1 kHz (tau_cl = 48 periods), setpoint 0.8.
LOOP = dict(setpoint_ratio=0.8, lockin_bandwidth=10e3, feedback_bandwidth=1e3)


def line_rate(pixels, periods_per_pixel, retrace):
    """The line rate that gives `periods_per_pixel` drive periods per pixel."""
    return 1 / (pixels * periods_per_pixel * PERIOD * (2 if retrace else 1))


def settled(ds, dwell_periods):
    """How far the worst transient a flat pixel sees has decayed: the loop is first order with
    tau_cl (designed), and the pixels compared start at least `dwell_periods` after a change."""
    return math.exp(-dwell_periods * PERIOD / ds.attrs["closed_loop_time_s"])


def crossing(base, physical, a_set, z_guess):
    """The Z (nm) where the approach curve of `base` + `physical` (warm-started from 25 nm down,
    as the engage approaches) has the steady amplitude a_set (nm): a cubic through the points
    of a 0.05 nm grid around the crossing, so its interpolation error is far below 1e-5 nm."""
    z = np.r_[np.linspace(25e-9, z_guess + 1e-9, 12), np.linspace(z_guess + 0.75e-9, z_guess - 0.75e-9, 31)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", tmafm.UnsteadyWarning)
        ds = tmafm.approach(tmafm.Config(base, physical=physical), z=z, retract=False, max_periods=3000,
                            steady_tol=1e-10, workers=1)
    a = ds["amplitude"].sel(direction="approach").values
    zz = ds["z"].values * 1e9
    near = np.argsort(np.abs(a - a_set))[:8]
    fit = np.polynomial.Polynomial.fit(a[near], zz[near], 3)
    return float(fit(a_set)), float(np.ptp(zz[near]))


def test_two_materials_height_step_is_the_approach_curves_difference():
    # Flat sample, polystyrene at x < 50 nm and a softer polymer from x = 50 nm: the apparent
    # height step is the difference of the Z where each material's approach curve meets A_set.
    # Tolerance: pixels 2 (polystyrene) and 7 (soft) lie >= 2.5 pixels = 12 tau_cl after any
    # change (the engage's last error, the boundary), so the loop's residual is
    # e^-12 of at most a few nm; the approach curves' steady amplitudes are exact to the solver
    # and steady_tol (1e-10 relative); the cubic's error is below 1e-5 nm; 1e-3 nm covers them.
    pixels, per_pixel = 8, 240
    ds = scan_line("tapping_polystyrene", physical=FAST, scan_length=100e-9, pixels=pixels,
                   line_rate=line_rate(pixels, per_pixel, False), retrace=False, material_b=SOFT,
                   material_boundary=50e-9, **LOOP)
    assert ds.attrs["periods_per_pixel"] == per_pixel
    height = ds["height"].sel(direction="trace").values
    assert np.ptp(height[1:4]) < 1e-3 and np.ptp(height[6:]) < 1e-3  # flat on each material
    a_set = ds.attrs["setpoint_nm"]
    z_a, _ = crossing("tapping_polystyrene", FAST, a_set, height[2] * 1e-9)
    z_b, _ = crossing("tapping_polystyrene", {**FAST, **SOFT}, a_set, height[7] * 1e-9)
    tol = 1e-3 + 5 * settled(ds, 2.5 * per_pixel)
    assert height[2] == pytest.approx(z_a, abs=tol)
    assert height[7] == pytest.approx(z_b, abs=tol)
    assert height[7] - height[2] == pytest.approx(z_b - z_a, abs=2 * tol)
    assert abs(z_b - z_a) > 0.1  # the materials do differ in apparent height
    # The material's column says where the tip was.
    np.testing.assert_array_equal(ds["material"].sel(direction="trace").values, [0, 0, 0, 0, 1, 1, 1, 1])


def test_a_step_of_known_height_is_recovered_on_trace_and_retrace():
    # A 2 nm step up at x = 50 nm on polystyrene: far from the edge (>= 2.5 pixels = 12 tau_cl
    # after it, on both passes) the profile is the topography plus the engaged distance, so the
    # step is H to the loop's residual (e^-12 of H) and the solver's tolerance (1e-3 nm).
    pixels, per_pixel, step = 8, 240, 2e-9
    ds = scan_line("tapping_polystyrene", physical=FAST, scan_length=100e-9, pixels=pixels,
                   line_rate=line_rate(pixels, per_pixel, True), topography="step", step_height=step,
                   step_position=50e-9, **LOOP)
    tol = 1e-3 + step * 1e9 * settled(ds, 2.5 * per_pixel)
    for direction in ("trace", "retrace"):
        height = ds["height"].sel(direction=direction).values
        low = height[1] if direction == "trace" else height[0]
        high = height[7] if direction == "trace" else height[6]
        assert high - low == pytest.approx(step * 1e9, abs=tol), direction
        # The distance Z - h is the same on both sides: the amplitude is held.
        distance = ds["distance"].sel(direction=direction).values
        assert abs(distance[7] - distance[0]) < tol
    np.testing.assert_allclose(ds["topography"].sel(direction="trace").values, [0] * 4 + [2.0] * 4)
    # Trace and retrace agree far from the edge.
    trace, retrace = (ds["height"].sel(direction=d).values for d in ("trace", "retrace"))
    assert abs(trace[1] - retrace[1]) < tol and abs(trace[6] - retrace[6]) < tol


def test_settling_follows_the_designed_closed_loop_time():
    # A slow loop (300 Hz: tau_cl = 0.53 ms = 159 periods) over a 0.2 nm step (the plant linear
    # over it): the height error Z - Z_final after the step decays as exp(-t/tau_cl).  The PI's
    # zero cancels the cantilever's lag tau_c; what is left of the plant's dynamics (the
    # lock-in's lag tau_f = 1/(2 pi B_lockin), the error of the lag model in contact, at most
    # tau_c itself, and the one-period delay) moves the slow pole by at most
    # omega_cl (tau_c + tau_f + T) relative, here 0.14; the fit over 0.5..3 tau_cl adds little.
    pixels, per_pixel, step = 4, 300, 0.2e-9
    b_fb, b_lockin = 300.0, 10e3
    ds = scan_line("tapping_polystyrene", physical=FAST, scan_length=40e-9, pixels=pixels,
                   line_rate=line_rate(pixels, per_pixel, False), retrace=False, setpoint_ratio=0.8,
                   lockin_bandwidth=b_lockin, feedback_bandwidth=b_fb, topography="step",
                   step_height=step, step_position=20e-9, record=True)
    tau_cl = ds.attrs["closed_loop_time_s"]
    assert tau_cl == pytest.approx(1 / (2 * math.pi * b_fb), rel=1e-12)
    t = ds["period_time"].values
    z = ds["period_height"].values
    x = ds["period_x"].values
    after = x >= 20.0
    t0 = t[after][0] - PERIOD  # the first period over the step ends at t0 + T
    # Z_final = Z before the step + H (the distance held: test_a_step_of_known_height_...).
    error = z[after] - (z[~after][-1] + step * 1e9)
    window = (t[after] - t0 > 0.5 * tau_cl) & (t[after] - t0 < 3 * tau_cl)
    slope, _ = np.polyfit(t[after][window] - t0, np.log(np.abs(error[window])), 1)
    tau_c = ds.attrs["cantilever_time_s"]
    tol = 2 * math.pi * b_fb * (tau_c + 1 / (2 * math.pi * b_lockin) + PERIOD)
    assert -1 / slope == pytest.approx(tau_cl, rel=tol)
    # tau_c, measured from the ring-up, is 2Q/omega0 (drive at resonance), to the period.
    assert tau_c == pytest.approx(2 * 50 / (2 * math.pi * 300e3), abs=PERIOD)
    # The error after the step never changes sign (a first-order loop does not overshoot).
    assert np.all(error[t[after] - t0 > 0.5 * tau_cl] < 0)


def test_the_lockin_filter_has_its_stated_bandwidth():
    # Over the step of a slow loop the first periods' filtered amplitude follows the raw one
    # through the filter: y_k = y_(k-1) + (1 - exp(-2 pi B T)) (x_k - y_(k-1)) (the filter's
    # step response 1 - exp(-2 pi B t)), recomputed here from the recorded raw amplitudes.
    # (A lock-in filters X and Y; the amplitude of the filtered pair equals the filtered
    # amplitude while the phase holds still, to the phase's change squared.)
    pixels, per_pixel, b_lockin = 2, 200, 5e3
    ds = scan_line("tapping_polystyrene", physical=FAST, scan_length=20e-9, pixels=pixels,
                   line_rate=line_rate(pixels, per_pixel, False), retrace=False, setpoint_ratio=0.8,
                   lockin_bandwidth=b_lockin, feedback_bandwidth=100.0, record=True)
    raw = ds["period_amplitude_raw"].values
    filtered = ds["period_amplitude"].values
    c = -math.expm1(-2 * math.pi * b_lockin * PERIOD)
    predicted = filtered[:-1] + c * (raw[1:] - filtered[:-1])
    np.testing.assert_allclose(filtered[1:], predicted, rtol=0, atol=1e-6)


@pytest.mark.parametrize("bad, message", [
    (dict(setpoint=15e-9), "give exactly one of them"),
    (dict(lockin_bandwidth=2e5), "scan: lockin_bandwidth = "),
    (dict(feedback_bandwidth=9e3), "scan: feedback_bandwidth = "),
    (dict(topography="cone"), "scan: topography = 'cone'"),
    (dict(topography="step", step_position=5e-9, step_height=-2e-6), "scan: step_height = "),
    (dict(pixels=0), "scan: pixels = 0"),
    (dict(line_rate=1e6), "less than one drive period per pixel"),
    (dict(material_b={"spring_constant": 2.0}, material_boundary=5e-9), "material_b: spring_constant = 2.0"),
    (dict(material_boundary=5e-9), "needs material_b"),
    (dict(setpoint_ratio=None, setpoint=25e-9), "must be below the free amplitude"),
    (dict(physical={**FAST, "tip_sample_distance": 15e-9}), "the tip touches the sample there"),
])
def test_bad_inputs_are_refused_in_one_line(bad, message):
    keywords = dict(scan_length=10e-9, pixels=2, line_rate=1e3, **LOOP)
    keywords.update(bad)
    if keywords.get("setpoint_ratio") is None:
        keywords.pop("setpoint_ratio")
    keywords.setdefault("physical", FAST)
    with pytest.raises(tmafm.InputError) as info:
        scan_line("tapping_polystyrene", **keywords)
    assert message in str(info.value)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("overrides", [
    {"model": {"contact_law": "dmt_vdw"}, "physical": FAST},
    {"physical": {**FAST, "sample_relaxation_time": 1e-6, "sample_modulus_relaxed": 0.2e9}},
    {"physical": {**FAST, "drive_frequency_2": 1.8e6, "free_amplitude_2": 0.5e-9}},
], ids=["dmt_vdw", "sls", "two_tones"])
def test_a_scan_composes_with_other_physics(overrides):
    # A sphere over two materials with another contact law, a viscoelastic sample or a second
    # drive tone (at 6 f0, so that a drive period holds whole periods of both): the scan runs,
    # and the height over the flat first material is the engaged one (it started there).
    ds = scan_line("tapping_polystyrene", scan_length=60e-9, pixels=3, line_rate=line_rate(3, 150, False),
                   retrace=False, topography="sphere", sphere_radius=5e-9, sphere_position=30e-9,
                   material_b=SOFT, material_boundary=40e-9, **LOOP, **overrides)
    height = ds["height"].sel(direction="trace").values
    assert np.all(np.isfinite(height))
    assert height[0] == pytest.approx(ds.attrs["engaged_height_nm"], abs=1e-2)
    # Pixel 1 (x = 20..40 nm) holds the sphere (x = 25..35 nm, 10 nm at its top): its mean
    # topography is between 0 and 10 nm, and so is its mean height above pixel 0's.
    topo = float(ds["topography"].values[0, 1])
    assert 3 < topo < 10
    assert 0.5 * topo < height[1] - height[0] < 10


# --- Thermal noise (&solver thermal_noise = 1, docs/model.md §21; docs/instrument.md "With thermal
# noise").  One mode: the noise grid of three modes is 17 times finer, and mode 1 carries the
# amplitude noise at the drive.
ONE_MODE = {"n_modes": 1}
K_B, TEMPERATURE, K, F0, Q = 1.380649e-23, 298.15, 40.0, 300e3, 50.0
#: The thermal rms of the tip deflection, sqrt(k_B T/k) (nm): 0.0101 nm.
SIGMA = math.sqrt(K_B * TEMPERATURE / K) * 1e9
#: The free amplitude's decay time 2Q/omega0, in drive periods (15.9).
TAU_C = 2 * Q / (2 * math.pi * F0) / PERIOD


def noisy(seed, method="dop853"):
    return {"thermal_noise": 1, "noise_seed": seed, "method": method}


def steady_amplitude(z, free_amplitude=20e-9):
    """The noiseless steady amplitude (nm) of the one-mode FAST cantilever at rest distance z (m)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", tmafm.UnsteadyWarning)
        run = tmafm.observe(tmafm.Config("tapping_polystyrene", model=ONE_MODE,
                                         physical={**FAST, "tip_sample_distance": z,
                                                   "free_amplitude": free_amplitude}),
                            max_periods=3000, steady_tol=1e-12)
    return float(run.physical["amplitude"][-1])


#: The noisy flat line: 64 pixels of 240 periods, a 2 kHz loop (tau_cl = 23.9 periods) behind a
#: 20 kHz lock-in (tau_li = 2.4 periods).
NOISY_LINE = dict(pixels=64, per_pixel=240, b_fb=2e3, b_li=20e3, seed=3)


@pytest.fixture(scope="module")
def noisy_line():
    p = NOISY_LINE
    return scan_line("tapping_polystyrene", physical=FAST, model=ONE_MODE, solver=noisy(p["seed"]),
                     scan_length=100e-9, pixels=p["pixels"], line_rate=line_rate(p["pixels"], p["per_pixel"], False),
                     retrace=False, setpoint_ratio=0.8, lockin_bandwidth=p["b_li"], feedback_bandwidth=p["b_fb"],
                     record=True)


def test_with_thermal_noise_the_height_is_the_amplitude_noise_through_the_loop(noisy_line):
    # Over a flat sample the loop holds the filtered amplitude at A_set: below its bandwidth the
    # height follows -n/s, n the thermal amplitude noise the cantilever has at fixed Z, s = dA/dZ.
    # n's spectrum at low frequency (two-sided) is 2 g^2 sigma^2 tau_c: the thermal force's slow
    # envelope in phase with the drive acts as a modulation of the drive, which moves the
    # amplitude by g = (f/A0) dA/df times as much as in free air (where the amplitude is the
    # Ornstein-Uhlenbeck process of variance sigma^2 and time tau_c: g = 1).  A pixel of D
    # periods (D >> tau_cl) then scatters by sigma_h = (g sigma/s) sqrt(2 tau_c/D)
    # (docs/instrument.md).  s and g are the noiseless steady amplitude's derivatives at the
    # line's mean height (tmafm.observe, central differences).
    ds = noisy_line
    p = NOISY_LINE
    height = ds["height"].sel(direction="trace").values
    z = float(height.mean()) * 1e-9
    dz, dr = 0.02e-9, 1e-3
    slope = (steady_amplitude(z + dz) - steady_amplitude(z - dz)) / (2 * dz * 1e9)
    gain = (steady_amplitude(z, 20e-9 * (1 + dr)) - steady_amplitude(z, 20e-9 * (1 - dr))) / (2 * dr * 20.0)
    assert 0.1 < gain < 0.5  # the contact holds the amplitude: far from free air's 1
    predicted = gain * SIGMA / slope * math.sqrt(2 * TAU_C / p["per_pixel"])
    measured = height.std(ddof=1)
    # The pixel's own averaging keeps what the loop, the lock-in and the amplitude's own lag
    # (tau_c bounds it) low-pass: for a positively correlated process of correlation times
    # summing to tau_sum, the variance of a D-mean is S(0)/D (1 - c), 0 <= c <= 2 tau_sum/D.
    # The standard error of a standard deviation of N independent pixels is 1/sqrt(2(N - 1)).
    tau_sum = F0 / (2 * math.pi * p["b_fb"]) + F0 / (2 * math.pi * p["b_li"]) + TAU_C
    low = math.sqrt(1 - 2 * tau_sum / p["per_pixel"])
    error = 4 / math.sqrt(2 * (p["pixels"] - 1))
    assert low * (1 - error) < measured / predicted < 1 + error
    # Free air's amplitude noise (g = 1) would be 2 to 10 times this: the contact matters.
    assert measured < 0.5 * SIGMA / slope * math.sqrt(2 * TAU_C / p["per_pixel"])
    # docs/instrument.md quotes this test's numbers.
    text = " ".join((Path(__file__).resolve().parent.parent / "docs" / "instrument.md").read_text().split())
    for quoted in (f"s = {slope:.3f}, g = {gain:.3f}", f"σ_h = {predicted:.5f} nm",
                   f"seed {p['seed']} measures {measured:.5f} nm", f"{SIGMA:.4f} nm for k = 40 N/m"):
        assert quoted in text, quoted


def test_with_thermal_noise_the_height_follows_the_open_loop_noise_pathwise(noisy_line):
    # The same realisation at fixed Z (each period k draws the seed of period k, whatever the
    # setting: docs/instrument.md), the loop open: z_schedule holds the line's mean height for
    # as many periods as the scan ran before its line, then for the line.  Pixel by pixel the
    # closed loop's height is -n/s of that open-loop amplitude noise; what differs is the part
    # the loop does not follow within a pixel, a variance fraction of about (tau_cl + tau_li)/D,
    # so the correlation is at least sqrt(1 - 2 (tau_cl + tau_li)/D) = 0.88.
    ds = noisy_line
    p = NOISY_LINE
    height = ds["height"].sel(direction="trace").values
    z = float(height.mean()) * 1e-9
    first = int(round(float(ds["period_time"].values[0]) / PERIOD)) - 1
    ring = int(ds.attrs["ringup_periods"])
    line = p["pixels"] * p["per_pixel"]
    schedule = np.r_[np.full(ring, 25e-9), np.linspace(25e-9, z, first - ring), np.full(line, z)]
    base = tmafm.Config("tapping_polystyrene", physical=FAST, model=ONE_MODE, solver=noisy(p["seed"]))
    amplitude = z_schedule(base, schedule).values["amplitude"][first:]
    n = amplitude.reshape(p["pixels"], p["per_pixel"]).mean(axis=1)
    slope = ds.attrs["slope"]
    follows = -(n - n.mean()) / slope
    tau = F0 / (2 * math.pi * p["b_fb"]) + F0 / (2 * math.pi * p["b_li"])
    assert np.corrcoef(follows, height - height.mean())[0, 1] > math.sqrt(1 - 2 * tau / p["per_pixel"])


def test_with_thermal_noise_the_ringup_settles_to_the_thermal_scatter(noisy_line):
    # The amplitude never settles to 1e-6 with noise: the ring-up lasts until the transient from
    # rest, ~A0 exp(-t/tau_d) (tau_d = 2Q/omega0, mode 1's decay time), is below sigma/e:
    # tau_d (1 + ln(A/sigma)) = 136.7 periods here, A the amplitude then.  A0 is the mean of
    # the last tau_d: within the deficit sigma/e and 4 sigma (a mean's scatter is at most the
    # amplitude's) of the noiseless 20 nm.
    attrs = noisy_line.attrs
    a0 = attrs["free_amplitude_nm"]
    assert abs(attrs["ringup_periods"] - TAU_C * (1 + math.log(a0 / SIGMA))) <= 1
    assert abs(a0 - 20.0) < (4 + 1 / math.e) * SIGMA
    # The engage ended inside its band (4 sigma here: wider than 1e-3 A_set = 0.016 nm).
    assert attrs["engage_periods"] < 2000


def test_with_thermal_noise_a_scan_is_seeded_and_the_same_on_flight_exact_and_dop853():
    # Each period draws its own seed from noise_seed (docs/instrument.md), and the realisation
    # depends on the seed, the noise grid and N alone (docs/model.md §21): flight_exact and
    # dop853 integrate the same forces, to their tolerance (rtol 1e-9: 1e-6 nm of 13 nm).
    def run(seed, method):
        return scan_line("tapping_polystyrene", physical=FAST, model=ONE_MODE, solver=noisy(seed, method),
                         scan_length=20e-9, pixels=2, line_rate=line_rate(2, 60, False), retrace=False,
                         setpoint_ratio=0.8, lockin_bandwidth=20e3, feedback_bandwidth=2e3)
    dop = run(3, "dop853")
    exact = run(3, "flight_exact")
    again = run(3, "dop853")
    other = run(4, "dop853")
    for name in ("height", "amplitude", "phase", "peak_force"):
        np.testing.assert_array_equal(again[name].values, dop[name].values)
        np.testing.assert_allclose(exact[name].values, dop[name].values, rtol=0, atol=1e-6)
    assert np.abs(other["height"].values - dop["height"].values).max() > 1e-4


def test_the_pixel_phase_is_a_circular_mean():
    # The pixel's phase is the angle of its periods' mean filtered lock-in output (X, Y): a phase
    # that wraps across +-180 deg averages to 180, where the angles' arithmetic mean is 0.
    api = tmafm._fortran._objects.tmafm_api_scan
    angles = np.radians([179.0, -179.0, 178.0, -178.0])
    assert abs(abs(api.am_scan_mean_phase(np.cos(angles), np.sin(angles))) - 180) < 1e-12
    angles = np.radians([170.0, -176.0])        # mean 177 deg, across the wrap
    assert api.am_scan_mean_phase(2 * np.cos(angles), 2 * np.sin(angles)) == pytest.approx(177.0, abs=1e-12)
    angles = np.radians([-60.0, -80.0])          # amplitudes weigh: A = 1 and 3
    x, y = np.array([1, 3]) * np.cos(angles), np.array([1, 3]) * np.sin(angles)
    expected = math.degrees(math.atan2(y.sum(), x.sum()))
    assert api.am_scan_mean_phase(x, y) == pytest.approx(expected, abs=1e-12)


def test_the_scan_averages_its_phase_as_the_mean_lockin_output(noisy_line):
    # The scan's pixel phase is that circular mean of the recorded filtered (A cos phi, A sin phi)
    # of the pixel's periods (here, in tapping, near the arithmetic mean of the phases too).
    ds = noisy_line
    p = NOISY_LINE
    a = ds["period_amplitude"].values.reshape(p["pixels"], p["per_pixel"])
    phi = np.radians(ds["period_phase"].values.reshape(p["pixels"], p["per_pixel"]))
    expected = np.degrees(np.arctan2((a * np.sin(phi)).sum(axis=1), (a * np.cos(phi)).sum(axis=1)))
    np.testing.assert_allclose(ds["phase"].sel(direction="trace").values, expected, rtol=0, atol=1e-9)


@pytest.mark.parametrize("bad, message", [
    (dict(setpoint_ratio=0.96), "is under 10 thermal rms sigma"),
    (dict(solver={"thermal_noise": 1, "method": "rk4_paper"}), "thermal_noise = 1"),
])
def test_noisy_scans_that_cannot_work_are_refused_in_one_line(bad, message):
    # A setpoint so close to A0 that the approach's secant (over 0.1 (A0 - A_set)) would measure
    # the noise, not dA/dZ; a method that does not take the noise.
    keywords = dict(scan_length=10e-9, pixels=2, line_rate=1e3, physical=FAST, model=ONE_MODE, solver=noisy(1),
                    lockin_bandwidth=20e3, feedback_bandwidth=2e3, setpoint_ratio=0.8)
    keywords.update(bad)
    with pytest.raises(tmafm.InputError) as info:
        scan_line("tapping_polystyrene", **keywords)
    assert message in str(info.value)
    assert "\n" not in str(info.value)

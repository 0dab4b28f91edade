"""AM imaging (fortran/src/instrument/tmafm_am_scan.f90, docs/instrument.md "AM imaging"): a scan
line with the Z feedback over a topography and two materials, checked against approach curves,
the topography given, and the designed closed-loop time constant."""

import math
import warnings

import numpy as np
import pytest

import tmafm
from tmafm.instrument import scan_line

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

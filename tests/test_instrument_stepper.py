"""The instrument's period stepper (fortran/src/instrument/tmafm_period_stepper.f90,
docs/instrument.md): a run stepped one drive period at a time."""

import warnings

import numpy as np
import pytest

import tmafm
from tmafm.instrument import z_schedule

PERIODS = 120


@pytest.fixture(scope="module")
def observed():
    """tmafm.observe's per-period values of tapping_polystyrene at Z = 12 nm, per method."""
    out = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", tmafm.UnsteadyWarning)
        for method in ("flight_exact", "dop853", "dopri5"):
            config = tmafm.Config("tapping_polystyrene", solver={"method": method},
                                  physical={"tip_sample_distance": 12e-9})
            out[method] = (config, tmafm.observe(config, max_periods=PERIODS, stop_at_steady=False).physical)
    return out


@pytest.mark.parametrize("method", ["flight_exact", "dop853", "dopri5"])
def test_a_fixed_schedule_is_one_observed_run(observed, method):
    # Stepping restarts the integrator at every period boundary, so the two runs agree to the
    # method's tolerance (rtol 1e-9 in tapping_polystyrene), not to the bit: flight_exact's free
    # flights are exact and its contacts dop853's.
    config, physical = observed[method]
    stepped = z_schedule(config, np.full(PERIODS, 12e-9))
    for name in ("amplitude", "peak_force", "dissipated_energy", "mean_deflection", "contact_time"):
        # (the mean deflection, a small difference of the motion, on the amplitude's scale)
        scale = np.abs(physical["amplitude" if name == "mean_deflection" else name]).max()
        assert np.abs(stepped.values[name] - physical[name]).max() <= 1e-6*scale, name
    assert np.abs(stepped.values["phase"] - physical["phase"]).max() <= 1e-5
    assert stepped.units["peak_force"] == "nN"
    period = 1/300.0e3
    np.testing.assert_allclose(stepped.time, period*np.arange(1, PERIODS + 1), rtol=1e-12)


def test_a_step_in_z_keeps_the_tip_where_it_was():
    # At a new Z the gap d (the length unit) changes: the state is carried over in metres, so the
    # tip's deflection is continuous across the step and V_T (the gap) jumps by exactly -dZ.
    config = tmafm.Config("tapping_polystyrene", physical={"tip_sample_distance": 25e-9})
    far = z_schedule(config, np.full(60, 25e-9))
    stepped = z_schedule(config, np.concatenate([np.full(60, 25e-9), np.full(1, 15e-9)]))
    near = z_schedule(config, np.full(1, 15e-9))  # from rest at 15 nm: a different first period
    # The first 60 periods are the same run.
    np.testing.assert_array_equal(stepped.values["amplitude"][:60], far.values["amplitude"])
    # The 61st period starts from the tip's motion at 25 nm, 10 nm closer: its mean deflection is
    # the same motion's (to the small change the nearer surface makes in a free period), and far
    # from the rest start's.
    assert stepped.values["amplitude"][60] == pytest.approx(far.values["amplitude"][59], rel=2e-2, abs=0)
    assert abs(stepped.values["amplitude"][60] - near.values["amplitude"][0]) > 5


def test_bad_schedules_are_refused_in_one_line():
    with pytest.raises(tmafm.InputError, match=r"z\[1\] = nan"):
        z_schedule("tapping_polystyrene", [25e-9, np.nan])
    with pytest.raises(tmafm.InputError, match="gap"):
        z_schedule("tapping_polystyrene", [25e-9, -1.0])
    with pytest.raises(tmafm.InputError, match="SI units"):
        z_schedule("fig2_n4", [25e-9])
    with pytest.raises(tmafm.InputError, match="rk4_event"):
        z_schedule("tapping_polystyrene", [25e-9], solver={"method": "rk4_event"})


def test_thermal_noise_takes_a_new_realisation_every_period():
    # Each period of the stepper is a run of its own with its own seed (docs/instrument.md): the
    # per-period lock-in amplitude and phase then scatter as a single noisy run's do, by
    # sqrt(k_B T/k) and sqrt(k_B T/k)/A (docs/model.md §21; k = 2 N/m, A = 10 nm: 0.0454 nm and
    # 0.260 deg).  Q = 20: the amplitude's correlation time is Q/pi ~ 6 periods, so 1000 periods
    # hold ~80 independent samples and a standard deviation is known to ~8 %; 0.3 is about 4
    # standard errors.  A realisation repeated every period would scatter far less once settled.
    base = tmafm.Config("thermal_air", physical={"free_amplitude": 10e-9})
    stepped = z_schedule(base, np.full(1200, 100e-9))
    thermal = np.sqrt(1.380649e-23*298.15/2.0)*1e9
    amplitude = stepped.values["amplitude"][200:]
    phase = np.radians(stepped.values["phase"][200:])
    assert amplitude.mean() == pytest.approx(10.0, rel=2e-2, abs=0)
    assert amplitude.std() == pytest.approx(thermal, rel=0.3, abs=0)
    assert phase.std() == pytest.approx(thermal/10.0, rel=0.3, abs=0)
    again = z_schedule(base, np.full(1200, 100e-9))
    np.testing.assert_array_equal(again.values["amplitude"], stepped.values["amplitude"])

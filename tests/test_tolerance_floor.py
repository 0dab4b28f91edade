"""atol -> 0+ is continuous with atol = 0 (integrators/tmafm_error_scale.f90, mode_floor_fraction).

A mode at rest (the default start: every a_j = a'_j = 0) used to be held to atol itself, so a
tiny positive atol asked its first error estimate, which is round-off, to be below 1e-300:
`&solver method='dop853', tau_end=5, rtol=1e-15, atol=1e-300 /` failed with a step size
underflow at tau = 0 where atol = 0 ran.  No mode is now held tighter than 2^-26 of the tip's
tolerance atol + rtol S_V.
"""

import numpy as np
import pytest

import tmafm

SHORT = {"solver": {"tau_end": 5.0}, "output": {"sample_dtau": 0.05}}


@pytest.mark.parametrize("method", ["dop853", "dopri5", "flight_exact"])
@pytest.mark.parametrize("rtol", [1e-15, 1e-7])
def test_tiny_atol_runs_as_atol_zero(method, rtol):
    zero = tmafm.run(SHORT, solver={"method": method, "rtol": rtol, "atol": 0.0})
    for atol in (1e-300, 1e-100):
        tiny = tmafm.run(SHORT, solver={"method": method, "rtol": rtol, "atol": atol})
        # atol this far below rtol S_V changes no weight: the same run, to the last bit.
        np.testing.assert_array_equal(tiny.vt, zero.vt)
        assert tiny.counters == zero.counters


@pytest.mark.parametrize("atol", [1e-40, 1e-30, 1e-25, 1e-20])
def test_small_atol_between_runs_close_to_atol_zero(atol):
    """Between the tiny and the usual atol, the runs differ from atol = 0 by the tolerance."""
    solver = {"method": "dop853", "rtol": 1e-15}
    zero = tmafm.run(SHORT, solver={**solver, "atol": 0.0})
    small = tmafm.run(SHORT, solver={**solver, "atol": atol})
    tolerance = 1e-15 * np.max(np.abs(zero.vt)) + atol
    assert np.max(np.abs(small.vt - zero.vt)) <= 100 * tolerance


def test_tiny_initial_amplitude_with_atol_zero():
    """A mode started at 1e-300 was held to rtol * 1e-300 absolute: the same underflow."""
    result = tmafm.run(SHORT, initial={"a0": [1e-300, 0.0, 0.0, 0.0]},
                       solver={"method": "dop853", "rtol": 1e-10, "atol": 0.0})
    zero = tmafm.run(SHORT, solver={"method": "dop853", "rtol": 1e-10, "atol": 0.0})
    assert np.max(np.abs(result.vt - zero.vt)) <= 100 * 1e-10 * np.max(np.abs(zero.vt))

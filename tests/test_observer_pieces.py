"""flight_exact's observer on the short flight pieces of a noisy run (a flight cut at every
point of the noise grid): the closed-form integrals take phi1(mu h) of a repeated piece length
from a cache, to first order in the pieces' differences of length, and the 2 + 2N extrema
scans of a piece share its ends (tmafm_flight_observables).

Oracles: the same flight integrated in one piece (no cache: a new observer, another length,
mostly the difference form) against the sum over its 40 short pieces taken by one observer;
and the same noisy run (same seed, the same held forces) observed by dop853 at a tight rtol,
whose observer integrates its own dense output by Gauss-Legendre.
"""

import math

import numpy as np
import pytest

import tmafm

from conftest import INPUTS
from testcore import core as _core

EPS = np.finfo(float).eps
SCENE = INPUTS / "tapping_polystyrene.nml"
HARMONICS = 5


def _piece_sums(path, tau0, y0, accel, s_a, s_b, pieces):
    whole, split, ierr, errmsg = _core.flight_piece_sums(str(path), HARMONICS, tau0, y0, accel, s_a, s_b, pieces)
    assert ierr == 0, errmsg
    return whole, split


@pytest.mark.parametrize("scene,tau0", [("tapping_polystyrene", 0.0), ("tapping_polystyrene", 1000.0),
                                        ("bimodal/tapping", 0.0)])
def test_the_pieces_of_a_flight_sum_to_its_whole(scene, tau0):
    """40 pieces as short as the noise grid's (the fastest mode's period/32) taken in turn by
    one observer sum to the integrals of the whole flight, to the rounding of the sums: one
    drive tone (three modes), and two tones (a general drive: its own exponents i j Omega_0).
    At tau0 = 1000 the pieces' lengths differ by the rounding of their ends (up to 2^-34 of a
    length): the cache's first-order correction is what keeps them there (without it, an
    error of about 40 |d| |f| = 2e-11 of the scale).  Two tones are checked near tau = 0 only:
    their lock-in products reach e^{i j Omega_0 tau} with j up to H + 2 h_2, whose phase's
    rounding, j Omega_0 tau eps at tau = 1000, is itself about 1e-12 of the scale (1.5e-12 seen)."""
    path = INPUTS / f"{scene}.nml"
    model = tmafm.Model(str(path))
    n = model.n_modes
    h = 2 * math.pi / (model.beta[-1] ** 2 * 32)
    # A state and a held force of the sizes a run meets (the first modes' tenths of the gap).
    y0 = np.concatenate([3e-4 * (-0.1) ** np.arange(n), -1e-3 * (-0.2) ** np.arange(n)])
    accel = 2e-4 * (-0.5) ** np.arange(n)
    s_a = 0.37
    pieces = 40
    whole, split = _piece_sums(path, tau0, y0, accel, s_a, s_a + pieces * h, pieces)
    # Lock-in sums, int p.a, the drive's and the beam's works: each group on its own scale.
    groups = {"lockin": slice(0, 2 * HARMONICS), "deflection": slice(2 * HARMONICS, 2 * HARMONICS + 1),
              "drive": slice(2 * HARMONICS + 1, 2 * HARMONICS + 2), "beam": slice(2 * HARMONICS + 2, None)}
    for name, part in groups.items():
        scale = np.abs(whole[part]).max()
        assert scale > 0, name
        # Each piece's integral is within a few eps of |f| h of the exact one; 64 eps per piece
        # is far above that and far below the 2e-11 an uncorrected cache would leave.
        np.testing.assert_allclose(split[part], whole[part], rtol=0, atol=64 * pieces * EPS * scale,
                                   err_msg=name)


def test_noisy_flight_exact_observables_equal_a_tight_dop853():
    """A noisy tapping run (Fig. 2, N = 3, two contacts a period): flight_exact's closed-form
    observer on its flight pieces against dop853 at rtol 1e-12 on the same force realisation,
    every observable, every period, to 1e-9 of its scale (phases to 1e-7 degrees), as the
    noiseless runs of test_observe_exact.  The noise moves them by percents."""
    periods, n = 6, 3
    runs = {}
    for method, rtol, noise in (("flight_exact", 1e-11, True), ("dop853", 1e-12, True), ("dop853", 1e-12, False)):
        runs[method, noise] = tmafm.observe(
            "fig2_n3", max_periods=periods, stop_at_steady=False,
            scene={"thermal_energy": 1e-9} if noise else {}, initial={"a0": [0.0] * n, "adot0": [0.0] * n},
            solver={"method": method, "rtol": rtol, "atol": 1e-20,
                    **({"thermal_noise": 1, "noise_seed": 3} if noise else {})})
    got, ref, quiet = runs["flight_exact", True], runs["dop853", True], runs["dop853", False]
    assert np.sum(ref.per_period["contacts_per_period"]) >= periods
    np.testing.assert_array_equal(got.per_period["contacts_per_period"], ref.per_period["contacts_per_period"])
    moved = 0.0
    for name, values in ref.per_period.items():
        a, b = np.asarray(got.per_period[name], float), np.asarray(values, float)
        assert np.array_equal(np.isnan(a), np.isnan(b)), name
        if name in ("phase", "harmonic_phase"):
            assert np.nanmax(np.abs(a - b)) < 1e-7, name
        else:
            scale = np.nanmax(np.abs(b))
            assert np.nanmax(np.abs(a - b)) <= 1e-9 * scale, name
            if scale > 0:
                moved = max(moved, np.nanmax(np.abs(np.asarray(quiet.per_period[name], float) - b)) / scale)
    assert moved > 1e-2

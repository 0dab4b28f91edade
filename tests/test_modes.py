"""Cantilever modes (docs/model.md §4): roots, normalisation, boundary values, orthogonality,
and accuracy against an extended-precision evaluation."""

import mpmath
import numpy as np
import pytest

from testcore import core as _core

N_MAX = 30
# Roots of 1 + cos b cosh b = 0 (Blevins, Formulas for natural frequency and mode shape).
KNOWN_ROOTS = [1.8751040687119611, 4.6940911329741745, 7.8547574382376126,
               10.995540734875467, 14.137168391046471]


def mode_values(n, xi, order):
    beta, values = _core.modes(n, np.asarray(xi, dtype=float), order)
    return beta, values


def test_roots_match_known_values():
    beta, _ = mode_values(5, [1.0], 0)
    np.testing.assert_allclose(beta, KNOWN_ROOTS, rtol=1e-14)


def test_roots_solve_the_frequency_equation_up_to_30():
    beta, _ = mode_values(N_MAX, [1.0], 0)
    residual = np.cos(beta) + 1 / np.cosh(beta)
    assert np.max(np.abs(residual)) < 1e-14
    assert np.all(np.diff(beta) > 2.8)
    # High roots approach (2j-1) pi/2 from the side of cos b = -sech b.
    j = np.arange(1, N_MAX + 1)
    assert np.max(np.abs(beta[5:] - (2 * j[5:] - 1) * np.pi / 2)) < 1e-6


def test_tip_value_is_two_with_alternating_sign():
    beta, tip = mode_values(N_MAX, [1.0], 0)
    expected = 2.0 * (-1.0) ** (np.arange(N_MAX))
    assert np.max(np.abs(tip[0] - expected)) <= 1e-12


def test_free_end_has_no_moment_and_no_shear():
    beta, curvature = mode_values(N_MAX, [1.0], 2)
    _, shear = mode_values(N_MAX, [1.0], 3)
    # Relative to the size of each derivative, b^2 and b^3 times O(1).
    assert np.max(np.abs(curvature[0]) / beta**2) <= 1e-12
    assert np.max(np.abs(shear[0]) / beta**3) <= 1e-12


def test_clamped_end_has_zero_value_and_slope():
    beta, value = mode_values(N_MAX, [0.0], 0)
    _, slope = mode_values(N_MAX, [0.0], 1)
    assert np.max(np.abs(value[0])) <= 1e-13
    assert np.max(np.abs(slope[0]) / beta) <= 1e-13


def test_normalised_and_orthogonal_up_to_30():
    *_, gram = _core.galerkin(N_MAX, 1.0)
    assert np.max(np.abs(np.diag(gram) - 1.0)) <= 1e-12
    assert np.max(np.abs(gram - np.diag(np.diag(gram)))) <= 1e-12


def _textbook_mode(beta, xi, order):
    """Independent oracle: the textbook form, in 60-digit arithmetic (mpmath)."""
    b = mpmath.mpf(beta)
    sigma = (mpmath.cosh(b) + mpmath.cos(b)) / (mpmath.sinh(b) + mpmath.sin(b))
    f = lambda x: mpmath.cosh(b * x) - mpmath.cos(b * x) - sigma * (mpmath.sinh(b * x) - mpmath.sin(b * x))
    return float(mpmath.diff(f, mpmath.mpf(xi), order))


@pytest.mark.parametrize("order", [0, 1, 2])
def test_shape_matches_extended_precision(order):
    mpmath.mp.dps = 60
    xi = np.array([0.0, 0.137, 0.5, 0.8, 0.999, 1.0])
    beta, values = mode_values(N_MAX, xi, order)
    for j in (0, 4, 12, 19, 29):
        # The oracle uses the same root (in double), so only the shape evaluation is compared.
        expected = np.array([_textbook_mode(beta[j], x, order) for x in xi])
        scale = beta[j] ** order
        assert np.max(np.abs(values[:, j] - expected)) / scale <= 5e-13, (j, order)

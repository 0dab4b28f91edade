"""Floquet multipliers of a multiple-shooting orbit by the periodic Schur decomposition
(tmafm.continuation.floquet_multipliers, docs/continuation.md section 4): known multipliers of a
synthetic product spanning 30 decades, an orbit against the plain product, singular factors, and
typed errors."""

from pathlib import Path

import numpy as np
import pytest

import tmafm
from tmafm import continuation as cont
from tmafm.continuation.periodic_schur import product_eigenvalues

BISTABLE = str(Path(__file__).resolve().parents[1] / "inputs" / "sweeps" / "bistable_n2.nml")
EPS = np.finfo(float).eps


def _rotation(angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s], [s, c]])


def _synthetic(k_factors, span, seed, n=60, pairs=6):
    """Factors A_k = Q_k T_k Q_(k-1)^T (Q_0 = Q_K random orthogonal) of a product with known
    multipliers: T_k upper triangular with 1x1 diagonal entries |mu|^(1/K) (the sign on T_1) and
    2x2 blocks |mu|^(1/K) S_(k+1) R(theta/K) S_k^-1 (S_K = S_0, so the product's block is
    |mu| S_0 R(theta) S_0^-1: the pair |mu| exp(+-i theta)), the moduli log-spaced from 1 down to
    10^-span, placed in random order.  Off the diagonal: N(0, 0.2^2) times the row's diagonal
    size, so the factors are well conditioned and the multipliers' condition under perturbations
    of the FACTORS is about K |mu|^(-1/K): the error a backward-stable product method may make."""
    rng = np.random.default_rng(seed)
    count = n - pairs
    logs = -np.linspace(0.0, span, count)
    rng.shuffle(logs[1:-1])
    blocks = [(2 if i < pairs else 1, 10.0 ** lg,
               rng.uniform(0.3, 2.8) if i < pairs else rng.choice([-1.0, 1.0]))
              for i, lg in enumerate(logs)]
    blocks = [blocks[i] for i in rng.permutation(count)]
    s = [np.eye(2) + 0.3 * rng.standard_normal((2, 2)) for _ in range(k_factors)]
    mask = np.triu(np.ones((n, n)), 1)
    pos = 0
    for size, _, _ in blocks:
        if size == 2:
            mask[pos, pos + 1] = 0.0
        pos += size
    factors, expected = [], []
    q = [np.linalg.qr(rng.standard_normal((n, n)))[0] for _ in range(k_factors)]
    for k in range(k_factors):
        t = np.zeros((n, n))
        pos = 0
        for size, modulus, extra in blocks:
            d = modulus ** (1.0 / k_factors)
            if size == 1:
                t[pos, pos] = d * (extra if k == 0 else 1.0)
            else:
                left = s[(k + 1) % k_factors]
                t[pos:pos + 2, pos:pos + 2] = d * left @ _rotation(extra / k_factors) \
                    @ np.linalg.inv(s[k])
            pos += size
        rows = np.max(np.abs(t), axis=1)
        t += 0.2 * rng.standard_normal((n, n)) * mask * rows[:, None]
        factors.append(q[k] @ t @ q[k - 1].T)
    for size, modulus, extra in blocks:
        if size == 1:
            expected.append(modulus * extra)
        else:
            expected += [modulus * np.exp(1j * extra), modulus * np.exp(-1j * extra)]
    return factors, np.array(expected)


def _relative_errors(got, expected):
    """For each expected multiplier, the distance to the nearest computed one over its size."""
    return np.array([np.min(np.abs(got - mu)) / abs(mu) for mu in expected])


@pytest.mark.parametrize("k_factors, span, seed", [(4, 24, 1), (5, 30, 4), (6, 30, 2),
                                                     (8, 30, 3)])
def test_synthetic_product_spanning_thirty_decades(k_factors, span, seed):
    """Every multiplier, 1 down to 10^-span, to 1e-8 relative.  The bound a backward-stable
    method meets is c K u |mu|^(-1/K) (9e-10 for K = 4 and 1e-24, 1.1e-9 for K = 5 and 1e-30,
    1.3e-10 for K = 6, 1e-11 for K = 8; K = 4 stops at 1e-24 because at 1e-30 the bound is 3e-8,
    above the 1e-8 asked).  The eigenvalues of the formed product lose every multiplier below
    about u |A_K| ... |A_1| ~ 1e-16: those below 1e-20 come out wrong by more than 100 %."""
    factors, expected = _synthetic(k_factors, span, seed)
    assert abs(np.max(np.abs(expected)) - 1.0) <= 4 * EPS
    assert abs(np.min(np.abs(expected)) * 10.0 ** span - 1.0) <= 4 * EPS
    mu = cont.floquet_multipliers(factors)
    assert mu.shape == (60,)
    assert np.all(np.diff(np.abs(mu)) <= 0)  # largest modulus first
    errors = _relative_errors(mu, expected)
    assert np.max(errors) <= 1e-8, np.max(errors)
    # and every computed multiplier is one of the expected ones (none counted twice)
    assert np.max(_relative_errors(expected, mu)) <= 1e-8
    product = factors[0]
    for a in factors[1:]:
        product = a @ product
    plain = _relative_errors(np.linalg.eigvals(product), expected)
    small = np.abs(expected) < 1e-20
    assert small.sum() >= 8
    assert np.all(plain[small] > 1.0), plain[small]


def test_one_segment_is_the_plain_eigenvalues_bit_for_bit():
    rng = np.random.default_rng(7)
    m = rng.standard_normal((6, 6))
    mu = np.linalg.eigvals(m)
    expected = mu[np.lexsort((-mu.imag, -np.abs(mu)))]
    got = cont.floquet_multipliers([m])
    assert np.array_equal(got, expected)


def test_singular_factors_and_exact_zeros_on_the_diagonal():
    """A_2 A_1 = N^T N with N the shift matrix (a triangular factor with an all-zero diagonal):
    the product is diag(0, 1, ..., 1); and a factor of rank 3 out of 8 (five zero multipliers)
    against the formed product, which is exact enough here (all multipliers O(1) or zero)."""
    n = 6
    shift = np.diag(np.ones(n - 1), 1)
    mu = cont.floquet_multipliers([shift, shift.T])
    assert np.max(np.abs(mu - np.r_[np.ones(n - 1), 0.0])) <= 10 * EPS
    rng = np.random.default_rng(11)
    low = rng.standard_normal((8, 3)) @ rng.standard_normal((3, 8))
    factors = [rng.standard_normal((8, 8)), low, rng.standard_normal((8, 8))]
    got = cont.floquet_multipliers(factors)
    plain = np.linalg.eigvals(factors[2] @ factors[1] @ factors[0])
    plain = plain[np.lexsort((-plain.imag, -np.abs(plain)))]
    scale = np.max(np.abs(plain))
    assert np.max(np.abs(got[:3] - plain[:3])) <= 1e-12 * scale
    assert np.max(np.abs(got[3:])) <= 1e-12 * scale


def test_two_segment_orbit_agrees_with_the_plain_product():
    """A tapping orbit of bistable_n2 (the scene of the monodromy test in test_continuation.py),
    solved as a period-2 orbit (two shooting segments): its
    multipliers are those of the plain product M_2 M_1 where the product is accurate (all four
    here, to 1e-10 of the largest; the largest to 1e-10 relative), and the squares of the
    period-1 orbit's multipliers (the same orbit: to the Newton tolerance's effect, 1e-8)."""
    model = tmafm.Model(BISTABLE, scene={"delta_hat": 0.0005})
    y = np.zeros(4)
    for _ in range(80):  # near the tapping attractor reached from rest
        y = cont.periodic_map(model, y, 1, 1e-9).y
    one = cont.periodic_orbit(model, y)
    assert one.stats["contacts"] == 1
    two = cont.periodic_orbit(model, one.states[0], period=2)
    assert two.stats["contacts"] == 2
    monodromies = [cont.periodic_map(model, x, 1).monodromy for x in two.states]
    mu = cont.floquet_multipliers(monodromies)
    assert np.array_equal(mu, two.multipliers)
    plain = np.linalg.eigvals(monodromies[1] @ monodromies[0])
    plain = plain[np.lexsort((-plain.imag, -np.abs(plain)))]
    assert abs(mu[0] - plain[0]) <= 1e-10 * abs(plain[0])
    assert np.max(np.abs(mu - plain)) <= 1e-10 * abs(plain[0])
    squares = one.multipliers ** 2
    assert np.max(_relative_errors(mu, squares)) <= 1e-8


@pytest.mark.parametrize("monodromies", [
    [],
    np.eye(4),
    [np.ones((3, 4))],
    [np.ones(4)],
    [np.eye(4), np.eye(3)],
    [np.eye(2), [[1.0, np.nan], [0.0, 1.0]]],
    [np.eye(2), [[1.0, np.inf], [0.0, 1.0]]],
    [np.eye(2) * (1 + 1j)],
    [[["a", "b"], ["c", "d"]]],
    3.0,
])
def test_bad_monodromies_raise_input_error(monodromies):
    with pytest.raises(tmafm.InputError):
        cont.floquet_multipliers(monodromies)


def test_product_eigenvalues_of_known_small_cases():
    """Rotations (a complex pair exactly on the unit circle) and diagonal factors."""
    rot = _rotation(0.3)
    got = product_eigenvalues([rot] * 4)
    assert np.max(np.abs(np.sort_complex(got) - np.sort_complex(np.exp([-1.2j, 1.2j])))) <= 1e-14
    got = product_eigenvalues([np.diag([1.0, 2.0, 3.0]), np.diag([3.0, 2.0, 1.0])])
    assert np.array_equal(np.sort(got.real), [3.0, 3.0, 4.0]) and np.all(got.imag == 0)


def test_a_stalled_first_attempt_is_rerun_in_another_basis(monkeypatch):
    """The fallback when the shifted sweeps stall: the same product in a fixed random orthogonal
    basis gives the same multipliers (here forced by failing the first attempt)."""
    from tmafm.continuation import periodic_schur

    rng = np.random.default_rng(5)
    factors = [rng.standard_normal((7, 7)) for _ in range(3)]
    expected = product_eigenvalues(factors)
    real = periodic_schur._periodic_qr
    calls = []

    def first_fails(t):
        calls.append(1)
        if len(calls) == 1:
            raise periodic_schur._NoConvergence("forced")
        return real(t)

    monkeypatch.setattr(periodic_schur, "_periodic_qr", first_fails)
    got = product_eigenvalues(factors)
    assert len(calls) == 2
    scale = np.max(np.abs(expected))
    assert np.max(np.abs(np.sort_complex(got) - np.sort_complex(expected))) <= 1e-13 * scale
    monkeypatch.setattr(periodic_schur, "_periodic_qr",
                        lambda t: (_ for _ in ()).throw(periodic_schur._NoConvergence("x")))
    with pytest.raises(tmafm.SolverError):
        product_eigenvalues(factors)


def test_repeated_multipliers_of_commuting_factors():
    """Factors Q D_k Q^T sharing one orthogonal basis, D_k with entries 0.5, 1, 2: the product
    is normal, its multipliers prod_k D_k (many repeated) are perfectly conditioned, and come
    out real to 1e-13 (a double multiplier must not turn into a complex pair sqrt(u) apart)."""
    rng = np.random.default_rng(10)
    n, k_factors = 12, 6
    q = np.linalg.qr(rng.standard_normal((n, n)))[0]
    diagonals = rng.choice([0.5, 1.0, 2.0], size=(k_factors, n))
    factors = [q @ np.diag(d) @ q.T for d in diagonals]
    expected = np.sort(np.prod(diagonals, axis=0))[::-1]
    mu = cont.floquet_multipliers(factors)
    assert np.max(np.abs(mu - expected)) <= 1e-13 * expected[0]


def test_random_products_against_the_formed_product():
    """120 products of K = 2..6 factors of size 1..12 (Gaussian, orthogonal, with half their
    columns zero, commuting symmetric) whose multipliers are all within a few decades of the
    largest, where the formed product is accurate: every call converges without the fallback,
    and the multipliers match the formed product's to 1e-11 of |A_K| ... |A_1| (both are
    backward stable to about n K u of it)."""
    from tmafm.continuation import periodic_schur

    rng = np.random.default_rng(2026)
    worst = 0.0
    for trial in range(120):
        n, k_factors = int(rng.integers(1, 13)), int(rng.integers(2, 7))
        kind = trial % 4
        if kind == 0:
            factors = [rng.standard_normal((n, n)) for _ in range(k_factors)]
        elif kind == 1:
            factors = [np.linalg.qr(rng.standard_normal((n, n)))[0] for _ in range(k_factors)]
        elif kind == 2:
            factors = [rng.standard_normal((n, n)) for _ in range(k_factors)]
            factors[int(rng.integers(k_factors))][:, :n // 2] = 0.0
        else:
            q = np.linalg.qr(rng.standard_normal((n, n)))[0]
            factors = [q @ np.diag(rng.choice([0.5, 1.0, 2.0], n)) @ q.T
                       for _ in range(k_factors)]
        got = periodic_schur._periodic_qr([a.copy() for a in factors])  # no fallback
        product = factors[0]
        for a in factors[1:]:
            product = a @ product
        plain = list(np.linalg.eigvals(product))
        scale = np.prod([np.linalg.norm(a, 2) for a in factors])
        for z in sorted(got, key=abs, reverse=True):
            j = int(np.argmin([abs(z - w) for w in plain]))
            worst = max(worst, abs(z - plain.pop(j)) / scale)
    assert worst <= 1e-11, worst

"""The eigenvalues of a product of matrices A_K ... A_1 without forming the product: the periodic
Schur decomposition by the periodic QR algorithm (Bojanczyk, Golub & Van Dooren 1992; Kressner,
"Numerical Methods for General and Structured Eigenvalue Problems", Springer 2005, ch. 3).

Orthogonal Q_0 = Q_K, Q_1, ..., Q_(K-1) bring the factors to T_k = Q_k^T A_k Q_(k-1): T_1 ...
T_(K-1) upper triangular and T_K upper quasi-triangular (1x1 and 2x2 blocks).  Every step is an
orthogonal transformation of one factor at a time, so the computed eigenvalues are the exact
eigenvalues of the product of factors A_k + E_k with |E_k| <= c n u |A_k| (u the unit round-off):
a small multiplier is lost only where it is ill-conditioned under perturbations of the FACTORS,
never because the product's round-off (u |A_K| ... |A_1|) swamps it.  Linear algebra only, numpy.
"""

from __future__ import annotations

import numpy as np

from ..errors import SolverError

__all__ = ["product_eigenvalues"]

_EPS = np.finfo(float).eps
_TINY = np.finfo(float).tiny


def _householder(x: np.ndarray):
    """v, tau with (I - tau v v^T) x = (beta, 0, ..., 0); v None when x is already so.  Scaled
    by max |x_i| first, so that no square under- or overflows."""
    tail = np.abs(x[1:])
    big = float(tail.max()) if tail.size else 0.0
    if big == 0.0:
        return None, 0.0
    xs = x / max(big, abs(float(x[0])))
    alpha = float(xs[0])
    norm = np.sqrt(alpha * alpha + float(xs[1:] @ xs[1:]))
    beta = -norm if alpha >= 0 else norm
    v = xs / (alpha - beta)
    v[0] = 1.0
    return v, (beta - alpha) / beta


def _reflect_rows(a: np.ndarray, rows: slice, v, tau) -> None:
    """a[rows, :] = (I - tau v v^T) a[rows, :]."""
    if v is not None:
        block = a[rows, :]
        block -= (tau * v)[:, None] * (v @ block)


def _reflect_cols(a: np.ndarray, cols: slice, v, tau) -> None:
    """a[:, cols] = a[:, cols] (I - tau v v^T)."""
    if v is not None:
        block = a[:, cols]
        block -= (block @ v)[:, None] * (tau * v)


def _hessenberg_triangular(t: list[np.ndarray]) -> None:
    """In place: T_1 ... T_(K-1) upper triangular, T_K upper Hessenberg (t[k] is T_(k+1)), by
    Householder reflections column by column around the cycle."""
    n = t[0].shape[0]
    last = len(t) - 1
    for j in range(n - 1):
        for k in range(last):
            v, tau = _householder(t[k][j:, j].copy())
            _reflect_rows(t[k], slice(j, n), v, tau)
            t[k][j + 1:, j] = 0.0
            _reflect_cols(t[k + 1], slice(j, n), v, tau)
        if j < n - 2:
            v, tau = _householder(t[last][j + 1:, j].copy())
            _reflect_rows(t[last], slice(j + 1, n), v, tau)
            t[last][j + 2:, j] = 0.0
            _reflect_cols(t[0], slice(j + 1, n), v, tau)


def _sweep(t: list[np.ndarray], lo: int, hi: int, x: np.ndarray) -> None:
    """One implicitly shifted periodic QR sweep on rows/columns lo..hi, started by the first
    column x (length m + 1) of the shift polynomial of the product: a bulge chased down the
    Hessenberg factor, each triangular factor restored by Householder reflections of its small
    block as the bulge passes through it."""
    h = t[-1]
    m = len(x) - 1
    for i in range(lo, hi):
        r = min(m, hi - i) + 1
        rows = slice(i, i + r)
        v, tau = _householder(np.array(x[:r], dtype=float) if i == lo else h[rows, i - 1].copy())
        _reflect_rows(h, rows, v, tau)
        if i > lo:
            h[i + 1:i + r, i - 1] = 0.0
        _reflect_cols(t[0], rows, v, tau)
        for k in range(len(t) - 1):
            tk = t[k]
            for c in range(i, i + r - 1):
                part = slice(c, i + r)
                v, tau = _householder(tk[part, c].copy())
                _reflect_rows(tk, part, v, tau)
                tk[c + 1:i + r, c] = 0.0
                _reflect_cols(t[k + 1], part, v, tau)


def _column_rotation(a: float, b: float) -> np.ndarray:
    """The rotation G with (a, b) G = (0, r)."""
    r = float(np.hypot(a, b))
    if r == 0.0:
        return np.eye(2)
    c, s = b / r, a / r
    return np.array([[c, s], [-s, c]])


def _transfer_zero(t: list[np.ndarray], j: int, hi: int) -> None:
    """A triangular factor has an exact zero at (j, j), j < hi, so the product is reduced between
    rows j and j+1 while the Hessenberg factor need not be: rotations from the bottom of the
    window up to j+1 make the Hessenberg factor's subdiagonal (j+1, j) zero (as SLICOT MB03WD
    does), keeping every factor in its form.  The leftover fill of T_1 at (j+1, j) is zero in
    exact arithmetic (the invariant subspace of the first j+1 axes is kept) and is set so."""
    h = t[-1]
    for kk in range(hi, j, -1):
        pair = [kk - 1, kk]
        for k in range(len(t) - 1, 0, -1):
            g = _column_rotation(t[k][kk, kk - 1], t[k][kk, kk])
            t[k][:, pair] = t[k][:, pair] @ g
            t[k][kk, kk - 1] = 0.0
            t[k - 1][pair, :] = g.T @ t[k - 1][pair, :]
        if kk < hi:
            pair = [kk, kk + 1]
            g = _column_rotation(t[0][kk + 1, kk], t[0][kk + 1, kk + 1])
            t[0][:, pair] = t[0][:, pair] @ g
            t[0][kk + 1, kk] = 0.0
            h[pair, :] = g.T @ h[pair, :]
    t[0][j + 1, j] = 0.0
    h[j + 1, j] = 0.0


def _zero_diagonal(t: list[np.ndarray], norms: list[float], lo: int, hi: int) -> int | None:
    """The first j in lo..hi-1 where a triangular factor's diagonal is below round-off of the
    factor's norm (then set to exactly zero), or None."""
    for k, tk in enumerate(t[:-1]):
        d = np.abs(np.diagonal(tk)[lo:hi])
        small = np.flatnonzero(d <= _EPS * norms[k])
        if small.size:
            j = lo + int(small[0])
            tk[j, j] = 0.0
            return j
    return None


def _triangular_product(t: list[np.ndarray], idx: slice) -> np.ndarray:
    """The diagonal block idx of T_(K-1) ... T_1 (triangular, so the product of the blocks)."""
    out = None
    for tk in t[:-1]:
        block = tk[idx, idx]
        out = block if out is None else block @ out
    return out


def _shift_column(t: list[np.ndarray], lo: int, hi: int, s: float, p: float) -> np.ndarray:
    """The first column of P^2 - s P + p I on the window (entries lo..lo+2), P the product."""
    idx = slice(lo, lo + 3)
    r = _triangular_product(t, idx)
    h = t[-1][idx, idx]
    y = h @ r[:, 0]
    x = h @ (r @ y) - s * y
    x[0] += p
    return x


def _bottom_2x2(t: list[np.ndarray], hi: int) -> np.ndarray:
    """The trailing 2x2 block (rows/columns hi-1, hi) of the product on the window."""
    c = max(hi - 2, 0)
    idx = slice(c, hi + 1)
    r = _triangular_product(t, idx)
    return t[-1][hi - 1:hi + 1, idx] @ r[:, -2:]


def _negligible(h: np.ndarray, i: int) -> bool:
    """The Hessenberg factor's subdiagonal h[i, i-1] is below round-off of its neighbours."""
    sub = abs(h[i, i - 1])
    near = abs(h[i - 1, i - 1]) + abs(h[i, i])
    if near == 0.0:
        near = np.max(np.abs(h))
    return sub <= _EPS * near or sub <= _TINY


def _diagonal(t: list[np.ndarray], i: int) -> float:
    return float(np.prod([tk[i, i] for tk in t]))


def _block_product(t: list[np.ndarray], l: int):
    """The 2x2 product of the factors' blocks l, l+1: its trace, determinant, discriminant."""
    idx = slice(l, l + 2)
    b = t[-1][idx, idx] @ _triangular_product(t, idx)
    tr = b[0, 0] + b[1, 1]
    det = b[0, 0] * b[1, 1] - b[0, 1] * b[1, 0]
    disc = (0.5 * (b[0, 0] - b[1, 1])) ** 2 + b[0, 1] * b[1, 0]
    return tr, det, disc


def _roots(t: list[np.ndarray], l: int):
    """The eigenvalues of the 2x2 product of block l, l+1: a complex pair with its modulus
    sqrt(prod |det B_k|) from the factors' own determinants, or two real roots."""
    tr, det, disc = _block_product(t, l)
    if disc < 0.0:
        h = t[-1]
        modulus = np.sqrt(abs(h[l, l] * h[l + 1, l + 1] - h[l, l + 1] * h[l + 1, l])
                          * np.prod([abs(tk[l, l] * tk[l + 1, l + 1]) for tk in t[:-1]]))
        z = complex(0.5 * tr, np.sqrt(-disc))
        z *= modulus / abs(z)
        return z, z.conjugate()
    big = 0.5 * tr + np.copysign(np.sqrt(disc), tr)
    return big, (det / big if big != 0.0 else 0.0)


def _two_by_two(t: list[np.ndarray], l: int):
    """The two eigenvalues of the deflated 2x2 block l, l+1.  A clearly complex pair (argument
    above 1e-3 from the real axis) comes from the block's product (_roots).  Otherwise single-
    shift periodic QR steps split the block into two 1x1 blocks (quadratic convergence), whose
    multipliers are the products of the factors' diagonals, accurate however far apart the two
    are; a pair that does not split in 30 steps (a double or nearly double multiplier, or a
    complex pair within 1e-3 of the real axis) comes from the block's product."""
    tr, _, disc = _block_product(t, l)
    if disc < 0.0 and -disc > 1e-6 * (0.5 * tr) ** 2:
        return _roots(t, l)
    h = t[-1]
    idx = slice(l, l + 2)
    for _ in range(30):
        if _negligible(h, l + 1):
            h[l + 1, l] = 0.0
            return _diagonal(t, l), _diagonal(t, l + 1)
        b = _bottom_2x2(t, l + 1)
        tr = b[0, 0] + b[1, 1]
        disc = max((0.5 * (b[0, 0] - b[1, 1])) ** 2 + b[0, 1] * b[1, 0], 0.0)
        roots = (0.5 * tr + np.sqrt(disc), 0.5 * tr - np.sqrt(disc))
        sigma = min(roots, key=lambda z: abs(z - b[1, 1]))
        x = h[idx, idx] @ _triangular_product(t, idx)[:, 0]
        x[0] -= sigma
        _sweep(t, l, l + 1, x)
    return _roots(t, l)


class _NoConvergence(Exception):
    pass


def product_eigenvalues(factors) -> np.ndarray:
    """The eigenvalues of A_K ... A_1 for factors = [A_1, ..., A_K] (square, same size, finite),
    by the periodic QR algorithm: unordered, complex.  Should the shifted sweeps stall (a cycle
    of shifts: not met on the random, singular, orthogonal and commuting products of
    tests/test_floquet.py), the algorithm
    is run once more on the factors in a fixed random orthogonal basis Q (A_1 Q, Q^T A_K: the
    same product), then raises SolverError."""
    t = [np.array(a, dtype=float) for a in factors]
    try:
        return _periodic_qr([tk.copy() for tk in t])
    except _NoConvergence:
        pass
    n = t[0].shape[0]
    q = np.linalg.qr(np.random.default_rng(20261126).standard_normal((n, n)))[0]
    t[0] = t[0] @ q
    t[-1] = q.T @ t[-1]
    try:
        return _periodic_qr(t)
    except _NoConvergence as exc:
        raise SolverError(str(exc)) from None


def _periodic_qr(t: list[np.ndarray]) -> np.ndarray:
    n = t[0].shape[0]
    # Exact power-of-two scaling of each factor to |A_k|max ~ 1; undone at the end.
    exponent = 0
    for k, tk in enumerate(t):
        big = np.max(np.abs(tk)) if n else 0.0
        if big == 0.0:
            return np.zeros(n, dtype=complex)
        e = int(np.frexp(big)[1])
        t[k] = np.ldexp(tk, -e)
        exponent += e
    _hessenberg_triangular(t)
    norms = [float(np.linalg.norm(tk)) for tk in t]  # Frobenius: kept by orthogonal steps
    h = t[-1]
    mu = np.zeros(n, dtype=complex)
    hi = n - 1
    iterations = 0
    total = 0
    while hi >= 0:
        lo = hi
        while lo > 0 and not _negligible(h, lo):
            lo -= 1
        if lo > 0:
            h[lo, lo - 1] = 0.0
        j = _zero_diagonal(t, norms, lo, hi)
        if j is not None:
            _transfer_zero(t, j, hi)
            continue
        if lo == hi:
            mu[hi] = _diagonal(t, hi)
            hi -= 1
            iterations = 0
            continue
        if lo == hi - 1:
            mu[lo], mu[hi] = _two_by_two(t, lo)
            hi -= 2
            iterations = 0
            continue
        iterations += 1
        total += 1
        if total > 40 * n:
            raise _NoConvergence(f"product_eigenvalues: the periodic QR algorithm did not converge "
                              f"in {total} sweeps ({n}x{n}, {len(t)} factors)")
        b = _bottom_2x2(t, hi)
        if iterations % 11 == 0:
            # exceptional shift (as LAPACK's dlahqr): break a cycle of the standard shifts
            w = abs(h[hi, hi - 1]) + abs(h[hi - 1, hi - 2])
            w *= abs(np.prod([tk[hi, hi] for tk in t[:-1]])) or 1.0
            s, p = 1.5 * w, w * w
        else:
            s = b[0, 0] + b[1, 1]
            p = b[0, 0] * b[1, 1] - b[0, 1] * b[1, 0]
        _sweep(t, lo, hi, _shift_column(t, lo, hi, s, p))
    return np.ldexp(mu.real, exponent) + 1j * np.ldexp(mu.imag, exponent)

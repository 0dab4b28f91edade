"""Sampling without libm: the drive phase the trajectory carries from one sample to the next
(tmafm_trajectory next_phase), and the recurrence that samples an exact flight
(tmafm_flight sample: each modal term turned by exp(lambda dt) per sample).

Both are re-anchored (sin/cos, exp) every 32 samples; the bounds below are what that leaves
of round-off, and far below what a wrong rotation, a wrong step or a missing anchor gives.
"""

import math

import mpmath
import numpy as np
import pytest

import tmafm
from testcore import core as _core

from conftest import INPUTS, write_nml

EPS = np.finfo(float).eps
ANCHOR_EVERY = 32          # phase_anchor_every (trajectory) and anchor_every (flight)


@pytest.mark.parametrize("method", ["flight_exact", "dop853", "rk4_paper"])
def test_drive_phase_of_the_samples_is_sin_omega_tau(method):
    """V_T - p.a - delta_hat is alpha2 sin(Omega tau) at every sample, and the rate's drive
    term alpha2 Omega cos(Omega tau), to the rounding of Omega tau itself plus the drift of at
    most 31 angle additions (a few ulp each): |error| <= alpha2 eps (4 * 32 + 2 |Omega tau|),
    plus the rounding of the sums p.a (N products, summed in another order here).  Without
    the anchors (measured by building with phase_anchor_every = 10^6) the drift over these
    31 416 samples reaches 7e-13 alpha2, 2.3x this bound; with them it stays at 0.4x."""
    scene = tmafm.Config("fig2_n4").scene
    alpha2, omega, delta = scene["alpha2"], scene["omega"], scene["delta_hat"]
    r = tmafm.run("fig2_n4", solver={"method": method, "tau_end": 100 * 2 * math.pi / omega},
                  output={"sample_dtau": 0.01})
    assert len(r.tau) == 31416
    p = tmafm.Model("fig2_n4").tip
    phase = omega * r.tau
    drift = alpha2 * EPS * (4 * ANCHOR_EVERY + 2 * np.abs(phase))
    sums = 8 * EPS * (np.abs(r.a) @ np.abs(p) + alpha2 + abs(delta))
    drive = r.vt - r.a @ p - delta
    assert np.all(np.abs(drive - alpha2 * np.sin(phase)) <= drift + sums)
    sums_rate = 8 * EPS * (np.abs(r.adot) @ np.abs(p) + alpha2 * omega)
    rate = r.vtdot - r.adot @ p
    assert np.all(np.abs(rate - alpha2 * omega * np.cos(phase)) <= omega * drift + sums_rate)
    # The contact flags are those of the stored V_T.
    np.testing.assert_array_equal(r.contact, (r.vt <= 0).astype(np.int8))


def flight_samples(tmp_path, tau0, y0, n_samples, dt=0.01, **scene):
    path = write_nml(tmp_path / "flight.nml", base=INPUTS / "fig2_n4.nml", scene=scene)
    recurrence, direct, ierr, errmsg = _core.flight_samples(str(path), tau0, y0, dt, n_samples)
    assert ierr == 0, errmsg
    return path, recurrence.T, direct.T


# A state as the Fig. 2 motion leaves a contact (a, a'), at tau0 = 300: late in a long run.
Y0 = np.array([-2.8e-4, 4.6e-5, 3.7e-6, -9.5e-7, -8.8e-4, -6.1e-4, 5.2e-5, 1.8e-5])


def largest_rate(path, alpha3):
    """max |lambda| of the free system A = [0, I; -M^-1 Lambda, -alpha3 M^-1] of a namelist."""
    f = tmafm.Model(str(path))._f
    n = int(f.n_modes)
    a = np.zeros((2 * n, 2 * n))
    a[:n, n:] = np.eye(n)
    a[n:, :n] = -np.array(f.inv_mass_eigen)
    a[n:, n:] = -alpha3 * np.array(f.inv_mass)
    return np.max(np.abs(np.linalg.eigvals(a)))


@pytest.mark.parametrize("alpha3", [0.4, 0.05, 0.0])
def test_flight_samples_equal_direct_evaluation(tmp_path, alpha3):
    """Over a flight of 20 000 samples (200 time units, 64 drive periods; no contact) the
    recurrence equals exp(lambda s) evaluated at every sample to 1e-13 of the state's size.
    Undamped (alpha3 = 0) the terms do not decay, and neither does the rounding of the direct
    evaluation's own argument lambda s (|lambda| s eps, up to 2.5e-12 at s = 200 for
    |lambda| = 114): there the bound is that rounding, twice."""
    path, recurrence, direct = flight_samples(tmp_path, 300.0, Y0, 20000, alpha3=alpha3,
                                              delta_hat=1.0)
    scale = np.max(np.abs(direct))
    assert scale > 1e-4
    bound = 1e-13 if alpha3 > 0 else 2 * EPS * largest_rate(path, alpha3) * 200.0
    assert np.max(np.abs(recurrence - direct)) <= bound * scale


@pytest.mark.parametrize("n_modes", [3, 5])
def test_flight_samples_of_the_general_kernel(tmp_path, n_modes):
    """N = 4 with four pairs (Fig. 2) has its own fixed-shape sample kernel; any other N takes
    the general one (row blocks of 8, the mode count at run time): it too equals direct
    evaluation to 1e-13 of the state over 2 000 samples."""
    a = np.resize(Y0[:4], n_modes) * (0.5 ** np.arange(n_modes))
    adot = np.resize(Y0[4:], n_modes) * (0.5 ** np.arange(n_modes))
    y0 = np.concatenate([a, adot])
    path = write_nml(tmp_path / "flight.nml", base=INPUTS / "fig2_n4.nml",
                     model={"n_modes": n_modes}, initial={"a0": [0.0] * n_modes},
                     scene={"delta_hat": 1.0})
    recurrence, direct, ierr, errmsg = _core.flight_samples(str(path), 300.0, y0, 0.01, 2000)
    assert ierr == 0, errmsg
    direct = direct.T
    scale = np.max(np.abs(direct))
    assert scale > 1e-5
    assert np.max(np.abs(recurrence.T - direct)) <= 1e-13 * scale


@pytest.mark.parametrize("n_modes", [1, 3, 4, 6])
def test_gap_rows_is_gap_at_phase_bit_for_bit(tmp_path, n_modes):
    """The trajectory's rows take V_T and its rate from model%gap_rows, a table at a time (a
    mode at a time down the rows from 8 rows up, else a row at a time): the sums of
    gap_at_phase, their one definition, in its order, so the same bits; no row outside
    first .. first + count - 1 is touched.  model%gap_rows through _core.gap_rows, which checks
    the rows are inside the table (f90wrap does not wrap it: nothing there checks them)."""
    path = write_nml(tmp_path / "gap.nml", base=INPUTS / "fig2_n4.nml",
                     model={"n_modes": n_modes}, initial={"a0": [0.0] * n_modes},
                     scene={"delta_hat": 0.0})
    f = tmafm.Model(str(path))._f
    rng = np.random.default_rng(7)
    rows = 80
    a = np.asfortranarray(rng.standard_normal((rows, n_modes)) * 1e-3)
    adot = np.asfortranarray(rng.standard_normal((rows, n_modes)) * 1e-3)
    phase = rng.uniform(0.0, 2 * np.pi, rows)
    a[5], adot[5], phase[5] = 0.0, 0.0, 0.0            # V_T = 0 exactly
    s, c = np.sin(phase), np.cos(phase)
    for first, count in [(1, 1), (4, 7), (2, 8), (5, 64), (80, 1)]:
        rows_of = slice(first - 1, first - 1 + count)
        vt = np.full(rows, np.nan)
        vtdot = np.full(rows, np.nan)
        ierr, errmsg = _core.gap_rows(str(path), first, a, adot, s[rows_of].copy(), c[rows_of].copy(),
                                      vt, vtdot)
        assert ierr == 0, errmsg
        pairs = [f.gap_at_phase(np.concatenate([a[i], adot[i]]), s[i], c[i])
                 for i in range(first - 1, first - 1 + count)]
        want = np.array(pairs, dtype=float).reshape(count, 2)
        np.testing.assert_array_equal(vt[rows_of].view(np.int64), want[:, 0].view(np.int64))
        np.testing.assert_array_equal(vtdot[rows_of].view(np.int64), want[:, 1].view(np.int64))
        outside = np.ones(rows, bool)
        outside[rows_of] = False
        assert np.all(np.isnan(vt[outside])) and np.all(np.isnan(vtdot[outside]))


def test_gap_rows_refuses_rows_outside_the_table(tmp_path):
    """Rows past the table's end (the reviewer's crash: 200000 rows of a 4-row table), before
    its start or none are refused with err_input and touch nothing; Model._f has no gap_rows."""
    path = write_nml(tmp_path / "gap.nml", base=INPUTS / "fig2_n4.nml")
    assert not hasattr(tmafm.Model(str(path))._f, "gap_rows")
    rows = 4
    a = np.zeros((rows, 4), order="F")
    for first, count in [(1, 200000), (4, 2), (0, 1), (-5, 3), (5, 1)]:
        vt, vtdot = np.full(rows, np.nan), np.full(rows, np.nan)
        ierr, errmsg = _core.gap_rows(str(path), first, a, a.copy(), np.zeros(count), np.zeros(count),
                                      vt, vtdot)
        assert ierr == 2, (first, count)
        assert "not inside the table of 4 rows" in errmsg.decode(), errmsg
        assert np.all(np.isnan(vt)) and np.all(np.isnan(vtdot))
    ierr, errmsg = _core.gap_rows(str(path), 1, np.zeros((rows, 3), order="F"), np.zeros((rows, 3), order="F"),
                                  np.zeros(1), np.zeros(1), vt, vtdot)
    assert ierr == 2 and "n_modes = 3 of the call does not match" in errmsg.decode(), errmsg


def exact_flight(model_fields, tau0, y0, dt, n_samples):
    """The free flight of y' = A y + b_s sin(Omega tau) + b_c cos(Omega tau) from y0 at tau0,
    in 40-digit arithmetic for the model's double-precision A, b_s, b_c: y = y_p + e^{A s} h."""
    ime, im, ds, dc, alpha3, omega = model_fields
    n = len(ds)
    mpmath.mp.dps = 40
    a = mpmath.zeros(2 * n, 2 * n)
    for i in range(n):
        a[i, n + i] = 1
        for j in range(n):
            a[n + i, j] = -mpmath.mpf(ime[i, j])
            a[n + i, n + j] = -mpmath.mpf(alpha3) * mpmath.mpf(im[i, j])
    m = 2 * n
    system, rhs = mpmath.zeros(2 * m, 2 * m), mpmath.zeros(2 * m, 1)
    om = mpmath.mpf(omega)
    for i in range(m):
        for j in range(m):
            system[i, j] = system[m + i, m + j] = a[i, j]
        system[i, m + i], system[m + i, i] = om, -om
    for i in range(n):
        rhs[n + i], rhs[m + n + i] = -mpmath.mpf(ds[i]), -mpmath.mpf(dc[i])
    uv = mpmath.lu_solve(system, rhs)
    u, v = uv[:m, 0], uv[m:, 0]
    step = mpmath.expm(a * mpmath.mpf(dt))
    t0 = mpmath.mpf(tau0)
    h = mpmath.matrix([mpmath.mpf(x) for x in y0]) - (u * mpmath.sin(om * t0) + v * mpmath.cos(om * t0))
    out = np.empty((n_samples, m))
    for k in range(n_samples):
        t = om * (t0 + k * mpmath.mpf(dt))
        out[k] = [float(x) for x in h + u * mpmath.sin(t) + v * mpmath.cos(t)]
        h = step * h
    return out


@pytest.mark.parametrize("alpha3", [0.05, 0.0])
def test_flight_samples_are_the_exact_solution(tmp_path, alpha3):
    """Against the exact flight (40 digits, the same double-precision A): the recurrence errs
    no more than direct evaluation does (both 1e-14 to 1e-13 of the state: the rounding of Omega tau
    and lambda s, and the conditioning of the eigenvectors), over 1000 samples (31 anchors)."""
    path, recurrence, direct = flight_samples(tmp_path, 300.0, Y0, 1000, alpha3=alpha3,
                                              delta_hat=1.0)
    model = tmafm.Model(str(path))
    f = model._f
    fields = (np.array(f.inv_mass_eigen), np.array(f.inv_mass), np.array(f.drive_sin),
              np.array(f.drive_cos), model.scene["alpha3"], model.scene["omega"])
    exact = exact_flight(fields, 300.0, Y0, 0.01, 1000)
    scale = np.max(np.abs(exact))
    error_direct = np.max(np.abs(direct - exact)) / scale
    error_recurrence = np.max(np.abs(recurrence - exact)) / scale
    assert error_direct <= 1e-12, error_direct
    assert error_recurrence <= 2 * error_direct + 10 * EPS, (error_recurrence, error_direct)


@pytest.mark.parametrize("method", ["rk4_paper", "rk4_event", "dopri5", "dop853", "flight_exact"])
def test_run_ends_at_the_last_sample_before_tau_end(method):
    """README: the run stops at the largest k sample_dtau <= tau_end; it does no work beyond it."""
    def run(tau_end):
        return tmafm.run(tmafm.Config("fig2_n4", solver={"method": method, "tau_end": tau_end},
                                      output={"sample_dtau": 0.5}))
    on_grid, between = run(8.5), run(8.95)
    assert between.tau[-1] == 8.5 and len(between.tau) == 18
    assert between.counters == on_grid.counters
    assert np.array_equal(between.switches, on_grid.switches)
    assert np.array_equal(between.a, on_grid.a)
    # One more sample is one more sample of work.
    assert run(9.0).counters["steps"] > on_grid.counters["steps"]

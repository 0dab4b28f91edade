"""The right-hand side kernel (tmafm_model) and the free-flight scan (tmafm_flight).

The reference file tests/data/rhs_reference.npz holds the right-hand side of the code as it
was before the kernel was rewritten (tests/data/make_rhs_reference.py says how it was made).
"""

import math
from pathlib import Path

import f90nml
import numpy as np
import pytest

import tmafm
from tmafm import _core

DATA = Path(__file__).resolve().parent / "data" / "rhs_reference.npz"
SCENES = ({}, {"xi0": 0.8, "theta": 0.2, "alpha4": 0.0})   # as in make_rhs_reference.py

# Tolerance against the old kernel, norm-wise per case.  Each acceleration is a sum of at
# most 2N + 4 <= 64 products (the B pass, the drive, the tip and moment terms), summed in a
# different order and with differently rounded coefficients (-alpha3 M^-1 folded at set-up,
# sin theta1 from the slope algebraically instead of through atan).  Recursive summation of
# k terms errs by at most k u sum|terms| (u = 1.1e-16), and the same holds for the old code,
# so two evaluations differ by at most 2 k u sum|terms| <= 1.4e-14 sum|terms|, which is
# attained only if every rounding has the same sign; as a random walk the bound is
# ~2 sqrt(k) u ~ 2e-15.  sum|terms| / |result| is ~1 at these random states (no
# cancellation: the largest term, beta_N^4 a_N, dominates).  1e-14 is therefore a bound
# that the reordering cannot reach, while any wrong term (a dropped product, a swapped
# sign, a wrong phase) moves the result by far more than that.
REFERENCE_RTOL = 1e-14


def _reference_cases():
    with np.load(DATA) as npz:
        d = {key: npz[key] for key in npz.files}
    offsets = np.concatenate([[0], np.cumsum(d["n"])])
    for k, n in enumerate(d["n"]):
        yield dict(n=int(n), convention=str(d["convention"][k]), law=str(d["law"][k]),
                   in_contact=bool(d["in_contact"][k]), scene=int(d["scene"][k]),
                   tau=float(d["tau"][k]),
                   a=d["a"][offsets[k]:offsets[k + 1]],
                   adot=d["adot"][offsets[k]:offsets[k + 1]],
                   rate=d["rate"][2 * offsets[k]:2 * offsets[k + 1]])


def _write_case(tmp_path, n, convention, law, scene_index):
    path = tmp_path / f"case_{n}_{convention}_{law}_{scene_index}.nml"
    if not path.exists():
        groups = {"model": {"n_modes": n, "convention": convention, "contact_law": law}}
        if SCENES[scene_index]:
            groups["scene"] = dict(SCENES[scene_index])
        f90nml.write(f90nml.Namelist(groups), str(path), force=True)
    return path


def test_reference_covers_every_combination():
    cases = list(_reference_cases())
    assert len(cases) == 960
    keys = {(c["n"], c["convention"], c["law"], c["in_contact"], c["scene"]) for c in cases}
    assert len(keys) == 30 * 2 * 2 * 2 * 2
    contact = [c for c in cases if c["in_contact"]]
    # In contact the force is on: the reference accelerations differ from the free ones.
    assert all(np.any(c["rate"][c["n"]:] != 0) for c in contact)


def test_derivative_equals_the_old_kernel(tmp_path):
    worst = 0.0
    for case in _reference_cases():
        path = _write_case(tmp_path, case["n"], case["convention"], case["law"], case["scene"])
        *_, rate, ierr, errmsg = _core.model_terms(str(path), case["tau"], case["a"],
                                                   case["adot"], case["in_contact"])
        assert ierr == 0, errmsg
        error = np.linalg.norm(rate - case["rate"]) / np.linalg.norm(case["rate"])
        worst = max(worst, error)
        assert error <= REFERENCE_RTOL, (case["n"], case["convention"], case["law"],
                                         case["in_contact"], case["scene"], error)
    print(f"largest relative difference from the old kernel: {worst:.2e}")


# M is I + alpha1 m m^T with |m|^2 <= 4N, so cond(M) <= 1 + 0.05 * 4 * 30 = 7, and numpy's
# solve errs by ~cond(M) N u relative to |F| + |C a'| + |K a|, ~3e-14 at N = 30; the kernel
# errs by ~2N u (see above).  1e-12 norm-wise leaves a factor 30 above both.
EXPLICIT_RTOL = 1e-12


@pytest.mark.parametrize("convention", ["paper", "consistent"])
def test_derivative_is_the_solution_of_the_explicit_system(tmp_path, convention):
    """a'' = M^-1 (F - C a' - K a) with M, C, K, F from model%matrices, for N = 1..30."""
    rng = np.random.default_rng(7)
    for n in (1, 2, 3, 4, 8, 13, 30):
        for law in ("hertz", "dmt"):
            path = tmp_path / f"{n}_{law}.nml"
            f90nml.write(f90nml.Namelist({"model": {"n_modes": n, "convention": convention,
                                                    "contact_law": law},
                                          "scene": {"xi0": 0.9, "theta": 0.3}}),
                         str(path), force=True)
            tip = _core.modes(n, np.array([0.9]), 0)[1][0]
            for in_contact in (False, True):
                j = np.arange(1, n + 1)
                tau = rng.uniform(0, 10)
                a = 1e-3 * rng.uniform(-1, 1, n) / j**2
                adot = 1e-2 * rng.uniform(-1, 1, n) / j
                if in_contact:      # V_T = -1e-4
                    a[0] -= (tip @ a + 5e-4 * math.sin(2 * tau) + 1e-4) / tip[0]
                mass, damping, stiffness, force, rate, ierr, errmsg = _core.model_terms(
                    str(path), tau, a, adot, in_contact)
                assert ierr == 0, errmsg
                expected = np.linalg.solve(mass, force - damping @ adot - stiffness @ a)
                np.testing.assert_array_equal(rate[:n], adot)
                error = np.linalg.norm(rate[n:] - expected) / np.linalg.norm(expected)
                assert error <= EXPLICIT_RTOL, (n, law, in_contact, error)
                if in_contact:      # the contact terms are really on
                    free = _core.model_terms(str(path), tau, a, adot, False)[4]
                    assert np.linalg.norm(free[n:] - rate[n:]) > 1e3 * EXPLICIT_RTOL * np.linalg.norm(expected)

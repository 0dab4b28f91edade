"""The two conventions differ exactly in the errata terms, each tested on its own
(docs/model.md §8).  Every check compares the explicit M, C, K, F of Eq. (15) built with one
correction against the printed forms, and requires every other term to be identical."""

import math

import numpy as np
import pytest

from testcore import core as _core

from conftest import write_nml

N = 4
TAU = 0.7
# K = Lambda - P2 G holds entries up to beta_4^4 ~ 1.5e4, so differences of K carry
# round-off of that size times eps: this is the absolute tolerance on them.
K_ROUNDOFF = 1e-11
OMEGA, ALPHA2, ALPHA4, L_OVER_D, G0_OVER_D = 2.0, 5e-4, 0.4, 60.0, 1.0
A_STATE = np.array([-6.0e-4, 3.0e-5, -2.0e-6, 4.0e-7])   # V_T < 0 at TAU
ADOT = np.array([1e-4, -2e-4, 3e-5, 1e-6])


def terms(tmp_path, errata, xi0=1.0, a=A_STATE, contact=True, law="hertz", convention="paper"):
    path = write_nml(tmp_path / f"{errata}_{xi0}_{law}.nml",
                     model={"n_modes": N, "errata": errata, "contact_law": law,
                            "convention": convention},
                     scene={"xi0": xi0})
    mass, damping, stiffness, force, rate, ierr, errmsg = _core.model_terms(
        str(path), TAU, a, ADOT, contact)
    assert ierr == 0, errmsg
    return dict(M=mass, C=damping, K=stiffness, F=force, rate=rate)


def shapes(xi, order, n=N):
    return _core.modes(n, np.array([xi]), order)[1][0]


def brackets(a, xi0=1.0, signed=False, kappa_scale=1.0):
    p, s = shapes(xi0, 0), shapes(xi0, 1)
    vt = p @ a + ALPHA2 * math.sin(OMEGA * TAU)
    st = _core.contact_state(vt, (s @ a) / L_OVER_D, math.pi / 12, 1.128e-4, 1,
                             6.7665e-5 * kappa_scale, 0.7413 * kappa_scale, signed)
    return st[4], st[5]


def assert_same(x, y, keys):
    for key in keys:
        np.testing.assert_array_equal(x[key], y[key], err_msg=key)


def test_state_is_in_contact():
    p = shapes(1.0, 0)
    assert p @ A_STATE + ALPHA2 * math.sin(OMEGA * TAU) < 0


def test_rate_is_the_solution_of_the_explicit_system(tmp_path):
    for errata in ("none", "all"):
        t = terms(tmp_path, errata, xi0=0.8)
        expected = np.linalg.solve(t["M"], t["F"] - t["C"] @ ADOT - t["K"] @ A_STATE)
        np.testing.assert_allclose(t["rate"][N:], expected, rtol=1e-10, atol=1e-12)
        np.testing.assert_array_equal(t["rate"][:N], ADOT)


def test_e1_base_damping_velocity(tmp_path):
    printed, fixed = terms(tmp_path, "none"), terms(tmp_path, "E1")
    assert_same(printed, fixed, "MCK")
    p = shapes(1.0, 0)
    delta = -ALPHA2 * ALPHA4 * OMEGA * math.cos(OMEGA * TAU) + ALPHA2 * ALPHA4 * math.sin(OMEGA * TAU)
    np.testing.assert_allclose(fixed["F"] - printed["F"], delta * p, rtol=1e-12, atol=1e-18)
    assert abs(delta) > 1e-5
    # Out of contact the term is absent in both.
    assert_same(terms(tmp_path, "none", contact=False), terms(tmp_path, "E1", contact=False), "MCKF")


def test_e2_axial_span_only_matters_inside_the_beam(tmp_path):
    assert_same(terms(tmp_path, "none"), terms(tmp_path, "E2"), "MCKF")
    printed, fixed = terms(tmp_path, "none", xi0=0.8), terms(tmp_path, "E2", xi0=0.8)
    assert_same(printed, fixed, "MCF")
    _, _, p2 = (None, *brackets(A_STATE, xi0=0.8))
    _, g_full, _, g_part, _ = _core.galerkin(N, 0.8)
    np.testing.assert_allclose(fixed["K"] - printed["K"], -p2 * (g_part - g_full),
                               rtol=1e-9, atol=K_ROUNDOFF)


def test_e3_moment_through_slope(tmp_path):
    printed, fixed = terms(tmp_path, "none"), terms(tmp_path, "E3")
    assert_same(printed, fixed, "MCK")
    _, p2 = brackets(A_STATE)
    slope, curvature = shapes(1.0, 1), shapes(1.0, 2)
    np.testing.assert_allclose(fixed["F"] - printed["F"], G0_OVER_D * p2 * (slope - curvature),
                               rtol=1e-9, atol=1e-18)
    assert np.max(np.abs(curvature)) < 1e-11  # the printed moment vanishes at the free end


def test_e4_halves_both_brackets(tmp_path):
    printed, fixed = terms(tmp_path, "none"), terms(tmp_path, "E4")
    free = terms(tmp_path, "none", contact=False)
    assert_same(printed, fixed, "MC")
    lam = np.diag(_core.modes(N, np.array([1.0]), 0)[0] ** 4)
    np.testing.assert_allclose(fixed["K"] - lam, (printed["K"] - lam) / 2, rtol=1e-9,
                               atol=K_ROUNDOFF)
    p1, p2 = brackets(A_STATE)
    p = shapes(1.0, 0)
    contact_push = L_OVER_D * p1 * p + G0_OVER_D * p2 * shapes(1.0, 2)
    np.testing.assert_allclose(fixed["F"] - printed["F"], -contact_push / 2, rtol=1e-9, atol=1e-17)
    assert np.max(np.abs(free["F"] - printed["F"])) > 0


def test_e6_tip_mass_at_xi0(tmp_path):
    assert_same(terms(tmp_path, "none"), terms(tmp_path, "E6"), "MCKF")
    printed, fixed = terms(tmp_path, "none", xi0=0.8), terms(tmp_path, "E6", xi0=0.8)
    assert_same(printed, fixed, "CK")
    at_tip, at_end = shapes(0.8, 0), shapes(1.0, 0)
    np.testing.assert_allclose(fixed["M"] - printed["M"],
                               0.05 * (np.outer(at_tip, at_tip) - np.outer(at_end, at_end)),
                               rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(fixed["F"] - printed["F"],
                               ALPHA2 * OMEGA**2 * 0.05 * (at_tip - at_end) * math.sin(OMEGA * TAU),
                               rtol=1e-10, atol=1e-18)


def test_e7_signed_slope(tmp_path):
    slope, p = shapes(1.0, 1), shapes(1.0, 0)
    # Two states in contact: the tip slope negative (both forms of theta1 agree) and positive.
    negative = A_STATE
    positive = A_STATE * np.array([1.0, -10.0, 1.0, 1.0])
    assert slope @ negative < 0 < slope @ positive
    assert p @ positive + ALPHA2 * math.sin(OMEGA * TAU) < 0
    assert_same(terms(tmp_path, "none", a=negative), terms(tmp_path, "E7", a=negative), "MCKF")
    printed, fixed = terms(tmp_path, "none", a=positive), terms(tmp_path, "E7", a=positive)
    assert_same(printed, fixed, "MC")
    p1, p2 = brackets(positive, signed=True)
    lam = np.diag(_core.modes(N, np.array([1.0]), 0)[0] ** 4)
    _, g, *_ = _core.galerkin(N, 1.0)
    np.testing.assert_allclose(fixed["K"] - lam, -p2 * g, rtol=1e-9, atol=K_ROUNDOFF)
    assert np.max(np.abs(fixed["K"] - printed["K"])) > 0


@pytest.mark.parametrize("law", ["hertz", "dmt"])
def test_conventions_are_exactly_the_errata_sets(tmp_path, law):
    for xi0 in (1.0, 0.8):
        assert_same(terms(tmp_path, "convention", xi0=xi0, law=law, convention="paper"),
                    terms(tmp_path, "none", xi0=xi0, law=law), "MCKF")
        assert_same(terms(tmp_path, "convention", xi0=xi0, law=law, convention="consistent"),
                    terms(tmp_path, "E1,E2,E3,E4,E6,E7", xi0=xi0, law=law), "MCKF")

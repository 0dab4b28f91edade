"""tmafm.Model: the core's model_t in Python, checked against the integrators' own steps, closed
forms of the Galerkin data (mpmath, an independent oracle on purpose), and its own identities."""

import itertools

import numpy as np
import pytest

import tmafm

mpmath = pytest.importorskip("mpmath")

CASES = list(itertools.product(("paper", "consistent"), ("hertz", "dmt")))


def _model(convention="paper", law="hertz", n=4, **scene):
    groups = {"model": {"n_modes": n, "convention": convention, "contact_law": law}}
    if scene:
        groups["scene"] = scene
    return tmafm.Model(groups)


def _state(rng, model, contact):
    """A random state whose tip gap V_T(0) has the sign of the phase asked for."""
    n = model.n_modes
    a = rng.uniform(-1e-3, 1e-3, n)
    adot = rng.uniform(-1e-2, 1e-2, n)
    vt = model.tip @ a + model.scene["delta_hat"]
    shift = (abs(vt) + 2e-4) * (-1 if contact else 1) - vt
    a[0] += shift / model.tip[0]
    return a, adot


@pytest.mark.parametrize("convention,law", CASES)
@pytest.mark.parametrize("contact", [False, True])
def test_derivative_is_the_integrators_rhs(convention, law, contact):
    """One rk4_paper step of the core equals RK4 built on Model.derivative (same phase rule)."""
    rng = np.random.default_rng(7 + contact)
    model = _model(convention, law, xi0=0.9)
    h = 1e-3
    for _ in range(3):
        a, adot = _state(rng, model, contact)
        assert (model.contact(0.0, a).vt <= 0) == contact
        result = tmafm.run({"model": {"n_modes": 4, "convention": convention, "contact_law": law},
                            "scene": {"xi0": 0.9},
                            "initial": {"a0": list(a), "adot0": list(adot)},
                            "solver": {"method": "rk4_paper", "dtau": h, "contact_refine": 1,
                                       "tau_end": h},
                            "output": {"sample_dtau": h}})
        y = np.concatenate([a, adot])
        f = lambda tau, state: model.derivative(tau, state, contact)  # noqa: E731
        k1 = f(0.0, y)
        k2 = f(h / 2, y + h / 2 * k1)
        k3 = f(h / 2, y + h / 2 * k2)
        k4 = f(h, y + h * k3)
        expected = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        got = np.concatenate([result.a[-1], result.adot[-1]])
        # The same arithmetic in another order: round-off of a few ulps of the state's scale.
        scale = np.abs(y).max() + h * np.abs(k1).max()
        np.testing.assert_allclose(got, expected, rtol=0, atol=64 * np.finfo(float).eps * scale)
        assert result.contact[0] == contact


@pytest.mark.parametrize("convention,law", CASES)
@pytest.mark.parametrize("contact", [False, True])
def test_matrices_reproduce_derivative(convention, law, contact):
    """a'' = M^-1 (F - C a' - K a) from Model.matrices equals Model.derivative."""
    rng = np.random.default_rng(11)
    model = _model(convention, law, n=6, xi0=0.95)
    for tau in rng.uniform(0, 10, 4):
        a, adot = _state(rng, model, contact)
        mass, damping, stiffness, force = model.matrices(tau, a, contact)
        accel = np.linalg.solve(mass, force - damping @ adot - stiffness @ a)
        rate = model.derivative(tau, np.concatenate([a, adot]), contact)
        np.testing.assert_array_equal(rate[:6], adot)
        scale = np.abs(mass).max() * np.abs(accel).max() + np.abs(force).max() \
            + np.abs(stiffness @ a).max() + np.abs(damping @ adot).max()
        np.testing.assert_allclose(rate[6:], accel, rtol=0, atol=1e3 * np.finfo(float).eps * scale)
        assert np.allclose(mass, model.mass)


@pytest.mark.parametrize("convention,law", CASES)
def test_energy_flow_sums_to_the_energy_rate(convention, law):
    """dE/dtau = a'.(M a'' + Lambda a) equals the sum of the powers, in both phases."""
    rng = np.random.default_rng(3)
    model = _model(convention, law, n=5, xi0=0.9)
    for contact in (False, True):
        a, adot = _state(rng, model, contact)
        flow = model.energy_flow(0.3, a, adot, contact)
        accel = model.derivative(0.3, np.concatenate([a, adot]), contact)[5:]
        rate = adot @ (model.mass @ accel) + adot @ (model.eigen * a)
        powers = sum(flow[name] for name in tmafm.POWER_NAMES)
        assert powers == pytest.approx(rate, rel=1e-10, abs=1e-14)
        assert flow["energy"] == pytest.approx(0.5 * adot @ model.mass @ adot
                                               + 0.5 * a @ (model.eigen * a), rel=1e-13)
        if not contact:
            assert flow["contact_normal"] == flow["contact_friction"] == 0


def test_contact_state_is_consistent():
    model = _model("consistent", "dmt")
    s = model.scene
    a = np.array([-2e-3, 1e-4, 0.0, 0.0])
    state = model.contact(0.4, a)
    assert state.vt == pytest.approx(model.tip @ a + s["alpha2"] * np.sin(s["omega"] * 0.4)
                                     + s["delta_hat"], rel=1e-14)
    assert state.radius == pytest.approx(np.sqrt(-state.vt * np.sin(state.theta1) / s["beta"]),
                                         rel=1e-14)
    assert state.normal == pytest.approx(state.radius ** 3 - 4 / 3, rel=1e-14)


def _clamped_free(j, xi):
    """Mode j of the clamped-free beam and its slope at xi, and its integral (mpmath)."""
    beta = mpmath.findroot(lambda b: mpmath.cos(b) * mpmath.cosh(b) + 1, (2 * j - 1) * mpmath.pi / 2)
    sigma = (mpmath.cosh(beta) + mpmath.cos(beta)) / (mpmath.sinh(beta) + mpmath.sin(beta))
    x = beta * xi
    phi = mpmath.cosh(x) - mpmath.cos(x) - sigma * (mpmath.sinh(x) - mpmath.sin(x))
    slope = beta * (mpmath.sinh(x) + mpmath.sin(x) - sigma * (mpmath.cosh(x) - mpmath.cos(x)))
    integral = (mpmath.sinh(beta) - mpmath.sin(beta)
                - sigma * (mpmath.cosh(beta) + mpmath.cos(beta) - 2)) / beta
    return float(beta), float(phi), float(slope), float(integral)


def test_galerkin_data_match_closed_forms_for_every_n():
    mpmath.mp.dps = 80
    xi0 = 0.85
    exact = np.array([_clamped_free(j, xi0) for j in range(1, 31)])
    at_one = np.array([_clamped_free(j, 1)[1] for j in range(1, 31)])
    for n in range(1, 31):
        model = _model("paper", "hertz", n=n, xi0=xi0, alpha1=0.05)
        assert model.n_modes == n
        np.testing.assert_allclose(model.beta, exact[:n, 0], rtol=1e-13)
        # phi grows like cosh(beta xi) term by term and cancels to O(1): the core's error
        # is that cancellation, about eps * exp(beta) / 2 relative to 1.
        tol = 10 * np.finfo(float).eps * np.exp(exact[:n, 0]) + 1e-12
        np.testing.assert_allclose(model.tip, exact[:n, 1], rtol=0, atol=tol.max())
        np.testing.assert_allclose(model.slope, exact[:n, 2], rtol=0,
                                   atol=(tol * exact[:n, 0]).max())
        np.testing.assert_allclose(model.integral, exact[:n, 3], rtol=0, atol=1e-12)
        m = at_one[:n]  # the printed tip mass sits at xi = 1
        np.testing.assert_allclose(model.mass, np.eye(n) + 0.05 * np.outer(m, m), rtol=0,
                                   atol=tol.max())


def test_model_from_config_and_overrides_agree():
    config = tmafm.Config("fig2_n4", model={"convention": "consistent"})
    a = tmafm.Model(config)
    b = tmafm.Model("fig2_n4", model={"convention": "consistent"})
    y = np.linspace(-1e-3, 1e-3, 8)
    np.testing.assert_array_equal(a.derivative(1.0, y, True), b.derivative(1.0, y, True))
    assert a.scene == config.scene
    assert np.array_equal(a.mass, config.model().mass)


@pytest.mark.parametrize("call", [
    lambda m: m.derivative(0.0, np.zeros(7), False),
    lambda m: m.derivative(0.0, np.zeros((2, 4)), False),
    lambda m: m.matrices(0.0, np.zeros(5), True),
    lambda m: m.contact(0.0, [0.0]),
    lambda m: m.energy_flow(0.0, np.zeros(4), np.zeros(3), True),
])
def test_wrong_shapes_are_input_errors(call):
    with pytest.raises(tmafm.InputError, match="shape"):
        call(_model())


@pytest.mark.parametrize("call,match", [
    (lambda m: m.derivative("soon", np.zeros(8), False), "tau"),
    (lambda m: m.derivative(float("nan"), np.zeros(8), False), "tau"),
    (lambda m: m.derivative(0.0, ["a"] * 8, False), "numbers"),
    (lambda m: m.contact(None, np.zeros(4)), "tau"),
    (lambda m: m.trajectory_energy_flow(np.zeros((2, 2)), np.zeros((4, 4)), np.zeros((4, 4)),
                                        np.zeros(4)), "samples"),
])
def test_bad_arguments_are_input_errors(call, match):
    with pytest.raises(tmafm.InputError, match=match):
        call(_model())

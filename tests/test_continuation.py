"""tmafm.continuation: the stroboscopic map's monodromy matrix against finite differences,
periodic orbits and their multipliers against brute-force runs, folds and period doublings
against sweeps, reproducibility, and typed errors (docs/continuation.md)."""

from pathlib import Path

import numpy as np
import pytest

import tmafm
from tmafm import continuation as cont

BISTABLE = str(Path(__file__).resolve().parents[1] / "inputs" / "sweeps" / "bistable_n2.nml")


def _settled(model, periods=80, rtol=1e-9):
    """A state near the attractor reached from rest: the map iterated `periods` times."""
    y = np.zeros(2 * model.n_modes)
    for _ in range(periods):
        y = cont.periodic_map(model, y, 1, rtol).y
    return y


# --- The monodromy matrix equals the finite-difference Jacobian of the map -----------------

@pytest.mark.parametrize("name, overrides", [
    ("hertz", {"scene": {"delta_hat": 0.0005, "alpha4": 0.0}}),
    ("dmt", {"scene": {"delta_hat": 0.0005, "alpha4": 0.0}, "model": {"contact_law": "dmt"}}),
    ("damped", {"scene": {"delta_hat": 0.0005, "alpha4": 0.4}}),
    ("damped_dmt", {"scene": {"delta_hat": 0.0005, "alpha4": 0.4}, "model": {"contact_law": "dmt"}}),
])
def test_monodromy_equals_finite_differences(name, overrides):
    """Central differences of P with step h = 1e-5 of the state's size: truncation error
    O(h^2) ~ 1e-10 and the map's tolerance rtol/h ~ 1e-8 relative, against the 1e-6 asked."""
    model = tmafm.Model(BISTABLE, **overrides)
    y = _settled(model)
    out = cont.periodic_map(model, y, 1, 1e-13)
    assert out.stats["contacts"] == 1  # a tapping orbit: one contact begun, with its switches
    assert out.stats["gap_min"] < 0 < out.stats["gap_max"]
    h = 1e-5 * np.max(np.abs(y))
    fd = np.empty_like(out.monodromy)
    for j in range(len(y)):
        e = np.zeros_like(y)
        e[j] = h
        fd[:, j] = (cont.periodic_map(model, y + e, 1, 1e-13).y
                    - cont.periodic_map(model, y - e, 1, 1e-13).y) / (2 * h)
    error = np.max(np.abs(out.monodromy - fd)) / np.max(np.abs(out.monodromy))
    assert error <= 1e-6, (name, error)


def test_free_orbit_multipliers_are_exp_of_the_free_system():
    """An orbit that never touches (bistable_n2 far from the sample): its monodromy matrix is
    exp(A T), so its multipliers are exp(lambda_k T) with lambda_k the eigenvalues of the free
    system A = [0 I; -M^-1 Lambda, -alpha3 M^-1], built here from the model's M and Lambda."""
    model = tmafm.Model(BISTABLE, scene={"delta_hat": 0.01})
    orbit = cont.periodic_orbit(model, np.zeros(4))
    assert orbit.stats["contacts"] == 0 and orbit.stable
    n = model.n_modes
    inv = np.linalg.inv(model.mass)
    a = np.block([[np.zeros((n, n)), np.eye(n)],
                  [-inv @ np.diag(model.eigen), -model.scene["alpha3"] * inv]])
    period = 2 * np.pi / model.scene["omega"]
    expected = np.exp(np.linalg.eigvals(a) * period)
    got = orbit.multipliers
    for mu in expected:
        assert np.min(np.abs(got - mu)) <= 1e-12 * max(1.0, abs(mu))

"""The scipy peer (studies/scipy_peer.py, a second implementation in numpy) against the core:
the same right-hand side at random states, and the same trajectory within the two
integrators' tolerances.  The peer reads the Galerkin data in memory, through tmafm.Model."""

import numpy as np
import pytest

import tmafm

pytest.importorskip("scipy")

from scipy_peer import ScipyPeer  # noqa: E402  (studies/scipy_peer.py, conftest's sys.path)

SCENES = [
    ("fig2_n4", {}),
    ("fig2_n4", {"model": {"convention": "consistent", "n_modes": 3},
                 "initial": {"a0": [1e-4, 0.0, 0.0]}}),
    ("fig7_dmt", {}),
]


@pytest.mark.parametrize("name,overrides", SCENES)
def test_peer_rhs_equals_core_derivative(name, overrides):
    peer = ScipyPeer(name, **overrides)
    model = tmafm.Model(name, **overrides)
    assert peer.n == model.n_modes
    rng = np.random.default_rng(7)
    for _ in range(20):
        y = rng.normal(scale=1e-3, size=2 * peer.n)
        tau = rng.uniform(0, 10)
        for in_contact in (False, True):
            core = model.derivative(tau, y, in_contact)
            mine = peer.rhs(tau, y, in_contact)
            # Two evaluations of the same formulas in a different order: round-off only.
            scale = np.max(np.abs(core)) + 1e-300
            assert np.max(np.abs(mine - core)) <= 1e-12 * scale


def test_peer_trajectory_matches_core():
    overrides = {"model": {"n_modes": 3}, "initial": {"a0": [2e-4, 0.0, 0.0]},
                 "solver": {"method": "flight_exact", "rtol": 1e-10, "atol": 1e-14, "tau_end": 4 * np.pi},
                 "output": {"sample_dtau": 0.05}}
    core = tmafm.run("fig2_n4", **overrides)
    peer = ScipyPeer("fig2_n4", **overrides).solve(4 * np.pi, 0.05, rtol=1e-10, atol=1e-14)
    # Both run at rtol 1e-10 with located switches: their V_T agree to the looser of the two
    # integrators' global errors, far below the 1e-4 size of V_T.
    assert peer["vt"].shape == core.vt.shape
    assert np.max(np.abs(peer["vt"] - core.vt)) < 1e-9
    assert len(peer["switches"]) == core.counters["phase_switches"]


def test_peer_rejects_bad_input_like_the_core():
    with pytest.raises(tmafm.InputError, match="n_modes = -1"):
        ScipyPeer("fig2_n4", model={"n_modes": -1})

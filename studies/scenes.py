"""Constructed scenes for tests and studies: inputs built by running tmafm itself.

Not part of the package: tests import it through tests/conftest.py (which puts studies/ on
sys.path), and the studies next to it import it as their sibling.
"""

from __future__ import annotations

import math

from tmafm import run

__all__ = ["grazing_scene"]


def grazing_scene(depth: float = 1e-9, n_modes: int = 2, damping: float = 2.0,
                  convention: str = "consistent") -> dict:
    """A namelist dict whose tip grazes the sample once per drive period.

    The beam (``n_modes`` modes, beam damping ``damping`` so that transients die fast) is
    put on its periodic free orbit, and the sample is placed ``depth`` (gap units) above the
    lowest point of V_T.  With the defaults each contact lasts about 1.4e-3, shorter than
    the paper's free step of 2e-3.
    """
    base = {"model": {"n_modes": n_modes, "convention": convention},
            "scene": {"alpha3": damping, "delta_hat": 1.0},
            "solver": {"method": "flight_exact", "rtol": 1e-12, "atol": 1e-18}}
    period = 2 * math.pi / 2.0
    settle = run(base, solver={"tau_end": 20 * period}, output={"sample_dtau": period / 50})
    start = {"a0": [float(x) for x in settle.a[-1]], "adot0": [float(x) for x in settle.adot[-1]]}
    orbit = run(base, initial=start, solver={"tau_end": period}, output={"sample_dtau": period / 100000})
    if orbit.counters["phase_switches"]:
        raise RuntimeError("the free orbit touched the sample: raise delta_hat")
    lowest = float(orbit.vt.min()) - 1.0
    return {"model": dict(base["model"]), "initial": start,
            "scene": {"alpha3": damping, "delta_hat": -lowest - depth}}

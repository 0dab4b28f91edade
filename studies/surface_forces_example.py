"""The numbers of docs/model.md §17's examples: the forces at a distance in use.

1. A biased tip (inputs/biased_tip.nml: tapping_polystyrene's lever, tip at 2.0 V, contact potential
   0.5 V) held 30 nm above the sample, out of reach of its 20 nm swing: the steady phase vs the tip
   bias is a parabola whose vertex is the contact potential (what Kelvin-probe AFM nulls).
2. A free ring-down of a 2 N/m, 70 kHz lever 10 nm above the sample at 1 V: its frequency shift
   against -f0/(2k) dF/dz of Hudlet's closed form (the check tests/test_surface_forces.py makes).
3. inputs/dlvo_water.nml in 1, 10 and 100 mM: the steady amplitude, phase and the force's extremes.

    python studies/surface_forces_example.py     # ~20 s of CPU; writes studies/results/surface_forces.json
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

import numpy as np

import tmafm

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(REPO / "tests"))
from test_surface_forces import A0, RADIUS, _ring_down_frequency, hudlet  # noqa: E402

OUT = HERE / "results" / "surface_forces.json"


def kelvin_parabola():
    biases = [-0.5, 0.0, 0.5, 1.0, 1.5]
    phases = []
    for bias in biases:
        obs = tmafm.observe(str(REPO / "inputs" / "biased_tip.nml"), max_periods=8000, steady_tol=1e-8,
                            physical={"tip_bias": bias, "tip_sample_distance": 30e-9}, observables=("lockin",),
                            solver={"atol": 1e-16})
        if not obs.steady:
            raise RuntimeError(f"tip_bias = {bias}: not steady ({obs.unsteady_reason})")
        phases.append(float(obs.physical["phase"][-1]))
    fit = np.polyfit(biases, phases, 2)
    return {"tip_bias_V": biases, "phase_deg": phases, "vertex_V": float(-fit[1] / (2 * fit[0])),
            "parabola_residual_deg": float(np.max(np.abs(np.polyval(fit, biases) - phases)))}


def ring_down():
    free, _ = _ring_down_frequency(0.0)
    biased, _ = _ring_down_frequency(1.0)
    separation = A0 + 10e-9
    for _ in range(60):
        separation = A0 + 10e-9 + hudlet(separation, 1.0, RADIUS, math.pi / 9, 15e-6) / 2.0
    h = 1e-13
    gradient = (hudlet(separation + h, 1.0, RADIUS, math.pi / 9, 15e-6)
                - hudlet(separation - h, 1.0, RADIUS, math.pi / 9, 15e-6)) / (2 * h)
    return {"free_Hz": free, "shift_Hz": biased - free, "formula_Hz": -70e3 / (2 * 2.0) * gradient,
            "gradient_N_per_m": gradient, "rest_separation_m": separation}


def dlvo():
    rows = {}
    for ionic in (1.0, 10.0, 100.0):
        obs = tmafm.observe(str(REPO / "inputs" / "dlvo_water.nml"), max_periods=400, steady_tol=1e-8,
                            physical={"ionic_strength": ionic})
        if not obs.steady:
            raise RuntimeError(f"ionic_strength = {ionic}: not steady ({obs.unsteady_reason})")
        model = tmafm.Model(str(REPO / "inputs" / "dlvo_water.nml"), physical={"ionic_strength": ionic})
        debye = model.scene["double_layer_range"] * model.config.derived["length_scale"]
        rows[f"{ionic:g}"] = {"debye_length_nm": debye * 1e9,
                              **{name: float(obs.physical[name][-1])
                                 for name in ("amplitude", "phase", "peak_force", "min_force", "min_gap")}}
    return rows


def main() -> int:
    start = time.process_time()
    result = {"kelvin_parabola": kelvin_parabola(), "ring_down": ring_down(), "dlvo_water": dlvo()}
    result["cpu_s"] = time.process_time() - start
    OUT.parent.mkdir(exist_ok=True)
    OUT.write_text(json.dumps(result, indent=1) + "\n")
    print(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())

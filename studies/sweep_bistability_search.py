"""The scan that found the bistable scene of docs/sweeps.md (inputs/sweeps/bistable_n2.nml):
warm-started approach/retract curves (tmafm.approach) over the drive frequency and amplitude,
scored by the largest relative amplitude difference between the two directions.

    /opt/tmafm-venv/bin/python studies/sweep_bistability_search.py

N = 2, the Sec. 3 scene otherwise, flight_exact at rtol 1e-8, 200 periods at most per point.
Writes studies/results/sweep_bistability_search.json.
"""

import json
from pathlib import Path

import numpy as np

import tmafm

REPO = Path(__file__).resolve().parent.parent
BASE = {"model": {"n_modes": 2, "contact_law": "hertz", "convention": "paper"},
        "initial": {"a0": [0.0, 0.0]},
        "solver": {"method": "flight_exact", "rtol": 1e-8, "tau_end": 10.0}}


def main():
    rows = []
    for alpha2 in (5e-4, 1e-3):
        # The free amplitude grows with alpha2: scale the offsets with it.
        deltas = np.linspace(12e-3, 0.0, 25) * alpha2 / 5e-4
        ds = tmafm.approach(dict(BASE, scene={"alpha2": alpha2}), delta_hat=deltas,
                            curves={"scene.omega": [3.3, 3.45, 3.6, 3.8]}, workers=2,
                            max_periods=200)
        for omega in ds["scene.omega"].values:
            part = ds.sel({"scene.omega": omega})
            a, r = part["amplitude"].sel(direction="approach"), part["amplitude"].sel(
                direction="retract")
            difference = (abs(a - r) / np.maximum(a, r)).values
            k = int(np.nanargmax(difference))
            rows.append({"alpha2": alpha2, "omega": float(omega),
                         "max_relative_difference": float(difference[k]),
                         "at_delta_hat": float(deltas[k]),
                         "bistable_points": int((difference > 0.2).sum())})
            print(json.dumps(rows[-1]), flush=True)
    # The first resonance out of contact: sqrt of the smallest eigenvalue of M^-1 K.
    mass, _, stiffness, _ = tmafm.Config(BASE).model().matrices(0.0, np.zeros(2), False)
    omega_1 = float(np.sqrt(np.min(np.linalg.eigvals(np.linalg.solve(mass, stiffness)).real)))
    print(f"omega_1 = {omega_1:.4f}")
    (REPO / "studies" / "results" / "sweep_bistability_search.json").write_text(
        json.dumps({"base": BASE, "omega_1": omega_1, "rows": rows}, indent=1))


if __name__ == "__main__":
    main()

"""Where bistable_n2 is bistable in (delta_hat, alpha2): the two folds where the motion jumps
(the period-1 branch's lower fold, where an approach jumps, and the period-2 branch's fold, where
a retract jumps) continued in alpha2 from 5e-4 to 4e-4 and to 6e-4 by
tmafm.continuation.fold_curve, over a brute-force map of the hysteresis (approach/retract sweeps
at five values of alpha2: where the two directions' amplitudes differ).  Each fold curve, at each
alpha2 of the map, lies within one grid step of the sweep's jump.

    /opt/tmafm-venv/bin/python studies/fold_curves.py

Writes studies/results/fold_curves.json and docs/figures/continuation_fold_curves.png.
"""

import json
import time
import warnings
from pathlib import Path

import numpy as np

import tmafm
from tmafm import continuation as cont

REPO = Path(__file__).resolve().parent.parent
BISTABLE = str(REPO / "inputs" / "sweeps" / "bistable_n2.nml")
KEY, KEY2 = "scene.delta_hat", "scene.alpha2"
ALPHA2 = np.array([4e-4, 4.5e-4, 5e-4, 5.5e-4, 6e-4])
GRID = np.round(np.linspace(5.5e-3, 1.0e-3, 91), 12)  # step 5e-5


def curves():
    ds = cont.continuation(BISTABLE, KEY, 8e-3, 0.0, max_points=400, workers=1)
    lab, per = ds["label"].values, ds["period"].values
    z = ds[KEY].values
    ones = np.flatnonzero((lab == "fold") & (per == 1))
    lower = int(ones[np.argmin(z[ones])])
    two = int(np.flatnonzero((lab == "fold") & (per == 2))[0])
    out = {}
    for name, k in (("approach", lower), ("retract", two)):
        parts = [cont.fold_curve(BISTABLE, KEY2, ds.isel(point=k), stop2, max_points=80)
                 for stop2 in (4e-4, 6e-4)]
        a2 = np.concatenate([parts[0][KEY2].values[::-1], parts[1][KEY2].values[1:]])
        zz = np.concatenate([parts[0][KEY].values[::-1], parts[1][KEY].values[1:]])
        out[name] = {"alpha2": a2.tolist(), "delta_hat": zz.tolist(),
                     "end_reasons": [str(p["end_reason"].values[-1]) for p in parts],
                     "period": int(per[k]), "start": float(z[k])}
    return out


def brute_force():
    rows = []
    for a2 in ALPHA2:
        base = tmafm.Config(BISTABLE, scene={"alpha2": float(a2)})
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", tmafm.UnsteadyWarning)
            sweep = tmafm.approach(base, delta_hat=GRID, workers=1)
        amp = sweep["amplitude"].values
        hysteresis = np.abs(amp[0] - amp[1]) > 0.05 * np.abs(amp).max(axis=0)
        jumps = {}
        for k, direction in enumerate(("approach", "retract")):
            idx = np.flatnonzero(sweep["jump"].values[k])
            jumps[direction] = [[float(GRID[i]), float(GRID[i - 1])] if direction == "approach"
                                else [float(GRID[i + 1]), float(GRID[i])] for i in idx]
        rows.append({"alpha2": float(a2), "hysteresis": hysteresis.astype(int).tolist(),
                     "jumps": jumps})
    return rows


def main():
    t0 = time.process_time()
    fold = curves()
    t1 = time.process_time()
    maps = brute_force()
    t2 = time.process_time()
    step = float(GRID[0] - GRID[1])
    agreement = []
    for row in maps:
        for direction in ("approach", "retract"):
            c = fold[direction]
            z = float(np.interp(row["alpha2"], c["alpha2"], c["delta_hat"]))
            brackets = row["jumps"][direction]
            inside = any(lo - step <= z <= hi + step for lo, hi in brackets)
            agreement.append({"alpha2": row["alpha2"], "direction": direction, "fold": z,
                              "sweep_jumps": brackets, "within_one_step": bool(inside)})
    out = {"command": "python studies/fold_curves.py", "grid_step": step,
           "fold_curves": fold, "brute_force": maps, "agreement": agreement,
           "all_within_one_step": all(a["within_one_step"] for a in agreement),
           "cpu_s": {"curves": round(t1 - t0, 2), "brute_force": round(t2 - t1, 2)}}
    (REPO / "studies" / "results" / "fold_curves.json").write_text(json.dumps(out, indent=1) + "\n")
    for a in agreement:
        print(a)
    print(out["cpu_s"], out["all_within_one_step"], {d: fold[d]["end_reasons"] for d in fold})
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for row in maps:
        h = np.array(row["hysteresis"], dtype=bool)
        ax.plot(GRID[~h], np.full((~h).sum(), row["alpha2"]), ".", color="0.75", ms=3)
        ax.plot(GRID[h], np.full(h.sum(), row["alpha2"]), "s", color="C3", ms=3)
    for direction, color in (("approach", "C0"), ("retract", "C2")):
        c = fold[direction]
        ax.plot(c["delta_hat"], c["alpha2"], "-", color=color,
                label=f"fold of the period-{c['period']} branch ({direction} jump)")
    ax.plot([], [], "s", color="C3", ms=3, label="brute force: approach and retract differ")
    ax.plot([], [], ".", color="0.75", ms=3, label="brute force: they agree")
    ax.set_xlabel("scene.delta_hat")
    ax.set_ylabel("scene.alpha2")
    ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    fig.savefig(REPO / "docs" / "figures" / "continuation_fold_curves.png", dpi=110)


if __name__ == "__main__":
    main()

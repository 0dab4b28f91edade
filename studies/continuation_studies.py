"""The two studies of docs/continuation.md: the bistable approach curve of
inputs/sweeps/bistable_n2.nml continued in delta_hat (its folds against the approach/retract
sweep's jumps), and the period-doubling route of the Figs. 4-5 scene (inputs/fig4a.nml) in
alpha2 (the doubling located, the period-2 branch against a brute-force bifurcation diagram).

    /opt/tmafm-venv/bin/python studies/continuation_studies.py

Writes studies/results/continuation_studies.json and docs/figures/continuation_bistable.png,
docs/figures/continuation_alpha2.png (~2 min).
"""

import json
from pathlib import Path

import numpy as np

import tmafm
from tmafm.continuation import plots

REPO = Path(__file__).resolve().parent.parent
BISTABLE = str(REPO / "inputs" / "sweeps" / "bistable_n2.nml")
FIG4 = str(REPO / "inputs" / "fig4a.nml")


def _special(ds, key):
    out = []
    for i in np.flatnonzero(ds["label"].values != ""):
        label = str(ds["label"].values[i])
        if label in ("start", "end"):
            continue
        mu = ds["multiplier_re"].values[i] + 1j * ds["multiplier_im"].values[i]
        out.append({"label": label, "branch": int(ds["branch"].values[i]),
                    "period": int(ds["period"].values[i]), key: float(ds[key].values[i]),
                    "amplitude": float(ds["amplitude"].values[i]),
                    "stable": bool(ds["stable"].values[i]),
                    "multipliers": [[float(z.real), float(z.imag)] for z in mu]})
    return out


def _ends(ds, key):
    """Every branch's end: its number, period, value and end_reason (docs/continuation.md)."""
    return [{"branch": int(ds["branch"].values[i]), "period": int(ds["period"].values[i]),
             key: float(ds[key].values[i]), "end_reason": str(ds["end_reason"].values[i])}
            for i in np.flatnonzero(ds["end_reason"].values != "")]


def bistable():
    key = "scene.delta_hat"
    grid = np.linspace(8e-3, 0.0, 201)
    sweep = tmafm.approach(BISTABLE, delta_hat=grid, workers=1)
    ds = tmafm.continuation(BISTABLE, key, 8e-3, 0.0, max_points=400)
    jumps = {}
    for k, direction in enumerate(("approach", "retract")):
        idx = np.flatnonzero(sweep["jump"].values[k])
        # Approach runs the grid in order, retract backwards: the jump flagged at i lies
        # between grid[i - 1] and grid[i] (approach), grid[i + 1] and grid[i] (retract).
        jumps[direction] = [[float(grid[i - 1]), float(grid[i])] if direction == "approach"
                            else [float(grid[i + 1]), float(grid[i])] for i in idx]
    fig, axes = plots._pyplot().subplots(1, 2, figsize=(11, 4.2))
    # The orbit's smallest V_T: the same quantity as the sweep's min_gap (docs/observables.md);
    # the whole interval, and the bistable part enlarged.
    for ax in axes:
        plots.plot_branch(ds, None, "min_gap", sweep=sweep, ax=ax)
    axes[1].set_xlim(1.8e-3, 4.3e-3)
    axes[1].set_ylim(-8e-4, 1e-4)
    fig.tight_layout()
    plots._save(fig, REPO / "docs" / "figures" / "continuation_bistable.png")
    return {"command": "tmafm.continuation(bistable_n2, 'scene.delta_hat', 8e-3, 0, "
                       "max_points=400) against tmafm.approach(bistable_n2, 201 points)",
            "special_points": _special(ds, key), "ends": _ends(ds, key),
            "sweep_jumps": jumps, "grid_step": float(grid[0] - grid[1]),
            "points": int(ds.sizes["point"])}


def alpha2_route():
    key = "scene.alpha2"
    ds = tmafm.continuation(FIG4, key, 5e-4, 2e-3, max_points=200, max_period=4)
    values = np.linspace(1.0e-3, 2.0e-3, 21)
    diagram = tmafm.bifurcation(tmafm.Config(FIG4, solver={"method": "flight_exact",
                                                            "rtol": 1e-10}),
                                key, values, periods_kept=8, max_periods=400, workers=1)
    fig, ax = plots._pyplot().subplots(figsize=(6.4, 4.2))
    plots.plot_branch(ds, None, "tip", ax=ax)
    tip = diagram["tip"].values
    ax.plot(np.repeat(values, tip.shape[1]), tip.ravel(), ".", color="0.5", ms=3,
            label="brute force (section points)")
    ax.legend(fontsize=8)
    plots._save(fig, REPO / "docs" / "figures" / "continuation_alpha2.png")
    periods = [int(p) for p in diagram["period"].values]
    return {"command": "tmafm.continuation(fig4a, 'scene.alpha2', 5e-4, 2e-3, max_points=200, "
                       "max_period=4) against tmafm.bifurcation(fig4a flight_exact rtol 1e-10, "
                       "21 values in [1e-3, 2e-3], 400 periods)",
            "special_points": _special(ds, key), "ends": _ends(ds, key),
            "brute_force": {"alpha2": values.tolist(), "period": periods},
            "points": int(ds.sizes["point"])}


def main():
    out = {"bistable_n2": bistable(), "fig4_alpha2": alpha2_route()}
    path = REPO / "studies" / "results" / "continuation_studies.json"
    path.write_text(json.dumps(out, indent=1) + "\n")
    print(json.dumps({k: v["special_points"] for k, v in out.items()}, indent=1)[:4000])
    print(json.dumps({k: v.get("sweep_jumps", v.get("brute_force")) for k, v in out.items()}))


if __name__ == "__main__":
    main()

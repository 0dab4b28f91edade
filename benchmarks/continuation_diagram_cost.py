"""CPU time of the whole bistable_n2 diagram by continuation (both periods, the folds of both)
against brute-force approach/retract sweeps refined to the same accuracy, in one run.

The continuation: tmafm.continuation(bistable_n2, 'scene.delta_hat', 8e-3, 0, max_points=400)
(the period-1 branch with its two folds, its doublings and the period-2 branch with its fold).
Its accuracy: each fold against the same diagram at tol = loc_tol = 1e-11 and rtol = 1e-12
(the largest relative difference over the folds).

The brute force can see only the two folds where the motion jumps: the approach jump (the
period-1 branch's lower fold) and the retract jump (the period-2 branch's fold).  It runs the
201-point approach/retract sweep over the interval, then refines each jump: a warm-started sweep
of 10 steps across the bracket from the stable state before it (its final state), the bracket
of the largest amplitude step kept, 10 times narrower each level, until the bracket is within
the continuation's accuracy (relative to the fold), or a level no longer jumps where the
continuation's fold lies, or the brute force has spent BUDGET_FACTOR (6) times the
continuation's CPU time.  Each run goes its whole number of periods (next to a fold the steady
test takes the slow passage for a steady state and brackets the jump a step late), and each
level runs 3.2 times more periods per point than the one before (the passage past a fold at a
distance d takes ~ d^(-1/2) periods).  If the brute force stops
short of the continuation's accuracy, its time is a lower bound on the time it needs, and the
ratio an upper bound.

    /opt/tmafm-venv/bin/python benchmarks/continuation_diagram_cost.py

Both on one core (workers=1), CPU time (user + sys of this process, time.process_time);
writes benchmarks/results/continuation_diagram_cost.json and
docs/figures/continuation_diagram_cost.png (each fold's accuracy against the CPU time spent).
"""

import argparse
import json
import time
import warnings
from pathlib import Path

import numpy as np

import tmafm

REPO = Path(__file__).resolve().parent.parent
BISTABLE = str(REPO / "inputs" / "sweeps" / "bistable_n2.nml")
KEY = "scene.delta_hat"
MAX_PERIODS = 2000
#: The brute force's CPU budget in units of the continuation's.
BUDGET_FACTOR = 6.0


def _cpu(function):
    start = time.process_time()
    out = function()
    return time.process_time() - start, out


def _folds(ds):
    """(the period-1 folds low and high, the period-2 fold) of a diagram."""
    lab, per, z = ds["label"].values, ds["period"].values, ds[KEY].values
    one = sorted(z[(lab == "fold") & (per == 1)])
    two = z[(lab == "fold") & (per == 2)]
    assert len(one) == 2 and len(two) == 1, (one, two)
    return {"approach_fold": float(one[0]), "upper_fold": float(one[1]),
            "retract_fold": float(two[0])}


def _diagram(**options):
    return tmafm.continuation(BISTABLE, KEY, 8e-3, 0.0, max_points=400, workers=1, **options)


def _refine(state, low, high, direction, fold, target, budget):
    """Levels of warm-started runs narrowing the jump's bracket [low, high] tenfold each, from
    `state` (the stable orbit before the jump) in `direction` ('approach': from high down,
    'retract': from low up).  Each run goes the level's whole number of periods (no steady
    stop: next to a fold the passage is so slow that the steady test takes it for a steady
    state), MAX_PERIODS x 3.2^L at level L (the passage past a fold at a distance d takes
    ~ d^(-1/2) periods, so each tenfold narrower bracket needs ~3.2 times more).  Stops when
    the bracket is below target, when it no longer holds the fold, or when the CPU time spent
    exceeds `budget` (checked after every run).  Returns (levels, reached): the finished
    levels (bracket, holds the fold, periods, CPU seconds) and whether the target was
    reached."""
    levels = []
    n = len(state) // 2
    start = time.process_time()
    level = 0
    while high - low > target:
        values = np.linspace(high, low, 11) if direction == "approach" else np.linspace(low, high, 11)
        periods = int(MAX_PERIODS * 3.2 ** level)
        t0 = time.process_time()
        amplitude, states, x = [], [], state
        for v in values:
            if time.process_time() - start > budget:
                # The level left unfinished: its CPU time, spent without a narrower bracket.
                levels.append({"bracket": None, "width": None, "holds_fold": False,
                               "periods_per_run": periods, "unfinished": True,
                               "cpu_s": round(time.process_time() - t0, 3)})
                return levels, False
            base = tmafm.Config(BISTABLE, initial={"a0": list(x[:n]), "adot0": list(x[n:])})
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", tmafm.UnsteadyWarning)
                out = tmafm.approach(base, delta_hat=[float(v)], retract=False, workers=1,
                                     max_periods=periods, stop_at_steady=False)
            s = out.sel(direction="approach")
            amplitude.append(float(s["amplitude"].values[0]))
            x = s["final_state"].values[0]
            states.append(x)
        k = int(np.argmax(np.abs(np.diff(amplitude))))
        state = states[k]
        low, high = sorted((float(values[k]), float(values[k + 1])))
        ok = low <= fold <= high
        levels.append({"bracket": [low, high], "width": high - low, "holds_fold": ok,
                       "periods_per_run": periods,
                       "cpu_s": round(time.process_time() - t0, 3)})
        level += 1
        if not ok:
            return levels, False
    return levels, True


def brute_force(folds, accuracy, budget):
    """The coarse sweep, then each jump refined (_refine) with half the CPU budget each."""
    grid = np.linspace(8e-3, 0.0, 201)
    t0 = time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", tmafm.UnsteadyWarning)
        sweep = tmafm.approach(BISTABLE, delta_hat=grid, workers=1)
    out = {"coarse_cpu_s": round(time.process_time() - t0, 3)}
    for k, direction in enumerate(("approach", "retract")):
        jumps = np.flatnonzero(sweep["jump"].values[k])
        assert len(jumps) == 1, (direction, jumps)
        i = int(jumps[0])
        # approach runs the grid in order: the jump flagged at i lies between grid[i - 1] and
        # grid[i]; retract runs it backwards: between grid[i + 1] and grid[i].
        before = i - 1 if direction == "approach" else i + 1
        state = sweep["final_state"].values[k, before]
        low, high = sorted((grid[i], grid[before]))
        fold = folds[f"{direction}_fold"]
        levels, reached = _refine(state, low, high, direction, fold, accuracy * fold, budget / 2)
        out[direction] = {"coarse_bracket": [float(low), float(high)], "levels": levels,
                          "reached_accuracy": reached}
    return out


def main():
    parser = argparse.ArgumentParser()
    parser.parse_args()
    _diagram()  # warm-up
    t_cont, ds = _cpu(_diagram)
    folds = _folds(ds)
    fine = _folds(_diagram(tol=1e-11, loc_tol=1e-11, rtol=1e-12))
    accuracy = max(abs(folds[k] - fine[k]) / fine[k] for k in folds)
    # The brute force may spend BUDGET_FACTOR times the continuation's CPU time: if it has
    # not reached the continuation's accuracy by then, the ratio is below 1/BUDGET_FACTOR.
    t_brute, brute = _cpu(lambda: brute_force(folds, accuracy, BUDGET_FACTOR * t_cont))
    reached = {}
    for d, b in ((d, b) for d, b in brute.items() if d != "coarse_cpu_s"):
        good = [lv["width"] for lv in b["levels"] if lv["holds_fold"] and lv["width"] is not None]
        reached[d] = min(good) if good else b["coarse_bracket"][1] - b["coarse_bracket"][0]
    reached_rel = max(reached[d] / folds[f"{d}_fold"] for d in reached)
    out = {"command": "python benchmarks/continuation_diagram_cost.py",
           "continuation_cpu_s": round(t_cont, 3), "continuation_points": int(ds.sizes["point"]),
           "continuation_branches": sorted(int(b) for b in np.unique(ds["branch"].values)),
           "folds": folds, "folds_tight": fine, "continuation_accuracy_rel": accuracy,
           "brute_force_cpu_s": round(t_brute, 3), "brute_force": brute,
           "brute_force_bracket_rel": reached_rel,
           "brute_force_reached_accuracy": all(brute[d]["reached_accuracy"]
                                               for d in ("approach", "retract")),
           "max_periods": MAX_PERIODS, "budget_factor": BUDGET_FACTOR,
           "ratio_continuation_over_brute_force": round(t_cont / t_brute, 4)}
    print(json.dumps({k: v for k, v in out.items() if k != "brute_force"}))
    (REPO / "benchmarks" / "results" / "continuation_diagram_cost.json").write_text(
        json.dumps(out, indent=1) + "\n")
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    # Work against precision: the brute force's bracket (relative to the fold) against the CPU
    # time spent so far (the coarse sweep, then each level of both jumps in turn), and the
    # continuation's accuracy at its time.
    fig, ax = plt.subplots(figsize=(5.6, 3.8))
    spent = brute["coarse_cpu_s"]
    for d, marker in (("approach", "o"), ("retract", "s")):
        widths = [(brute[d]["coarse_bracket"][1] - brute[d]["coarse_bracket"][0]) / folds[f"{d}_fold"]]
        times = [spent]
        for lv in brute[d]["levels"]:
            spent += lv["cpu_s"]
            times.append(spent)
            # An unfinished level (the budget spent) or one that lost the fold narrows nothing.
            widths.append(lv["width"] / folds[f"{d}_fold"] if lv["holds_fold"] else widths[-1])
        ax.semilogy(times, widths, marker + "-", color="0.5", label=f"brute force, {d} jump")
    ax.semilogy([t_cont], [accuracy], "*", color="C0", ms=12,
                label="continuation, whole diagram")
    ax.set_xlabel("CPU time [s]")
    ax.set_ylabel("fold located to (relative)")
    ax.set_title(f"bistable_n2: ratio {t_cont / t_brute:.3f} (brute force stopped at "
                 f"{BUDGET_FACTOR:.0f}x)", fontsize=8)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(REPO / "docs" / "figures" / "continuation_diagram_cost.png", dpi=110)


if __name__ == "__main__":
    main()

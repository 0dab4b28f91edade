"""The two branches of docs/vdw.md's scene (inputs/sweeps/vdw_attractive.nml, contact_law =
'dmt_vdw') continued in Z with tmafm.continuation, and the folds checked against warm-started
approach and retract sweeps in steps of 0.002 nm around each.

The branch starts on the attractive (non-contact) orbit at Z = 10 nm and is followed down to
6.7 nm: it grazes the sample, folds, comes back up unstable, folds again and goes down as the
repulsive (tapping) branch.  Each fold is where a warm-started sweep jumps: the attractive
branch ends at the lower fold (the approach jumps there), the repulsive one at the upper fold
(the retract jumps there).  The fine sweeps start on the continued orbit (its section state as
the initial state) a little past the fold's stable side and step through it.

    python studies/vdw_continuation.py --json studies/results/vdw_continuation.json
"""

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

import tmafm
from tmafm import continuation as cont

REPO = Path(__file__).resolve().parent.parent
SCENE = "sweeps/vdw_attractive"
#: Z in nm is 1e4 delta_hat (the gap d = 10 um).
GAP_NM = 1e4
#: The continuation's range (delta_hat) and its start on the attractive orbit (a first-harmonic
#: guess: V_T's swing 9.5 nm at a 95 degree lag, which Newton corrects).
Z_START, Z_STOP = 1.0e-3, 6.7e-4
START_AMPLITUDE, START_LAG_DEG = 9.5e-4, -95.0
#: The fine sweeps: 0.002 nm steps over +-0.03 nm around each fold.
FINE_STEP, FINE_HALF = 2e-7, 3e-6


def start_state():
    model = tmafm.Model(SCENE, scene={"delta_hat": Z_START})
    p, omega, lag = model.tip[0], model.scene["omega"], math.radians(START_LAG_DEG)
    return [START_AMPLITUDE * math.sin(lag) / p, START_AMPLITUDE * omega * math.cos(lag) / p]


def branch():
    """The continued branch: its points and the labelled ones."""
    ds = cont.continuation(SCENE, "scene.delta_hat", Z_START, Z_STOP, y0=start_state(),
                           max_points=400, switch=False)
    return ds


def _point(ds, i):
    return {"z_nm": float(ds["scene.delta_hat"].values[i] * GAP_NM),
            "label": str(ds.label.values[i]), "stable": bool(ds.stable.values[i]),
            "amplitude_nm": float(ds.amplitude.values[i] * GAP_NM),
            "min_gap_nm": float(ds.min_gap.values[i] * GAP_NM),
            "contacts": float(ds.contacts.values[i]),
            "multiplier_abs": [float(v) for v in ds.multiplier_abs.values[i]]}


def fine_sweep(ds, fold_index, direction):
    """A warm-started sweep through the fold in FINE_STEP steps from the continued stable orbit
    nearest the fold on its stable side (direction: 'approach' goes down in Z, 'retract' up)."""
    z = ds["scene.delta_hat"].values
    stable = ds.stable.values
    fold = z[fold_index]
    sign = 1.0 if direction == "approach" else -1.0
    # The stable points on the fold's stable side (above it for the approach, below for the
    # retract), and among them the nearest to the fold with Z at least FINE_HALF away.
    candidates = [i for i in range(len(z)) if stable[i] and sign * (z[i] - fold) >= FINE_HALF]
    first = min(candidates, key=lambda i: abs(z[i] - fold))
    state = ds.state.values[first, 0]
    n = len(state) // 2
    # The continued point's own Z (the sweep starts on its orbit), then the multiples of
    # FINE_STEP from there through the fold to FINE_HALF past it.
    if direction == "approach":
        grid = np.arange(math.floor(z[first] / FINE_STEP), math.floor((fold - FINE_HALF) / FINE_STEP) - 1, -1)
    else:
        grid = np.arange(math.ceil(z[first] / FINE_STEP), math.ceil((fold + FINE_HALF) / FINE_STEP) + 1)
    grid = np.round(grid * FINE_STEP, 12)
    values = np.concatenate([[z[first]], grid[sign * (z[first] - grid) > FINE_STEP / 100]])
    base = tmafm.Config(SCENE, initial={"a0": list(state[:n]), "adot0": list(state[n:])})
    out = tmafm.approach(base, values, retract=False, max_periods=6000,
                         observables=["lockin", "extrema"], workers=1)
    s = out.sel(direction="approach")
    phase = s.phase.values
    zz = s["scene.delta_hat"].values
    amplitude = s.amplitude.values
    # The jump: the one amplitude step far larger than the others (the branches are ~0.15 nm
    # apart in amplitude, the steps along a branch ~0.002 nm).  (Not the phase's -90 degrees:
    # the repulsive orbit at the retract fold lags by just over 90 degrees.)
    steps = np.abs(np.diff(amplitude))
    k = int(np.argmax(steps))
    return {"start_z_nm": float(z[first] * GAP_NM),
            "z_nm": [round(float(v * GAP_NM), 6) for v in zz],
            "phase_deg": phase.tolist(), "amplitude_nm": (amplitude * GAP_NM).tolist(),
            "min_gap_nm": (s.min_gap.values * GAP_NM).tolist(),
            "steady": s.steady.values.astype(int).tolist(),
            "jump_between_nm": [round(float(zz[j] * GAP_NM), 6) for j in (k, k + 1)],
            "jump_nm": float(steps[k] * GAP_NM), "largest_other_step_nm": float(np.max(np.delete(steps, k)) * GAP_NM)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    start = time.process_time()
    ds = branch()
    cpu = time.process_time() - start
    labelled = [_point(ds, i) for i in range(ds.sizes["point"]) if ds.label.values[i]]
    folds = [i for i in range(ds.sizes["point"]) if ds.label.values[i] == "fold"]
    assert len(folds) == 2, labelled
    z = ds["scene.delta_hat"].values
    lower, upper = sorted(folds, key=lambda i: z[i])
    out = {"command": "python studies/vdw_continuation.py --json studies/results/vdw_continuation.json",
           "scene": SCENE, "continuation_cpu_seconds": cpu, "points": int(ds.sizes["point"]),
           "labelled": labelled,
           "approach_fold_nm": float(z[lower] * GAP_NM), "retract_fold_nm": float(z[upper] * GAP_NM),
           "grazing_nm": [p["z_nm"] for p in labelled if p["label"] == "grazing"],
           "fine_step_nm": FINE_STEP * GAP_NM,
           "approach": fine_sweep(ds, lower, "approach"),
           "retract": fine_sweep(ds, upper, "retract")}
    # VEDA's Z0 is the tip-sample distance at rest, s = Z + a0 (tmafm's contact V_T = 0 is s = a0).
    a0_nm = float(tmafm.Model(SCENE).scene["vdw_range"] * GAP_NM)
    out["a0_nm"] = a0_nm
    out["veda_z0_nm"] = {"grazing": out["grazing_nm"][0] + a0_nm, "approach_fold": out["approach_fold_nm"] + a0_nm,
                         "retract_fold": out["retract_fold_nm"] + a0_nm}
    for p in labelled:
        print(f"{p['label']:8s} Z = {p['z_nm']:.5f} nm  stable {p['stable']}  A = {p['amplitude_nm']:.4f} nm  "
              f"min gap {p['min_gap_nm']:+.5f} nm")
    for d in ("approach", "retract"):
        print(f"{d}: fine sweep from Z = {out[d]['start_z_nm']:.4f} nm jumps between "
              f"{out[d]['jump_between_nm']} nm (amplitude step {out[d]['jump_nm']:.4f} nm, the "
              f"largest other {out[d]['largest_other_step_nm']:.4f} nm)")
    print(f"continuation CPU {cpu:.1f} s, {out['points']} points; VEDA Z0 = Z + a0, a0 = {a0_nm:.4f} nm: "
          f"{out['veda_z0_nm']}")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()

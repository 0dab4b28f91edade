"""Trials of the first steps in tau after a warped contact entry (docs/performance.md, "The first
steps in tau after the warp"): steps, rejections and right-hand sides of a trial build whose
hand-over from sigma to tau is chosen at run time by the environment variable TMAFM_V.

The trial build is commit b2bf63b (the patch's base) with studies/handover_trials.patch
applied (not kept in the solver: every variant cost more right-hand sides than the hand-over it would replace):

    mkdir /tmp/trial && git archive b2bf63b | tar -x -C /tmp/trial && cd /tmp/trial \
        && patch -p1 < studies/handover_trials.patch && meson setup build-t && ninja -C build-t tmafm \
        && cd - && python studies/handover_trials.py --exe /tmp/trial/build-t/tmafm --out /tmp/ht

Variants (TMAFM_V): 0 the hand-over as built (first tau step 2 sigma dsigma from the warp's
controller, the controller restarted, PI for 4 steps); 1 the first tau step the last warped
step's length in tau times the PI factor of the last two warped norms; 10 the hand-over as
built, the controller's history kept (PI from the warped norms); 11 both.  With TMAFM_TRACE
set, the trial build also writes every contact step tried to stderr (warped or not, tau, its
length in tau, its error norm) and `warp end` at each hand-over.

Counters (the npz `counters`, whole runs) summed over every scene and tolerance of
benchmarks/contact_steps.py with alpha2 scaled by 9 factors in [0.92, 1.08] (a steady contact's
step pattern is periodic, so one scene gives one draw of where its rejections fall; the sweep
averages over them), 60 drive periods each, one sample per period; and the two runs of the
session's targets: Fig. 2 (inputs/fig2_n4.nml, flight_exact at the default tolerances, 100
periods, samples every 0.01) and the tilted scene at rtol 1e-10, atol 1e-14, 200 periods.
Writes handover_trials.json into --out.
"""

import argparse
import importlib.util
import json
import math
import os
import re
import subprocess
import tempfile
from pathlib import Path

import f90nml
import numpy as np

# benchmarks/contact_steps.py: its scenes, namelists and counters.
BENCHMARKS = Path(__file__).resolve().parent.parent / "benchmarks"
_spec = importlib.util.spec_from_file_location("contact_steps", BENCHMARKS / "contact_steps.py")
cs = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(cs)

SPREAD = np.linspace(0.92, 1.08, 9)
SWEEP_PERIODS = 60


def imaginary_stability_limit():
    """The largest y with |R(iy')| <= 1 for all y' <= y, R the stability function of dop853's
    eighth-order solution, from the coefficients in tmafm_dop853.f90 (steps of 0.01)."""
    src = (cs.REPO / "fortran/src/integrators/tmafm_dop853.f90").read_text()
    a, b = np.zeros((12, 12)), np.zeros(12)
    for name, value in re.findall(r"\b([ab]\d+(?:_\d+)?) = (-?[0-9.]+(?:e-?\d+)?)_dp", src):
        idx = [int(i) - 1 for i in name[1:].split("_")]
        if name[0] == "a" and idx[0] < 12:
            a[idx[0], idx[1]] = float(value)
        elif name[0] == "b":
            b[idx[0]] = float(value)
    y = 0.0
    while True:
        z = 1j * (y + 0.01)
        if abs(1 + z * b @ np.linalg.solve(np.eye(12) - z * a, np.ones(12))) > 1 + 1e-12:
            return y
        y += 0.01


def counters(exe, variant, nml, scratch):
    path = Path(scratch) / "run.nml"
    f90nml.write(f90nml.Namelist(nml), str(path), force=True)
    subprocess.run([exe, "-q", str(path)], check=True, cwd=scratch, env=dict(os.environ, TMAFM_V=str(variant)))
    with np.load(nml["output"]["file"]) as z:
        return [int(c) for c in z["counters"]]


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--exe", required=True, help="the trial build's tmafm")
    parser.add_argument("--variants", nargs="+", default=["0", "1", "10", "11"])
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    result = {"sweep": {}, "runs": {}, "dop853_imaginary_stability_limit": round(imaginary_stability_limit(), 2)}
    print("dop853 stable on the imaginary axis to |z| =", result["dop853_imaginary_stability_limit"])
    with tempfile.TemporaryDirectory() as scratch:
        npz = str(Path(scratch) / "out.npz")
        for scene in cs.SCENES:
            for rtol, atol in cs.TOLERANCES:
                key = f"{scene} {rtol:.0e}"
                sums = {v: np.zeros(5, dtype=np.int64) for v in args.variants}
                for factor in SPREAD:
                    nml = cs.namelist(scene, {"method": "flight_exact", "rtol": rtol, "atol": atol},
                                      SWEEP_PERIODS, cs.PERIOD, npz)
                    nml["scene"]["alpha2"] = float(nml["scene"]["alpha2"]) * float(factor)
                    for v in args.variants:
                        sums[v] += counters(args.exe, v, nml, scratch)
                result["sweep"][key] = {v: sums[v].tolist() for v in args.variants}
                print(key, {v: (round(sums[v][3] / SWEEP_PERIODS / len(SPREAD), 1),
                                round(sums[v][2] / SWEEP_PERIODS / len(SPREAD), 2)) for v in args.variants},
                      flush=True)
        fig2 = {g: dict(v) for g, v in f90nml.read(str(cs.REPO / "inputs" / "fig2_n4.nml")).items()}
        fig2["solver"] = {"method": "flight_exact", "tau_end": 100 * math.pi}
        fig2["output"] = {"file": npz, "format": "npy", "sample_dtau": 0.01}
        tilted = cs.namelist("tilted_hertz_3", {"method": "flight_exact", "rtol": 1e-10, "atol": 1e-14},
                             200, cs.PERIOD, npz)
        for name, nml in (("fig2 100 periods", fig2), ("tilted_hertz_3 1e-10 200 periods", tilted)):
            result["runs"][name] = {v: counters(args.exe, v, nml, scratch) for v in args.variants}
            print(name, result["runs"][name], flush=True)
    total = {v: np.sum([row[v] for row in result["sweep"].values()], axis=0).tolist() for v in args.variants}
    result["sweep_total"] = total
    result["counters"] = list(cs.COUNTERS)
    for v in args.variants:
        print(f"variant {v}: sweep total RHS {total[v][3]} ({total[v][3] / total[args.variants[0]][3] - 1:+.2%}),"
              f" rejected {total[v][2]} ({total[v][2] / total[args.variants[0]][2] - 1:+.1%}), steps {total[v][0]}")
    (out / "handover_trials.json").write_text(json.dumps(result, indent=1) + "\n")


if __name__ == "__main__":
    main()

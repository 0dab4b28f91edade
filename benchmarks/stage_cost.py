"""Instructions of a dop853 contact step besides its right-hand sides, per function, for one or
more tmafm executables (e.g. a build of main and the working tree's).

    /opt/tmafm-venv/bin/python benchmarks/stage_cost.py OLD/tmafm build-x/tmafm \
        [--labels 'main c023ff6' 'stages'] [--out /tmp/stage_cost]

Two runs of flight_exact, whose contact phases are dop853 steps (tmafm_method_adaptive):
  t3    tilted_hertz_3 (benchmarks/period_cost.py's scene: N = 3, state length 6), rtol 1e-10,
        atol 1e-14, 200 periods, one sample a period;
  fig2  inputs/fig2_n4.nml (N = 4), flight_exact at its defaults, 100 periods, sample_dtau 0.01
        (every contact step holds samples, so it builds its dense output).
Both write the .npz format.  Each executable runs each input once under valgrind's callgrind;
the self cost of each function below (callgrind_annotate) is divided by the dop853 steps tried
(contact_steps + rejected_steps of the run's counters), the dense output's too (it is built
only for the steps that hold a sample or a switch).  The counters of every executable must
agree (the steps are the same), and it prints the largest difference of each run's arrays
(tau, V_T, a, a', switches) from the first executable's, relative to each array's largest
magnitude.  Writes stage_cost.json and stage_cost.png into --out (default benchmarks/results/).
Instructions, unlike CPU time, do not depend on the load of the shared machine.  The step
loop's own work (adaptive_advance, gap_state, check_blowup) and libm's pow (the PI
controller's two real powers until it took square roots) are listed as well.
"""

import argparse
import json
import re
import subprocess
import tempfile
from pathlib import Path

import f90nml
import numpy as np

from _builds import TARGET_RUNS

REPO = Path(__file__).resolve().parent.parent

#: The two runs of issue 8's targets (benchmarks/_builds.py), under this script's short names.
INPUTS = {"t3": TARGET_RUNS["tilted_hertz_3"], "fig2": TARGET_RUNS["fig2"]}

#: Functions whose self cost is reported: key -> the parts of their (LTO-mangled) names to
#: match; a symbol counts for the key of the longest part it contains.  The dense output's
#: stages moved from prepare_dense into dop853_dense_stages, and its sum into dense_sum.
FUNCTIONS = {
    "dop853_stages": ["dop853_MOD_dop853_stages"],
    "dop853_error_norm": ["dop853_MOD_dop853_error_norm"],
    "dop853_step": ["dop853_MOD_dop853_step"],
    "scale_update": ["error_scale_MOD_scale_update"],
    "controller_next_step": ["embedded_pair_MOD_controller_next_step"],
    "prepare_dense": ["dop853_MOD_dop853_prepare_dense", "dop853_MOD_dop853_dense_stages"],
    "dense": ["dop853_MOD_dop853_dense", "dop853_MOD_dense_sum"],
    "adaptive_advance": ["method_adaptive_MOD_adaptive_advance"],
    "gap_state": ["method_adaptive_MOD_gap_state"],
    "check_blowup": ["trajectory_MOD_check_blowup"],
    "pow (libm)": ["pow@@GLIBC", "__ieee754_pow"],
    "rhs_kernel": ["tmafm_model_MOD_rhs_kernel"],
}
PATTERNS = {part: key for key, parts in FUNCTIONS.items() for part in parts}


def write_input(name, directory):
    nml = f90nml.read(REPO / "inputs" / "fig2_n4.nml")
    for group, values in INPUTS[name].items():
        nml[group].update(values)
    nml["output"]["file"] = f"{name}.npz"
    nml["output"]["format"] = "npy"
    path = directory / f"{name}.nml"
    nml.write(path, force=True)
    return path


def profile(exe, path, directory, tag):
    """Total instructions, self cost per function and counters of one run."""
    out = directory / f"cg.{tag}"
    proc = subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", str(exe),
                           "-q", path.name], cwd=directory, check=True, stdout=subprocess.DEVNULL,
                          stderr=subprocess.PIPE, text=True)
    total = int(re.search(r"Collected\s*:\s*(\d+)", proc.stderr).group(1))
    table = subprocess.run(["callgrind_annotate", "--threshold=100", str(out)], check=True,
                           capture_output=True, text=True).stdout
    self_cost = {key: 0 for key in FUNCTIONS}
    for line in table.splitlines():
        match = re.match(r"\s*([\d,]+)\s+\([^)]*\)\s+\S*:(\S+)", line)
        if not match:
            continue
        cost, symbol = int(match.group(1).replace(",", "")), match.group(2)
        parts = [part for part in PATTERNS if part in symbol]
        if parts:
            self_cost[PATTERNS[max(parts, key=len)]] += cost
    arrays = dict(np.load(directory / path.with_suffix(".npz").name))
    return total, self_cost, arrays


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("executables", nargs="+")
    parser.add_argument("--labels", nargs="+", default=None)
    parser.add_argument("--out", default=str(REPO / "benchmarks" / "results"))
    args = parser.parse_args()
    labels = args.labels or args.executables
    results = {"inputs": INPUTS, "runs": []}
    saved = {}
    with tempfile.TemporaryDirectory() as tmp:
        directory = Path(tmp)
        paths = {name: write_input(name, directory) for name in INPUTS}
        for exe, label in zip(args.executables, labels):
            entry = {"label": label, "executable": str(exe)}
            for name, path in paths.items():
                total, self_cost, arrays = profile(Path(exe).resolve(), path, directory,
                                                   f"{name}.{len(results['runs'])}")
                counters = arrays["counters"].tolist()
                first = saved.setdefault(name, arrays)
                # Largest difference from the first executable's run, in units of each array's
                # largest magnitude: 0 when the results are equal to the last bit.
                differences = {key: float(np.max(np.abs(arrays[key] - first[key]))
                                          / max(np.max(np.abs(first[key])), 1e-300))
                               for key in ("tau", "vt", "vtdot", "a", "adot", "switches")
                               if arrays[key].shape == first[key].shape and arrays[key].size}
                steps, contact, rejected, rhs, switches = counters
                tried = contact + rejected
                entry[name] = {"instructions": total, "counters": counters, "steps_tried": tried,
                               "self": self_cost, "relative_difference": differences,
                               "per_step": {k: v / tried for k, v in self_cost.items()}}
            results["runs"].append(entry)
    for name in INPUTS:
        same = all(run[name]["counters"] == results["runs"][0][name]["counters"]
                   for run in results["runs"])
        results[f"{name}_counters_agree"] = same
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "stage_cost.json").write_text(json.dumps(results, indent=1) + "\n")
    for name in INPUTS:
        largest = [max(run[name]["relative_difference"].values()) for run in results["runs"]]
        print(f"{name}: counters agree: {results[f'{name}_counters_agree']}; largest relative "
              "difference from the first: " + ", ".join(f"{x:.1e}" for x in largest))
        print(f"  {'':22s}" + "".join(f"{run['label']:>16s}" for run in results["runs"]))
        print(f"  {'run instructions':22s}" + "".join(f"{run[name]['instructions'] / 1e6:>15.2f}M"
                                                       for run in results["runs"]))
        for key in FUNCTIONS:
            print(f"  {key + ' /step':22s}" + "".join(f"{run[name]['per_step'][key]:>16.0f}"
                                                      for run in results["runs"]))
    plot(results, out / "stage_cost.png")


def plot(results, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    keys = [k for k in FUNCTIONS if k != "rhs_kernel"]
    fig, axes = plt.subplots(1, len(INPUTS), figsize=(11, 4), sharey=True)
    width = 0.8 / len(results["runs"])
    for ax, name in zip(axes, INPUTS):
        for i, run in enumerate(results["runs"]):
            ax.bar(np.arange(len(keys)) + i * width, [run[name]["per_step"][k] for k in keys],
                   width, label=f"{run['label']} ({run[name]['instructions'] / 1e6:.1f} M a run)")
        ax.set_xticks(np.arange(len(keys)) + width * (len(results["runs"]) - 1) / 2, keys,
                      rotation=45, ha="right")
        ax.set_title(f"{name}: instructions per dop853 step tried, besides the RHS")
        ax.title.set_fontsize(9)
        ax.legend(fontsize=8)
    axes[0].set_ylabel("instructions (self) / step")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


if __name__ == "__main__":
    main()

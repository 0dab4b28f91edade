"""Cost of writing the output: text against .npz, CPU time per sample row.

Each case runs the executable with --timings, which reports the CPU time of the write phase
(formatting, CRC, write(2) calls, fsync, rename) and its wall time, in the same process as
the run.  Both formats are timed on the same runs, alternately, and the median of the
repeats is kept; the ratio text/npz is computed within one invocation of this script.

    /opt/tmafm-venv/bin/python benchmarks/output_write.py            # writes the JSON + PNG
    /opt/tmafm-venv/bin/python benchmarks/output_write.py --repeats 3 --out /tmp
"""

import argparse
import json
import re
import statistics
import subprocess
import tempfile
from pathlib import Path

import f90nml

import tmafm

HERE = Path(__file__).resolve().parent
INPUTS = HERE.parent / "inputs"

#: (label, n_modes, tau_end, method): the default Fig. 2 run over 100 periods, and a wide one.
CASES = [
    ("fig2 N=4, 100 periods", 4, 314.159, "rk4_paper"),
    ("fig2 N=16, 50 periods", 16, 157.08, "dopri5"),
]
TIMINGS = re.compile(r"write ([0-9.]+) s CPU \(([0-9.]+) s wall\)")


def write_input(folder: Path, n_modes: int, tau_end: float, method: str, fmt: str) -> Path:
    nml = f90nml.read(str(INPUTS / "fig2_n4.nml"))
    nml["model"]["n_modes"] = n_modes
    nml.pop("initial", None)
    nml["solver"]["tau_end"] = tau_end
    nml["solver"]["method"] = method
    nml["output"] = {"file": "out.npz" if fmt == "npy" else "out.dat", "format": fmt}
    path = folder / f"{fmt}.nml"
    nml.write(str(path), force=True)
    return path


def time_write(exe: str, path: Path, folder: Path):
    proc = subprocess.run([exe, str(path), "-q", "--timings"], cwd=folder, capture_output=True,
                          text=True, check=True)
    cpu, wall = map(float, TIMINGS.search(proc.stderr).groups())
    return cpu, wall


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--out", type=Path, default=HERE / "results")
    args = parser.parse_args()
    exe = tmafm.executable()
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for label, n_modes, tau_end, method in CASES:
            paths = {fmt: write_input(folder, n_modes, tau_end, method, fmt) for fmt in ("text", "npy")}
            samples = {fmt: [] for fmt in paths}
            for _ in range(args.repeats):
                for fmt, path in paths.items():
                    samples[fmt].append(time_write(exe, path, folder))
            rows = sum(1 for line in open(folder / "out.dat") if not line.startswith("#"))
            entry = {"case": label, "n_modes": n_modes, "rows": rows,
                     "bytes": {"text": (folder / "out.dat").stat().st_size,
                               "npy": (folder / "out.npz").stat().st_size}}
            for fmt in paths:
                cpu = statistics.median(s[0] for s in samples[fmt])
                wall = statistics.median(s[1] for s in samples[fmt])
                entry[fmt] = {"cpu_s": cpu, "wall_s": wall, "cpu_us_per_row": 1e6 * cpu / rows}
            entry["cpu_ratio_text_over_npy"] = entry["text"]["cpu_s"] / max(entry["npy"]["cpu_s"], 1e-6)
            results.append(entry)
            print(f"{label}: {rows} rows; text {entry['text']['cpu_us_per_row']:.3f} us/row CPU, "
                  f"npz {entry['npy']['cpu_us_per_row']:.3f} us/row CPU, "
                  f"ratio {entry['cpu_ratio_text_over_npy']:.1f}; wall text {entry['text']['wall_s']:.3f} s, "
                  f"npz {entry['npy']['wall_s']:.3f} s")
    report = {"benchmark": "output_write", "repeats": args.repeats, "tmafm": tmafm.__version__,
              "note": "median CPU and wall seconds of the write phase (tmafm --timings); wall includes fsync",
              "cases": results}
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "output_write.json").write_text(json.dumps(report, indent=2) + "\n")
    plot(results, args.out / "output_write.png")


def plot(results, path: Path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 3.6))
    width = 0.38
    for k, (fmt, label) in enumerate((("text", "text (17 digits)"), ("npy", ".npz"))):
        values = [r[fmt]["cpu_us_per_row"] for r in results]
        xs = [i + (k - 0.5) * width for i in range(len(results))]
        bars = ax.bar(xs, values, width, label=label)
        ax.bar_label(bars, fmt="%.3f", fontsize=8)
    ax.set_xticks(range(len(results)), [f"{r['case']}\n{r['rows']} rows" for r in results])
    ax.set_ylabel("write CPU time per row (µs)")
    ax.set_yscale("log")
    ax.set_title("Output write cost (median of runs; tmafm --timings)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)


if __name__ == "__main__":
    main()

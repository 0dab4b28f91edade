"""AM imaging's cost: one 256-pixel scan line (trace and retrace) of a standard scene with the
Z feedback (docs/instrument.md, "AM imaging"), its CPU time and its plot.

    /opt/tmafm-venv/bin/python benchmarks/scan_line.py            # -> benchmarks/results/
    /opt/tmafm-venv/bin/python benchmarks/scan_line.py --out /tmp/scan   # elsewhere

The scene (SCENE below): the standard tapping cantilever on polystyrene
(inputs/tapping_polystyrene.nml: k = 40 N/m, f0 = 300 kHz, Q = 400, A0 = 20 nm), a 500 nm line
at a line rate of 2 Hz, setpoint A/A0 = 0.8, lock-in bandwidth 2 kHz, feedback bandwidth
200 Hz, a 5 nm step up at x = 150 nm, a softer, more adhesive polymer (E = 0.3 GPa, gamma =
0.05 J/m^2) from x = 350 nm.  Timed in CPU time (user + sys of this process; the imports and a
warm-up call excluded), written to scan_line.json and scan_line.png (the scan's plot).
"""

import argparse
import json
import resource
from pathlib import Path

import numpy as np

import tmafm.instrument

REPO = Path(__file__).resolve().parent.parent
SCENE = dict(scan_length=500e-9, pixels=256, line_rate=2.0, setpoint_ratio=0.8, lockin_bandwidth=2e3,
             feedback_bandwidth=200.0, topography="step", step_height=5e-9, step_position=150e-9,
             material_b={"youngs_modulus_sample": 0.3e9, "adhesion_energy": 0.05},
             material_boundary=350e-9)


def cpu_seconds() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--out", type=Path, default=None,
                        help="folder for the JSON and the figure (default: benchmarks/results/)")
    args = parser.parse_args()
    results = args.out or REPO / "benchmarks" / "results"
    results.mkdir(parents=True, exist_ok=True)
    # Warm-up: the imports and the core's first call (a short, fast line).
    tmafm.instrument.scan_line("tapping_polystyrene", scan_length=10e-9, pixels=2, line_rate=2e3,
                               setpoint_ratio=0.8, lockin_bandwidth=2e3, feedback_bandwidth=200.0,
                               physical={"quality_factor": 50.0})
    before = cpu_seconds()
    ds = tmafm.instrument.scan_line("tapping_polystyrene", **SCENE)
    cpu = cpu_seconds() - before
    a = ds.attrs
    engage = int(a["ringup_periods"] + a["engage_periods"])
    height = ds["height"].sel(direction="retrace").values
    x = ds["x"].values
    # The apparent steps the line shows (retrace, means of the pixels well inside each region).
    region = [(x > lo) & (x < hi) for lo, hi in ((50, 130), (250, 330), (400, 480))]
    levels = [float(height[r].mean()) for r in region]
    report = {
        "command": "python benchmarks/scan_line.py",
        "input": "inputs/tapping_polystyrene.nml",
        "scene": {k: v for k, v in SCENE.items()},
        "cpu_s": cpu,
        "scan_periods": int(a["periods"]),
        "engage_periods": engage,
        "periods_per_pixel": int(a["periods_per_pixel"]),
        "cpu_us_per_period": 1e6 * cpu / (int(a["periods"]) + engage),
        "free_amplitude_nm": a["free_amplitude_nm"],
        "setpoint_nm": a["setpoint_nm"],
        "slope": a["slope"],
        "proportional_gain": a["proportional_gain"],
        "integral_gain_per_s": a["integral_gain_1_per_s"],
        "cantilever_time_s": a["cantilever_time_s"],
        "closed_loop_time_s": a["closed_loop_time_s"],
        "apparent_step_nm": levels[1] - levels[0],
        "apparent_material_step_nm": levels[2] - levels[1],
        "phase_contrast_deg": float(np.mean(ds["phase"].sel(direction="retrace").values[region[2]])
                                    - np.mean(ds["phase"].sel(direction="retrace").values[region[1]])),
    }
    (results / "scan_line.json").write_text(json.dumps(report, indent=1) + "\n")
    tmafm.instrument.plot_scan(ds, results / "scan_line.png")
    print(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()

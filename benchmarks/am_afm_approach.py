"""The AM-AFM approach curve of docs/sweeps.md: a standard tapping cantilever (k = 40 N/m,
f0 = 300 kHz, Q = 400, R = 10 nm, silicon) on polystyrene in air, A0 = 20 nm, Z from 25 nm
down to contact and back (inputs/tapping_polystyrene.nml), with its plot and its CPU time.

    /opt/tmafm-venv/bin/python benchmarks/am_afm_approach.py            # -> benchmarks/results/
    /opt/tmafm-venv/bin/python benchmarks/am_afm_approach.py --out /tmp/am   # elsewhere

Runs tmafm.approach("tapping_polystyrene", z=np.linspace(25e-9, 0, 26), max_periods=6000,
steady_tol=1e-8) on one worker (every point warm-started from the previous one, both ways), timed in CPU time
(user + sys of this process, its threads included; the imports and a warm-up call excluded),
and writes am_afm_approach.json (the numbers docs/sweeps.md quotes, benchmarks/check_docs.py
checks them) and the figure docs/figures/am_afm_approach.png (with --out: into --out).
"""

import argparse
import json
import resource
import warnings
from pathlib import Path

import numpy as np

import tmafm
from tmafm.sweeps import plots

REPO = Path(__file__).resolve().parent.parent
Z = np.linspace(25e-9, 0.0, 26)
KEYWORDS = dict(max_periods=6000, steady_tol=1e-8, workers=1)
#: The distances whose values the docs quote (m).
QUOTED = (25e-9, 19e-9, 15e-9, 10e-9, 5e-9, 0.0)


def cpu_seconds() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def point(ds, direction: str, z: float) -> dict:
    """The quoted values at one Z (nm, nN, degree, pW; A/A0)."""
    at = ds.sel(direction=direction).sel(z=z, method="nearest")
    indentation = max(0.0, -float(at.min_gap))
    return {"z_nm": float(at.z) * 1e9, "amplitude_nm": float(at.amplitude),
            "setpoint": float(at.setpoint), "phase_deg": float(at.phase),
            "peak_force_nN": float(at.peak_force), "indentation_nm": indentation,
            "dissipated_power_pW": float(at.dissipated_power),
            "tip_sample_power_pW": float(at.tip_sample_power), "period": int(at.period),
            "periods": int(at.periods)}


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--out", type=Path, default=None,
                        help="folder for the JSON and the figure (default: benchmarks/results/ "
                             "and docs/figures/)")
    args = parser.parse_args()
    results = args.out or REPO / "benchmarks" / "results"
    figures = args.out or REPO / "docs" / "figures"
    results.mkdir(parents=True, exist_ok=True)
    figures.mkdir(parents=True, exist_ok=True)
    tmafm.approach("tapping_polystyrene", z=[25e-9], retract=False, max_periods=2, workers=1,
                   stop_at_steady=False)  # warm-up: imports and the core's first call
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", tmafm.UnsteadyWarning)
        before = cpu_seconds()
        ds = tmafm.approach("tapping_polystyrene", z=Z, **KEYWORDS)
        cpu = cpu_seconds() - before
    summary = tmafm.sweeps.summarize(ds)
    points = int(ds["periods"].size)
    report = {
        "command": "python benchmarks/am_afm_approach.py",
        "input": "inputs/tapping_polystyrene.nml",
        "z_nm": [float(x) * 1e9 for x in Z],
        "keywords": KEYWORDS,
        "points": points,
        "cpu_s": cpu,
        "periods_run": int(ds["periods"].sum()),
        "cpu_us_per_period": 1e6 * cpu / int(ds["periods"].sum()),
        "free_amplitude_nm": float(ds.attrs["free_amplitude"]),
        "unsteady_points": int((ds["period"] == 0).sum()),
        "warnings": [str(w.message) for w in caught],
        "failures": int(ds.attrs["failures"]),
        "jumps": summary["jumps"],
        "approach": [point(ds, "approach", z) for z in QUOTED],
        "retract": [point(ds, "retract", z) for z in QUOTED],
        "contact_onset_nm": {d: float(ds.sel(direction=d).z.where(
            ds.sel(direction=d).contacts_per_period > 0).max()) * 1e9
            for d in ("approach", "retract")},
    }
    (results / "am_afm_approach.json").write_text(json.dumps(report, indent=1) + "\n")
    plots.plot(ds, figures / "am_afm_approach.png")
    print(f"{points} points, {report['periods_run']} periods, {cpu:.2f} s CPU "
          f"({report['cpu_us_per_period']:.1f} us per period)")
    for row in report["approach"]:
        print(row)


if __name__ == "__main__":
    main()

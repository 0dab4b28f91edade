"""What the specialised elastic kernels save over the composed one (docs/model.md §16): callgrind
instructions of the same run through `rhs_kernel`/`general_kernel` (drive phase 0) and through
`composed_kernel` (drive phase 1e-12 rad: a general drive, the same physics to 1e-12).

    /opt/tmafm-venv/bin/python benchmarks/composed_cost.py [--json FILE] [--png FILE]

Runs the installed executable (tmafm.executable()) under valgrind's callgrind on three scenes by
dop853 (whose cost is the right-hand side and the step, not the exact flight): Fig. 2 (N = 4,
the small kernel), the 3-mode tilted scene, and Fig. 2 with N = 6 (general_kernel).  The ratio
composed/specialised is the result; instruction counts are deterministic for a build.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _builds  # noqa: E402

import tmafm  # noqa: E402

PHASE = 1e-12
SCENES = {
    "fig2_n4_dop853": {"solver": {"method": "dop853", "rtol": 1e-10, "atol": 1e-14, "tau_end": 60.0}},
    "tilted_hertz_3_dop853": {**_builds.TARGET_RUNS["tilted_hertz_3"],
                              "solver": {"method": "dop853", "rtol": 1e-10, "atol": 1e-14, "tau_end": 60.0}},
    "fig2_n6_dop853": {"model": {"n_modes": 6}, "initial": {"a0": [0.0] * 6, "adot0": [0.0] * 6},
                       "solver": {"method": "dop853", "rtol": 1e-10, "atol": 1e-14, "tau_end": 60.0}},
}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=Path, default=_builds.REPO / "benchmarks" / "results" / "composed_cost.json")
    parser.add_argument("--png", type=Path, default=_builds.REPO / "benchmarks" / "results" / "composed_cost.png")
    args = parser.parse_args(argv)
    exe = tmafm.executable()
    result = {"phase": PHASE, "runs": {}}
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for name, overrides in SCENES.items():
            row = {}
            for label, phase in (("specialised", 0.0), ("composed", PHASE)):
                scene = {**overrides.get("scene", {}), "drive_phase": phase}
                nml = _builds.scene_file(f"{name}_{label}", {**overrides, "scene": scene}, work)
                row[label] = _builds.callgrind([str(exe), "-q", str(nml)], work)
            row["ratio"] = round(row["composed"] / row["specialised"], 4)
            result["runs"][name] = row
            print(f"{name}: specialised {row['specialised']:,}, composed {row['composed']:,} "
                  f"instructions (composed/specialised = {row['ratio']:.3f})")
    args.json.write_text(json.dumps(result, indent=2) + "\n")
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return 0
    names = list(result["runs"])
    fig, ax = plt.subplots(figsize=(6, 3.2))
    ax.bar(range(len(names)), [result["runs"][n]["ratio"] for n in names], color="C1")
    ax.axhline(1.0, color="k", lw=0.8)
    ax.set_xticks(range(len(names)), names, rotation=15, fontsize=8)
    ax.set_ylabel("instructions, composed / specialised")
    ax.set_title("the composed kernel's cost on elastic one-tone scenes (callgrind)", fontsize=9)
    fig.tight_layout()
    fig.savefig(args.png, dpi=120)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""What the optional physics costs when it is off: callgrind instructions of one build against
another on the runs issue 21 names, with every switch off.

    /opt/tmafm-venv/bin/python benchmarks/off_cost.py --base 615b428 [--head HEAD] [--json FILE]

Builds both revisions (meson release, benchmarks/_builds.py) into a temporary folder and counts
the instructions of three runs of each executable under valgrind's callgrind:
- "fig2": Fig. 2's scene by flight_exact over 100 periods (_builds.TARGET_RUNS, .npz output);
- "tilted_hertz_3": the 3-mode tilted scene at rtol 1e-10 over 200 periods (TARGET_RUNS);
- "fig2_n4_rk4_paper": inputs/fig2_n4.nml as packaged (rk4_paper, text output).
Instruction counts are deterministic for a given build and machine; the ratio is the result.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _builds  # noqa: E402


def counts(exe: Path, work: Path) -> dict[str, int]:
    """Instructions of the three runs of one executable."""
    row = {}
    for name, overrides in _builds.TARGET_RUNS.items():
        row[name] = _builds.callgrind([str(exe), "-q", str(_builds.scene_file(name, overrides, work))], work)
    row["fig2_n4_rk4_paper"] = _builds.callgrind(
        [str(exe), "-q", str(_builds.REPO / "inputs" / "fig2_n4.nml"), "-o", str(work / "fig2_n4.dat")], work)
    return row


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", required=True, help="the revision before the switches")
    parser.add_argument("--head", default="HEAD", help="the revision measured (default HEAD)")
    parser.add_argument("--json", type=Path, help="write the counts and ratios here")
    args = parser.parse_args(argv)
    def revision(rev: str) -> str:
        return subprocess.run(["git", "-C", str(_builds.REPO), "rev-parse", "--short", rev], check=True,
                              capture_output=True, text=True).stdout.strip()

    result = {"base": revision(args.base), "head": revision(args.head), "runs": {}}
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        row = {}
        for label, rev in (("base", args.base), ("head", args.head)):
            source = _builds.export_revision(rev, work / f"src_{label}")
            _builds.build(source, work / f"build_{label}")
            row[label] = counts(work / f"build_{label}" / "tmafm", work)
    for name in row["base"]:
        base, head = row["base"][name], row["head"][name]
        result["runs"][name] = {"base": base, "head": head, "change_percent": round(100 * (head - base) / base, 3)}
        print(f"{name}: {base:,} -> {head:,} instructions ({100 * (head - base) / base:+.3f} %)")
    if args.json:
        args.json.write_text(json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Fuzz campaign: the contract of tests/test_fuzz.py over many seeded cases, on 2 processes.

    /opt/tmafm-venv/bin/python studies/fuzz_campaign.py [--cases 10000] [--first-seed 0]
        [--jobs 2] [--out studies/results/fuzz_campaign.json]

Writes JSON: the tmafm version and git commit, the counts per outcome class (overall and per
mutation kind), the CPU time, and every case that broke the contract (seed, kind, class,
detail, the first 2000 bytes of its text), and the cases counted beyond the contract
(unprintable error messages); `generate(seed)` in tests/test_fuzz.py rebuilds any
case from its seed.
"""

import argparse
import importlib.util
import json
import resource
import subprocess
import sys
import time
from collections import Counter, defaultdict
from multiprocessing import Pool
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
_spec = importlib.util.spec_from_file_location("test_fuzz", REPO / "tests" / "test_fuzz.py")
fuzz = importlib.util.module_from_spec(_spec)
sys.modules["test_fuzz"] = fuzz
_spec.loader.exec_module(fuzz)

_EXE = None


def _init(exe):
    global _EXE
    _EXE = exe


def one(seed: int) -> dict:
    case = fuzz.generate(seed)
    outcome, detail = fuzz.check(_EXE, case)
    row = {"seed": seed, "kind": case.kind, "outcome": outcome}
    if outcome not in ("ok", "ok-error"):
        row.update(detail=detail[:1000], text=case.text[:2000].decode("utf-8", "backslashreplace"))
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=10_000)
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--out", type=Path, default=REPO / "studies" / "results" / "fuzz_campaign.json")
    args = parser.parse_args()
    exe = fuzz.executable()
    version = subprocess.run([exe, "--version"], capture_output=True, text=True).stdout.strip()
    commit = subprocess.run(["git", "-C", str(REPO), "rev-parse", "HEAD"], capture_output=True,
                            text=True).stdout.strip()
    start, cpu0 = time.time(), resource.getrusage(resource.RUSAGE_CHILDREN)
    seeds = range(args.first_seed, args.first_seed + args.cases)
    with Pool(args.jobs, initializer=_init, initargs=(exe,)) as pool:
        rows = pool.map(one, seeds, chunksize=20)
    cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    outcomes = Counter(r["outcome"] for r in rows)
    by_kind = defaultdict(Counter)
    for r in rows:
        by_kind[r["kind"]][r["outcome"]] += 1
    failures = [r for r in rows if r["outcome"] not in fuzz.GOOD]
    report = {
        "command": "python studies/fuzz_campaign.py " + " ".join(sys.argv[1:]),
        "tmafm": version, "commit": commit, "cases": len(rows),
        "seeds": [seeds.start, seeds.stop - 1], "time_limit_s": fuzz.TIME_LIMIT,
        "wall_s": round(time.time() - start, 1),
        "cpu_s": round(cpu1.ru_utime + cpu1.ru_stime - cpu0.ru_utime - cpu0.ru_stime, 1),
        "outcomes": dict(outcomes.most_common()),
        "broke_contract": len(failures),
        "by_kind": {k: dict(v.most_common()) for k, v in sorted(by_kind.items())},
        "failures": failures,
        "beyond_contract": [r for r in rows if r["outcome"] in fuzz.GOOD - {"ok", "ok-error"}],
    }
    args.out.write_text(json.dumps(report, indent=1) + "\n")
    print(json.dumps({k: report[k] for k in ("cases", "outcomes", "broke_contract", "wall_s", "cpu_s")}))


if __name__ == "__main__":
    main()

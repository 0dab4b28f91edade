"""What the Ctrl-C poll of runs started from Python costs (docs/model-notes.md, item 12).

A run asks pywrap/tmafm_check_signals.c at its first step and every poll_every steps
(fortran/src/run/tmafm_trajectory.f90) whether a Python signal handler raised.  This prints:
  - one poll's CPU time, called through ctypes (which releases the GIL around the call, as a run
    does), and the same for libc's abs: their difference is the poll (GIL free, no signal);
  - with --callgrind, its instructions: PyGILState_Ensure + PyGILState_Release +
    PyErr_CheckSignals per call, inclusive (valgrind, about 15 s);
  - for the cheapest and the dearest steps (rk4_paper with N = 1; dop853 at rtol 1e-10 with
    N = 30): CPU per step, the polls' share of the run (the ctypes time per poll, an upper
    bound), and the CPU from a Ctrl-C to the stop (poll_every steps at most).

    python benchmarks/poll_cost.py [--callgrind] [--json out.json]
"""

import argparse
import ctypes
import json
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import tmafm
import tmafm._core

ROOT = Path(__file__).resolve().parents[1]
POLL_EVERY = int(re.search(r"integer, parameter :: poll_every = (\d+)",
                           (ROOT / "fortran/src/run/tmafm_trajectory.f90").read_text())[1])
SCENES = {
    "cheapest: fig2_n1, rk4_paper": ("fig2_n1", {"solver": {"tau_end": 400.0},
                                                 "output": {"sample_dtau": 1.0}}),
    "dearest: N = 30, dop853, rtol 1e-10": ("fig2_n4", {
        "model": {"n_modes": 30}, "initial": {"a0": [0.0] * 30},
        "solver": {"tau_end": 40.0, "method": "dop853", "rtol": 1e-10, "atol": 1e-14},
        "output": {"sample_dtau": 1.0}}),
}
LOOP = """
import ctypes, tmafm._core
poll = ctypes.CDLL(tmafm._core.__file__).tmafm_check_signals
for _ in range({n}):
    poll()
"""


def ctypes_times(n: int = 300_000, repeats: int = 5) -> tuple[float, float]:
    """Least CPU seconds per call of the poll and of libc abs, through ctypes."""
    poll = ctypes.CDLL(tmafm._core.__file__).tmafm_check_signals
    nop = ctypes.CDLL(None).abs
    best_poll = best_nop = float("inf")
    for _ in range(repeats):
        start = time.process_time()
        for _ in range(n):
            poll()
        best_poll = min(best_poll, (time.process_time() - start) / n)
        start = time.process_time()
        for _ in range(n):
            nop(0)
        best_nop = min(best_nop, (time.process_time() - start) / n)
    return best_poll, best_nop


def callgrind_instructions(n: int = 10_000) -> float:
    """Instructions per poll: the three Python C-API calls it makes, inclusive."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "poll.cg"
        subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", sys.executable,
                        "-c", LOOP.format(n=n)], check=True, capture_output=True)
        text = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--threshold=100", str(out)],
                              check=True, capture_output=True, text=True).stdout
    total = 0
    for name in ("PyGILState_Ensure", "PyGILState_Release", "PyErr_CheckSignals"):
        counts = [int(m[1].replace(",", "")) for m in
                  re.finditer(r"^\s*([\d,]+) \([^)]*\)\s+\S*:" + name + r" \[", text, re.M)]
        total += max(counts)
    return total / n


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--callgrind", action="store_true", help="count the poll's instructions")
    parser.add_argument("--json", type=Path, help="also write the numbers here")
    args = parser.parse_args()
    poll_s, nop_s = ctypes_times()
    out = {"poll_every": POLL_EVERY, "poll_through_ctypes_us": poll_s * 1e6,
           "abs_through_ctypes_us": nop_s * 1e6, "poll_us": (poll_s - nop_s) * 1e6}
    print(f"poll_every = {POLL_EVERY}")
    print(f"one poll through ctypes {poll_s * 1e6:.3f} us, libc abs {nop_s * 1e6:.3f} us: "
          f"the poll {(poll_s - nop_s) * 1e6:.3f} us")
    if args.callgrind:
        out["poll_instructions"] = callgrind_instructions()
        print(f"one poll: {out['poll_instructions']:.0f} instructions (callgrind)")
    for label, (name, overrides) in SCENES.items():
        config = tmafm.Config(name, **overrides)
        start = time.process_time()
        result = config.run()
        seconds = time.process_time() - start
        steps = result.counters["steps"]
        polls = steps // POLL_EVERY + 1
        step_us = seconds / steps * 1e6
        share = polls * poll_s / seconds
        out[label] = {"cpu_s": seconds, "steps": steps, "step_us": step_us, "polls": polls,
                      "poll_share_at_most": share, "stop_within_ms": POLL_EVERY * step_us / 1e3}
        print(f"{label}: {steps} steps in {seconds:.3f} s CPU ({step_us:.2f} us a step), {polls} "
              f"polls: at most {100 * share:.3f} % of the run; a Ctrl-C stops it within "
              f"{POLL_EVERY * step_us / 1e3:.1f} ms of CPU")
    if args.json:
        args.json.write_text(json.dumps(out, indent=2) + "\n")


if __name__ == "__main__":
    main()

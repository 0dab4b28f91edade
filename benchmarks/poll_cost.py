"""What the Ctrl-C poll of runs started from Python costs (docs/model-notes.md, item 12).

A run started on Python's main thread asks pywrap/tmafm_check_signals.c at its first update,
then, looking at the clock every poll_every updates, once poll_interval_ms of wall time (and
poll_spacing times the last poll's own time) passed since the last poll returned
(fortran/src/solve/tmafm_trajectory.f90); runs on other threads never poll.  This prints:
  - one poll's CPU time, called through ctypes (which releases the GIL around the call, as a run
    does), and the same for libc's abs: their difference is the poll (GIL free, no signal);
  - with --callgrind, its instructions: PyGILState_Ensure + PyGILState_Release +
    PyErr_CheckSignals per call, inclusive (valgrind, about 15 s);
  - for the cheapest and the dearest steps (rk4_paper with N = 1; dop853 at rtol 1e-10 with
    N = 30): CPU per step, the polls' share of the run (at most one poll per poll_interval_ms,
    at the ctypes time per poll: an upper bound), and the CPU from a SIGINT to the
    KeyboardInterrupt, measured (a timer thread signals the process halfway through the run;
    the largest of --stops tries);
  - the cheapest run's wall time (less the time it waited for a CPU) with another thread
    spinning in Python code over the same run with none, on the main thread (it polls, and
    each poll waits for the GIL) and on a worker thread (it does not poll); least of --repeats
    each, interleaved.

    python benchmarks/poll_cost.py [--callgrind] [--stops 5] [--repeats 3] [--json out.json]
"""

import argparse
import ctypes
import json
import re
import subprocess
import sys
import signal
import tempfile
import threading
import time
from pathlib import Path

import tmafm
import tmafm._fwrap

ROOT = Path(__file__).resolve().parents[1]
_TRAJECTORY = (ROOT / "fortran/src/solve/tmafm_trajectory.f90").read_text()
POLL_EVERY = int(re.search(r"integer, parameter :: poll_every = (\d+)", _TRAJECTORY)[1])
POLL_INTERVAL_MS = int(re.search(r"integer, parameter :: poll_interval_ms = (\d+)", _TRAJECTORY)[1])
SCENES = {
    "cheapest: fig2_n1, rk4_paper": ("fig2_n1", {"solver": {"tau_end": 400.0},
                                                 "output": {"sample_dtau": 1.0}}),
    "dearest: N = 30, dop853, rtol 1e-10": ("fig2_n4", {
        "model": {"n_modes": 30}, "initial": {"a0": [0.0] * 30},
        "solver": {"tau_end": 40.0, "method": "dop853", "rtol": 1e-10, "atol": 1e-14},
        "output": {"sample_dtau": 1.0}}),
}
LOOP = """
import ctypes, tmafm._fwrap
poll = ctypes.CDLL(tmafm._fwrap.__file__).tmafm_check_signals
for _ in range({n}):
    poll()
"""


def ctypes_times(n: int = 300_000, repeats: int = 5) -> tuple[float, float]:
    """Least CPU seconds per call of the poll and of libc abs, through ctypes."""
    poll = ctypes.CDLL(tmafm._fwrap.__file__).tmafm_check_signals
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


def stop_cpu(config: "tmafm.Config", run_cpu: float) -> float:
    """CPU seconds from a SIGINT, sent halfway through the run's CPU time, to the
    KeyboardInterrupt out of config.run() on this (the main) thread."""
    sent = []

    def fire():
        sent.append(time.process_time())
        signal.raise_signal(signal.SIGINT)

    timer = threading.Timer(run_cpu / 2, fire)
    timer.start()
    try:
        config.run()
    except KeyboardInterrupt:
        return time.process_time() - sent[0]
    finally:
        timer.cancel()
    raise RuntimeError("the run was not stopped: raise its length")


def cpu_wait() -> float:
    """Seconds this thread has waited for a CPU (runnable, not running): the second field of
    /proc/thread-self/schedstat; 0 where there is none."""
    try:
        with open("/proc/thread-self/schedstat") as f:
            return int(f.read().split()[1]) / 1e9
    except (OSError, IndexError, ValueError):
        return 0.0


def spinner_ratio(config: "tmafm.Config", on_main: bool, repeats: int) -> dict:
    """Least time of config.run() with another thread spinning in Python code, over that with
    none, on the main thread or on a worker thread: the wall time less the time the running
    thread waited for a CPU (on a busy host the spinner competes for one)."""
    def once(spin: bool) -> float:
        done, out = threading.Event(), {}

        def run():
            waited, start = cpu_wait(), time.monotonic()
            config.run()
            out["wall"] = time.monotonic() - start - (cpu_wait() - waited)
            done.set()

        def spinner():
            while not done.is_set():
                pass

        if on_main and not spin:
            run()
            return out["wall"]
        other = threading.Thread(target=spinner if on_main else run)
        other.start()
        if on_main:
            run()
        elif spin:
            spinner()
        other.join()
        return out["wall"]

    walls = {False: [], True: []}
    for _ in range(repeats):
        for spin in (False, True):
            walls[spin].append(once(spin))
    return {"quiet_s": min(walls[False]), "spinner_s": min(walls[True]),
            "ratio": min(walls[True]) / min(walls[False])}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--callgrind", action="store_true", help="count the poll's instructions")
    parser.add_argument("--stops", type=int, default=5, help="SIGINTs per scene")
    parser.add_argument("--repeats", type=int, default=3, help="runs per spinner case")
    parser.add_argument("--json", type=Path, help="also write the numbers here")
    args = parser.parse_args()
    signal.signal(signal.SIGINT, signal.default_int_handler)
    poll_s, nop_s = ctypes_times()
    out = {"poll_every": POLL_EVERY, "poll_interval_ms": POLL_INTERVAL_MS,
           "poll_through_ctypes_us": poll_s * 1e6,
           "abs_through_ctypes_us": nop_s * 1e6, "poll_us": (poll_s - nop_s) * 1e6}
    print(f"one poll through ctypes {poll_s * 1e6:.3f} us, libc abs {nop_s * 1e6:.3f} us: "
          f"the poll {(poll_s - nop_s) * 1e6:.3f} us")
    if args.callgrind:
        out["poll_instructions"] = callgrind_instructions()
        print(f"one poll: {out['poll_instructions']:.0f} instructions (callgrind)")
    print(f"poll_every = {POLL_EVERY} updates, poll_interval_ms = {POLL_INTERVAL_MS}")
    for label, (name, overrides) in SCENES.items():
        config = tmafm.Config(name, **overrides)
        start, wall = time.process_time(), time.monotonic()
        result = config.run()
        seconds, wall = time.process_time() - start, time.monotonic() - wall
        steps = result.counters["steps"]
        polls = int(wall * 1e3 / POLL_INTERVAL_MS) + 1
        step_us = seconds / steps * 1e6
        share = polls * poll_s / seconds
        stops = [stop_cpu(config, seconds) for _ in range(args.stops)]
        out[label] = {"cpu_s": seconds, "steps": steps, "step_us": step_us, "polls_at_most": polls,
                      "poll_share_at_most": share, "stop_cpu_ms": [s * 1e3 for s in stops]}
        print(f"{label}: {steps} steps in {seconds:.3f} s CPU ({step_us:.2f} us a step), at most "
              f"{polls} polls: at most {100 * share:.4f} % of the run; a SIGINT stopped it within "
              f"{1e3 * max(stops):.1f} ms of CPU (median {1e3 * sorted(stops)[len(stops) // 2]:.1f}, "
              f"{len(stops)} tries)")
    name, overrides = SCENES["cheapest: fig2_n1, rk4_paper"]
    cheapest = tmafm.Config(name, **overrides)
    for where, on_main in (("main thread", True), ("worker thread", False)):
        ratio = spinner_ratio(cheapest, on_main, args.repeats)
        out[f"spinner, run on the {where}"] = ratio
        print(f"cheapest run on the {where}: {ratio['quiet_s']:.3f} s (wall less CPU-queue wait), "
              f"with another thread spinning in Python {ratio['spinner_s']:.3f} s: {ratio['ratio']:.2f}x")
    if args.json:
        args.json.write_text(json.dumps(out, indent=2) + "\n")


if __name__ == "__main__":
    main()

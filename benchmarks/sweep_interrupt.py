"""How long each sweep entry point takes to stop on Ctrl-C (docs/sweeps.md, "Where the runs go").

For each case, a child Python process runs the sweep on the bistable scene
(inputs/sweeps/bistable_n2.nml, 200 periods per point, no steady-state stop, 2 workers).
The parent sends SIGINT DELAY s after the call starts: to the child alone, or with --group
to its whole process group, as a terminal's Ctrl-C does. It prints one JSON line per case:
  - `call_s`: the undisturbed call's wall time (with --full, no SIGINT);
  - `to_kbi_s`: wall time from the SIGINT to KeyboardInterrupt coming out of the call;
  - `to_exit_s`: wall time to the child's exit (Dask: includes closing the LocalCluster);
  - `tracebacks`: the tracebacks on the child's stderr. The child does not catch the
    KeyboardInterrupt, so its own main thread's traceback is 1 of them.

    python benchmarks/sweep_interrupt.py [CASE ...] [--delay 2] [--full] [--group]

Wall times on a shared machine: rerun, and compare to_kbi_s with call_s.
"""

import argparse
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

BISTABLE = Path(__file__).resolve().parents[1] / "inputs" / "sweeps" / "bistable_n2.nml"

CHILD = textwrap.dedent("""
    import sys, time, numpy as np, tmafm, xarray, tqdm.auto, tmafm.sweeps
    base = tmafm.Config(sys.argv[1])
    def timed(call):
        print('go', flush=True)
        t0 = time.monotonic()
        try:
            call()
        except KeyboardInterrupt:
            print('kbi', time.monotonic(), flush=True)
            raise
        print('done', time.monotonic() - t0, flush=True)
    if __name__ == '__main__':
""")
Q = "workers=2, max_periods=200, stop_at_steady=False"
FREQ = "np.linspace(3.0, 4.4, 30), curves={'scene.alpha2': [4e-4, 5e-4, 6e-4, 7e-4]}"
GRID = "{'scene.omega': np.linspace(3.0, 4.4, 480)}"
BASIN = "np.linspace(-4e-3, 2e-3, 32), np.linspace(-8e-3, 8e-3, 32), steady_tol=1e-4, tol=1e-2"
DASK = ("from dask.distributed import Client\n"
        "with Client(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as c:\n"
        "    timed(lambda: {})")
CASES = {
    "frequency_curves": f"timed(lambda: tmafm.frequency_sweep(base, {FREQ}, progress=True, {Q}))",
    "approach_curves": "timed(lambda: tmafm.approach(base, np.linspace(8e-3, 0, 30), curves="
                       f"{{'scene.alpha2': [4e-4, 5e-4, 6e-4, 7e-4]}}, {Q}))",
    "grid_batch": f"timed(lambda: tmafm.sweep(base, {GRID}, {Q}))",
    "grid_processes": f"timed(lambda: tmafm.sweep(base, {GRID}, backend='processes', {Q}))",
    "bifurcation": f"timed(lambda: tmafm.bifurcation(base, 'scene.omega', np.linspace(3.0, 4.4, 480), {Q}))",
    "basin_batch": f"timed(lambda: tmafm.basin(base, {BASIN}, {Q}))",
    "basin_processes": f"timed(lambda: tmafm.basin(base, {BASIN}, backend='processes', {Q}))",
    "grid_dask": DASK.format(f"tmafm.sweep(base, {GRID}, client=c, chunk=4, {Q})"),
    "frequency_curves_dask": DASK.format(f"tmafm.frequency_sweep(base, {FREQ}, client=c, {Q})"),
    "basin_dask": DASK.format(f"tmafm.basin(base, {BASIN}, client=c, {Q})"),
}


def probe(name: str, delay: float, full: bool, group: bool) -> dict:
    with_main = CHILD + textwrap.indent(CASES[name], "    ") + "\n"
    with open(Path(os.environ.get("TMPDIR", "/tmp")) / f"sweep_interrupt_{os.getpid()}.py", "w") as f:
        f.write(with_main)  # a file, so that the spawned pool processes can import the main module
    proc = subprocess.Popen([sys.executable, f.name, str(BISTABLE)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=group)
    try:
        for line in proc.stdout:
            if line.startswith("go"):
                break
        signalled = None
        if not full:
            time.sleep(delay)
            signalled = time.monotonic()
            if group:
                os.killpg(proc.pid, signal.SIGINT)
            else:
                proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=900)
        ended = time.monotonic()
    finally:
        proc.kill()
        os.unlink(f.name)
    kbi = [float(l.split()[1]) for l in out.splitlines() if l.startswith("kbi")]
    done = [float(l.split()[1]) for l in out.splitlines() if l.startswith("done")]
    return {"case": name, "signal": None if full else ("group" if group else "child"),
            "returncode": proc.returncode, "call_s": round(done[0], 2) if done else None,
            "to_kbi_s": round(kbi[0] - signalled, 3) if kbi and signalled else None,
            "to_exit_s": None if full else round(ended - signalled, 2),
            "tracebacks": err.count("Traceback")}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("cases", nargs="*", default=list(CASES), help=", ".join(CASES))
    parser.add_argument("--delay", type=float, default=2.0, help="s from the call's start to SIGINT")
    parser.add_argument("--full", action="store_true", help="no SIGINT: the undisturbed call")
    parser.add_argument("--group", action="store_true", help="SIGINT the process group")
    args = parser.parse_args()
    for name in args.cases:
        print(json.dumps(probe(name, args.delay, args.full, args.group)), flush=True)


if __name__ == "__main__":
    main()

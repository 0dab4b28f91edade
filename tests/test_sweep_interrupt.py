"""Ctrl-C stops the sweeps whose runs are not on the calling thread (docs/sweeps.md, "Where the
runs go"): the continuation curves on worker threads and the process pool.

Python runs signal handlers only in its main thread, so the core's Ctrl-C poll cannot stop a
worker thread's run.  The calling thread waits for the workers in short slices, and on
KeyboardInterrupt sets the sweep's stop event (checked by the threads before each point),
cancels what has not started, terminates a process pool, and re-raises once the workers are
gone.  Each test runs a child Python process and sends it SIGINT while the sweep runs."""

import textwrap
from pathlib import Path

import pytest

from conftest import drive_interrupted_child

pytest.importorskip("xarray")
pytest.importorskip("tqdm")

BISTABLE = Path(__file__).resolve().parents[1] / "inputs" / "sweeps" / "bistable_n2.nml"

#: The child's helpers.  `reference` times the sweep undisturbed; `phase` tells the parent it
#: starts (the parent sends SIGINT `delay` s later), and reports what came out of the call, the
#: CPU time (all threads) and wall time from the SIGINT handler to the call's end, and what
#: is left: threads, pool processes, open progress bars.
PRELUDE = textwrap.dedent("""
    import json, multiprocessing, signal, sys, threading, time
    import numpy as np
    import tqdm
    import tmafm, tmafm.sweeps, xarray

    def report(**fields):
        print(json.dumps(fields), flush=True)

    def reference(name, call):
        cpu, wall = time.process_time(), time.monotonic()
        call()
        cpu, wall = time.process_time() - cpu, time.monotonic() - wall
        report(reference=name, cpu=cpu, wall=wall)
        return wall

    def phase(name, call, delay):
        marks = []
        def handler(signum, frame):
            marks.append((time.process_time(), time.monotonic()))
            raise KeyboardInterrupt
        signal.signal(signal.SIGINT, handler)
        threads = threading.active_count()  # with tqdm's monitor thread, once a bar was made
        report(start=name, delay=delay)
        try:
            call()
            outcome = "returned"
        except BaseException as exc:
            outcome = type(exc).__name__
            if not isinstance(exc, KeyboardInterrupt):
                outcome += ": " + str(exc)
        cpu, wall = time.process_time(), time.monotonic()
        signal.signal(signal.SIGINT, signal.default_int_handler)
        report(phase=name, outcome=outcome, handled=len(marks),
               cpu_after=cpu - marks[0][0] if marks else None,
               wall_after=wall - marks[0][1] if marks else None,
               threads=threading.active_count() - threads, children=len(multiprocessing.active_children()),
               bars=len(tqdm.tqdm._instances))
""")


def _drive(child: str, *args, timeout: float = 300) -> dict:
    """Run the child; SIGINT `delay` s after each phase it starts.  Its reports by name."""
    reports, err = drive_interrupted_child(PRELUDE + textwrap.dedent(child), args,
                                           lambda fields: fields["delay"], timeout)
    # No worker thread or pool process printed a traceback (the child caught the main one).
    assert "Traceback" not in err and "Exception in thread" not in err, err[-3000:]
    return reports


def _assert_stopped(report: dict) -> None:
    """KeyboardInterrupt came out of the call, and nothing of the sweep is left running."""
    assert report["outcome"] == "KeyboardInterrupt", report
    assert report["handled"] == 1, report
    assert report["threads"] == 0, report       # the worker threads have ended
    assert report["children"] == 0, report      # the pool's processes have ended
    assert report["bars"] == 0, report          # the progress bar is closed


def test_ctrl_c_stops_threaded_continuation_curves_and_the_sweep_command(tmp_path):
    """4 frequency curves on 2 threads, SIGINT a quarter of the way in: once the handler has
    run, the threads finish the point they are in and stop (before, the whole sweep ran
    first).  The sweep command, interrupted the same way, prints one line, returns 130 and
    leaves no file behind (before, a 25-line traceback)."""
    sweep_file = tmp_path / "curves.nml"
    sweep_file.write_text(textwrap.dedent(f"""\
        &sweep
            kind = 'frequency', base = '{BISTABLE}'
            start = 3.0, stop = 4.4, count = 12
            curve_key = 'scene.alpha2', curve_values = 4e-4, 5e-4, 6e-4, 7e-4
            max_periods = 200, stop_at_steady = .false., workers = 2
        /
    """))
    reports = _drive("""
        base = tmafm.Config(sys.argv[1])
        sweep = lambda: tmafm.frequency_sweep(
            base, np.linspace(3.0, 4.4, 12), curves={"scene.alpha2": [4e-4, 5e-4, 6e-4, 7e-4]},
            workers=2, progress=True, max_periods=200, stop_at_steady=False)
        wall = reference("curves", sweep)
        phase("curves", sweep, 0.25 * wall)
        def command():
            import contextlib, io
            err = io.StringIO()
            with contextlib.redirect_stderr(err):
                code = tmafm.sweeps.main([sys.argv[2], "-o", sys.argv[3], "--progress"])
            report(command_code=code, command_err=err.getvalue())
        phase("command", command, 0.25 * wall)
    """, BISTABLE, sweep_file, tmp_path / "curves.nc")
    full = reports["curves_reference"]
    _assert_stopped(reports["curves"])
    # The command catches the KeyboardInterrupt: one line and exit status 130 (128 + SIGINT,
    # as a shell reports the executable's death by SIGINT), not a traceback.
    assert reports["command"]["outcome"] == "returned", reports["command"]
    assert reports["command_code"] == 130, reports
    lines = [line for line in reports["command_err"].splitlines() if "tmafm.sweeps" in line]
    assert lines == ["tmafm.sweeps: interrupted"], reports["command_err"]
    assert "Traceback" not in reports["command_err"], reports["command_err"]
    assert reports["command"]["handled"] == 1 and reports["command"]["threads"] == 0, reports
    assert reports["command"]["children"] == 0 and reports["command"]["bars"] == 0, reports
    # The work done after the handler: the points in progress, 2 of the 96 (4 curves, 12
    # values, up and down); CPU of all threads, against the undisturbed sweep's.
    assert reports["curves"]["cpu_after"] < 0.1 * full["cpu"], (reports, full)
    assert reports["command"]["cpu_after"] < 0.1 * full["cpu"], (reports, full)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["curves.nml"]  # no .nc, .png or temp


def test_ctrl_c_stops_a_process_pool_sweep():
    """sweep(backend="processes") and basin(backend="processes"): the tasks not started are
    cancelled and the pool's processes terminated; before, the chunks already handed to the
    pool ran to their end.  SIGINT halfway through the undisturbed sweep's wall time (the
    processes start in about a second)."""
    reports = _drive("""
        base = tmafm.Config(sys.argv[1])
        quick = dict(workers=2, backend="processes", max_periods=200, stop_at_steady=False)
        grid = lambda: tmafm.sweep(base, {"scene.omega": np.linspace(3.0, 4.4, 160)}, **quick)
        phase("grid", grid, 0.5 * reference("grid", grid))
        axes = np.linspace(-4e-3, 2e-3, 24), np.linspace(-8e-3, 8e-3, 24)
        basin = lambda: tmafm.basin(base, *axes, known_attractors=False, chunk=48, **quick)
        phase("basin", basin, 0.5 * reference("basin", basin))
    """, BISTABLE)
    for name in ("grid", "basin"):
        _assert_stopped(reports[name])
        # Terminating and joining the processes; wall time: the work is in the processes.
        full = reports[name + "_reference"]
        assert reports[name]["wall_after"] < 0.1 * full["wall"], (reports, full)

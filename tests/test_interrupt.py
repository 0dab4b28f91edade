"""Ctrl-C stops a run started from Python (docs/model-notes.md, item 12).

A run releases the GIL, so Python's SIGINT handler only notes the signal; the core asks
pywrap/tmafm_check_signals.c at a run's first step and every poll_every steps, which runs the
pending handlers.  When one raises, the run stops and that exception comes out of the call.
Each test runs a child Python process and sends it SIGINT while the core integrates."""

import json
import signal
import subprocess
import sys
import textwrap
import threading
import time

import numpy as np
import pytest

ARRAYS = ("tau", "vt", "vtdot", "contact", "a", "adot", "switches")

#: The child's helpers: `phase` starts a call after telling the parent, which then sends SIGINT,
#: and reports what came out of it and the CPU time the call took.
PRELUDE = textwrap.dedent("""
    import json, signal, sys, time
    import numpy as np
    import tmafm
    from tmafm.observe import observe_states

    class Stop(Exception):
        pass

    def report(**fields):
        print(json.dumps(fields), flush=True)

    def phase(name, call, expected_cpu):
        report(start=name, expected_cpu=expected_cpu)
        started = time.process_time()
        try:
            call()
            outcome = "returned"
        except BaseException as exc:
            outcome = type(exc).__name__
            if not isinstance(exc, (KeyboardInterrupt, Stop)):
                outcome += ": " + str(exc)
        report(phase=name, outcome=outcome, cpu=time.process_time() - started)

    def save(result, path):
        np.savez(path, counters=np.array(list(result.counters.values())),
                 **{k: getattr(result, k) for k in %r})

    def cpu_of(call):
        started = time.process_time()
        out = call()
        return time.process_time() - started, out
""" % (ARRAYS,))


def _drive(child: str, *args, delay: float = 0.5, timeout: float = 300) -> dict:
    """Run the child; SIGINT `delay` s after each phase it starts.  The phases' reports by name."""
    proc = subprocess.Popen([sys.executable, "-c", PRELUDE + textwrap.dedent(child), *map(str, args)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    reports = {}
    watchdog = threading.Timer(timeout, proc.kill)  # a child that hangs fails, not the suite
    watchdog.start()
    try:
        for line in proc.stdout:
            fields = json.loads(line)
            if "start" in fields:
                reports[fields["start"]] = {"expected_cpu": fields["expected_cpu"]}
                if fields["expected_cpu"] is not None:
                    time.sleep(delay)  # inside the core by now: the call takes seconds
                    proc.send_signal(signal.SIGINT)
            elif "phase" in fields:
                reports[fields["phase"]].update(fields)
            else:
                reports.update(fields)
        err = proc.stderr.read()
        proc.wait(timeout=60)
    finally:
        watchdog.cancel()
        proc.kill()
    # Exits cleanly: no SIGSEGV (f90wrap's old longjmp handler), nothing left raised.
    assert proc.returncode == 0, (proc.returncode, err[-3000:])
    return reports


def _assert_stopped(report: dict, outcome: str) -> None:
    """The call raised `outcome` well before it would have finished."""
    assert report["outcome"] == outcome, report
    assert report["cpu"] < 0.25 * report["expected_cpu"], report


def test_ctrl_c_stops_a_run_and_the_next_run_matches_a_fresh_process(tmp_path):
    reports = _drive("""
        signal.signal(signal.SIGINT, signal.default_int_handler)  # also under a SIG_IGN parent
        # The run's CPU time, from a run 1/25 as long: the long one would take about 12 s.
        cpu, _ = cpu_of(lambda: tmafm.run("fig2_n4", solver={"tau_end": 400.0},
                                          output={"sample_dtau": 1.0}))
        long_run = tmafm.Config("fig2_n4", solver={"tau_end": 10000.0}, output={"sample_dtau": 1.0})
        phase("run", long_run.run, 25 * cpu)
        phase("function", lambda: tmafm.run(long_run), 25 * cpu)
        save(tmafm.run("fig2_n4", solver={"tau_end": 20.0}), sys.argv[1])
        report(done=True)
    """, tmp_path / "after.npz")
    _assert_stopped(reports["run"], "KeyboardInterrupt")
    _assert_stopped(reports["function"], "KeyboardInterrupt")
    assert reports["done"]
    _drive("""
        save(tmafm.run("fig2_n4", solver={"tau_end": 20.0}), sys.argv[1])
    """, tmp_path / "fresh.npz")
    after, fresh = np.load(tmp_path / "after.npz"), np.load(tmp_path / "fresh.npz")
    for name in ARRAYS + ("counters",):
        assert np.array_equal(after[name], fresh[name]), name


def test_a_handlers_own_exception_comes_out_of_every_entry_point():
    """A SIGINT handler that raises its own exception: that exception stops the run, the
    automatic-N search and the batches, and no wrapper turns it into a tmafm error."""
    reports = _drive("""
        def handler(signum, frame):
            raise Stop("from the handler")
        signal.signal(signal.SIGINT, handler)
        base = tmafm.Config("fig2_n4")
        cpu, _ = cpu_of(lambda: tmafm.run(base, solver={"tau_end": 400.0}, output={"sample_dtau": 1.0}))
        phase("run", tmafm.Config(base, solver={"tau_end": 10000.0}, output={"sample_dtau": 1.0}).run,
              25 * cpu)
        # The search for N runs comparison runs of up to 30 modes at rtol 1e-10: over
        # mode_horizon = 100, at least 50 times the CPU of the search over 2 (which stops at
        # N = 18, and whose runs are 50 times shorter); about a minute of CPU.
        auto = {"n_modes": 0, "mode_tol": 1e-6}
        cpu, _ = cpu_of(lambda: tmafm.Config("fig2_n4", model=dict(auto, mode_horizon=2.0)))
        phase("auto_n", lambda: tmafm.Config("fig2_n4", model=dict(auto, mode_horizon=100.0)), 50 * cpu)
        # Batches of 32 short inputs on 2 threads: the caller's run stops at once, the other
        # thread's at the end of its input, and the inputs not started are skipped.
        cpu, _ = cpu_of(lambda: tmafm.observe_batch([base], threads=1, max_periods=25,
                                                    stop_at_steady=False))
        phase("observe_batch", lambda: tmafm.observe_batch([base] * 32, threads=2, max_periods=25,
                                                           stop_at_steady=False), 32 * cpu)
        states = np.zeros((32, 8))
        states[:, 0] = np.linspace(0, 0.5, 32)
        phase("observe_states", lambda: observe_states(base, states, threads=2, max_periods=25,
                                                             stop_at_steady=False), 32 * cpu)
        report(done=True)
    """)
    for name in ("run", "auto_n", "observe_batch", "observe_states"):
        _assert_stopped(reports[name], "Stop")
    assert reports["done"]


def test_a_handler_that_does_not_raise_lets_the_run_finish_with_its_result():
    """The handler runs while the core integrates (at a poll, not when the call returns), and
    the run goes on to the same result as an undisturbed one."""
    reports = _drive("""
        calls = []
        signal.signal(signal.SIGINT, lambda signum, frame: calls.append(time.monotonic()))
        config = tmafm.Config("fig2_n4", solver={"tau_end": 1500.0}, output={"sample_dtau": 0.5})
        cpu, quiet = cpu_of(config.run)
        report(start="signalled", expected_cpu=cpu)
        started = time.monotonic()
        signalled = config.run()
        report(phase="signalled", outcome="returned", run=[started, time.monotonic()], calls=calls,
               same=all(np.array_equal(getattr(quiet, k), getattr(signalled, k)) for k in %r)
               and quiet.counters == signalled.counters)
    """ % (ARRAYS,))
    report = reports["signalled"]
    assert report["outcome"] == "returned"
    started, ended = report["run"]
    assert len(report["calls"]) == 1, report
    assert started < report["calls"][0] < ended, report  # inside the call, not after it
    assert report["same"], report


def test_interrupted_runs_leave_no_memory_behind():
    """Interrupted calls (a SIGALRM handler that raises, every 20 ms) free what they made: the
    run's handle and samples, a Config's, and the batches' output arrays (f2py frees them only
    on success: pywrap/f90wrap_gen.py free_outputs_on_failure).  glibc's count of bytes in use
    after 10 rounds and after 40 differ by far less than one round's samples."""
    reports = _drive("""
        import ctypes
        class Mallinfo2(ctypes.Structure):
            _fields_ = [(name, ctypes.c_size_t) for name in
                        ("arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks", "fsmblks",
                         "uordblks", "fordblks", "keepcost")]
        libc = ctypes.CDLL(None)
        libc.mallinfo2.restype = Mallinfo2
        def in_use():
            info = libc.mallinfo2()
            return info.uordblks + info.hblkhd
        def stop(signum, frame):
            raise Stop()
        signal.signal(signal.SIGALRM, stop)
        base = tmafm.Config("fig2_n4")
        # 10 MB of samples, a few MB of batch outputs, and a long search for N.
        long_run = tmafm.Config(base, solver={"tau_end": 10000.0}, output={"sample_dtau": 0.1})
        calls = [long_run.run,
                 lambda: tmafm.Config(base, model={"n_modes": 0, "mode_horizon": 100.0, "mode_tol": 1e-6}),
                 lambda: tmafm.observe_batch([base] * 4, threads=1, max_periods=2000, stop_at_steady=False),
                 lambda: observe_states(base, np.zeros((4, 8)), threads=1, max_periods=2000,
                                              stop_at_steady=False)]
        used, stopped = [], 0
        for round in range(40):
            for call in calls:
                signal.setitimer(signal.ITIMER_REAL, 0.02)
                try:
                    call()
                except Stop:
                    stopped += 1
                signal.setitimer(signal.ITIMER_REAL, 0)
            used.append(in_use())
        report(used=used, stopped=stopped)
    """)
    assert reports["stopped"] == 160
    growth = reports["used"][-1] - reports["used"][9]
    assert growth < 1_000_000, reports["used"]

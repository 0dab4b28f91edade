"""Ctrl-C stops a run started from Python (docs/model-notes.md, item 12).

A run releases the GIL, so Python's SIGINT handler only notes the signal; the core asks
pywrap/tmafm_check_signals.c at a run's first update and then at most every 10 ms of wall time
(runs started on Python's main thread only), which runs the pending handlers.  When one raises,
the run stops and that exception comes out of the call.
Each test runs a child Python process and sends it SIGINT while the core integrates."""

import sys
import textwrap
import threading
import time

import numpy as np
import pytest

from conftest import drive_interrupted_child

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


#: SIGINT goes this share of a phase's expected CPU time after it starts (wall time: on a busy
#: host the child has then done less), so the delay scales with this machine's speed.
DELAY_SHARE = 1 / 20


def _drive(child: str, *args, timeout: float = 300) -> dict:
    """Run the child; SIGINT DELAY_SHARE of its expected CPU after each phase it starts (none
    where it expects none).  The phases' reports by name."""
    def delay(fields):
        cpu = fields["expected_cpu"]
        return None if cpu is None else DELAY_SHARE * cpu
    reports, _ = drive_interrupted_child(PRELUDE + textwrap.dedent(child), args, delay, timeout)
    return reports


def _assert_stopped(report: dict, outcome: str) -> None:
    """The call raised `outcome` well before it would have finished (SIGINT came at
    DELAY_SHARE = 0.05 of its expected CPU at the latest)."""
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


def test_ctrl_c_stops_a_run_that_never_touches_the_surface():
    """flight_exact with the tip far from the surface: the whole run is one free flight (one
    step), whose samples are written a chunk at a time; it polls after each chunk, so SIGINT
    stops it long before the end (before, it polled only after the flight: at the end)."""
    reports = _drive("""
        signal.signal(signal.SIGINT, signal.default_int_handler)
        config = tmafm.Config("fig2_n4", model={"n_modes": 30}, initial={"a0": [0.0] * 30},
                              scene={"delta_hat": 5.0},
                              solver={"method": "flight_exact", "tau_end": 2e4, "max_steps": 10**9},
                              output={"sample_dtau": 0.1})
        cpu, result = cpu_of(config.run)
        report(steps=result.counters["steps"], contact_steps=result.counters["contact_steps"])
        del result
        phase("flight", config.run, cpu)
    """)
    assert (reports["steps"], reports["contact_steps"]) == (1, 0), reports
    _assert_stopped(reports["flight"], "KeyboardInterrupt")


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
        if not hasattr(libc, "mallinfo2"):  # glibc < 2.33, or not glibc
            report(skip="no mallinfo2 in this C library")
            sys.exit(0)
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
    if "skip" in reports:
        pytest.skip(reports["skip"])
    assert reports["stopped"] == 160
    growth = reports["used"][-1] - reports["used"][9]
    assert growth < 1_000_000, reports["used"]


def _thread_cpu_wait() -> float:
    """Seconds this thread has waited for a CPU (runnable, not running): /proc/thread-self/
    schedstat's second field; 0 where there is none."""
    try:
        with open("/proc/thread-self/schedstat") as f:
            return int(f.read().split()[1]) / 1e9
    except (OSError, IndexError, ValueError):
        return 0.0


def test_a_worker_threads_run_does_not_wait_for_a_main_thread_running_python():
    """Only Python's main thread polls (signal handlers run only there): a run on another
    thread never takes the GIL, so a main thread spinning in Python code does not slow it.
    Each GIL hand-over waits for the switch interval, here 20 ms; when every run polled, each
    poll of the worker's run (every 1024 steps, well under 1 ms) waited that long, many times
    the quiet run's time.  The time compared is the worker's wall time less the time it waited
    for a CPU (the spinner takes one), quiet and spinning runs interleaved, least of two each."""
    import tmafm
    config = tmafm.Config("fig2_n1", solver={"tau_end": 400.0}, output={"sample_dtau": 1.0})

    def on_worker(spin: bool) -> float:
        done, out = threading.Event(), {}

        def run():
            waited, start = _thread_cpu_wait(), time.monotonic()
            config.run()
            out["time"] = time.monotonic() - start - (_thread_cpu_wait() - waited)
            done.set()

        worker = threading.Thread(target=run)
        worker.start()
        while spin and not done.is_set():
            pass
        worker.join()
        return out["time"]

    interval = sys.getswitchinterval()
    sys.setswitchinterval(0.02)
    try:
        times = {False: [], True: []}
        for _ in range(2):
            for spin in (False, True):
                times[spin].append(on_worker(spin))
    finally:
        sys.setswitchinterval(interval)
    assert min(times[True]) < 2 * min(times[False]), times

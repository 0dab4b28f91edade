"""Runs in Python threads: the core holds no mutable module state and the run entry point
releases the GIL, so threads give the serial results bit for bit and overlap in time.
(Throughput is measured in benchmarks/python_overhead.py, not here.)"""

import ctypes
import signal
import threading
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

import tmafm

SCENES = [
    ("fig2_n4", {"solver": {"tau_end": 4.0}}),
    ("fig7_dmt", {"model": {"convention": "consistent"}, "solver": {"tau_end": 4.0}}),
    ("fig3", {"solver": {"tau_end": 4.0, "method": "dopri5"}}),
    ("physical_polystyrene", {"solver": {"tau_end": 4.0, "method": "flight_exact"}}),
]
ARRAYS = ("tau", "vt", "vtdot", "contact", "a", "adot", "switches")


def _run(case):
    name, overrides = case
    return tmafm.run(name, **overrides)


def test_two_threads_give_the_serial_results_bit_for_bit():
    serial = [_run(case) for case in SCENES]
    with ThreadPoolExecutor(max_workers=2) as pool:
        threaded = list(pool.map(_run, SCENES * 2))
    for k, result in enumerate(threaded):
        reference = serial[k % len(SCENES)]
        for name in ARRAYS:
            assert np.array_equal(getattr(result, name), getattr(reference, name)), (k, name)
        assert result.counters == reference.counters
        assert result.resolved == reference.resolved


def test_the_gil_is_released_while_the_core_integrates():
    """While one thread is inside the core, the main thread keeps running Python code."""
    config = tmafm.Config("fig2_n4", solver={"tau_end": 40.0})
    span = {}

    def worker():
        span["start"] = time.perf_counter()
        config.run()
        span["end"] = time.perf_counter()

    thread = threading.Thread(target=worker)
    ticks = []
    thread.start()
    while thread.is_alive():
        ticks.append(time.perf_counter())
        time.sleep(0.001)
    thread.join()
    inside = [t for t in ticks if span["start"] <= t <= span["end"]]
    duration = span["end"] - span["start"]
    # Holding the GIL would freeze this loop for the whole run: one gap as long as the run.
    gaps = np.diff([span["start"], *inside, span["end"]])
    assert len(inside) >= 5, (len(inside), duration)
    assert gaps.max() < 0.5 * duration, (gaps.max(), duration)


def test_configs_built_in_threads_read_their_own_text():
    """Building configurations (a file plus overrides) in four threads at once, without the GIL:
    every built text must equal the serial one.  gfortran 12 kept the length of a deferred-length
    function result (entry_text in the merge of base and override texts) in a static variable of
    the caller; with the GIL released, 229 of 4000 builds of this mix read another thread's
    length (cut lines, NUL bytes) before those functions got lengths from their arguments
    (docs/model-notes.md, finding 11)."""
    cases = [(name, {"solver": {"tau_end": 4.0}}) for name in
             ("fig2_n4", "fig7_dmt", "fig3", "physical_polystyrene")]
    cases += [("fig2_n4", {"initial": {"a0": [1e-4, 0.0, 0.0, 2e-5]}, "output": {"sample_dtau": 0.02}}),
              ("fig3", {"model": {"mode_tol": 0.05}, "solver": {"rtol": 1e-8}})]
    serial = [tmafm.Config(name, **overrides).text for name, overrides in cases]

    def build(k):
        name, overrides = cases[k % len(cases)]
        return k % len(cases), tmafm.Config(name, **overrides).text

    with ThreadPoolExecutor(max_workers=4) as pool:
        wrong = [k for k, (index, text) in enumerate(pool.map(build, range(1200)))
                 if text != serial[index]]
    assert wrong == [], (len(wrong), wrong[:5])


def _os_sigint_handler() -> int:
    """Address of the SIGINT handler the OS has installed (signal.getsignal only tells the
    Python-level one, which f90wrap's C handler never changed)."""
    getsig = ctypes.pythonapi.PyOS_getsig
    getsig.restype, getsig.argtypes = ctypes.c_void_p, [ctypes.c_int]
    return getsig(signal.SIGINT)


def test_overlapping_released_calls_leave_pythons_sigint_handler():
    """f90wrap saved the SIGINT handler, installed its own (a longjmp to one global jmp_buf),
    and put the saved one back around every call.  A call that starts while another is inside
    the core (GIL released) saved f90wrap's handler; when the first returned first, the second
    put f90wrap's handler back for good, and the next Ctrl-C jumped into a stale jmp_buf
    (segmentation fault).  pywrap/f90wrap_gen.py removes that handler from the wrappers."""
    python_handler = _os_sigint_handler()
    # Python's own record (signal.default_int_handler, or SIG_IGN when the tests run as a
    # background job); it never saw f90wrap's handler, so the OS-level check above is the test.
    python_level = signal.getsignal(signal.SIGINT)
    short = tmafm.Config("fig2_n4", solver={"tau_end": 20.0})
    long_ = tmafm.Config("fig2_n4", solver={"tau_end": 200.0})
    overlapped = 0
    for _ in range(5):
        span = {}

        def worker():
            span["started"] = time.perf_counter()
            short.run()
            span["ended"] = time.perf_counter()

        thread = threading.Thread(target=worker)
        thread.start()
        time.sleep(0.01)
        started = time.perf_counter()
        long_.run()
        ended = time.perf_counter()
        thread.join()
        # The order that left the handler behind: the thread's run started first and ended
        # first, inside this run.
        overlapped += span["started"] < started < span["ended"] < ended
        assert _os_sigint_handler() == python_handler
        assert signal.getsignal(signal.SIGINT) is python_level
        if overlapped >= 2:
            break
    assert overlapped >= 1


# Ctrl-C during a run (it now stops the run): tests/test_interrupt.py.

"""Runs in Python threads: the core holds no mutable module state and the run entry point
releases the GIL, so threads give the serial results bit for bit and overlap in time.
(Throughput is measured in benchmarks/python_overhead.py, not here.)"""

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

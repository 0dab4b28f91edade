"""Where a sweep's runs go: the core's batch on local threads, a pool of processes, or a
dask.distributed Client; the progress bar; and pools that a Ctrl-C stops (docs/sweeps.md,
"Where the runs go")."""

from __future__ import annotations

import contextlib
import itertools
import math
import os
import signal
import threading
from concurrent.futures import ThreadPoolExecutor
from concurrent.futures import wait as _wait_futures

import numpy as np

from .._namelist import _NOT_NUMBERS, shown
from ..errors import InputTypeError
from ..observe import MAX_THREADS
from .runs import _run_chunk, _run_chunk_processes, _warn_failures, _warn_unsteady


def _is_client(client) -> bool:
    """Whether `client` looks like a dask.distributed.Client (what a sweep calls on it)."""
    return all(callable(getattr(client, name, None)) for name in ("submit", "cancel",
                                                                   "scheduler_info"))


def _check_run(workers=None, client=None, progress=False, chunk=None, backend="batch",
               user="tmafm.sweep") -> None:
    """Check the arguments that say where and how the runs go, before anything is built:
    InputTypeError (a TypeError too) for a wrong type, InputError for a bad value; and the
    extras a sweep needs (xarray; tqdm for a progress bar): MissingExtraError."""
    from .._extras import require
    _workers(workers)
    if client is not None and not _is_client(client):
        raise InputTypeError(f"client = {shown(client)}: must be a dask.distributed.Client (with "
                             f"submit, cancel and scheduler_info) or None")
    if not isinstance(progress, (bool, np.bool_)):
        raise InputTypeError(f"progress = {shown(progress)}: must be True or False")
    if chunk is not None and (isinstance(chunk, _NOT_NUMBERS)
                              or not isinstance(chunk, (int, np.integer)) or chunk < 1):
        raise InputTypeError(f"chunk = {shown(chunk)}: must be a positive integer or None")
    if not isinstance(backend, str) or backend not in ("batch", "processes"):
        raise InputTypeError(f"backend = {shown(backend)}: must be 'batch' or 'processes'")
    require("xarray", user)
    if progress:
        require("tqdm", f"{user}(progress=True)")
    if client is not None:
        require("distributed", f"{user}(client=...)")


# --- Pools that a Ctrl-C stops (docs/sweeps.md, "Where the runs go") -------------------------

#: Seconds: the slices in which the calling thread waits for a pool's results, so that a Ctrl-C
#: reaches it between two slices even where lock waits cannot be interrupted.
_WAIT_SLICE = 0.2


class _Stopped(Exception):
    """Raised by a worker thread's task that found the sweep's stop event set: it is kept in
    the task's future, which nobody reads (the sweep is raising its own exception)."""


def _results(futures, done=None) -> list:
    """Each future's result (concurrent.futures), in order.  The calling thread waits in slices
    of _WAIT_SLICE s, so a KeyboardInterrupt reaches it while the workers run; ``done(k)`` is
    called after the k-th result."""
    results = []
    for k, future in enumerate(futures):
        while not future.done():
            _wait_futures([future], timeout=_WAIT_SLICE)
        results.append(future.result())
        if done is not None:
            done(k)
    return results


@contextlib.contextmanager
def _thread_pool(workers: int):
    """(a ThreadPoolExecutor, the threading.Event its tasks check between runs).  When the
    with-block raises (a KeyboardInterrupt while waiting, or a task's error), the event is set,
    the tasks not started are cancelled, and the exception goes on once every thread has
    finished the run it is in: Python runs signal handlers only in its main thread, so the
    core's Ctrl-C poll cannot stop a worker thread's run.  The event belongs to this call."""
    stop = threading.Event()
    pool = ThreadPoolExecutor(max_workers=workers)
    try:
        yield pool, stop
    except BaseException:
        stop.set()
        pool.shutdown(wait=True, cancel_futures=True)
        raise
    pool.shutdown(wait=True)


def _ignore_sigint() -> None:
    """A pool process's initializer: a terminal's Ctrl-C reaches the whole process group, and
    the parent, not each process, decides (it terminates them, _process_pool)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


@contextlib.contextmanager
def _process_pool(workers: int):
    """A ProcessPoolExecutor of spawned processes that ignore SIGINT.  When the with-block
    raises (a KeyboardInterrupt while waiting, or a task's error), the tasks not started are
    cancelled and the processes are terminated at once (they write nothing: their results
    come back through the pool), then the exception goes on."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn"),
                               initializer=_ignore_sigint)
    try:
        yield pool
    except BaseException:
        _terminate(pool)
        raise
    pool.shutdown(wait=True)


def _terminate(pool) -> None:
    """Cancel a process pool's tasks not started and terminate its processes, then join it."""
    terminate = getattr(pool, "terminate_workers", None)  # Python >= 3.14
    if terminate is not None:
        terminate()
    else:
        # Before 3.14 the pool has no public way: its processes are in pool._processes.
        processes = list((getattr(pool, "_processes", None) or {}).values())
        for process in processes:
            process.terminate()
    pool.shutdown(wait=True, cancel_futures=True)


def _dask_results(client, futures, done=None) -> list:
    """Each Dask future's result, in order (a Future's wait already sees a Ctrl-C).  When the
    wait raises, every future is cancelled first: the tasks not started never run, and a
    running task ends on its worker, its result dropped (Dask cannot stop a running task)."""
    try:
        results = []
        for k, future in enumerate(futures):
            results.append(future.result())
            if done is not None:
                done(k)
        return results
    except BaseException:
        client.cancel(futures)
        raise


def _chunks(n: int, chunk: int | None, workers: int) -> list[range]:
    if chunk is None:
        chunk = max(1, min(256, math.ceil(n / (4 * max(1, workers)))))
    if not isinstance(chunk, (int, np.integer)) or isinstance(chunk, _NOT_NUMBERS) or chunk < 1:
        raise InputTypeError(f"chunk = {shown(chunk)}: must be a positive integer")
    return [range(i, min(n, i + int(chunk))) for i in range(0, n, int(chunk))]


def _workers(workers) -> int:
    """Local threads or processes: None (all cores) or 1 to tmafm.observe.MAX_THREADS."""
    if workers is None:
        return os.cpu_count() or 1
    limit = MAX_THREADS
    if not isinstance(workers, (int, np.integer)) or isinstance(workers, _NOT_NUMBERS) \
            or not 1 <= workers <= limit:
        raise InputTypeError(f"workers = {shown(workers)}: must be an integer from 1 to {limit}, "
                             f"or None")
    return int(workers)


def _progress(total: int, enabled: bool, label: str):
    if not enabled:
        return None
    from tqdm.auto import tqdm
    return tqdm(total=total, desc=label, unit="run")


def _run_points(base: dict, points: list[dict], *, workers=None, client=None, progress=False,
                chunk=None, backend="batch", keep=0, keywords=None, label="sweep",
                configs=None) -> list[dict]:
    """Summaries of every point, in order, on local cores or on a Dask client.  ``configs``
    (the validated Configs of the points) saves building them again in this process."""
    keywords = keywords or {}
    n_workers = _workers(workers)
    if client is not None:
        n_workers = max(1, len(client.scheduler_info().get("workers", {})) or n_workers)
    pieces = _chunks(len(points), chunk, n_workers)
    bar = _progress(len(points), progress, label)
    results: list = [None] * len(pieces)
    try:
        if client is not None:
            from dask.distributed import as_completed
            futures = {client.submit(_run_chunk, base, [points[i] for i in piece], 1, keywords,
                                     keep, pure=False): k for k, piece in enumerate(pieces)}
            try:
                for future in as_completed(futures):
                    results[futures[future]] = future.result()
                    if bar is not None:
                        bar.update(len(pieces[futures[future]]))
            except BaseException:  # Ctrl-C: no task not started runs (_dask_results)
                client.cancel(list(futures))
                raise
        elif backend == "processes":
            with _process_pool(n_workers) as pool:
                futures = [pool.submit(_run_chunk_processes,
                                       (base, [points[i] for i in piece], keywords, keep))
                           for piece in pieces]
                results = _results(futures, None if bar is None else
                                   lambda k: bar.update(len(pieces[k])))
        elif backend == "batch":
            for k, piece in enumerate(pieces):
                results[k] = _run_chunk(base, [points[i] for i in piece], n_workers, keywords,
                                        keep, None if configs is None else
                                        [configs[i] for i in piece])
                if bar is not None:
                    bar.update(len(piece))
        else:
            raise InputTypeError(f"backend = {shown(backend)}: must be 'batch' or 'processes'")
    finally:
        if bar is not None:
            bar.close()
    summaries = list(itertools.chain.from_iterable(results))
    _warn_unsteady(summaries, label, keywords)
    _warn_failures(summaries, label)
    return summaries

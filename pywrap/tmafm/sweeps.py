"""Sweeps at scale: grids of runs, approach/retract and frequency sweeps, bifurcation diagrams and
basin maps, each returned as an xarray.Dataset (needs the [sweep] extra: xarray, dask, tqdm).

Every grid point is one input: the base input with the swept keys ('group.key', e.g.
'scene.delta_hat') replaced.  All points are validated (a tmafm.Config each) before any run
starts, so a bad key or value raises one InputError and nothing runs.  Each point is then
observed period by period by the core (tmafm.observe_batch), stopped at steady state or after
max_periods periods.  Work is spread over local cores (workers=, the core's OpenMP batch) or
over a dask.distributed Client (client=, one task per chunk of points).

    >>> import tmafm
    >>> ds = tmafm.sweep("fig2_n4", {"scene.delta_hat": [0.2, 0.4]}, max_periods=20)
    >>> ds.amplitude.dims
    ('scene.delta_hat',)

The file-driven command line is ``python -m tmafm.sweeps FILE [-o OUT.nc]`` (docs/sweeps.md).
"""

from __future__ import annotations

import argparse
import contextlib
import itertools
import math
import os
import signal
import sys
import threading
from collections.abc import Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from concurrent.futures import wait as _wait_futures
from pathlib import Path

import numpy as np

from ._namelist import GROUPS, KEY_TYPES, shown
from ._run import Config
from .errors import InputError, InputFileError, InputTypeError, SolverError, TmafmError, raise_for

__all__ = ["sweep", "approach", "frequency_sweep", "bifurcation", "basin", "read_sweep_file",
           "run_sweep_file", "write_dataset", "summarize", "mark_jumps", "label_attractors",
           "STEADY_NAMES", "main"]

#: The steady values every sweep dataset carries (besides period, steady and periods).
STEADY_NAMES = ("amplitude", "phase", "mean_deflection", "min_gap", "peak_force", "contact_time",
                "contacts_per_period", "dissipated_energy", "dissipated_beam",
                "dissipated_contact_damping", "dissipated_friction", "drive_work", "virial")
#: The keywords of tmafm.observe that a sweep passes on.
OBSERVE_KEYWORDS = ("max_periods", "p_max", "steady_tol", "steady_repeats", "harmonics",
                    "stop_at_steady", "observables")


# --- Keys, values and validation -----------------------------------------------------------

def _split_key(key) -> tuple[str, str]:
    """('scene', 'delta_hat') of 'scene.delta_hat'; InputError for a key the core does not know."""
    if not isinstance(key, str) or key.count(".") != 1:
        raise InputError(f"sweep key {shown(key)}: must be 'group.key', e.g. 'scene.delta_hat'")
    group, name = key.split(".")
    if group not in GROUPS:
        raise InputError(f"sweep key {shown(key)}: unknown group '{group}' (known: {', '.join(GROUPS)})")
    if name not in KEY_TYPES[group]:
        raise InputError(f"sweep key {shown(key)}: &{group} {name}: unknown key (known: "
                         f"{', '.join(KEY_TYPES[group])})")
    if group == "output":
        raise InputError(f"sweep key {shown(key)}: the &output group cannot be swept (a sweep writes "
                         f"no run output)")
    return group, name


#: The most modes the core takes (fortran/src/physics/tmafm_modes.f90 max_modes).
MAX_MODES = 30


class _Axis(np.ndarray):
    """The values of one axis: a 1-D array (the coordinate) that remembers the values as given
    (``raw``), so an integer key gets integers and a bad value is named as the user wrote it."""

    raw: list


def _axis_values(key: str, values, real: bool = False) -> np.ndarray:
    """The values of one axis as a 1-D array; InputError when empty or not 1-D (``real``: not
    finite real numbers either, for axes that are not input keys, e.g. a basin's a1)."""
    try:
        if isinstance(values, (str, bytes, Mapping)) or not hasattr(values, "__iter__"):
            raise TypeError
        size = len(values)
    except TypeError:  # a number, a 0-d array, a generator
        raise InputTypeError(f"sweep axis {shown(key)}: values must be a 1-D sequence, not "
                             f"{shown(values)}") from None
    _check_points(size, f"sweep axis {shown(key)} ({size} values)")
    raw = [_value(v) for v in values]
    try:
        array = np.asarray(raw)
    except Exception as exc:  # ragged lists and the like
        raise InputError(f"sweep axis {shown(key)}: values must be a 1-D sequence "
                         f"({shown(str(exc))[1:-1]})") from None
    if array.ndim != 1:
        raise InputError(f"sweep axis {shown(key)}: values must be a 1-D sequence, got shape "
                         f"{array.shape}")
    if array.size == 0:
        raise InputError(f"sweep axis {shown(key)}: no values (an empty axis)")
    if real:
        for value in raw:
            if not _is_real(value):
                raise InputError(f"sweep axis {shown(key)}: values must be finite real numbers, got "
                                 f"{shown(value)}")
        array = np.asarray(raw, dtype=float)
    axis = array.view(_Axis)
    axis.raw = raw
    return axis


def _is_real(value) -> bool:
    """Whether `value` is a finite real number (a bool is not; an int too large for a float is
    not)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer,
                                                                     np.floating)):
        return False
    try:
        return math.isfinite(float(value))
    except OverflowError:
        return False


def _raw(axis) -> list:
    return getattr(axis, "raw", None) or list(axis)


def _check_axes(axes) -> dict:
    """{key: 1-D values} of a Mapping of axes, keys checked; InputError otherwise."""
    if not isinstance(axes, Mapping):
        raise InputTypeError(f"axes must be a dict 'group.key' -> values, not "
                             f"{type(axes).__name__}")
    if not axes:
        raise InputError("sweep: no axes given (give at least one 'group.key' -> values)")
    checked = {}
    for key, values in axes.items():
        _split_key(key)
        checked[key] = _axis_values(key, values)
    return checked


def _value(value):
    """A numpy scalar as a Python number (namelist text wants plain values)."""
    return value.item() if isinstance(value, np.generic) else value


def _overrides(point: Mapping) -> dict:
    """{group: {key: value}} of {'group.key': value}."""
    groups: dict = {}
    for key, value in point.items():
        group, name = _split_key(key)
        groups.setdefault(group, {})[name] = _value(value)
    return groups


def _base_dict(base) -> dict:
    """The resolved base input as a dict of groups (picklable, for other processes)."""
    config = base if isinstance(base, Config) else Config(base)
    groups = config.to_dict()
    groups.pop("output", None)
    return groups


def _merged(base: dict, overrides: Mapping) -> dict:
    groups = {g: dict(v) for g, v in base.items()}
    for group, values in overrides.items():
        groups.setdefault(group, {}).update(values)
    return groups


def _resized_initial(groups: dict, point: Mapping) -> dict:
    """When n_modes is swept, the base's &initial vectors cut or padded with zeros to N."""
    n = point.get("model.n_modes")
    initial = groups.get("initial")
    if not isinstance(n, (int, np.integer)) or isinstance(n, bool) or not initial \
            or not 0 <= n <= MAX_MODES:
        return groups  # the core refuses an N out of range, by name
    for name in ("a0", "adot0"):
        if name in initial and f"initial.{name}" not in point:
            values = np.atleast_1d(np.asarray(initial[name], dtype=float))
            if n > 0:
                initial[name] = np.concatenate([values, np.zeros(n)])[:n].tolist()
            elif not values.any():
                del initial[name]  # automatic N: zero initial values need no length
    return groups


def _config(base: dict, point: Mapping) -> Config:
    """The Config of one point; InputError naming the point when the core refuses it."""
    try:
        return Config(_resized_initial(_merged(base, _overrides(point)), point))
    except InputError as exc:
        where = ", ".join(f"{k} = {_short(v)}" for k, v in point.items())
        raise type(exc)(f"sweep point {where}: {exc}") from None


def _short(value) -> str:
    value = _value(value)
    try:
        if isinstance(value, (list, tuple, np.ndarray)) and len(value) <= 30:
            return "[" + ", ".join(f"{float(v):.6g}" for v in value) + "]"
        return f"{value:.6g}" if isinstance(value, float) else shown(value)
    except (TypeError, ValueError, OverflowError):  # not numbers: as messages show any value
        return shown(value)


def _observe_keywords(keywords: Mapping) -> dict:
    """The keywords passed on to tmafm.observe, every value checked now (before any run)."""
    unknown = set(keywords) - set(OBSERVE_KEYWORDS)
    if unknown:
        raise InputTypeError(f"unknown keyword(s) {', '.join(sorted(map(str, unknown)))} (a "
                             f"sweep passes on: {', '.join(OBSERVE_KEYWORDS)})")
    out = dict(keywords)
    observe = _observe_api()
    defaults = dict(max_periods=100, p_max=8, steady_tol=1e-6, steady_repeats=3, harmonics=3,
                    stop_at_steady=True)
    observe._options(**{k: out.get(k, v) for k, v in defaults.items()})
    if out.get("observables") is not None:
        # Kept as the tuple of groups it selects.
        out["observables"] = observe.observable_groups(out["observables"])
    return out


# --- Arguments checked before anything is built or run --------------------------------------

#: Bytes a sweep holds per grid point while it runs, at most: the point, its validated Config,
#: its summary and its share of the Dataset.  Measured: 8.3 kB per point (the peak resident
#: memory of a 1500-point grid of fig2_n4, N = 4: ``pytest -s tests/test_sweep_limits.py -k
#: memory`` prints it and checks it is below this); this is about twice that, for a margin.
BYTES_PER_POINT = 16384


def _available_memory() -> int:
    """Bytes of memory available now: MemAvailable of /proc/meminfo, else the physical memory."""
    try:
        with open("/proc/meminfo", encoding="ascii") as handle:
            for line in handle:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return 2**62


def _bytes(count: int) -> str:
    for unit, size in (("PB", 1e15), ("TB", 1e12), ("GB", 1e9), ("MB", 1e6)):
        if count >= size:
            return f"{count / size:.3g} {unit}"
    return f"{count / 1e3:.3g} kB"


def _check_points(points: int, what: str, floats_per_point: int = 0) -> None:
    """InputError naming `what` (the axes and their sizes, as given) when a sweep of `points`
    points would hold more memory than is available (BYTES_PER_POINT each, plus
    `floats_per_point` kept values of 8 bytes)."""
    need = points * (BYTES_PER_POINT + 8 * floats_per_point)
    available = _available_memory()
    if need > available:
        raise InputError(f"{what}: {points} points would hold about {_bytes(need)} in memory, "
                         f"more than the {_bytes(available)} available")


def _sizes(axes: Mapping) -> str:
    return " x ".join(f"{key} ({len(values)} values)" for key, values in axes.items())


def _is_client(client) -> bool:
    """Whether `client` looks like a dask.distributed.Client (what a sweep calls on it)."""
    return all(callable(getattr(client, name, None)) for name in ("submit", "cancel",
                                                                   "scheduler_info"))


def _check_run(workers=None, client=None, progress=False, chunk=None, backend="batch",
               user="tmafm.sweep") -> None:
    """Check the arguments that say where and how the runs go, before anything is built:
    InputTypeError (a TypeError too) for a wrong type, InputError for a bad value; and the
    extras a sweep needs (xarray; tqdm for a progress bar): MissingExtraError."""
    from ._extras import require
    _workers(workers)
    if client is not None and not _is_client(client):
        raise InputTypeError(f"client = {shown(client)}: must be a dask.distributed.Client (with "
                             f"submit, cancel and scheduler_info) or None")
    if not isinstance(progress, (bool, np.bool_)):
        raise InputTypeError(f"progress = {shown(progress)}: must be True or False")
    if chunk is not None and (isinstance(chunk, (bool, np.bool_))
                              or not isinstance(chunk, (int, np.integer)) or chunk < 1):
        raise InputTypeError(f"chunk = {shown(chunk)}: must be a positive integer or None")
    if not isinstance(backend, str) or backend not in ("batch", "processes"):
        raise InputTypeError(f"backend = {shown(backend)}: must be 'batch' or 'processes'")
    require("xarray", user)
    if progress:
        require("tqdm", f"{user}(progress=True)")
    if client is not None:
        require("distributed", f"{user}(client=...)")


def _check_flag(name: str, value) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise InputTypeError(f"{name} = {shown(value)}: must be True or False")
    return bool(value)


def _check_positive(name: str, value, upper: float = math.inf) -> float:
    """A finite real number > 0 (and < upper); InputError otherwise."""
    if not _is_real(value) or not 0 < float(value) < upper:
        bound = "" if upper == math.inf else f" and < {upper:g}"
        raise InputError(f"{name} = {shown(value)}: must be a finite number > 0{bound}")
    return float(value)


# --- Running points ------------------------------------------------------------------------

def _observe_api():
    """The module tmafm.observe (the package's attribute of that name is the function)."""
    import importlib
    return importlib.import_module("tmafm.observe")


def _names(keywords: Mapping | None = None) -> tuple:
    """The steady observables a dataset carries: the core's list (tmafm.observe.OBSERVABLES),
    cut to those the keywords' ``observables`` compute."""
    observe = _observe_api()
    selected = (keywords or {}).get("observables")
    return observe.computed_names(observe.observable_groups(selected))


def _summary(obs, keep: int = 0) -> dict:
    """The picklable part of an Observation a sweep keeps: steady values, period, states."""
    steady = obs.steady_values()
    names = [name for name in _names() if name in steady]
    out = {"steady": bool(obs.steady), "period": int(obs.period), "periods": int(obs.periods),
           "values": {name: float(steady[name]) for name in names},
           "final_state": np.asarray(obs.final_state, dtype=float).copy()}
    for name in ("harmonic_amplitude", "harmonic_phase"):
        if name in steady:
            out[name] = np.asarray(steady[name], dtype=float).copy()
    poincare = np.asarray(obs.poincare, dtype=float)
    period = int(obs.period)
    out["orbit"] = poincare[-period:].copy() if period > 0 else poincare[-1:].copy()
    if keep:
        out["poincare"] = poincare[-keep:].copy()
    out["physical"] = {}
    if getattr(obs, "physical", None) is not None:
        physical = obs.steady_values(physical=True)
        out["physical"] = {name: float(physical[name]) for name in names if name in physical}
    return out


def _run_chunk(base: dict, points: Sequence[Mapping], threads, keywords: Mapping,
               keep: int = 0, configs: Sequence[Config] | None = None) -> list[dict]:
    """Observe the points of one chunk with the core's batch; one summary per point.
    ``configs``, when given, are the points' validated Configs (same process only)."""
    observe = _observe_api()
    if configs is None:
        configs = [_config(base, point) for point in points]
    try:
        observations = observe.observe_batch(configs, threads=threads, **keywords)
    except SolverError:
        # One run failed (the batch names the first): run the chunk's points one by one, so
        # every other point keeps its result and each failure is recorded with its message.
        return [_observe_one(observe, config, keywords, keep) for config in configs]
    return [_summary(obs, keep) for obs in observations]


def _observe_one(observe, config: Config, keywords: Mapping, keep: int = 0) -> dict:
    """The summary of one run, or a failed summary carrying the solver's message."""
    try:
        return _summary(observe.observe_batch([config], threads=1, **keywords)[0], keep)
    except SolverError as exc:
        return _failed_summary(str(exc), 2 * config.n_modes, keep, _names(keywords))


def _failed_summary(message: str, n_state: int, keep: int = 0, names=()) -> dict:
    """A point whose run failed (SolverError, BlowUpError): NaN values, period 0."""
    out = {"steady": False, "period": 0, "periods": 0, "error": message,
           "values": {name: np.nan for name in names}, "physical": None,
           "final_state": np.full(n_state, np.nan), "orbit": np.full((1, n_state), np.nan)}
    if keep:
        out["poincare"] = np.full((keep, n_state), np.nan)
    return out


def _run_chunk_processes(args):
    base, points, keywords, keep = args
    return _run_chunk(base, points, 1, keywords, keep)


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
    if not isinstance(chunk, (int, np.integer)) or isinstance(chunk, bool) or chunk < 1:
        raise InputTypeError(f"chunk = {shown(chunk)}: must be a positive integer")
    return [range(i, min(n, i + int(chunk))) for i in range(0, n, int(chunk))]


def _workers(workers) -> int:
    """Local threads or processes: None (all cores) or 1 to tmafm.observe.MAX_THREADS."""
    if workers is None:
        return os.cpu_count() or 1
    limit = _observe_api().MAX_THREADS
    if not isinstance(workers, (int, np.integer)) or isinstance(workers, (bool, np.bool_)) \
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
    return list(itertools.chain.from_iterable(results))


# --- Datasets ------------------------------------------------------------------------------

def _units(base_config: Config) -> tuple[dict, dict]:
    """(units, physical units) of the observables (tmafm.observe.UNITS, PHYSICAL_UNITS)."""
    observe = _observe_api()
    return dict(observe.UNITS), dict(observe.PHYSICAL_UNITS)


def _steady_variables(summaries: list[dict], shape: tuple, dims: tuple, units: dict,
                      physical_units: dict) -> dict:
    """The steady variables of a list of summaries (one per point, in grid order)."""
    good = [s for s in summaries if "error" not in s]
    names = [name for name in _names() if any(name in s["values"] for s in summaries)]
    columns = {name: np.array([s["values"].get(name, np.nan) for s in summaries], dtype=float)
               for name in names}
    physical = {}
    for name in names:
        if good and all(name in s["physical"] for s in good):
            physical[name] = np.array([s["physical"][name] if "error" not in s else np.nan
                                       for s in summaries], dtype=float)
    for name in ("harmonic_amplitude", "harmonic_phase"):
        if good and all(name in s for s in good):
            size = len(good[0][name])
            columns[name] = np.array([s[name] if "error" not in s else np.full(size, np.nan)
                                      for s in summaries], dtype=float)
    return _steady_columns(columns, physical, np.array([s["period"] for s in summaries]),
                           np.array([s["steady"] for s in summaries]),
                           np.array(["error" in s for s in summaries]),
                           np.array([s["periods"] for s in summaries]), shape, dims, units,
                           physical_units)


def _steady_columns(columns: dict, physical: dict, period, steady, failed, periods,
                    shape: tuple, dims: tuple, units: dict, physical_units: dict) -> dict:
    """The steady variables from arrays over the points (grid order): ``columns`` {name: (n,)
    or (n, harmonics)}, ``physical`` {name: (n,)}, and period, steady, failed, periods (n,)."""
    import xarray as xr
    data = {}
    for name in _names():
        if name not in columns:
            continue
        data[name] = xr.Variable(dims, columns[name].reshape(shape),
                                 attrs={"units": units.get(name, "1"),
                                        "long_name": f"steady {name}"})
        if name in physical:
            unit = physical_units.get(name, "")
            data[f"{name}_{unit}" if unit else f"{name}_physical"] = xr.Variable(
                dims, physical[name].reshape(shape),
                attrs={"units": unit, "long_name": f"steady {name} ({unit})"})
    for name in ("harmonic_amplitude", "harmonic_phase"):
        if name in columns:
            data[name] = xr.Variable((*dims, "harmonic"), columns[name].reshape(*shape, -1),
                                     attrs={"units": units.get(name, ""),
                                            "long_name": f"steady {name} (harmonics 1, 2, ...)"})
    data["period"] = xr.Variable(dims, np.asarray(period, dtype=np.int32).reshape(shape),
                                 attrs={"units": "drive periods",
                                        "long_name": "period of the steady motion (0: none found)"})
    data["steady"] = xr.Variable(dims, np.asarray(steady, dtype=np.int8).reshape(shape),
                                 attrs={"long_name": "1 where steady state was reached"})
    data["failed"] = xr.Variable(dims, np.asarray(failed, dtype=np.int8).reshape(shape),
                                 attrs={"long_name": "1 where the run failed (SolverError); "
                                                     "its values are NaN"})
    data["periods"] = xr.Variable(dims, np.asarray(periods, dtype=np.int32).reshape(shape),
                                  attrs={"units": "drive periods", "long_name": "periods run"})
    return data


def _attrs(base, kind: str, keywords: dict) -> dict:
    from . import __version__
    attrs = {"tmafm_kind": kind, "tmafm_version": str(__version__),
             "base": base.label if isinstance(base, Config) else str(base)
             if isinstance(base, (str, os.PathLike)) else "<dict input>"}
    for key, value in keywords.items():
        if key == "observables":  # a list of groups: NetCDF attributes want one text
            value = "all" if value is None else ",".join(value)
        attrs[f"observe_{key}"] = int(value) if isinstance(value, bool) else value
    return attrs


def _failure_attrs(summaries: list[dict]) -> dict:
    """The count of failed runs and the first one's message, for the Dataset's attributes."""
    errors = [s["error"] for s in summaries if "error" in s]
    return {"failures": len(errors), "first_failure": errors[0] if errors else ""}


def _base_config(base) -> Config:
    # An input that names no &solver method runs the observed runs' default (flight_exact).
    return base if isinstance(base, Config) else _observe_api().observed_config(base)


def _validate(base: dict, points: list[dict]) -> list[Config]:
    """Every point's Config, built up front: the first bad one raises, before any run."""
    return [_config(base, point) for point in points]


def sweep(base, axes, *, workers=None, client=None, progress=False, chunk=None,
          backend="batch", **observe_keywords):
    """A grid of runs over any input keys; an xarray.Dataset of steady values.

    ``axes`` maps 'group.key' to 1-D values; the grid is their outer product (C order, the
    first key slowest).  The Dataset has one dimension per key, named as the key, and one
    variable per steady observable (STEADY_NAMES, with units as attributes; plus
    ``<name>_<unit>`` in physical units when the base has &physical), ``period`` (0 where
    none was found), ``steady`` and ``periods``.  Every point is validated before any run.
    ``workers`` threads of the core's batch (default: all cores), or ``backend='processes'``
    for a process pool; ``client`` a dask.distributed Client (one task per chunk).
    """
    _check_run(workers, client, progress, chunk, backend, "tmafm.sweep")
    axes = _check_axes(axes)
    keywords = _observe_keywords(observe_keywords)
    _check_points(math.prod(len(v) for v in axes.values()), f"sweep axes {_sizes(axes)}")
    base_config = _base_config(base)
    base_groups = _base_dict(base_config)
    keys = list(axes)
    points = [dict(zip(keys, combo)) for combo in itertools.product(*map(_raw, axes.values()))]
    configs = _validate(base_groups, points)
    summaries = _run_points(base_groups, points, configs=configs, workers=workers, client=client,
                            progress=progress, chunk=chunk, backend=backend, keywords=keywords)
    return _grid_dataset(base, base_config, axes, summaries, keywords, "sweep")


def _grid_dataset(base, base_config, axes, summaries, keywords, kind):
    import xarray as xr
    keys = list(axes)
    shape = tuple(len(v) for v in axes.values())
    units, physical_units = _units(base_config)
    data = _steady_variables(summaries, shape, tuple(keys), units, physical_units)
    coords = {key: xr.Variable((key,), np.asarray(values), attrs={"long_name": key})
              for key, values in axes.items()}
    attrs = _attrs(base, kind, keywords)
    attrs.update(_failure_attrs(summaries))
    return xr.Dataset(data, coords=coords, attrs=attrs)


# --- Continuation: approach/retract and frequency sweeps -----------------------------------

def _warm_chain(base: dict, key: str, values, curve_point: Mapping, n_modes: int,
                keywords: Mapping, start_state=None, stop=None) -> tuple[list[dict], np.ndarray]:
    """Observe `values` of `key` in order, each point starting from the previous final state.
    ``stop`` (a threading.Event, in a worker thread) is checked before each point: once set,
    _Stopped is raised."""
    observe = _observe_api()
    state = start_state
    summaries = []
    for value in values:
        if stop is not None and stop.is_set():
            raise _Stopped()
        point = dict(curve_point)
        point[key] = value
        if state is not None:
            point["initial.a0"] = state[:n_modes].tolist()
            point["initial.adot0"] = state[n_modes:].tolist()
        summary = _observe_one(observe, _config(base, point), keywords)
        summaries.append(summary)
        if "error" not in summary:  # after a failed point, go on from the last good state
            state = summary["final_state"]
    return summaries, state


def _both_ways(base: dict, key: str, first, n_modes: int, curve_point: Mapping,
               keywords: Mapping, reverse: bool, stop=None) -> list[list[dict]]:
    """[forward summaries, backward summaries (in forward order)] of one curve; ``stop`` as in
    _warm_chain."""
    forward, state = _warm_chain(base, key, first, curve_point, n_modes, keywords, stop=stop)
    if not reverse:
        return [forward]
    backward, _ = _warm_chain(base, key, first[::-1], curve_point, n_modes, keywords, state,
                              stop)
    return [forward, backward[::-1]]


def mark_jumps(values, threshold: float = 0.2, ratio: float = 2.0) -> np.ndarray:
    """Flag jumps along the last axis (the order of travel): True at point i when the step
    d_i = |y[i] - y[i-1]| exceeds `threshold` times the curve's range of y AND `ratio` times
    both neighbouring steps d_(i-1) and d_(i+1).  So a branch that changes steeply but
    smoothly is not a jump, and a switch between branches is (marked on its arrival point)."""
    threshold = _check_positive("mark_jumps threshold", threshold)
    ratio = _check_positive("mark_jumps ratio", ratio)
    try:
        if isinstance(values, (str, bytes)):
            raise TypeError("not numbers")
        y = np.asarray(values, dtype=float)
    except (TypeError, ValueError, OverflowError) as exc:
        raise InputError(f"mark_jumps values must be real numbers: {shown(str(exc))[1:-1]}") \
            from None
    if y.ndim == 0:
        raise InputError(f"mark_jumps values must be an array of at least one dimension, got "
                         f"{shown(values)}")
    if y.size == 0:
        return np.zeros(y.shape, dtype=bool)
    flat = y.reshape(-1, y.shape[-1])
    flags = np.zeros(flat.shape, dtype=bool)
    for row, out in zip(flat, flags):
        if row.size < 2 or not np.isfinite(row).all():
            continue
        step = np.abs(np.diff(row))
        span = np.ptp(row)
        if span == 0:
            continue
        left = np.concatenate([[0.0], step[:-1]])
        right = np.concatenate([step[1:], [0.0]])
        out[1:] = (step > threshold * span) & (step > ratio * left) & (step > ratio * right)
    return flags.reshape(y.shape)


#: The observables whose jumps mark a change of branch in continuation sweeps.
JUMP_NAMES = ("amplitude", "phase")


def _continuation(base, key: str, values, *, directions: tuple[str, str], reverse: bool,
                  curves, workers, client, progress, jump_threshold, kind, keywords):
    _check_run(workers, client, progress, user=f"tmafm.{kind}")
    import xarray as xr
    reverse = _check_flag("retract" if kind == "approach" else "reverse", reverse)
    keywords = _observe_keywords(keywords)
    if keywords.get("observables") is not None and "lockin" not in keywords["observables"]:
        # The jumps are found on amplitude and phase: the lock-in group is always computed.
        keywords["observables"] = _observe_api().observable_groups(
            ("lockin",) + tuple(keywords["observables"]))
    jump_threshold = _check_positive("jump_threshold", jump_threshold)
    _split_key(key)
    values = _axis_values(key, values)
    empty = curves is None or (isinstance(curves, Mapping) and not curves)
    curves = {} if empty else _check_axes(curves)
    if key in curves:
        raise InputError(f"{kind}: {shown(key)} is both the swept key and a curve key")
    _check_points(math.prod(len(v) for v in curves.values()) * len(values) * (2 if reverse else 1),
                  f"{kind} axes {_sizes(dict(curves, **{key: values}))}")
    base_config = _base_config(base)
    base_groups = _base_dict(base_config)
    n_modes = base_config.n_modes
    curve_keys = list(curves)
    curve_points = [dict(zip(curve_keys, combo))
                    for combo in itertools.product(*map(_raw, curves.values()))]
    _validate(base_groups, [dict(c, **{key: v}) for c in curve_points for v in _raw(values)])

    bar = _progress(len(curve_points), progress, kind)
    done = None if bar is None else lambda k: bar.update(1)
    try:
        if client is not None:
            futures = [client.submit(_both_ways, base_groups, key, _raw(values), n_modes, c, keywords,
                                     reverse, pure=False) for c in curve_points]
            results = _dask_results(client, futures, done)
        else:
            # One curve per thread.  A Ctrl-C reaches this (main) thread while it waits; the
            # threads stop before their next point, and KeyboardInterrupt comes out.
            with _thread_pool(_workers(workers)) as (pool, stop):
                futures = [pool.submit(_both_ways, base_groups, key, _raw(values), n_modes, c,
                                       keywords, reverse, stop) for c in curve_points]
                results = _results(futures, done)
    finally:
        if bar is not None:
            bar.close()

    used = directions if reverse else directions[:1]
    # Summaries in the order (direction, curve..., value).
    ordered = [s for d in range(len(used)) for r in results for s in r[d]]
    dims = ("direction", *curve_keys, key)
    shape = (len(used), *(len(v) for v in curves.values()), len(values))
    units, physical_units = _units(base_config)
    data = _steady_variables(ordered, shape, dims, units, physical_units)
    n_state = 2 * n_modes
    data["final_state"] = xr.Variable(
        (*dims, "state"), np.array([s["final_state"] for s in ordered]).reshape(*shape, n_state),
        attrs={"long_name": "state (a, a') at the last period boundary"})
    # A jump is marked along the direction of travel: the first point of the new branch.
    flags = np.zeros(shape, dtype=bool)
    for name in JUMP_NAMES:
        observed = data[name].values
        travel = [observed[0]] + ([observed[1][..., ::-1]] if reverse else [])
        for d, y in enumerate(travel):
            if name == "phase":  # degrees: a wrap at +-180 is no jump
                y = np.unwrap(y, period=360.0, axis=-1)
            found = mark_jumps(y, jump_threshold)
            flags[d] |= found if d == 0 else found[..., ::-1]
    data["jump"] = xr.Variable(dims, flags.astype(np.int8), attrs={
        "long_name": "1 where amplitude or phase jumped on arriving at this point "
                     "(tmafm.sweeps.mark_jumps)", "threshold": float(jump_threshold)})
    coords = {key: xr.Variable((key,), np.asarray(values)),
              "direction": xr.Variable(("direction",), np.array(used, dtype="U8"))}
    for ckey, cvalues in curves.items():
        coords[ckey] = xr.Variable((ckey,), np.asarray(cvalues))
    attrs = _attrs(base, kind, keywords)
    attrs.update(_failure_attrs(ordered))
    attrs["swept_key"] = key
    attrs["order"] = f"{used[0]} runs {key} in the order given" + (
        f", {used[1]} in reverse" if reverse else "")
    return xr.Dataset(data, coords=coords, attrs=attrs)


def approach(base, delta_hat, *, retract=True, curves=None, workers=None, client=None,
             progress=False, jump_threshold=0.2, **observe_keywords):
    """Approach/retract: sweep scene.delta_hat through `delta_hat` (give them decreasing: the
    tip approaches the sample), then back, each point warm-started from the previous one's final
    state, so bistable branches show.  ``curves`` ({'group.key': values}) adds curves, run in
    parallel.  The Dataset has dims ('direction', *curve keys, 'scene.delta_hat') with
    direction 'approach'/'retract', the steady values, ``jump`` and ``final_state``."""
    return _continuation(base, "scene.delta_hat", delta_hat, directions=("approach", "retract"),
                         reverse=retract, curves=curves, workers=workers, client=client,
                         progress=progress, jump_threshold=jump_threshold, kind="approach",
                         keywords=observe_keywords)


def frequency_sweep(base, omega, *, reverse=True, curves=None, workers=None, client=None,
                    progress=False, jump_threshold=0.2, **observe_keywords):
    """Frequency sweep: scene.omega through `omega` (give them increasing), then back, warm
    started as in approach(); direction 'up'/'down'."""
    return _continuation(base, "scene.omega", omega, directions=("up", "down"), reverse=reverse,
                         curves=curves, workers=workers, client=client, progress=progress,
                         jump_threshold=jump_threshold, kind="frequency_sweep",
                         keywords=observe_keywords)


# --- Bifurcation diagrams and basins -------------------------------------------------------

def _tip_displacement(config: Config, states: np.ndarray) -> np.ndarray:
    """p^T a (the tip's modal displacement, V_T without drive and offset) of states (.., 2N)."""
    model = config.model()
    n = config.n_modes
    scene = config.scene
    # V_T = p^T a + alpha2 sin(Omega tau) + delta_hat; at a period boundary sin(...) = 0.
    flat = states.reshape(-1, 2 * n)
    vt = np.array([model.contact(0.0, row[:n]).vt for row in flat]) - scene["delta_hat"]
    return vt.reshape(states.shape[:-1])


def bifurcation(base, key, values, *, periods_kept=32, workers=None, client=None,
                progress=False, chunk=None, backend="batch", max_periods=200,
                stop_at_steady=False, observables=(), **observe_keywords):
    """Poincaré points against a swept key: the last `periods_kept` section points of each run.

    Variables (dims (key, 'kept')): ``a1`` and ``adot1`` (first mode), ``tip`` = p^T a (the
    tip's modal displacement at the section, where the drive phase is 0), ``vt`` = V_T there;
    plus ``period`` and the steady values of ``observables`` (none by default: the section
    points need none; e.g. ``observables=["lockin"]`` adds amplitude and phase).  Runs go
    max_periods periods (200) and do not stop at steady state unless asked, so the last points
    sample the attractor.
    """
    _check_run(workers, client, progress, chunk, backend, "tmafm.bifurcation")
    import xarray as xr
    _split_key(key)
    values = _axis_values(key, values)
    if isinstance(periods_kept, (bool, np.bool_)) or not isinstance(periods_kept, (int, np.integer)) \
            or periods_kept < 1:
        raise InputTypeError(f"periods_kept = {shown(periods_kept)}: must be a positive integer")
    keywords = _observe_keywords(dict(observe_keywords, max_periods=max_periods,
                                      stop_at_steady=stop_at_steady, observables=observables))
    if periods_kept > max_periods:
        raise InputError(f"periods_kept = {periods_kept} is more than max_periods = {max_periods}")
    where = f"bifurcation axis {shown(key)} ({len(values)} values), periods_kept = {periods_kept}"
    _check_points(len(values), where, 8 * int(periods_kept))  # N = 1 until the base is read
    base_config = _base_config(base)
    _check_points(len(values), where, int(periods_kept) * (4 * base_config.n_modes + 4))
    base_groups = _base_dict(base_config)
    points = [{key: v} for v in _raw(values)]
    configs = _validate(base_groups, points)
    summaries = _run_points(base_groups, points, configs=configs, workers=workers, client=client,
                            progress=progress, chunk=chunk, backend=backend,
                            keep=periods_kept, keywords=keywords, label="bifurcation")
    ds = _grid_dataset(base, base_config, {key: np.asarray(values)}, summaries, keywords,
                       "bifurcation")
    # Each point's own N (a swept model.n_modes changes it): states of 2 N_i values each.
    sizes = [2 * config.n_modes for config in configs]
    kept = np.full((len(values), periods_kept, max(sizes)), np.nan)
    for i, s in enumerate(summaries):
        rows = s["poincare"]
        kept[i, periods_kept - len(rows):, :rows.shape[1]] = rows
    dims = (key, "kept")
    ds["a1"] = xr.Variable(dims, kept[..., 0], attrs={"long_name": "a1 at the Poincaré section"})
    ds["adot1"] = xr.Variable(dims, np.stack([kept[i, :, size // 2] for i, size in
                                              enumerate(sizes)]),
                              attrs={"long_name": "a1' at the section"})
    tip = np.stack([_tip_displacement(configs[i], kept[i, :, :sizes[i]])
                    for i in range(len(points))])
    ds["tip"] = xr.Variable(dims, tip, attrs={"long_name": "p^T a at the section"})
    offsets = np.array([c.scene["delta_hat"] for c in configs])
    ds["vt"] = xr.Variable(dims, tip + offsets[:, None],
                           attrs={"long_name": "V_T at the section (drive phase 0)"})
    ds.attrs["swept_key"] = key
    return ds


def same_orbit(x: np.ndarray, y: np.ndarray, tol: float) -> bool:
    """True when two periodic Poincaré orbits (p x 2N) agree within `tol` up to a cyclic shift."""
    if x.shape != y.shape:
        return False
    return any(np.max(np.abs(np.roll(x, k, axis=0) - y)) <= tol for k in range(x.shape[0]))


def minimal_period(orbit: np.ndarray, tol: float) -> int:
    """The smallest period q (q divides p) of a periodic Poincaré orbit (p x 2N, points in
    order) by the core's steady-state rule (tmafm.observe.steady_test): its points, taken
    cyclically, repeat q periods on within `tol` (absolute), and its q points are distinct.
    A steady-state test can call a period-1 point period-2 while the transient still
    alternates around it (a negative Floquet multiplier); p when no q fits."""
    from .observe import steady_test
    orbit = np.asarray(orbit, dtype=float)
    p = orbit.shape[0]
    if p == 1:
        return 1
    size = float(np.max(np.abs(orbit))) or 1.0
    q = steady_test(np.concatenate([orbit, orbit]), p, min(tol / size, 0.5), p, scale=size)["period"]
    return q if q and p % q == 0 else p


def minimal_orbit(orbit: np.ndarray, tol: float) -> np.ndarray:
    """The orbit cut to its minimal period (``minimal_period``)."""
    return np.asarray(orbit)[:minimal_period(orbit, tol)]


def label_attractors(orbits: Sequence[np.ndarray], periods: Sequence[int],
                     tol: float) -> tuple[np.ndarray, list[np.ndarray]]:
    """(labels, representative orbits): points whose orbits (cut to their minimal period, by
    the core's rule) agree within `tol` up to a cyclic shift share a label 0, 1, ... (in the
    order of first appearance); no period found gives -1."""
    labels = np.full(len(orbits), -1, dtype=np.int32)
    periods = np.asarray(periods, dtype=int)
    cut: dict[int, list] = {}          # minimal period -> [(points, orbits), ...]
    for p in np.unique(periods[periods > 0]):
        index = np.flatnonzero(periods == p)
        stack = np.stack([np.asarray(orbits[i])[-p:] for i in index])
        minimal = np.array([minimal_period(orbit, tol) for orbit in stack], dtype=int)
        for q in np.unique(minimal):
            take = minimal == q
            cut.setdefault(int(q), []).append((index[take], stack[take, :q]))
    # The first point not yet labelled founds the next label; every later point of the same
    # minimal period within tol of it (up to a shift) takes it: the same labels as comparing
    # each point in turn with the representatives found so far, with numpy doing the points.
    groups = {}
    for q, parts in cut.items():
        index = np.concatenate([i for i, _ in parts])
        stack = np.concatenate([o for _, o in parts])
        order = np.argsort(index, kind="stable")
        groups[q] = (index[order], stack[order])
    free = {q: np.ones(len(index), dtype=bool) for q, (index, _) in groups.items()}
    known: list[np.ndarray] = []
    while True:
        firsts = [(groups[q][0][free[q]][0], q) for q in groups if free[q].any()]
        if not firsts:
            break
        i, q = min(firsts)
        index, stack = groups[q]
        representative = stack[np.searchsorted(index, i)]
        distance = np.full(len(index), np.inf)
        for shift in range(q):
            rolled = np.roll(stack, shift, axis=1)
            distance = np.minimum(distance, np.max(np.abs(rolled - representative),
                                                   axis=(1, 2)))
        take = free[q] & (distance <= tol)
        take[np.searchsorted(index, i)] = True
        labels[index[take]] = len(known)
        free[q] &= ~take
        known.append(representative)
    return labels, known


def _coarse_stride(shape: tuple, coarse) -> int:
    """The stride of the first pass of a basin map: about 256 points, at least every 2nd point
    of both axes when both have 4 points or more (otherwise every point)."""
    if coarse is None:
        if min(shape) < 4:
            return 1
        return max(2, int(round(math.sqrt(shape[0] * shape[1] / 256))))
    if isinstance(coarse, bool) or not isinstance(coarse, (int, np.integer)) or coarse < 1:
        raise InputTypeError(f"coarse = {shown(coarse)}: must be a positive integer or None")
    return int(coarse)


def _basin_chunk(config, states, threads, keywords, attractors):
    """One chunk of basin runs (observe_states); a dict of arrays (picklable).  `config` is a
    Config in this process, or its dict of groups for another process (a Config holds a
    handle into this process's Fortran memory and must not be pickled)."""
    observe = _observe_api()
    if not isinstance(config, Config):
        config = Config(config)
    out = observe.observe_states(config, states, threads=threads, attractors=attractors,
                                 **keywords)
    return {"steady": out.steady, "physical": out.physical, "orbit": out.orbit,
            "periods": out.periods, "period": out.period, "attractor": out.attractor,
            "failed": out.failed, "first_failure": out.first_failure, "jitter": out.jitter}


def _basin_chunk_processes(args):
    return _basin_chunk(*args)


#: Periods a new attractor's orbit is followed further before runs may stop at it.
REFINE_PERIODS = 32


def _new_attractors(chunk: dict, known: list, tol: float, run_config, keywords: Mapping) -> list:
    """The orbits (p Poincaré points, in order) of the attractors a chunk's runs found by the
    steady-state test that match none of `known` (within tol times their size).  Each orbit is
    followed REFINE_PERIODS more periods from the run's final state, so that it lies on the
    attractor well within the steady tolerance (the test stops a run while its points still
    approach the orbit by about steady_tol per period)."""
    found = []
    for k in np.flatnonzero((chunk["period"] > 0) & (chunk["attractor"] < 0)):
        p = int(chunk["period"][k])
        orbit = chunk["orbit"][k, -p:]
        if not np.all(np.isfinite(orbit)):
            continue
        size = float(np.max(np.abs(orbit))) or 1.0
        # rk4_paper's orbits are known only to its jitter (docs/observables.md).
        resolution = max(tol * size, float(chunk["jitter"][k]))
        if any(same_orbit(minimal_orbit(orbit, resolution), minimal_orbit(o, resolution),
                          resolution) for o in known + found):
            continue
        refine = dict(keywords, observables=(), stop_at_steady=False,
                      max_periods=max(REFINE_PERIODS, p), capture=None)
        further = _observe_api().observe_states(run_config, orbit[-1:], threads=1, **refine)
        if further.failed[0] or further.period[0] != p:
            continue  # not a clean period-p orbit once followed further: use it for no run
        found.append(further.orbit[0, -p:].copy())
    return found


def basin(base, a1, adot1, *, tol=1e-3, workers=None, client=None, progress=False, chunk=None,
          backend="batch", observables=(), known_attractors=True, coarse=None, confirm=None,
          capture=None, **observe_keywords):
    """A basin map: a grid of initial states a1(0) x a1'(0) (other modes from the base's
    &initial), each labelled by the attractor it reaches.  Variables (dims ('a1', 'adot1')):
    ``attractor`` (0, 1, ...: points whose final Poincaré orbits agree within `tol` times the
    largest |state| up to a cyclic shift share a label; -1: no period found),
    ``attractor_period``, ``period`` (the steady-state test's), ``periods``, ``stopped_known``
    (1 where the run stopped at a known attractor) and the steady values of ``observables``
    (none by default; e.g. ``["lockin"]`` adds amplitude and phase);
    ``attractor_orbit_<k>`` holds each attractor's Poincaré orbit.

    With ``known_attractors`` (the default) a first pass runs every `coarse`-th point of both
    axes (about 256 points); the other points then run in chunks, each run stopped as soon
    as its Poincaré points repeat an attractor already found (docs/sweeps.md, "Stopping at a
    known attractor").  The input is read and its model built once per chunk, and each run
    starts from its state in memory (tmafm.observe.observe_states)."""
    _check_run(workers, client, progress, chunk, backend, "tmafm.basin")
    import xarray as xr
    keywords = _observe_keywords(dict(observe_keywords, observables=observables))
    a1 = _axis_values("a1", a1, real=True)
    adot1 = _axis_values("adot1", adot1, real=True)
    tol = _check_positive("tol", tol, 1.0)
    known_attractors = _check_flag("known_attractors", known_attractors)
    _coarse_stride((len(a1), len(adot1)), coarse)
    p_max = keywords.get("p_max", 8)
    if confirm is not None and (isinstance(confirm, (bool, np.bool_)) or not isinstance(
            confirm, (int, np.integer)) or not 1 <= confirm <= 10_000_000):
        raise InputTypeError(f"confirm = {shown(confirm)}: must be an integer from 1 to "
                             f"10000000, or None")
    if capture is not None:
        capture = _check_positive("capture", capture, 1.0)
    where = f"basin axes a1 ({len(a1)} values) x adot1 ({len(adot1)} values)"
    _check_points(len(a1) * len(adot1), where, 2 * (2 * p_max + 2))  # N = 1 until the base is read
    base_config = _base_config(base)
    base_groups = _base_dict(base_config)
    n = base_config.n_modes
    _check_points(len(a1) * len(adot1), where, 2 * n * (2 * p_max + 2))
    initial = base_groups.get("initial", {})
    a0 = np.zeros(n)
    adot0 = np.zeros(n)
    a0[:] = np.resize(np.asarray(initial.get("a0", [0.0]), dtype=float), n) if "a0" in initial \
        else 0.0
    adot0[:] = np.resize(np.asarray(initial.get("adot0", [0.0]), dtype=float), n) \
        if "adot0" in initial else 0.0
    shape = (len(a1), len(adot1))
    states = np.empty((shape[0], shape[1], 2 * n))
    states[:] = np.concatenate([a0, adot0])
    states[..., 0] = np.asarray(a1, dtype=float)[:, None]
    states[..., n] = np.asarray(adot1, dtype=float)[None, :]
    states = states.reshape(-1, 2 * n)
    bad = np.flatnonzero(~np.all(np.isfinite(states) & (np.abs(states) <= 1.0), axis=1))
    if bad.size:
        i, j = np.unravel_index(int(bad[0]), shape)
        raise InputError(f"basin point a1 = {_short(a1[i])}, adot1 = {_short(adot1[j])}: "
                         f"&initial values must be finite with |value| <= 1 (gap units)")
    stride = _coarse_stride(shape, coarse)
    # One resolved text for every run: the base with its N fixed (an automatic N is chosen once).
    run_groups = dict(base_groups, model=dict(base_groups.get("model", {}), n_modes=n))
    run_config = Config(run_groups)
    order = np.arange(states.shape[0]).reshape(shape)
    if known_attractors and keywords.get("stop_at_steady", True):
        first = order[::stride, ::stride].ravel()
        rest = np.setdiff1d(order.ravel(), first)
    else:
        first, rest = order.ravel(), np.zeros(0, dtype=int)
    n_workers = _workers(workers)
    size = int(chunk) if chunk is not None else 2048
    if capture is None:
        capture = tol  # the labels' own resolution (docs/sweeps.md)
    observe_kw = dict(keywords, confirm=confirm, capture=capture)
    results: dict = {}
    known: list = []
    bar = _progress(states.shape[0], progress, "basin")
    # Local batches run chunk after chunk, each stopping at what the ones before found;
    # processes and Dask run a pass's chunks at once, with what the first pass found.
    incremental = client is None and backend == "batch"

    def run_pass(indices, attractors):
        pieces = [indices[i:i + size] for i in range(0, len(indices), size)]
        if client is not None:
            futures = [client.submit(_basin_chunk, run_groups, states[p], 1, observe_kw,
                                     attractors, pure=False) for p in pieces]
            outs = _dask_results(client, futures)
        elif backend == "processes":
            with _process_pool(n_workers) as pool:
                outs = _results([pool.submit(_basin_chunk_processes,
                                             (run_groups, states[p], 1, observe_kw, attractors))
                                 for p in pieces])
        elif backend == "batch":
            outs = []
            for p in pieces:
                outs.append(_basin_chunk(run_config, states[p], n_workers, observe_kw,
                                         attractors))
                if known_attractors:  # later chunks may stop at what this one found
                    attractors = attractors + _new_attractors(outs[-1], attractors, tol,
                                                              run_config, observe_kw)
                if bar is not None:
                    bar.update(len(p))
        else:
            raise InputTypeError(f"backend = {shown(backend)}: must be 'batch' or 'processes'")
        if bar is not None and not incremental:
            bar.update(len(indices))
        for p, out in zip(pieces, outs):
            results[tuple(p[:1])] = (p, out)
        return attractors

    try:
        known = run_pass(first, [])
        if known_attractors and rest.size:
            if not incremental:  # the chunks ran at once: collect what the first pass found
                for p, out in list(results.values()):
                    known = known + _new_attractors(out, known, tol, run_config, observe_kw)
            run_pass(rest, known)
    finally:
        if bar is not None:
            bar.close()

    total = states.shape[0]
    merged: dict = {}
    failures = []
    for p, out in sorted(results.values(), key=lambda item: item[0][0]):
        for name in ("orbit", "periods", "period", "attractor", "failed", "jitter"):
            merged.setdefault(name, np.empty((total, *out[name].shape[1:]),
                                             dtype=out[name].dtype))[p] = out[name]
        for group in ("steady", "physical"):
            for name, values in (out[group] or {}).items():
                merged.setdefault(f"{group}:{name}", np.empty((total, *values.shape[1:])))[p] = \
                    values
        if out["first_failure"]:
            failures.append((p[0], out["first_failure"]))
    period = merged["period"]
    failed = merged["failed"]
    p_max = merged["orbit"].shape[1]
    orbits = [merged["orbit"][k, p_max - max(int(period[k]), 1):] for k in range(total)]
    finite = [np.all(np.isfinite(o)) for o in orbits]
    scale = max((float(np.max(np.abs(o))) for o, ok in zip(orbits, finite) if ok), default=0.0) \
        or 1.0
    # A fixed-step method's orbits are known only to its jitter level (rk4_paper): attractors
    # closer than that are not told apart (docs/observables.md, "Steady state").
    jitter = merged["jitter"][np.isfinite(merged["jitter"]) & (period > 0)]
    resolution = max(tol * scale, float(jitter.max()) if jitter.size else 0.0)
    labels, reps = label_attractors(orbits, [int(q) if ok else 0 for q, ok in zip(period, finite)],
                                    resolution)
    units, physical_units = _units(base_config)
    columns = {name.split(":", 1)[1]: v for name, v in merged.items() if name.startswith("steady:")}
    physical = {name.split(":", 1)[1]: v for name, v in merged.items()
                if name.startswith("physical:")}
    data = _steady_columns(columns, physical, period, period > 0, failed, merged["periods"],
                           shape, ("a1", "adot1"), units, physical_units)
    data["attractor"] = xr.Variable(("a1", "adot1"), labels.reshape(shape), attrs={
        "long_name": "attractor label (-1: no period found)", "tolerance": resolution})
    data["attractor_period"] = xr.Variable(("a1", "adot1"), np.array(
        [len(reps[k]) if k >= 0 else 0 for k in labels], dtype=np.int32).reshape(shape),
        attrs={"long_name": "period of the attractor reached (0: none found)"})
    data["stopped_known"] = xr.Variable(("a1", "adot1"), (merged["attractor"] >= 0).astype(
        np.int8).reshape(shape), attrs={"long_name": "1 where the run stopped at an attractor "
                                                     "found before (docs/sweeps.md)"})
    for k, orbit in enumerate(reps):
        data[f"attractor_orbit_{k}"] = xr.Variable((f"orbit_{k}_point", "state"), orbit)
    coords = {"a1": xr.Variable(("a1",), a1, attrs={"long_name": "a1(0)"}),
              "adot1": xr.Variable(("adot1",), adot1, attrs={"long_name": "a1'(0)"})}
    attrs = _attrs(base, "basin", keywords)
    failures.sort()
    attrs.update({"failures": int(failed.sum()),
                  "first_failure": failures[0][1] if failures else ""})
    attrs["attractors"] = len(reps)
    attrs["known_attractors"] = int(bool(known_attractors))
    attrs["coarse_stride"] = stride
    attrs["capture"] = float(capture)
    attrs["confirm"] = int(confirm if confirm is not None else keywords.get("steady_repeats", 3))
    return xr.Dataset(data, coords=coords, attrs=attrs)


# --- Sweep files and the command line ------------------------------------------------------

_FILE_KEYS = {"kind": str, "base": str, "key": str, "start": float, "stop": float, "count": int,
              "values": list, "key2": str, "start2": float, "stop2": float, "count2": int,
              "curve_key": str, "curve_values": list, "reverse": bool, "max_periods": int,
              "p_max": int, "steady_tol": float, "steady_repeats": int, "harmonics": int,
              "stop_at_steady": bool, "periods_kept": int, "tol": float,
              "jump_threshold": float, "workers": int, "output": str, "method": str,
              "rtol": float, "atol": float, "observables": list, "known_attractors": bool,
              "coarse": int}
_KINDS = ("grid", "approach", "frequency", "bifurcation", "basin")


#: Keys whose list entries are numbers, and those whose entries are strings.
_NUMBER_LISTS, _STRING_LISTS = ("values", "curve_values"), ("observables",)
#: Value kinds of the strict reader (tmafm_nml_syntax value_*).
_INTEGER, _REAL, _LOGICAL, _STRING, _WORD = 1, 2, 3, 4, 5


def _sweep_groups(path: Path) -> dict:
    """{group: {key: [values]}} of a sweep file, parsed by tmafm's strict reader (the one the
    executable uses): text outside a group, an empty value, an indexed key, an unquoted
    string, a NUL byte, a key or a group given twice are errors, never skipped or merged."""
    from ._fortran import api
    from ._run import _read_text
    label = shown(str(path))[1:-1]
    data = _read_text(path)
    codes = np.zeros(8 * len(data) + 1024, dtype=np.int32)
    length, ierr, errmsg = api.namelist_syntax(data, label.encode("utf-8", "backslashreplace"), codes)
    raise_for(ierr, errmsg)
    if length < 0:
        raise InputError(f"{label}: the file is too complex to read")
    groups: dict = {}
    seen_groups: dict = {}
    entries: dict = {}
    record: list = []
    field: list = []
    for code in codes[:length].tolist():
        if code >= 0:
            field.append(code)
            continue
        if code == -1:
            record.append(bytes(field).decode("utf-8", "surrogateescape"))
            field = []
            continue
        ordinal, group, entry, key, kind, repeat, text = record
        record = []
        if seen_groups.setdefault(group, ordinal) != ordinal:
            raise InputError(f"{label}: &{group} appears twice: give one &{group} group")
        where = f"{label}: &{group} {key}"
        if entries.setdefault((group, key), entry) != entry:
            raise InputError(f"{where}: the key is given twice")
        kind = int(kind)
        if kind == _INTEGER:
            value = int(text)
        elif kind == _REAL:
            value = float(text.replace("d", "e").replace("D", "E"))
        elif kind == _LOGICAL:
            value = text.lstrip(".")[:1].lower() == "t"
        elif kind == _STRING:
            value = text
        elif kind == _WORD:
            raise InputError(f"{where} = {text}: a string must be quoted: write {key} = '{text}'")
        else:
            raise InputError(f"{where} = {shown(text)}: not a number, a logical or a quoted string")
        groups.setdefault(group, {}).setdefault(key, []).extend([value] * int(repeat))
    return groups


def read_sweep_file(path) -> dict:
    """The &sweep group of a sweep file, checked: a dict of its keys (docs/sweeps.md)."""
    path = _input_name(path, "sweep file")
    try:
        is_file = path.is_file()
    except (OSError, ValueError):  # a name too long, a NUL byte
        is_file = False
    if not is_file:
        raise InputFileError(f"sweep file '{path}' not found")
    groups = _sweep_groups(path)
    if "sweep" not in groups:
        raise InputError(f"{path}: no &sweep group")
    extra = [g for g in groups if g != "sweep"]
    if extra:
        raise InputError(f"{path}: unknown group(s) &{', &'.join(extra)} (a sweep file has &sweep)")
    spec = {}
    for key, values in groups["sweep"].items():
        if key not in _FILE_KEYS:
            raise InputError(f"{path}: &sweep {key}: unknown key (known: {', '.join(_FILE_KEYS)})")
        kind = _FILE_KEYS[key]
        if kind is list:
            item = str if key in _STRING_LISTS else (int, float)
            if any(isinstance(v, bool) or not isinstance(v, item) for v in values):
                raise InputError(f"{path}: &sweep {key} = {shown(values)}: every entry must be a "
                                 f"{'quoted string' if item is str else 'number'}")
            spec[key] = list(values)
            continue
        if len(values) != 1:
            raise InputError(f"{path}: &sweep {key} = {shown(values)}: give one value")
        value = values[0]
        if kind is float and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        if not isinstance(value, kind) or (kind is int and isinstance(value, bool)) or (
                kind is float and isinstance(value, bool)):
            raise InputError(f"{path}: &sweep {key} = {value!r}: must be a {kind.__name__}")
        spec[key] = value
    for key in ("kind", "base"):
        if key not in spec:
            raise InputError(f"{path}: &sweep {key}: missing (required)")
    if spec["kind"] not in _KINDS:
        raise InputError(f"{path}: &sweep kind = '{spec['kind']}': must be one of "
                         f"{', '.join(_KINDS)}")
    base = Path(spec["base"])
    if not base.is_absolute() and (path.parent / base).is_file():
        spec["base"] = str(path.parent / base)
    spec["_file"] = str(path)
    return spec


def _axis_size(spec: dict, suffix: str = "") -> tuple[int, str]:
    """(number of values, 'key = value' as the file gives them) of one axis of a sweep file."""
    where = spec["_file"]
    if suffix == "" and "values" in spec:
        return len(spec["values"]), f"values ({len(spec['values'])} entries)"
    missing = [k + suffix for k in ("start", "stop", "count") if k + suffix not in spec]
    if missing:
        raise InputError(f"{where}: &sweep {', '.join(missing)}: missing (give start{suffix}, "
                         f"stop{suffix}, count{suffix}" + (" or values)" if not suffix else ")"))
    count = spec["count" + suffix]
    if count < 1:
        raise InputError(f"{where}: &sweep count{suffix} = {count}: must be at least 1")
    for key in ("start" + suffix, "stop" + suffix):
        if not math.isfinite(spec[key]):
            raise InputError(f"{where}: &sweep {key} = {spec[key]}: must be finite")
    return count, f"count{suffix} = {count}"


def _axis_of(spec: dict, suffix: str = "") -> np.ndarray:
    _axis_size(spec, suffix)
    if suffix == "" and "values" in spec:
        return np.asarray(spec["values"], dtype=float)
    return np.linspace(spec["start" + suffix], spec["stop" + suffix], spec["count" + suffix])


def _check_file_size(spec: dict) -> None:
    """Before any array is built: the sweep's points fit in the memory available
    (_check_points), the message naming the file's keys and values."""
    kind = spec["kind"]
    axes = [_axis_size(spec)]
    if kind == "basin" or (kind == "grid" and "key2" in spec):
        axes.append(_axis_size(spec, "2"))
    points = math.prod(count for count, _ in axes)
    floats = 0
    if kind in ("approach", "frequency"):
        points *= max(1, len(spec.get("curve_values", []))) * (2 if spec.get("reverse", True)
                                                               else 1)
    elif kind == "bifurcation":
        floats = 8 * spec.get("periods_kept", 32)
    elif kind == "basin":
        floats = 2 * (2 * spec.get("p_max", 8) + 2)
    _check_points(points, f"{spec['_file']}: &sweep {', '.join(text for _, text in axes)}",
                  floats)


def run_sweep_file(path, *, workers=None, client=None, progress=False):
    """Run the sweep a file describes; return its Dataset."""
    spec = read_sweep_file(path)
    _check_file_size(spec)
    kind, base = spec["kind"], spec["base"]
    solver = {k: spec[k] for k in ("method", "rtol", "atol") if k in spec}
    if solver:
        base = Config(base, solver=solver)
    keywords = {k: spec[k] for k in OBSERVE_KEYWORDS if k in spec}
    workers = workers if workers is not None else spec.get("workers")
    common = dict(workers=workers, client=client, progress=progress)
    curves = ({spec["curve_key"]: spec["curve_values"]} if "curve_key" in spec else None)
    if kind == "grid":
        axes = {spec.get("key", "scene.delta_hat"): _axis_of(spec)}
        if "key2" in spec:
            axes[spec["key2"]] = _axis_of(spec, "2")
        return sweep(base, axes, **common, **keywords)
    if kind == "approach":
        return approach(base, _axis_of(spec), retract=spec.get("reverse", True), curves=curves,
                        jump_threshold=spec.get("jump_threshold", 0.2), **common, **keywords)
    if kind == "frequency":
        return frequency_sweep(base, _axis_of(spec), reverse=spec.get("reverse", True),
                               curves=curves, jump_threshold=spec.get("jump_threshold", 0.2),
                               **common, **keywords)
    if kind == "bifurcation":
        if "key" not in spec:
            raise InputError(f"{spec['_file']}: &sweep key: missing (required for bifurcation)")
        extra = {k: spec[k] for k in ("periods_kept",) if k in spec}
        return bifurcation(base, spec["key"], _axis_of(spec), **extra, **common, **keywords)
    extra = {k: spec[k] for k in ("known_attractors", "coarse") if k in spec}
    return basin(base, _axis_of(spec), _axis_of(spec, "2"), tol=spec.get("tol", 1e-3), **extra,
                 **common, **keywords)


def summarize(ds) -> dict:
    """The facts docs/sweeps.md quotes, from a sweep Dataset: jump positions per curve and
    direction, attractor counts, period counts, where the bifurcation points split."""
    _check_dataset(ds, "summarize")
    kind = ds.attrs.get("tmafm_kind")
    if kind not in ("sweep", "approach", "frequency_sweep", "bifurcation", "basin") \
            or "period" not in ds:
        raise InputError(f"summarize: not a tmafm sweep dataset (tmafm_kind = {shown(kind)})")
    out = {"kind": kind, "failures": int(ds.attrs.get("failures", 0)),
           "periods_found": {str(int(k)): int((ds["period"].values == k).sum())
                             for k in np.unique(ds["period"].values)}}
    if kind in ("approach", "frequency_sweep"):
        key = ds.attrs["swept_key"]
        curve_dims = [d for d in ds["jump"].dims if d not in ("direction", key)]
        stacked = ds.stack(curve=curve_dims) if curve_dims else ds.expand_dims(curve=[0])
        out["jumps"] = []
        for c in range(stacked.sizes["curve"]):
            for direction in ds["direction"].values:
                part = stacked.isel(curve=c).sel(direction=direction)
                flags = part["jump"].values.astype(bool)
                label = {d: float(part[d].values) for d in curve_dims}
                out["jumps"].append(dict(label, direction=str(direction),
                                         at=part[key].values[flags].tolist(),
                                         amplitude_max=float(np.nanmax(part["amplitude"]))))
    elif kind == "bifurcation":
        key = ds.attrs["swept_key"]
        vt = ds["vt"]
        spread = ((vt.max("kept") - vt.min("kept")) / np.abs(vt).max("kept")).values
        out["split_1e-6_at"] = ds[key].values[spread > 1e-6].tolist()
        out["period"] = dict(zip(map(float, ds[key].values), map(int, ds["period"].values)))
    elif kind == "basin":
        labels = ds["attractor"].values
        out["attractors"] = int(ds.attrs["attractors"])
        out["points_per_label"] = {str(int(k)): int((labels == k).sum()) for k in
                                   np.unique(labels)}
    return out


def main(argv=None) -> int:
    """``python -m tmafm.sweeps FILE [-o OUT.nc] [--workers N] [--plot PNG] [--progress]``.

    Exit status: 0 success; 2 any error (one line on stderr, nothing written: the extras the
    sweep needs and the size of its grid are checked before it runs); 130 on Ctrl-C (one line,
    nothing written).  argparse's own usage errors exit 2 too."""
    if argv is not None and (isinstance(argv, (str, bytes)) or not isinstance(argv, Sequence)
                             or not all(isinstance(a, str) for a in argv)):
        raise InputTypeError(f"argv = {shown(argv)}: must be a list of strings or None")
    parser = argparse.ArgumentParser(prog="python -m tmafm.sweeps",
                                     description="Run the sweep described by a &sweep file.")
    parser.add_argument("file", help="the sweep file (a &sweep namelist, docs/sweeps.md)")
    parser.add_argument("-o", "--output", help="the NetCDF file to write (default: &sweep "
                        "output, or FILE with .nc)")
    parser.add_argument("--workers", type=int, default=None, help="local threads (default: all)")
    parser.add_argument("--plot", default=None, help="the PNG to draw (default: OUTPUT.png)")
    parser.add_argument("--no-plot", action="store_true", help="write no plot")
    parser.add_argument("--progress", action="store_true", help="show a progress bar")
    parser.add_argument("--summarize", action="store_true", help="FILE is a sweep NetCDF file: "
                        "print its summary (jumps, attractors, periods) as JSON")
    args = parser.parse_args(argv)
    try:
        if args.summarize:
            import json
            print(json.dumps(summarize(read_dataset(args.file)), indent=1))
            return 0
        spec = read_sweep_file(args.file)
        out = Path(args.output or spec.get("output") or Path(args.file).with_suffix(".nc"))
        png = None if args.no_plot else Path(args.plot) if args.plot else out.with_suffix(".png")
        _check_targets(out, png, [Path(args.file), Path(spec["base"])])
        _check_extras(png is not None, args.progress)
        _check_file_size(spec)
        ds = run_sweep_file(args.file, workers=args.workers, progress=args.progress)
        # Both files are made in memory first, so a plot that fails writes no NetCDF file.
        from ._extras import netcdf_engine
        from ._safefile import write_bytes
        data = _netcdf_bytes(ds, netcdf_engine("python -m tmafm.sweeps"))
        picture = None
        if png is not None:
            from .sweepplots import render
            picture = render(ds, png.suffix)
        existed = os.path.lexists(out)
        write_bytes(out, data, "NetCDF file")
        print(f"wrote {out}")
        if picture is not None:
            try:
                write_bytes(png, picture, "plot file")
            except BaseException:
                if not existed and out.is_file():  # the NetCDF file this command created
                    out.unlink()
                raise
            print(f"wrote {png}")
    except TmafmError as exc:
        print(f"tmafm.sweeps: error: {exc}", file=sys.stderr)
        return 2
    except MemoryError:
        print("tmafm.sweeps: error: not enough memory for this sweep: give fewer points",
              file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("tmafm.sweeps: interrupted", file=sys.stderr)
        return 130
    return 0


def _check_extras(plot: bool, progress: bool) -> None:
    """Before the sweep runs: the modules it needs (xarray, a NetCDF writer, matplotlib for
    the plot, tqdm for --progress); MissingExtraError naming the extra otherwise."""
    from ._extras import netcdf_engine, require
    user = "python -m tmafm.sweeps"
    require("xarray", user)
    netcdf_engine(user)
    if plot:
        require("matplotlib", f"{user} (the plot; --no-plot writes none)")
    if progress:
        require("tqdm", f"{user} --progress")


def _netcdf_bytes(ds, engine: str) -> bytes:
    """The NetCDF file of a Dataset, as bytes (written in a private folder, then read)."""
    import tempfile
    with tempfile.TemporaryDirectory() as folder:
        scratch = Path(folder) / "sweep.nc"
        ds.to_netcdf(scratch, engine=engine)
        return scratch.read_bytes()


def _same_file(a: Path, b: Path) -> bool:
    """Whether two names are one file: the same inode if both exist, else the same absolute
    path."""
    try:
        return os.path.samefile(a, b)
    except OSError:
        return os.path.abspath(a) == os.path.abspath(b)


def _check_targets(out: Path, png, inputs) -> None:
    """Before the sweep runs: the NetCDF file and the plot are neither an input (the sweep
    file, its base) nor each other, so that nothing the run read is replaced."""
    for target, what in ((out, "the NetCDF file"), (png, "the plot")):
        if target is None:
            continue
        for source in inputs:
            if _same_file(target, source):
                raise InputFileError(f"{what} {shown(str(target))} is the input "
                                     f"{shown(str(source))}: give another name (-o, --plot)")
    if png is not None and _same_file(out, png):
        raise InputFileError(f"the NetCDF file and the plot are both {shown(str(out))}: give "
                             f"another name (-o, --plot)")


def _input_name(path, what: str) -> Path:
    """A file name (str or os.PathLike) as a Path; InputTypeError for anything else."""
    try:
        name = os.fspath(path)
        if not isinstance(name, str):
            raise TypeError
    except TypeError:
        raise InputTypeError(f"{what} name must be a str or an os.PathLike, not "
                             f"{type(path).__name__}") from None
    return Path(name)


def _check_dataset(ds, what: str):
    """`ds` if it is an xarray.Dataset; InputTypeError otherwise."""
    import xarray as xr
    if not isinstance(ds, xr.Dataset):
        raise InputTypeError(f"{what}: ds must be an xarray.Dataset (a sweep's result), not "
                             f"{type(ds).__name__}")
    return ds


def read_dataset(path):
    """A sweep NetCDF file, loaded into memory; InputFileError if it is missing, InputError if
    it is not a sweep dataset (what ``--summarize`` reads)."""
    from ._extras import require
    xr = require("xarray", "tmafm.sweeps.read_dataset")
    path = _input_name(path, "sweep dataset")
    try:
        is_file = path.is_file()
    except (OSError, ValueError):
        is_file = False
    if not is_file:
        raise InputFileError(f"sweep dataset {shown(str(path))} not found")
    try:
        with xr.open_dataset(path) as ds:
            ds = ds.load()
    except Exception as exc:  # the NetCDF back ends raise many kinds
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise InputError(f"{shown(str(path))}: not a readable NetCDF file: "
                         f"{shown(first)[1:-1]}") from None
    if "tmafm_kind" not in ds.attrs or "period" not in ds:
        raise InputError(f"{shown(str(path))}: not a tmafm sweep dataset (no tmafm_kind "
                         f"attribute or period variable)")
    return ds


def write_dataset(ds, path) -> Path:
    """Write a sweep Dataset to NetCDF as the executable writes its output: a new temporary
    file, synced and renamed (a device or FIFO is written directly); InputFileError if it
    cannot be written.  Nothing is left behind on a failure or a KeyboardInterrupt."""
    from ._extras import netcdf_engine
    from ._safefile import as_path, write_with
    _check_dataset(ds, "write_dataset")
    path = as_path(path, "NetCDF file")
    engine = netcdf_engine("tmafm.sweeps.write_dataset")
    return write_with(path, lambda name: ds.to_netcdf(name, engine=engine), what="NetCDF file")


if __name__ == "__main__":
    sys.exit(main())

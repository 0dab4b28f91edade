"""The runs of a sweep: one chunk of points observed by the core (the only calls into the
core's observers), and the picklable summary a sweep keeps of each run."""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence

import numpy as np

from .._run import Config
from ..errors import FailedRunWarning, SolverError, UnsteadyWarning
from ..observe import (_core_scales, computed_names, observable_groups, observe_batch,
                       observe_states)
from .points import _config


def _names(keywords: Mapping | None = None) -> tuple:
    """The steady observables a dataset carries: the core's list (tmafm.observe.OBSERVABLES),
    cut to those the keywords' ``observables`` compute."""
    selected = (keywords or {}).get("observables")
    return computed_names(observable_groups(selected))


def _summary(obs, keep: int = 0) -> dict:
    """The picklable part of an Observation a sweep keeps: steady values, period, states."""
    steady = obs.steady_values()
    names = [name for name in _names() if name in steady]
    out = {"steady": bool(obs.steady), "period": int(obs.period), "periods": int(obs.periods),
           "unsteady_reason": getattr(obs, "unsteady_reason", "") or "",
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
        for name in ("harmonic_amplitude", "harmonic_phase"):
            if name in physical:
                out["physical"][name] = np.asarray(physical[name], dtype=float).copy()
        out["drive_period_s"] = _drive_period(obs.config)
    return out


def _drive_period(config: Config) -> float:
    """The drive period of a &physical Config in s: 2 pi/Omega times the core's time scale."""
    return 2 * np.pi / float(config.scene["omega"]) * _core_scales(config)["time"]


def _run_chunk(base: dict, points: Sequence[Mapping], threads, keywords: Mapping,
               keep: int = 0, configs: Sequence[Config] | None = None) -> list[dict]:
    """Observe the points of one chunk with the core's batch; one summary per point.
    ``configs``, when given, are the points' validated Configs (same process only)."""
    if configs is None:
        configs = [_config(base, point) for point in points]
    try:
        observations = observe_batch(configs, threads=threads, warn=False, **keywords)
    except SolverError:
        # One run failed (the batch names the first): run the chunk's points one by one, so
        # every other point keeps its result and each failure is recorded with its message.
        return [_observe_one(config, keywords, keep) for config in configs]
    return [_summary(obs, keep) for obs in observations]


def _observe_one(config: Config, keywords: Mapping, keep: int = 0) -> dict:
    """The summary of one run, or a failed summary carrying the solver's message."""
    try:
        return _summary(observe_batch([config], threads=1, warn=False, **keywords)[0], keep)
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


def _basin_chunk(config, states, threads, keywords, attractors):
    """One chunk of basin runs (observe_states); a dict of arrays (picklable).  `config` is a
    Config in this process, or its dict of groups for another process (a Config holds a
    handle into this process's Fortran memory and must not be pickled)."""
    if not isinstance(config, Config):
        config = Config(config)
    out = observe_states(config, states, threads=threads, attractors=attractors, **keywords)
    return {"steady": out.steady, "physical": out.physical, "orbit": out.orbit,
            "periods": out.periods, "period": out.period, "attractor": out.attractor,
            "failed": out.failed, "first_failure": out.first_failure, "jitter": out.jitter}


def _basin_chunk_processes(args):
    return _basin_chunk(*args)


def _followed(config: Config, states: np.ndarray, keywords: Mapping):
    """The runs of a few states on one thread (observe_states): how a new attractor's orbit is
    followed further (attractors._new_attractors)."""
    return observe_states(config, states, threads=1, **keywords)


def _warn_unsteady(summaries, label: str, keywords: Mapping) -> None:
    """One tmafm.UnsteadyWarning for a whole sweep (not one per point): how many of its runs,
    asked to stop at a steady state, ended without one, and the first one's reason."""
    if not keywords.get("stop_at_steady", True):
        return
    reasons = [s.get("unsteady_reason") for s in summaries
               if s is not None and not s.get("steady") and "error" not in s]
    reasons = [r for r in reasons if r]
    if reasons:
        warnings.warn(f"{label}: {len(reasons)} of {len(summaries)} runs ended without a steady "
                      f"state (the dataset's period is 0 there); the first: {reasons[0]}",
                      UnsteadyWarning, stacklevel=3)


def _warn_failed(count: int, total: int, first: str, label: str, stacklevel: int = 3) -> None:
    """One tmafm.FailedRunWarning for a whole sweep whose runs failed (their points hold NaN,
    ``failed`` = 1): how many of its runs, and the first one's message."""
    if count:
        warnings.warn(f"{label}: {count} of {total} runs failed (the dataset's values are NaN "
                      f"and failed is 1 there); the first: {first}", FailedRunWarning,
                      stacklevel=stacklevel)


def _warn_failures(summaries, label: str) -> None:
    """_warn_failed for a list of summaries (None for a point not run)."""
    errors = [s["error"] for s in summaries if s is not None and "error" in s]
    _warn_failed(len(errors), len(summaries), errors[0] if errors else "", label, stacklevel=5)

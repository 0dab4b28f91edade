"""Attractors: periodic Poincaré orbits compared up to a cyclic shift and cut to their
minimal period by the core's steady-state rule, the labels of a basin map, and the new
attractors a chunk of basin runs found."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from ..observe import steady_test
from .runs import _followed


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
        further = _followed(run_config, orbit[-1:], refine)
        if further.failed[0] or further.period[0] != p:
            continue  # not a clean period-p orbit once followed further: use it for no run
        found.append(further.orbit[0, -p:].copy())
    return found

"""Per-drive-period observables computed by the core while it integrates (no trajectory kept).

``observe`` runs one input, ``observe_batch`` many (the core's OpenMP batch, GIL released).
Each period T = 2 pi/Omega, from tau = 0, gives the lock-in amplitude and phase of V_T, its
harmonics, the mean deflection, min and max V_T, each mode's max and min in and out of
contact, the peak normal force, the contact time and count,
the energy dissipated (beam damping, contact damping, friction), the drive work, the virial
and the Poincare point; the run may stop itself at a steady state.  docs/observables.md
defines every quantity, its units and its signs.

``observables=`` picks what a run computes (``OBSERVABLE_GROUPS``; all by default): a basin
map needs only the Poincare points, which are always computed, as are the contact time and
count.  ``observe_states`` runs one input from many initial states (a basin map) and may
stop each run at a known attractor.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from ._fortran import LIMITS, OBSERVABLE_TABLE, api, batch_t, polls
from ._namelist import _NOT_NUMBERS, shown
from ._checks import real_array
from ._run import Config, _for_core, _source
from .errors import InputError, InputTypeError, SolverError, UnsteadyWarning, raise_for

__all__ = ["Observation", "observe", "observe_batch", "observe_states", "StatesObservation",
           "OBSERVABLES", "OBSERVABLE_GROUPS", "UNITS", "PHYSICAL_UNITS", "CF_UNITS",
           "PHYSICAL_CF_UNITS", "physical_scales", "steady_period",
           "steady_test", "steady_harmonic", "unsteady_text", "observed_config", "DEFAULT_METHOD",
           "observable_groups"]

#: The core's observable table (tmafm._fortran.OBSERVABLE_TABLE), and its rows by name.
_TABLE = OBSERVABLE_TABLE
_ROW = {r["name"]: r for r in _TABLE}


def _indexed(kind: str) -> tuple[str, ...]:
    """The names of the core's rows of one kind, in their index order (1, 2, ...)."""
    rows = sorted((r for r in _TABLE if r["kind"] == kind), key=lambda r: r["index"])
    if [r["index"] for r in rows] != list(range(1, len(rows) + 1)):
        raise ImportError(f"tmafm: the core's {kind} observables are not indexed 1..{len(rows)}")
    return tuple(r["name"] for r in rows)


#: The per-period scalar observables, in the core's column order (tmafm_observers obs_*).
OBSERVABLES = _indexed("column")
#: Model units of each observable (d: the gap; tau: time in units of sqrt(m L^4/(E1 I)).
UNITS = {r["name"]: r["unit"] for r in _TABLE}
#: Located extrema of each mode per period (n_periods, N), in the core's ext_* column order.
MODAL_EXTREMA = _indexed("modal")
#: The groups of observables a run may compute (``observables=``), with their core bit
#: (tmafm_observers group_*).  contact_time, contacts_per_period and the Poincare points are
#: always computed.
OBSERVABLE_GROUPS = {g: tuple(r["name"] for r in _TABLE if r["group"] == g)
                     for g in dict.fromkeys(r["group"] for r in _TABLE if r["bit"])}
_GROUP_BITS = {r["group"]: r["bit"] for r in _TABLE if r["bit"]}
#: Always computed scalars, whatever ``observables`` asks (the Poincare points are too).
ALWAYS = tuple(name for name in OBSERVABLES if _ROW[name]["group"] == "always")
#: SI-derived units of ``Observation.physical`` (inputs given in &physical).
PHYSICAL_UNITS = {r["name"]: r["si_unit"] for r in _TABLE if r["si_unit"]}
#: Each SI-derived unit of the core's table as a ``units`` attribute (udunits/CF spelling, as
#: pint and pint-xarray read it): the sweeps' datasets of &physical inputs carry these.
CF_UNITS = {"nm": "nm", "deg": "degree", "us": "us", "nN": "nN", "aJ": "aJ", "1": "1"}
#: The ``units`` attribute of each observable of a &physical input (PHYSICAL_UNITS spelled as
#: CF_UNITS; a unit CF_UNITS does not know is kept as the core writes it).
PHYSICAL_CF_UNITS = {name: CF_UNITS.get(unit, unit) for name, unit in PHYSICAL_UNITS.items()}
#: The SI value of one of the core's SI-derived units (nm -> 1e-9 m, ...).
_SI_VALUE = {"nm": 1e-9, "us": 1e-6, "nN": 1e-9, "aJ": 1e-18}


#: The method an observed run (tmafm.observe, observe_batch, the sweeps) takes when its input
#: names none (docs/observables.md, "Which method"): located switches, exact free flights.
#: The packaged inputs name rk4_paper (the paper's scheme, for the figures) and keep it.
DEFAULT_METHOD = "flight_exact"

#: The steady test's reasons (tmafm_steady_state unsteady_*), by code.
_REASONS = {1: "short", 2: "no_repeat", 3: "not_distinct", 4: "settling"}


def _names_method(nml) -> bool:
    """Whether an input (path, packaged name, dict; a Config counts as naming its method) gives
    &solver method itself."""
    if isinstance(nml, Config):
        return True
    if isinstance(nml, Mapping):
        return any(str(g).lower() == "solver" and isinstance(v, Mapping)
                   and any(str(k).lower() == "method" for k in v) for g, v in nml.items())
    text = _source(nml, {})[0]
    if isinstance(text, bytes):
        text = text.decode("utf-8", "replace")
    codes = np.zeros(8 * len(text) + 64, dtype=np.int32)
    length, ierr, _ = api.namelist_syntax(_for_core(text), b"observe input", codes)
    if ierr or length < 0:
        return True  # Config reports the error; no default is put in
    fields, field, records = [], [], []
    for code in codes[:length]:
        if code == -1:
            fields.append("".join(map(chr, field)))
            field = []
        elif code == -2:
            records.append(fields)
            fields = []
        else:
            field.append(int(code))
    return any(r[1].lower() == "solver" and r[3].lower() == "method" for r in records)


def observed_config(nml, **overrides) -> Config:
    """The Config an observed run of ``nml`` (plus ``overrides``) integrates: DEFAULT_METHOD
    when neither names &solver method, else the input as given."""
    if isinstance(nml, Config) and not overrides:
        return nml
    solver = next((v for g, v in overrides.items() if str(g).lower() == "solver"), None)
    named = isinstance(solver, Mapping) and any(str(k).lower() == "method" for k in solver)
    if not named and not _names_method(nml):
        overrides = dict(overrides)
        key = next((g for g in overrides if str(g).lower() == "solver"), "solver")
        overrides[key] = {**(overrides.get(key) or {}), "method": DEFAULT_METHOD}
    return Config(nml, **overrides)


def physical_scales(config) -> dict | None:
    """The core's scales of a &physical input (tmafm_units scales_t, through its observable
    table): {'length': m per gap unit d, 'time': s per tau, 'force': N per E1 I/L^2, 'energy':
    J per E1 I d^2/L^3}; None for a dimensionless input.  Python computes no scale: each is the
    core's factor to an SI-derived unit times that unit's SI value (nm = 1e-9 m, ...)."""
    config = config if isinstance(config, Config) else Config(config)
    if "physical" not in config.to_dict():
        return None
    return _core_scales(config)


def _core_scales(config: Config) -> dict:
    """physical_scales of a Config known to be &physical (no check)."""
    factors = np.zeros(len(_TABLE))
    ierr, errmsg = api.observable_table_factors(config._f, factors)
    raise_for(int(ierr), _message(errmsg))
    out = {}
    for row, factor in zip(_TABLE, factors):
        if row["scale"] in ("length", "time", "force", "energy") and row["scale"] not in out:
            out[row["scale"]] = float(factor) * _SI_VALUE[row["si_unit"]]
    return out


def _message(errmsg) -> str:
    """A blank-padded message of the core as a str."""
    return (errmsg.decode("utf-8", "replace") if isinstance(errmsg, bytes) else str(errmsg)).strip()


def unsteady_text(reason: int, periods: int, evidence=None, repeats: int | None = None) -> str:
    """The reason an observed run has no steady state, as a sentence ('' when steady).
    ``evidence``: [reason, closest repeat, its lag, tolerance, jitter level] (relative to the
    orbit's size), as the core reports them."""
    if reason == 0:
        return ""
    if reason == 1:
        return (f"too few periods: {periods} cannot confirm a period with steady_repeats = "
                f"{repeats}" if repeats else f"too few periods ({periods}) to confirm a period")
    closest = lag = tol = jitter = None
    if evidence is not None:
        _, closest, lag, tol, jitter = (float(x) for x in evidence)
    if reason == 3:
        return (f"after {periods} periods the points repeat but are not distinct (a decaying "
                f"flip transient)")
    if reason == 4:
        return (f"after {periods} periods the points repeat within the method's jitter level "
                f"({jitter:.2e} of the orbit's size) but were still approaching the orbit")
    text = f"no repeat within tol after {periods} periods"
    if closest is not None and np.isfinite(closest):
        text += (f": the closest repeat (every {int(lag)} period{'s' if lag != 1 else ''}) is "
                 f"{closest:.2e} of the orbit's size, above ")
        text += (f"the method's jitter level {jitter:.2e}" if jitter and jitter > tol
                 else f"the tolerance {tol:.2e}")
    return text


@dataclass
class Observation:
    """The observables of one run, one entry per drive period (see docs/observables.md).
    ``unsteady_reason`` says why no steady state was found ('' when ``steady``); ``evidence``
    holds the steady test's numbers (closest repeat, its lag, the tolerance and the method's
    jitter level, relative to the orbit's size)."""

    periods: int
    period: int
    steady: bool
    per_period: dict
    poincare: np.ndarray
    final_state: np.ndarray
    units: dict = field(default_factory=lambda: dict(UNITS))
    physical: dict | None = None
    physical_units: dict = field(default_factory=lambda: dict(PHYSICAL_UNITS))
    config: Config | None = field(default=None, repr=False)
    unsteady_reason: str = ""
    evidence: dict = field(default_factory=dict)
    steady_harmonics: tuple | None = field(default=None, repr=False)

    def steady_values(self, physical: bool = False) -> dict:
        """Each observable averaged over the last found period (p periods); when none was
        found, over the last q periods, q the lag of the closest repeat (``evidence
        ['closest_lag']``, the best candidate for the orbit's period; 1 when there is none):
        the run's ``period`` is then 0 and ``unsteady_reason`` says why.  Floats, and arrays
        (one per harmonic) for the harmonics.
        Amplitude and phase (and the harmonics) are the core's steady harmonic: the harmonic of
        V_T over those periods, its phase free of the +-180 wrap (docs/observables.md).
        ``physical=True`` averages the SI-derived values instead."""
        source = self.physical if physical else self.per_period
        if source is None:
            raise InputError("this Observation has no physical units (the input did not give "
                             "&physical)")
        last = self.period if self.period > 0 else max(int(self.evidence.get("closest_lag", 1) or 1), 1)
        last = min(last, max(len(self.poincare) - 1, 1))
        out = {}
        for name, values in source.items():
            mean = np.mean(values[-last:], axis=0)
            out[name] = float(mean) if np.ndim(mean) == 0 else mean
        if self.steady_harmonics is not None and "harmonic_amplitude" in out:
            amplitude, phase, length = self.steady_harmonics
            factor = length if physical else 1.0
            out["harmonic_amplitude"] = amplitude * factor
            out["harmonic_phase"] = phase.copy()
            out["amplitude"] = float(amplitude[0] * factor)
            out["phase"] = float(phase[0])
        # Each drive tone's lock-in: the harmonic over those periods, as the core's steady values
        # (observe_states) take it: mean A cos(phi), mean A sin(phi), free of the +-180 wrap.
        for k in (1, 2):
            amp, ph = f"tone{k}_amplitude", f"tone{k}_phase"
            if amp in source and ph in source:
                a, p = np.asarray(source[amp][-last:]), np.radians(np.asarray(source[ph][-last:]))
                s, c = np.sum(a * np.cos(p)) / a.size, np.sum(a * np.sin(p)) / a.size
                out[amp], out[ph] = float(np.hypot(s, c)), float(np.degrees(np.arctan2(c, s)))
        # A general drive (a second tone, or a drive phase: docs/model.md §15): amplitude and
        # phase are tone 1's lock-in, as the core's per-period and steady values take them.
        scene = self.config.scene if self.config is not None else {}
        general = scene.get("alpha2_2", 0.0) != 0 or scene.get("drive_phase", 0.0) != 0
        if general and "tone1_amplitude" in out and "amplitude" in out:
            out["amplitude"], out["phase"] = out["tone1_amplitude"], out["tone1_phase"]
        return out


def observable_groups(observables) -> tuple[str, ...]:
    """The groups (OBSERVABLE_GROUPS keys, in their order) that compute ``observables``: None
    for all; otherwise group names or observable names (a name selects its whole group; the
    always-computed ones and 'poincare' select none).  InputError for an unknown name."""
    if observables is None:
        return tuple(OBSERVABLE_GROUPS)
    if isinstance(observables, str):
        observables = (observables,)
    try:
        names = list(observables)
    except TypeError:
        raise InputTypeError(f"observables = {shown(observables)}: must be None or a sequence of "
                             f"names") from None
    chosen = set()
    for name in names:
        if not isinstance(name, str):
            raise InputTypeError(f"observables: {shown(name)} is not a name")
        if name in OBSERVABLE_GROUPS:
            chosen.add(name)
            continue
        owner = [g for g, members in OBSERVABLE_GROUPS.items() if name in members]
        if owner:
            chosen.add(owner[0])
        elif name not in ALWAYS + ("poincare",):
            raise InputError(f"observables: unknown name {shown(name)} (groups: "
                             f"{', '.join(OBSERVABLE_GROUPS)}; or an observable: "
                             f"{', '.join(OBSERVABLES)})")
    return tuple(g for g in OBSERVABLE_GROUPS if g in chosen)


def _group_bits(groups) -> int:
    return sum(_GROUP_BITS[g] for g in groups)


def computed_names(groups) -> tuple[str, ...]:
    """The scalar observables (OBSERVABLES order) that the groups compute."""
    members = set(ALWAYS).union(*(OBSERVABLE_GROUPS[g] for g in groups))
    return tuple(name for name in OBSERVABLES if name in members)


def _options(max_periods, p_max, steady_tol, steady_repeats, harmonics, stop_at_steady):
    checked = {}
    for name, value, most in (("max_periods", max_periods, LIMITS["max_observed_periods"]),
                              ("p_max", p_max, LIMITS["max_p_max"]),
                              ("steady_repeats", steady_repeats, LIMITS["max_observed_periods"]),
                              ("harmonics", harmonics, LIMITS["max_harmonics"])):
        if isinstance(value, _NOT_NUMBERS) or not isinstance(value, (int, np.integer)):
            raise InputTypeError(f"observe {name} = {shown(value)}: must be an integer")
        if not 1 <= value <= most:
            raise InputError(f"observe {name} = {value}: must be 1 to {most}")
        checked[name] = int(value)
    if isinstance(steady_tol, bool) or not isinstance(steady_tol, (int, float, np.floating)):
        raise InputTypeError(f"observe steady_tol = {shown(steady_tol)}: must be a number")
    if not 0 < steady_tol < 1:
        raise InputError(f"observe steady_tol = {steady_tol}: must be > 0 and < 1")
    if not isinstance(stop_at_steady, (bool, np.bool_)):
        raise InputTypeError(f"observe stop_at_steady = {shown(stop_at_steady)}: must be True or False")
    checked["steady_tol"] = float(steady_tol)
    checked["stop_at_steady"] = bool(stop_at_steady)
    return checked


#: Most OpenMP threads a batch takes: libgomp crashed the interpreter (SIGSEGV) when asked for
#: 100000 (tests/test_api_hostile.py).
MAX_THREADS = 1024


def _threads(threads, what: str, items: int) -> int:
    """The OpenMP thread count for the core (0: the OpenMP default), at most one per item."""
    if threads is None:
        return 0
    if isinstance(threads, _NOT_NUMBERS) or not isinstance(threads, (int, np.integer)) \
            or not 1 <= threads <= MAX_THREADS:
        raise InputError(f"{what} threads = {shown(threads)}: must be an integer from 1 to "
                         f"{MAX_THREADS}, or None")
    return max(1, min(int(threads), items))


def _no_memory(exc: MemoryError, opts: dict) -> SolverError:
    return SolverError(f"not enough memory for max_periods = {opts['max_periods']}, harmonics = "
                       f"{opts['harmonics']}, p_max = {opts['p_max']}: lower them ({exc})")


def observe_batch(configs: Sequence, *, threads: int | None = None, max_periods: int = 100,
                  p_max: int = 8, steady_tol: float = 1e-6, steady_repeats: int = 3,
                  harmonics: int = 3, stop_at_steady: bool = True,
                  observables=None, warn: bool = True) -> list[Observation]:
    """Observe every input of ``configs`` (paths, packaged names, dicts or tmafm.Config) with the
    core's OpenMP batch, the GIL released; ``threads=None`` takes the OpenMP default.
    ``observables`` (None: all) selects the groups computed (OBSERVABLE_GROUPS); per_period
    then holds only the observables computed.  Results do not depend on the number of
    threads.  An input that names no &solver method runs DEFAULT_METHOD (flight_exact).  The
    steady test follows the method (docs/observables.md, "Steady state"); a run asked to stop
    at a steady state that ends without one warns (tmafm.UnsteadyWarning; ``warn=False``: the
    caller reports it, as the sweeps do once per sweep) and says why
    (Observation.unsteady_reason)."""
    opts = _options(max_periods, p_max, steady_tol, steady_repeats, harmonics, stop_at_steady)
    groups = observable_groups(observables)
    if not isinstance(warn, (bool, np.bool_)):
        raise InputTypeError(f"observe_batch warn = {shown(warn)}: must be True or False")
    if isinstance(configs, (str, bytes, os.PathLike, Mapping, Config)) \
            or not hasattr(configs, "__iter__"):
        raise InputTypeError(f"observe_batch takes a list of inputs, not {shown(configs)}; use "
                             f"tmafm.observe for one")
    configs = [observed_config(c) for c in configs]
    threads = _threads(threads, "observe_batch", len(configs))
    if not configs:
        return []
    # The Configs' config_t handles are copied into the batch as they are: no text, no parse.
    batch = batch_t()
    for c in configs:
        api.batch_add(batch, c._f)
    n_modes = np.array([c.n_modes for c in configs], dtype=np.int32)
    n, n_state, m, h = len(configs), 2 * int(n_modes.max()), opts["max_periods"], opts["harmonics"]
    try:
        values = np.zeros((n, m, len(OBSERVABLES)), order="F")
        harm_amp = np.zeros((n, m, h), order="F")
        harm_phase = np.zeros((n, m, h), order="F")
        poincare = np.zeros((n, m + 1, n_state), order="F")
        max_gap = np.zeros((n, m), order="F")
        modal = np.zeros((n, m, n_state // 2, 4), order="F")
        n_periods, found, has_scales, ierr = (np.zeros(n, dtype=np.int32) for _ in range(4))
        factors = np.zeros((n, len(OBSERVABLES)), order="F")
        steady_amp = np.zeros((n, h), order="F")
        steady_phase = np.zeros((n, h), order="F")
        evidence = np.zeros((n, 5), order="F")
        code, errmsg = api.batch_run(
            batch, m, h, opts["p_max"], opts["steady_tol"], opts["steady_repeats"],
            opts["stop_at_steady"], _group_bits(groups), threads, polls(), values, harm_amp,
            harm_phase, poincare, max_gap, modal, n_periods, found, factors, has_scales, steady_amp,
            steady_phase, evidence, ierr)
    except MemoryError as exc:
        raise _no_memory(exc, opts) from None
    if code:
        raise_for(int(code), _message(errmsg))
    bad = np.flatnonzero(ierr)
    if bad.size:
        k = int(bad[0])
        raise_for(int(ierr[k]), f"{configs[k].label}: {_message(errmsg)}")
    out = []
    columns = [(j, name) for j, name in enumerate(OBSERVABLES) if name in computed_names(groups)]
    for k, config in enumerate(configs):
        m = int(n_periods[k])
        s = 2 * int(n_modes[k])
        per = {name: values[k, :m, j].copy() for j, name in columns}
        if "lockin" in groups:
            per["harmonic_amplitude"] = harm_amp[k, :m, :].copy()
            per["harmonic_phase"] = harm_phase[k, :m, :].copy()
        if "extrema" in groups:
            per["max_gap"] = max_gap[k, :m].copy()
            for j, name in enumerate(MODAL_EXTREMA):
                per[name] = modal[k, :m, :n_modes[k], j].copy()
        physical = None
        if has_scales[k]:
            physical = {name: per[name] * factors[k, j] for j, name in columns}
            if "lockin" in groups:
                physical["harmonic_amplitude"] = per["harmonic_amplitude"] * factors[k, 0]
                physical["harmonic_phase"] = per["harmonic_phase"].copy()
            for name in ("max_gap",) + MODAL_EXTREMA:
                if name in per:
                    physical[name] = per[name] * factors[k, 0]
        points = poincare[k, :m + 1, :s].copy()
        reason = int(round(evidence[k, 0]))
        text = unsteady_text(reason, m, evidence[k], opts["steady_repeats"])
        out.append(Observation(
            periods=m, period=int(found[k]), steady=bool(found[k] > 0), per_period=per,
            poincare=points, final_state=points[-1].copy(), physical=physical, config=config,
            unsteady_reason=text,
            evidence={"reason": _REASONS.get(reason, "steady"), "closest": float(evidence[k, 1]),
                      "closest_lag": int(evidence[k, 2]), "tol": float(evidence[k, 3]),
                      "jitter": float(evidence[k, 4])},
            steady_harmonics=(steady_amp[k].copy(), steady_phase[k].copy(), float(factors[k, 0]))
            if "lockin" in groups else None))
        if warn and found[k] == 0 and opts["stop_at_steady"]:
            warnings.warn(f"{config.label}: {text}", UnsteadyWarning, stacklevel=3)
    return out


def observe(nml, *, max_periods: int = 100, p_max: int = 8, steady_tol: float = 1e-6,
            steady_repeats: int = 3, harmonics: int = 3, stop_at_steady: bool = True,
            observables=None, **overrides) -> Observation:
    """Observe one input (a path, a packaged name, a dict or a tmafm.Config, plus ``overrides``
    of groups as in tmafm.run); see observe_batch."""
    config = observed_config(nml, **overrides)
    return observe_batch([config], threads=1, max_periods=max_periods, p_max=p_max,
                         steady_tol=steady_tol, steady_repeats=steady_repeats,
                         harmonics=harmonics, stop_at_steady=stop_at_steady,
                         observables=observables)[0]


@dataclass
class StatesObservation:
    """The runs of ``observe_states``, one row per initial state: ``steady`` ({name: (n,)}
    steady values of the observables computed; ``harmonic_amplitude``/``harmonic_phase``
    (n, harmonics) with lockin), ``orbit`` (n, p_max, 2N: the last p_max Poincare points, the
    final state last, NaN before the first), ``periods``, ``period`` (0: none found),
    ``attractor`` (the known attractor matched, 0-based; -1: none), ``failed`` (bool) and the
    first failure's message; ``reason`` (n,): why no period was found (0: found; codes of
    tmafm_steady_state unsteady_*: 1 too few periods, 2 no repeat within tol, 3 points not
    distinct, 4 still approaching within the method's jitter); ``jitter`` (n,): the method's
    jitter level at the last point (absolute; 0 for a located method)."""

    steady: dict
    orbit: np.ndarray
    periods: np.ndarray
    period: np.ndarray
    attractor: np.ndarray
    failed: np.ndarray
    first_failure: str = ""
    physical: dict | None = None
    reason: np.ndarray | None = None
    jitter: np.ndarray | None = None


def observe_states(config, states, *, threads: int | None = None, max_periods: int = 100,
                   p_max: int = 8, steady_tol: float = 1e-6, steady_repeats: int = 3,
                   harmonics: int = 3, stop_at_steady: bool = True, observables=None,
                   attractors: Sequence = (), confirm: int | None = None,
                   capture: float | None = None) -> StatesObservation:
    """Observe one input from many initial states (rows of ``states``: [a0, adot0], 2N each)
    with the core's OpenMP batch; the input is read and its model built once.  ``attractors``
    (orbits, each p x 2N, points in order): a run whose Poincare points come within
    ``capture`` (default steady_tol; relative to the orbit's size) of orbit k's points, in
    order, each closer than the one before, ``confirm`` times in a row (default
    steady_repeats) is labelled k and stopped (docs/sweeps.md).
    A run that fails (SolverError) is marked ``failed`` (NaN values); a bad input, option or
    state raises InputError before any run."""
    opts = _options(max_periods, p_max, steady_tol, steady_repeats, harmonics, stop_at_steady)
    groups = observable_groups(observables)
    config = config if isinstance(config, Config) else Config(config)
    n = config.n_modes
    try:
        states = np.asarray(states, dtype=float)
    except (TypeError, ValueError, OverflowError) as exc:
        raise InputError(f"observe_states states: must be real numbers ({shown(str(exc))[1:-1]})") \
            from None
    if states.ndim != 2 or states.shape[1] != 2 * n:
        raise InputError(f"observe_states states: shape {states.shape}, must be (points, {2 * n})")
    confirm = opts["steady_repeats"] if confirm is None else confirm
    if isinstance(confirm, _NOT_NUMBERS) or not isinstance(confirm, (int, np.integer)) \
            or not 1 <= confirm <= 10_000_000:
        raise InputTypeError(f"observe_states confirm = {shown(confirm)}: must be an integer from 1 "
                             f"to 10000000")
    capture = opts["steady_tol"] if capture is None else capture
    if isinstance(capture, bool) or not isinstance(capture, (int, float, np.floating)) \
            or not 0 < capture < 1:
        raise InputError(f"observe_states capture = {shown(capture)}: must be a number > 0 and < 1")
    try:
        orbits = [np.asarray(o, dtype=float).reshape(-1, 2 * n) for o in attractors]
    except (TypeError, ValueError, OverflowError) as exc:
        raise InputError(f"observe_states attractors: each must be points x {2 * n} real numbers "
                         f"({shown(str(exc))[1:-1]})") from None
    if orbits:
        points = np.asfortranarray(np.concatenate(orbits).T)
        first = np.cumsum([1] + [len(o) for o in orbits]).astype(np.int32)
    else:
        points = np.zeros((2 * n, 1), order="F")
        first = np.ones(1, dtype=np.int32)
    threads = _threads(threads, "observe_states", len(states))
    n_points, h = len(states), opts["harmonics"]
    try:
        steady = np.zeros((n_points, len(OBSERVABLES)), order="F")
        harm_amp = np.zeros((n_points, h), order="F")
        harm_phase = np.zeros((n_points, h), order="F")
        orbit = np.zeros((n_points, opts["p_max"], 2 * n), order="F")
        n_periods, found, matched, run_ierr, reason = (np.zeros(n_points, dtype=np.int32)
                                                       for _ in range(5))
        factors = np.zeros(len(OBSERVABLES))
        jitter = np.zeros(n_points)
        has_scales, ierr, errmsg = api.observe_states_of(
            config._f, np.asfortranarray(states), opts["max_periods"], h, opts["p_max"],
            opts["steady_tol"], opts["steady_repeats"], opts["stop_at_steady"], _group_bits(groups),
            points, first, int(confirm), float(capture), threads, polls(), steady, harm_amp,
            harm_phase, orbit, n_periods, found, matched, factors, run_ierr, reason, jitter)
    except MemoryError as exc:
        raise _no_memory(exc, opts) from None
    message = _message(errmsg)
    if ierr:
        raise_for(int(ierr), f"{config.label}: {message}")
    failed = run_ierr != 0
    names = computed_names(groups)
    values = {name: steady[:, j] for j, name in enumerate(OBSERVABLES) if name in names}
    if "lockin" in groups:
        values["harmonic_amplitude"] = harm_amp
        values["harmonic_phase"] = harm_phase
    physical = None
    if has_scales:
        physical = {name: steady[:, j] * factors[j] for j, name in enumerate(OBSERVABLES)
                    if name in names}
    return StatesObservation(steady=values, orbit=orbit, periods=n_periods, period=found,
                             attractor=matched.astype(np.int32) - 1, failed=failed,
                             first_failure=message if failed.any() else "",
                             physical=physical, reason=reason, jitter=jitter)


def steady_test(points, p_max: int = 8, tol: float = 1e-6, repeats: int = 3, floor=None,
                scale: float | None = None) -> dict:
    """The core's steady-state test (tmafm_steady_state steady_test, the one rule) on a sequence
    of points (rows): the smallest period p <= p_max whose last ``repeats`` points repeat within
    max(tol * size, floor) (size: the orbit's, or ``scale``; ``floor``: an absolute jitter
    level per point) and whose p points are distinct.  {'period' (0: none), 'reason'
    ('steady', 'short', 'no_repeat', 'not_distinct', 'settling'), 'closest' (the closest
    repeat relative to the size), 'closest_lag', 'steps' ({lag: largest step relative to the
    size} over the last ``repeats`` points, the evidence)}."""
    for name, value in (("p_max", p_max), ("repeats", repeats)):
        if isinstance(value, _NOT_NUMBERS) or not isinstance(value, (int, np.integer)) \
                or not 1 <= value <= 10_000_000:
            raise InputTypeError(f"steady_test {name} = {shown(value)}: must be an integer from "
                                 f"1 to 10000000")
    if isinstance(tol, (bool, np.bool_)) or not isinstance(tol, (int, float, np.floating)) \
            or not 0 < tol < 1:
        raise InputError(f"steady_test tol = {shown(tol)}: must be a number > 0 and < 1")
    points = real_array("steady_test", "points", points, (1, 2))
    if points.ndim == 1:
        points = points[:, None]
    if floor is None:
        floor = np.zeros(len(points))
    else:
        floor = real_array("steady_test", "floor", floor, (0, 1))
        if floor.ndim == 1 and floor.shape != (len(points),):
            raise InputError(f"steady_test floor has {floor.size} values for {len(points)} points")
        if np.any(floor < 0):
            raise InputError("steady_test floor must be >= 0")
        floor = np.broadcast_to(floor, (len(points),)).copy()
    if scale is not None:
        scale = float(real_array("steady_test", "scale", scale, 0))
        if not scale > 0:
            raise InputError(f"steady_test scale = {shown(scale)}: must be > 0")
    steps = np.zeros(int(p_max))
    period, reason, closest, lag, ierr, errmsg = api.steady_test_of(
        np.asfortranarray(points), int(p_max), float(tol), int(repeats), floor,
        -1.0 if scale is None else scale, steps)
    raise_for(int(ierr), _message(errmsg))
    return {"period": int(period), "reason": _REASONS.get(int(reason), "steady"),
            "closest": float(closest), "closest_lag": int(lag),
            "steps": {p + 1: float(x) for p, x in enumerate(steps) if x >= 0}}


def steady_period(points, p_max: int = 8, tol: float = 1e-6, repeats: int = 3) -> int:
    """The core's steady-state classifier on a sequence of points (rows): the smallest period
    p <= p_max whose last ``repeats`` points repeat within tol (relative to the orbit's size)."""
    return steady_test(points, p_max, tol, repeats)["period"]


def steady_harmonic(amplitude, phase) -> tuple[float, float]:
    """The core's steady harmonic of an orbit (tmafm_steady_state steady_harmonic): from its
    per-period amplitudes and phases (degrees), the harmonic of V_T over the orbit's periods,
    (amplitude, phase in degrees, in (-180, 180])."""
    amplitude = np.atleast_1d(np.asarray(amplitude, dtype=float))
    phase = np.atleast_1d(np.asarray(phase, dtype=float))
    if amplitude.shape != phase.shape or amplitude.ndim != 1 or amplitude.size == 0:
        raise InputError("steady_harmonic: amplitude and phase must be 1-D of one nonzero length")
    a, p, ierr, errmsg = api.steady_harmonic_of(amplitude, phase)
    raise_for(int(ierr), _message(errmsg))
    return float(a), float(p)

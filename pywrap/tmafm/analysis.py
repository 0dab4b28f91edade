"""Analysis of a run, as the paper reads its figures: steady state, period, modal amplitudes
in and out of contact, per-period contact measures and dissipation, and the harmonics of V_T.

Everything works on a :class:`tmafm.Result`.  Array work is numpy; what needs the model
(contact forces, powers, modal energy) comes from the Fortran core (``tmafm.Model``),
so no physics is written here.  The per-period measures the core observes itself
(``tmafm.observe``: contact time and count, min and max V_T, each mode's max and min in and
out of contact, dissipation, lock-in amplitude and phase, harmonics) are taken from it, exact to
the trajectory's accuracy: the run's own input
is integrated again over its whole drive periods, without samples (``observation``).  Only a
Result the core cannot re-run (no input, a synthetic one, or ``rk4_event``) falls back to its
samples.

Definitions used throughout:

* ``since`` (where a measure starts) defaults to the first sample: tau = 0, or the start of
  the run's output window (``&output sample_from``, ``last_periods``), whose Poincare
  sections are the run's own period boundaries inside the window;
* drive period T = 2 pi / Omega; Poincare sections are the states at tau = k T, which needs
  ``sample_dtau = T / m`` for a whole number m (``sample_dtau_for``);
* a section distance is the max-norm of the state difference, each component scaled by its
  range over the samples of the run after `since` (the size of the motion, not of the
  sections, which shrinks to zero on a periodic orbit);
* the period is the core's steady-state rule (tmafm_steady_state, as the observed runs use it:
  ``classify_sections``) on those scaled distances; its default tolerance follows the
  integrator (``default_tolerance``): the paper's scheme repeats itself only to its
  first-order error, the located methods to their tolerance;
* lock-in amplitude and phase over several periods are the core's steady harmonic (the
  harmonic over those periods, free of the +-180 wrap);
* "amplitude" of a mode over a set of samples: both ``max |a_j|`` and the half peak-to-peak
  ``(max a_j - min a_j)/2``.
"""

from __future__ import annotations

import math

import numpy as np

from ._model import POWER_NAMES, Model
from ._checks import real_array
from ._namelist import _NOT_NUMBERS, shown
from ._run import Config, Result
from .errors import InputError, InputTypeError

__all__ = ["observation", "drive_period", "sample_dtau_for", "poincare_sections", "section_distances",
           "default_tolerance", "state_scale",
           "classify_sections", "classify_period", "steady_state", "modal_amplitudes", "vt_max",
           "energy_flow", "per_period", "energy_balance", "lockin", "harmonics", "summary",
           "deflection_psd", "POWER_NAMES"]



#: Harmonics the core computes for the analysis (``harmonics`` asks for more if needed).
_CORE_HARMONICS = 10


# Arguments: a wrong type or value is a typed tmafm error naming it, before any work.

def _result(result, what: str):
    if not isinstance(result, Result):
        raise InputTypeError(f"{what}: result must be a tmafm.Result, not {type(result).__name__}")
    return result


def _real(what: str, name: str, value, optional: bool = False, positive: bool = False):
    """A finite real number (None too when optional); InputError otherwise."""
    if value is None and optional:
        return None
    ok = not isinstance(value, _NOT_NUMBERS) and isinstance(value, (int, float, np.integer,
                                                                          np.floating))
    try:
        ok = ok and math.isfinite(float(value)) and (not positive or float(value) > 0)
    except OverflowError:
        ok = False
    if not ok:
        raise InputError(f"{what}: {name} = {shown(value)}: must be a finite number"
                         + (" > 0" if positive else "") + (" or None" if optional else ""))
    return float(value)


def _scale(what: str, scale, sections: np.ndarray) -> np.ndarray:
    """A scale per state component: finite numbers > 0, one per column of the sections."""
    scale = real_array(what, "scale", scale, 1)
    if scale.shape != sections.shape[1:] or not np.all(scale > 0):
        raise InputError(f"{what}: scale must be {sections.shape[1]} numbers > 0, one per state "
                         f"component, got shape {scale.shape}")
    return scale


def _since(what: str, result, since) -> float:
    """A time within the run's samples (None: the first sample, tau = 0 unless the run kept an
    output window); InputError otherwise."""
    if since is None:
        return float(result.tau[0]) if np.size(result.tau) else 0.0
    since = _real(what, "since", since)
    start, end = (float(result.tau[0]), float(result.tau[-1])) if np.size(result.tau) else (0, 0)
    if not start <= since <= end:
        raise InputError(f"{what}: since = {since:g}: must lie within the run's samples, "
                         f"{start:g} <= tau <= {end:g}")
    return since


def _count(what: str, name: str, value, optional: bool = False, low: int = 1) -> int | None:
    """An integer from `low` to 10**7 (None too when optional); InputError otherwise."""
    if value is None and optional:
        return None
    if isinstance(value, _NOT_NUMBERS) or not isinstance(value, (int, np.integer)) \
            or not low <= value <= 10_000_000:
        raise InputError(f"{what}: {name} = {shown(value)}: must be an integer from {low} to "
                         f"10000000" + (" or None" if optional else ""))
    return int(value)


def observation(result, harmonics: int = _CORE_HARMONICS):
    """The core's per-period observables (a tmafm.Observation) of the run behind `result`: its
    input (method, tolerances, initial state) integrated again over the run's whole drive
    periods.  None when the core cannot re-run it (no input, a synthetic Result, rk4_event)."""
    _result(result, "observation")
    harmonics = _count("observation", "harmonics", harmonics)
    cache = result.__dict__.setdefault("_observations", {})
    for count, obs in cache.items():
        if count >= harmonics:
            return obs
    config = getattr(result, "config", None)
    if config is None:
        try:
            groups = {g: dict(v) for g, v in result.resolved.todict(complex_tuple=False).items()
                      if not g.startswith("_")}
        except AttributeError:
            return None
        if "model" not in groups or not ({"scene", "physical"} & set(groups)):
            return None
        config = _model_of(result).config
    if config.to_dict()["solver"]["method"] == "rk4_event":
        return None
    periods = int(math.floor(result.tau[-1] / drive_period(result) + 1e-9))
    if periods < 1:
        return None
    from .observe import observe
    obs = observe(config, max_periods=periods, stop_at_steady=False, harmonics=harmonics)
    cache[harmonics] = obs
    return obs


def drive_period(result) -> float:
    """T = 2 pi / Omega of the run."""
    _result(result, "drive_period")
    return 2 * math.pi / result.scene["omega"]


def sample_dtau_for(omega: float, per_period: int = 200) -> float:
    """The output interval that puts `per_period` samples in each drive period."""
    omega = _real("sample_dtau_for", "omega", omega, positive=True)
    per_period = _count("sample_dtau_for", "per_period", per_period)
    return 2 * math.pi / omega / per_period


def _stride(result) -> int:
    dt = result.tau[1] - result.tau[0]
    ratio = drive_period(result) / dt
    stride = int(round(ratio))
    if stride < 2 or abs(ratio - stride) > 1e-6 * ratio:
        raise InputError(f"sample_dtau = {dt!r} does not divide the drive period "
                         f"{drive_period(result)!r}: use sample_dtau_for(omega, m)")
    return stride


def _offset(result) -> int:
    """The run's index of the first sample, tau[0] = offset * sample_dtau: 0, or the first
    sample of an output window (``&output sample_from``, ``last_periods``)."""
    if result.tau.size < 2:
        return 0
    return int(round(result.tau[0] / (result.tau[1] - result.tau[0])))


def _first_period_sample(result, since: float, stride: int) -> int:
    """The index into the samples of the first whole period boundary at or after `since` and
    at or after the first sample (an output window may start inside a period)."""
    offset = _offset(result)
    period = max(int(math.ceil(since / drive_period(result) - 1e-9)), -(-offset // stride))
    return period * stride - offset


def poincare_sections(result) -> tuple[np.ndarray, np.ndarray]:
    """Times k T and states (a, adot) at every whole drive period of the run's samples (of
    an output window: its period boundaries)."""
    _result(result, "poincare_sections")
    stride = _stride(result)
    index = np.arange(_first_period_sample(result, 0.0, stride), result.tau.size, stride)
    return result.tau[index], np.hstack([result.a[index], result.adot[index]])


def state_scale(result, since: float | None = None) -> np.ndarray:
    """Range of each state component (a, adot) over the samples after `since`."""
    _result(result, "state_scale")
    since = _since("state_scale", result, since)
    keep = result.tau >= since
    states = np.hstack([result.a[keep], result.adot[keep]])
    scale = np.ptp(states, axis=0)
    scale[scale == 0] = 1.0
    return scale


def default_tolerance(result) -> float:
    """A section-distance tolerance above the integrator's own error: 2e-3 (dtau/2e-3) for
    rk4_paper (first order), 1e-5 (dtau/2e-3)^4 for rk4_event, 1e3 rtol for the adaptive
    methods; never below 1e-9."""
    _result(result, "default_tolerance")
    solver = result.resolved["solver"]
    method = solver["method"]
    if method == "rk4_paper":
        tol = 2e-3 * solver["dtau"] / 2e-3
    elif method == "rk4_event":
        tol = 1e-5 * (solver["dtau"] / 2e-3) ** 4
    else:
        tol = 1e3 * solver["rtol"]
    return max(tol, 1e-9)


def section_distances(sections: np.ndarray, n: int, scale: np.ndarray | None = None) -> np.ndarray:
    """Scaled max-norm distances between sections k and k - n, for k = n .. end (diagnostics;
    the classification itself is the core's, ``classify_sections``).
    `scale` defaults to the largest |value| of each component over the sections."""
    sections = real_array("section_distances", "sections", sections, 2)
    n = _count("section_distances", "n", n)
    if n >= sections.shape[0]:
        raise InputError(f"section_distances: n = {n}: must be less than the {sections.shape[0]} "
                         f"sections")
    if scale is not None:
        scale = _scale("section_distances", scale, sections)
    if scale is None:
        scale = np.abs(sections).max(axis=0)
        scale[scale == 0] = 1.0
    return (np.abs(sections[n:] - sections[:-n]) / scale).max(axis=1)


def _scaled(sections: np.ndarray, scale: np.ndarray | None) -> np.ndarray:
    """The sections divided component-wise by `scale` (default: their largest |value|)."""
    if scale is None:
        scale = np.abs(sections).max(axis=0)
        scale = np.where(scale == 0, 1.0, scale)
    return sections / scale


def classify_sections(sections: np.ndarray, tol: float = 1e-6, max_period: int = 16,
                      window: int | None = None, scale: np.ndarray | None = None) -> dict:
    """Period-n or non-periodic, by the core's steady-state rule (tmafm_steady_state, the one
    the observed runs use; tmafm.observe.steady_test): the smallest n <= max_period whose
    scaled section distances over the last `window` sections all stay below tol and whose n
    points are distinct.  Each component is scaled by `scale` (default: its largest |value|
    over the last window + max_period sections).  Returns the evidence: for each n, the largest
    distance seen, and the core's reason when there is no period."""
    from .observe import steady_test
    sections = real_array("classify_sections", "sections", sections, 2)
    tol = _real("classify_sections", "tol", tol, positive=True)
    max_period = _count("classify_sections", "max_period", max_period)
    window = _count("classify_sections", "window", window, optional=True)
    if scale is not None:
        scale = _scale("classify_sections", scale, sections)
    window = window or 2 * max_period
    if sections.shape[0] < window + max_period:
        raise InputError(f"need at least {window + max_period} drive periods, have {sections.shape[0]}")
    tail = sections[-(window + max_period):]
    test = steady_test(_scaled(tail, scale), max_period, tol, window, scale=1.0)
    evidence = test["steps"]
    if test["period"]:
        n = test["period"]
        return {"kind": f"period-{n}", "period": n, "tol": tol, "distances": evidence}
    return {"kind": "non-periodic", "period": None, "tol": tol, "distances": evidence,
            "reason": test["reason"]}


def classify_period(result, tol: float | None = None, max_period: int = 16,
                    window: int | None = None) -> dict:
    """classify_sections on the Poincare sections of a run, scaled by the size of the
    motion over the second half of the run (of its samples); tol defaults to default_tolerance."""
    _result(result, "classify_period")
    tol = _real("classify_period", "tol", tol, optional=True, positive=True)
    tol = default_tolerance(result) if tol is None else tol
    return classify_sections(poincare_sections(result)[1], tol, max_period, window,
                             state_scale(result, (result.tau[0] + result.tau[-1]) / 2))


def steady_state(result, tol: float | None = None, max_period: int = 16, hold: int = 4) -> dict:
    """The first drive period from which the sections repeat with some period n <= max_period
    for all later sections, at least `hold` cycles, by the core's rule (classify_sections):
    for the smallest such n, the earliest section s such that every section from s on
    repeats the one n periods earlier (distance <= tol, each component scaled by the size of
    the motion over the second half of the run, of its samples).  ``reached`` is False otherwise.  tol
    defaults to default_tolerance."""
    from .observe import steady_test
    _result(result, "steady_state")
    tol = _real("steady_state", "tol", tol, optional=True, positive=True)
    max_period = _count("steady_state", "max_period", max_period)
    hold = _count("steady_state", "hold", hold)
    tol = default_tolerance(result) if tol is None else tol
    times, sections = poincare_sections(result)
    points = _scaled(sections, state_scale(result, (result.tau[0] + result.tau[-1]) / 2))
    total = points.shape[0]

    def repeats_from(start: int, n: int) -> bool:
        """Whether every section from `start` on repeats the one n earlier (core's rule)."""
        count = total - start - n
        return count >= 1 and steady_test(points[start:], n, tol, count, scale=1.0)["period"] == n

    for n in range(1, max_period + 1):
        if total < n * (hold + 1) + 1:
            break
        if not repeats_from(total - n * hold - n, n):
            continue
        low, high = 0, total - n * hold - n      # repeats_from(high, n) holds; find the least
        while low < high:
            mid = (low + high) // 2
            if repeats_from(mid, n):
                high = mid
            else:
                low = mid + 1
        return {"reached": True, "tau": float(times[low]), "period": n, "tol": tol}
    return {"reached": False, "tau": None, "period": None, "tol": tol}


def _model_of(result) -> Model:
    """The model of a run: its own Config when it has one, else its resolved input (in memory)."""
    if getattr(result, "config", None) is not None:
        return Model(result.config)
    groups = {g: dict(v) for g, v in result.resolved.todict(complex_tuple=False).items()
              if not g.startswith("_")}
    n = result.n_modes
    groups.setdefault("model", {})["n_modes"] = n  # the N the run used (also when automatic)
    initial = groups.setdefault("initial", {})
    for key in ("a0", "adot0"):
        values = list(np.atleast_1d(initial.get(key, [])))[:n]
        initial[key] = values + [0.0] * (n - len(values))
    return Model(Config(groups))


def energy_flow(result) -> dict:
    """Per sample: the powers (POWER_NAMES), the modal energy, and the contact state."""
    _result(result, "energy_flow")
    model = _model_of(result)
    if model.scene["capillary_strength"] > 0:
        # The samples keep the phase (contact or not), not whether a meniscus holds the tip in
        # flight, which its force there needs: the core's observation has its work.
        raise InputError("energy_flow: a capillary meniscus (&scene capillary_strength = "
                         f"{model.scene['capillary_strength']:.6g}) acts in flight while it holds, which "
                         "the samples do not record; its work per period is tmafm.observe's "
                         "dissipated_adhesion")
    power, energy, state = model.trajectory_energy_flow(
        result.tau, result.a, result.adot, result.contact)
    out = {name: power[:, k] for k, name in enumerate(POWER_NAMES)}
    out["energy"] = energy
    for k, name in enumerate(("theta1", "radius", "normal_group", "friction_group", "p1", "p2")):
        out[name] = state[:, k]
    return out


def _integrate(power, result, first, last):
    """The integral of a sampled power over samples first..last.  The power jumps where the
    phase changes, so a sample interval that holds a switch (result.switches) is split there,
    each side extrapolated linearly from its own phase: the error stays O(sample_dtau^2)."""
    tau = result.tau
    total = 0.0
    switches = np.asarray(result.switches, dtype=float)
    for i in range(first, last):
        t0, t1 = tau[i], tau[i + 1]
        inside = switches[(switches > t0) & (switches < t1)]
        if inside.size != 1 or result.contact[i] == result.contact[i + 1] or i == 0 or i + 2 >= tau.size:
            total += 0.5 * (t1 - t0) * (power[i] + power[i + 1])
            continue
        ts = inside[0]
        left = power[i] + (power[i] - power[i - 1]) * (ts - t0) / (t0 - tau[i - 1])
        right = power[i + 1] - (power[i + 2] - power[i + 1]) * (t1 - ts) / (tau[i + 2] - t1)
        total += 0.5 * (ts - t0) * (power[i] + left) + 0.5 * (t1 - ts) * (right + power[i + 1])
    return float(total)


def energy_balance(result, tau0: float, tau1: float) -> dict:
    """Change of modal energy over [tau0, tau1] against the work of each force, integrated
    from the samples with the switches split out (error O(sample_dtau^2))."""
    _result(result, "energy_balance")
    tau0 = _real("energy_balance", "tau0", tau0)
    tau1 = _real("energy_balance", "tau1", tau1)
    if not result.tau.size or not result.tau[0] <= tau0 <= tau1 <= result.tau[-1] + 1e-12:
        raise InputError(f"energy_balance: tau0 = {tau0:g}, tau1 = {tau1:g}: must lie in the "
                         f"run's samples, tau0 <= tau1")
    flow = energy_flow(result)
    first = int(np.searchsorted(result.tau, tau0 - 1e-12))
    last = int(np.searchsorted(result.tau, tau1 + 1e-12)) - 1
    work = {name: _integrate(flow[name], result, first, last) for name in POWER_NAMES}
    change = float(flow["energy"][last] - flow["energy"][first])
    return {"energy_change": change, "work": work, "residual": change - sum(work.values())}


def _observed_periods(result, since):
    """The core's observation and the rows of its whole drive periods after `since` (the
    window of per_period), or None when there is no observation or no such period."""
    obs = observation(result)
    if obs is None:
        return None
    k0 = int(math.ceil(since / drive_period(result) - 1e-9))
    if k0 >= obs.periods:
        return None
    return obs, slice(k0, obs.periods)


def modal_amplitudes(result, since: float | None = None) -> dict:
    """Per mode, in contact and out of contact after `since`: max |a_j| and half peak-to-peak
    (max a_j - min a_j)/2.  The extrema are the core's, located on the dense output between
    the switches over the whole drive periods after `since` (``observation``); a Result the
    core cannot re-run falls back to its samples after `since`.  ``samples`` counts the
    samples of each phase after `since` either way."""
    _result(result, "modal_amplitudes")
    since = _since("modal_amplitudes", result, since)
    keep = result.tau >= since
    observed = _observed_periods(result, since)
    out = {}
    for label, mask in (("contact", keep & (result.contact == 1)), ("free", keep & (result.contact == 0))):
        if observed is not None:
            obs, rows = observed
            high = obs.per_period[f"modal_max_{label}"][rows]
            low = obs.per_period[f"modal_min_{label}"][rows]
            if np.all(np.isnan(high)):
                out[label] = None
                continue
            high, low = np.nanmax(high, axis=0), np.nanmin(low, axis=0)
        else:
            if not mask.any():
                out[label] = None
                continue
            high, low = result.a[mask].max(axis=0), result.a[mask].min(axis=0)
        out[label] = {"max_abs": np.maximum(np.abs(high), np.abs(low)).tolist(),
                      "half_peak_to_peak": (0.5 * (high - low)).tolist(),
                      "samples": int(mask.sum())}
    return out


def vt_max(result, since: float | None = None) -> float:
    """The largest V_T after `since`: the core's located maximum over the whole drive periods
    after `since` (``observation``), or the largest sample when the core cannot re-run it."""
    _result(result, "vt_max")
    since = _since("vt_max", result, since)
    observed = _observed_periods(result, since)
    if observed is not None:
        obs, rows = observed
        return float(np.max(obs.per_period["max_gap"][rows]))
    return float(result.vt[result.tau >= since].max())


def per_period(result, since: float | None = None) -> list[dict]:
    """For every whole drive period after `since`: contact fraction, contacts begun, maximum
    indentation (-min V_T) and min V_T (these four, and the works, from the core's
    observation when there is one), peak normal and friction groups ((L/d) kappa f_c and (L/d) kappa h
    are the forces in units of E1 I d / L^3; here f_c and h themselves), and the work of the
    contact damping and of friction, and the energy dissipated in all."""
    _result(result, "per_period")
    since = _since("per_period", result, since)
    stride = _stride(result)
    flow = energy_flow(result)
    first = _first_period_sample(result, since, stride)
    obs = observation(result)
    rows = []
    for start in range(first, result.tau.size - stride, stride):
        sl = slice(start, start + stride + 1)
        tau = result.tau[sl]
        k = (start + _offset(result)) // stride
        if obs is not None and k < obs.periods:
            p = obs.per_period
            rows.append({
                "tau_start": float(tau[0]),
                "contact_fraction": float(p["contact_time"][k] / drive_period(result)),
                "contacts": int(p["contacts_per_period"][k]),
                "max_indentation": float(max(0.0, -p["min_gap"][k])),
                "peak_normal_group": float(np.max(np.abs(flow["normal_group"][sl]))),
                "peak_friction_group": float(np.max(np.abs(flow["friction_group"][sl]))),
                "work_contact_damping": float(-p["dissipated_contact_damping"][k]),
                "work_friction": float(-p["dissipated_friction"][k]),
                "dissipated": float(p["dissipated_energy"][k]),
                "min_gap": float(p["min_gap"][k]),
            })
            continue
        contact = result.contact[sl]
        onsets = int(np.count_nonzero(np.diff(contact) == 1))
        work = {name: _integrate(flow[name], result, start, start + stride) for name in POWER_NAMES}
        rows.append({
            "tau_start": float(tau[0]),
            "contact_fraction": float(np.mean(contact[:-1])),
            "contacts": onsets,
            "max_indentation": float(max(0.0, -result.vt[sl].min())),
            "peak_normal_group": float(np.max(np.abs(flow["normal_group"][sl]))),
            "peak_friction_group": float(np.max(np.abs(flow["friction_group"][sl]))),
            "work_contact_damping": work["contact_damping"],
            "work_friction": work["contact_friction"],
            "dissipated": -(work["beam_damping"] + work["contact_damping"] + work["contact_friction"]),
            "min_gap": float(result.vt[sl].min()),
        })
    return rows


def _whole_periods(result, since):
    stride = _stride(result)
    start = _first_period_sample(result, since, stride)
    periods = (result.tau.size - 1 - start) // stride
    if periods < 1:
        raise InputError("no whole drive period after `since`")
    return slice(start, start + periods * stride), periods


def lockin(result, since: float | None = None) -> dict:
    """Amplitude and phase (radians) of V_T at the drive frequency over whole periods after
    `since`: V_T ~ mean + amplitude sin(Omega tau + phase); the mean of the core's per-period
    Fourier coefficients when it observes the run."""
    _result(result, "lockin")
    since = _since("lockin", result, since)
    sl, periods = _whole_periods(result, since)
    obs = observation(result)
    if obs is not None:
        k0 = (sl.start + _offset(result)) // _stride(result)
        rows = slice(k0, min(k0 + periods, obs.periods))
        # The core's steady harmonic: the harmonic over the periods, free of the +-180 wrap.
        from .observe import steady_harmonic
        amplitude, phase = steady_harmonic(obs.per_period["amplitude"][rows],
                                           obs.per_period["phase"][rows])
        mean = np.mean(obs.per_period["mean_deflection"][rows]) + result.scene.get("delta_hat", 0.0)
        return {"mean": float(mean), "amplitude": amplitude, "phase": math.radians(phase),
                "periods": periods}
    tau, vt = result.tau[sl], result.vt[sl]
    omega = result.scene["omega"]
    in_phase = 2 * np.mean(vt * np.sin(omega * tau))
    quadrature = 2 * np.mean(vt * np.cos(omega * tau))
    return {"mean": float(np.mean(vt)), "amplitude": float(math.hypot(in_phase, quadrature)),
            "phase": float(math.atan2(quadrature, in_phase)), "periods": periods}


def harmonics(result, since: float | None = None, k_max: int = 20) -> np.ndarray:
    """Amplitudes of V_T at k Omega, k = 0..k_max, over whole periods after `since` (the core's
    per-period Fourier coefficients, averaged; |FFT| of the samples as the fallback)."""
    _result(result, "harmonics")
    since = _since("harmonics", result, since)
    k_max = _count("harmonics", "k_max", k_max)
    sl, periods = _whole_periods(result, since)
    obs = observation(result, max(k_max, _CORE_HARMONICS))
    if obs is not None:
        k0 = (sl.start + _offset(result)) // _stride(result)
        rows = slice(k0, min(k0 + periods, obs.periods))
        from .observe import steady_harmonic
        amp = obs.per_period["harmonic_amplitude"][rows, :k_max]
        phase = obs.per_period["harmonic_phase"][rows, :k_max]
        mean = np.mean(obs.per_period["mean_deflection"][rows]) + result.scene.get("delta_hat", 0.0)
        coefficients = [steady_harmonic(amp[:, k], phase[:, k])[0] for k in range(amp.shape[1])]
        return np.concatenate([[abs(mean)], coefficients])
    spectrum = np.abs(np.fft.rfft(result.vt[sl])) / (result.vt[sl].size / 2)
    spectrum[0] /= 2
    return spectrum[: (k_max + 1) * periods: periods][: k_max + 1]


def summary(result, since: float | None = None, tol: float | None = None) -> dict:
    """The measures the paper discusses, for a run whose sample_dtau divides the period."""
    _result(result, "summary")
    since = None if since is None else _since("summary", result, since)
    tol = _real("summary", "tol", tol, optional=True, positive=True)
    period = drive_period(result)
    if since is None:
        since = (result.tau[0] + result.tau[-1]) / 2
    tol = default_tolerance(result) if tol is None else tol
    cls = classify_period(result, tol=tol, max_period=8, window=8)
    rows = per_period(result, since)
    amplitudes = modal_amplitudes(result, since)
    return {"classification": cls["kind"], "period": cls["period"], "tolerance": tol,
            "section_distances": cls["distances"],
            "steady_state": steady_state(result, tol=tol, max_period=8),
            "contact_fraction": float(np.mean([r["contact_fraction"] for r in rows])),
            "contacts_per_period": float(np.mean([r["contacts"] for r in rows])),
            "vt_min": float(min(r["min_gap"] for r in rows) if rows
                            else result.vt[result.tau >= since].min()),
            "vt_max": vt_max(result, since),
            "max_indentation": float(max(r["max_indentation"] for r in rows)),
            "dissipated_per_period": float(np.mean([r["dissipated"] for r in rows])),
            "modal_amplitudes": amplitudes, "lockin": lockin(result, since),
            "harmonics": harmonics(result, since, 10).tolist(), "since": since,
            "drive_period": period}


def deflection_psd(result, segments: int = 8, since: float | None = None):
    """The one-sided power spectral density of the tip's deflection (Welch: the samples after
    ``since`` cut in ``segments`` halves-overlapping Hann-windowed segments, their periodograms
    averaged), for the thermal spectrum of a run with ``&solver thermal_noise = 1``
    (docs/model.md, section 21).  Returns ``(f, S, dof)``: frequencies and density, and the
    estimate's degrees of freedom (each S has a relative standard error of about
    sqrt(2/dof)).  For a scene given in ``&physical``: f in Hz and S in m^2/Hz from the core's
    SI series (``deflection_m``, ``t_s``); for a ``&scene`` input: f in cycles per unit tau and
    S in d^2 tau, of the tip's displacement p.a.  The mean is removed from each segment.
    Check ``sum(S) df`` against the deflection's variance (Parseval)."""
    what = "deflection_psd"
    result = _result(result, what)
    segments = _count(what, "segments", segments)
    since = _since(what, result, since)
    keep = result.tau >= since
    if result.physical is not None:
        t = np.asarray(result.physical["t_s"], dtype=float)[keep]
        x = np.asarray(result.physical["deflection_m"], dtype=float)[keep]
    else:
        t = np.asarray(result.tau, dtype=float)[keep]
        x = np.asarray(result.a, dtype=float)[keep] @ Model(result.config).tip
    length = 2 * (x.size // (segments + 1))
    if length < 8:
        raise InputError(f"{what}: segments = {segments}: the run keeps {x.size} samples after "
                         f"since, too few for segments of at least 8 samples")
    dt = (t[-1] - t[0]) / (t.size - 1)
    window = np.hanning(length)
    norm = 2.0 * dt / np.sum(window**2)
    step = length // 2
    total = np.zeros(length // 2 + 1)
    count = 0
    for start in range(0, x.size - length + 1, step):
        piece = x[start:start + length]
        spectrum = np.fft.rfft(window * (piece - piece.mean()))
        total += np.abs(spectrum) ** 2
        count += 1
    density = norm * total / count
    density[0] /= 2
    if length % 2 == 0:
        density[-1] /= 2
    f = np.fft.rfftfreq(length, dt)
    # Hann windows overlapping by half are correlated by 0.167 (Welch 1967): 2 count/(1 + 2
    # 0.167^2), about 1.9 count degrees of freedom (2 for one segment).
    return f, density, 2.0 * count / (1.0 + 2 * 0.167**2 * (count > 1))


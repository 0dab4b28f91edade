"""tmafm.bifurcation: the Poincaré section points of runs against a swept key."""

from __future__ import annotations

import numpy as np

from .._namelist import _NOT_NUMBERS, shown
from .._run import Config
from ..errors import InputError, InputTypeError
from .dataset import _grid_dataset
from ..observe import _core_scales
from .executors import _check_run, _run_points
from .points import (_axis_values, _base_config, _base_dict, _check_points, _for_keys,
                     _observe_keywords, _raw,
                     _split_key, _validate)


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
    if isinstance(periods_kept, _NOT_NUMBERS) or not isinstance(periods_kept, (int, np.integer)) \
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
    base_groups = _for_keys(_base_dict(base_config), [key])
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
    tip = np.stack([_tip_displacement(configs[i], kept[i, :, :sizes[i]])
                    for i in range(len(points))])
    offsets = np.array([c.scene["delta_hat"] for c in configs])
    adot1 = np.stack([kept[i, :, size // 2] for i, size in enumerate(sizes)])
    section = {"a1": (kept[..., 0], "a1 at the Poincaré section"),
               "adot1": (adot1, "a1' at the section"),
               "tip": (tip, "p^T a at the section (the tip's modal displacement)"),
               "vt": (tip + offsets[:, None], "V_T at the section (drive phase 0)")}
    # A &physical scene's section points in nm (mm/s for a1'): each point's own scales (a
    # swept tip_sample_distance changes the gap d, the length unit).
    physical = "physical" in base_groups
    if physical:
        scales = [_core_scales(c) for c in configs]
        length = np.array([s["length"] for s in scales])[:, None]
        speed = length / np.array([s["time"] for s in scales])[:, None]
        factors = {"a1": (length * 1e9, "nm"), "adot1": (speed * 1e3, "mm/s"),
                   "tip": (length * 1e9, "nm"), "vt": (length * 1e9, "nm")}
    else:
        factors = {"a1": (1.0, "1"), "adot1": (1.0, "1"), "tip": (1.0, "1"), "vt": (1.0, "1")}
    for name, (values, long_name) in section.items():
        factor, unit = factors[name]
        ds[name] = xr.Variable(dims, values * factor, attrs={
            "units": unit, "units_system": "physical" if physical else "model",
            "long_name": long_name + ("" if physical else
                                      (" (in d/tau)" if name == "adot1" else " (in gap units d)"))})
    ds = ds.assign_coords(kept=xr.Variable(("kept",), np.arange(1, periods_kept + 1,
                                                                 dtype=np.int32),
                                           attrs={"units": "1", "long_name": "section point "
                                                  "kept (the last is the run's final one)"}))
    ds.attrs["swept_key"] = key
    return ds

"""Plots of a continuation Dataset (matplotlib): the branch (stable solid, unstable dashed,
special points labelled), optionally over a brute-force sweep of the same key (its points as
dots), in the manner of tmafm.sweeps.plots."""

from __future__ import annotations

import numpy as np

from ..sweeps.plots import _Memory, _pyplot, _save

__all__ = ["plot_branch", "render"]

#: Marker of each label.
_MARKERS = {"fold": ("o", "fold"), "period_doubling": ("s", "period doubling"),
            "neimark_sacker": ("D", "Neimark-Sacker"), "grazing": ("^", "grazing"),
            "contact_sequence": ("v", "contact sequence changes")}


def _check(ds):
    from ..errors import InputError, InputTypeError
    try:
        import xarray as xr
    except ImportError:  # pragma: no cover - the extra is checked by continuation()
        raise InputTypeError("plots need xarray") from None
    if not isinstance(ds, xr.Dataset) or ds.attrs.get("tmafm_kind") != "continuation":
        raise InputTypeError("plot_branch: ds must be the Dataset of tmafm.continuation()")
    if ds.sizes.get("point", 0) == 0:
        raise InputError("plot_branch: the Dataset has no points")
    return ds


def _runs(mask):
    """Index ranges [i, j) where mask is constant, with its value."""
    out, i = [], 0
    for j in range(1, len(mask) + 1):
        if j == len(mask) or mask[j] != mask[i]:
            out.append((i, j, bool(mask[i])))
            i = j
    return out


def plot_branch(ds, path, variable="amplitude", sweep=None, sweep_variable=None, ax=None):
    """Draw `variable` of a continuation Dataset against its key: each branch's stable stretches
    solid and unstable dashed, special points marked; `sweep` (a tmafm.approach /
    frequency_sweep / bifurcation Dataset of the same key) underneath as dots.  variable 'tip'
    draws every section point (period-n branches show n lines)."""
    ds = _check(ds)
    plt = _pyplot()
    key = ds.attrs["key"]
    own = ax is None
    if own:
        fig, ax = plt.subplots(figsize=(6.4, 4.2))
    if sweep is not None:
        name = sweep_variable or variable
        if name not in sweep and name.endswith("_si") and name[:-3] in sweep:
            name = name[:-3]  # an SI sweep holds its lengths in nm under the model's names
        if name not in sweep:
            from ..errors import InputError
            raise InputError(f"plot_branch: sweep_variable = {name!r} is not in the sweep")
        y = np.asarray(sweep[name])
        x = np.asarray(_sweep_axis(sweep, key))
        if y.ndim > 1 and y.shape[0] == x.size:  # (key, kept): a bifurcation diagram
            x = x.reshape((-1,) + (1,) * (y.ndim - 1))
        x = np.broadcast_to(x, y.shape)  # (direction, key): an approach or frequency sweep
        ax.plot(x.ravel(), y.ravel(), ".", color="0.6", ms=3, label=f"brute force ({name})")
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    shown = set()
    for k, b in enumerate(np.unique(ds["branch"])):
        sel = ds.where(ds["branch"] == b, drop=True)
        x = np.asarray(sel[key])
        y = np.asarray(sel[variable])
        ys = y.reshape(len(x), -1)
        stable = np.asarray(sel["stable"]).astype(bool)
        color = colors[k % len(colors)]
        name = f"branch {int(b)} (period {int(sel['period'].values[0])})"
        for i, j, st in _runs(stable):
            lo, hi = max(i - 1, 0), j  # join the stretches
            for col in range(ys.shape[1]):
                ax.plot(x[lo:hi], ys[lo:hi, col], "-" if st else "--", color=color, lw=1.4,
                        label=name)
                name = None
        labels = np.asarray(sel["label"])
        for lab, (marker, text) in _MARKERS.items():
            hit = labels == lab
            if hit.any():
                ax.plot(x[hit], ys[hit, 0], marker, mfc="none", color="k", ms=7,
                        label=None if lab in shown else text)
                shown.add(lab)
    key_unit = ds[key].attrs.get("units", "")
    ax.set_xlabel(f"{key} [{key_unit}]" if key_unit not in ("", "1") else key)
    unit = ds[variable].attrs.get("units", "")
    ax.set_ylabel(f"{variable} [{unit}]" if unit and unit != "1" else variable)
    ax.legend(fontsize=8)
    if own:
        fig.tight_layout()
        return _save(fig, path)
    return ax


def _sweep_axis(sweep, key):
    """The sweep's coordinate of the continued key: the key itself, or the coordinate whose
    long_name names it (an SI approach's z names physical.tip_sample_distance)."""
    if key in sweep.coords or key in sweep:
        return sweep[key]
    for name, coord in sweep.coords.items():
        if f"({key})" in str(coord.attrs.get("long_name", "")):
            return coord
    from ..errors import InputError
    raise InputError(f"plot_branch: the sweep has no coordinate of key = {key!r} "
                     f"(coordinates {sorted(map(str, sweep.coords))})")


def render(ds, suffix: str = ".png", **keywords) -> bytes:
    """plot_branch into bytes (the format from suffix)."""
    memory = _Memory(suffix.lstrip("."))
    plot_branch(ds, memory, **keywords)
    return memory.data

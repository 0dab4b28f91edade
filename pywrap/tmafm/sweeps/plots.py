"""Plots of sweep datasets (matplotlib): one function per kind, and plot() that picks by kind.

    >>> from tmafm.sweeps import plots                                    # doctest: +SKIP
    >>> plots.plot(tmafm.approach("fig2_n4", delta_hat=...), "approach.png")
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["plot", "render", "plot_approach", "plot_frequency", "plot_bifurcation", "plot_basin",
           "plot_grid"]


def _pyplot():
    from .._extras import require
    matplotlib = require("matplotlib", "tmafm.sweeps.plots")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


#: How a unit is shown on an axis: (factor, shown unit).  Metres in nm, Hz in kHz, the rest as
#: the dataset stores them (nm, nN, degree, aJ, pW, ...).
_SHOWN = {"m": (1e9, "nm"), "Hz": (1e-3, "kHz"), "degree": (1.0, "deg"), "us": (1.0, "µs")}
#: Axis names of the variables and coordinates of physical scenes.
_NAMES = {"z": "Z", "frequency": "drive frequency", "amplitude": "amplitude A",
          "setpoint": "A/A0", "peak_force": "peak force", "dissipated_power": "dissipated power",
          "tip_sample_power": "tip-sample dissipation", "physical.tip_sample_distance": "Z",
          "physical.drive_frequency": "drive frequency", "physical.free_amplitude": "A0",
          "mean_deflection": "mean deflection", "min_gap": "min gap",
          "contact_time": "contact time", "dissipated_energy": "dissipated energy"}


def _shown(ds, name: str):
    """(values as shown, axis label) of a variable or coordinate: its unit from ``units``
    (a physical unit shown as _SHOWN says), the model units as stored."""
    data = ds[name]
    unit = data.attrs.get("units", "")
    factor, shown = _SHOWN.get(unit, (1.0, unit))
    label = _NAMES.get(name, name) if data.attrs.get("units_system") == "physical" \
        or unit in _SHOWN or name in ("z", "frequency", "setpoint") else name
    text = f"{label} [{shown}]" if shown and shown != "1" else label
    return np.asarray(data.values) * factor, text


def _label(ds, name: str) -> str:
    return _shown(ds, name)[1]


def _title_base(ds) -> str:
    """The base input as a short name for a title: a path's file name, a packaged name as is."""
    base = str(ds.attrs.get("base", ""))
    return Path(base).name if base and not base.startswith("<") else base


class _Memory:
    """A plot's destination in memory (render): the format, and the bytes once drawn."""

    def __init__(self, format: str):
        self.format = format
        self.data = b""


def _save(fig, path) -> Path:
    """Save by the executable's output rules (tmafm._safefile: a temporary and a rename), or
    into memory for render()."""
    import io
    from .._safefile import save_figure
    try:
        if isinstance(path, _Memory):
            buffer = io.BytesIO()
            fig.savefig(buffer, format=path.format, dpi=110)
            path.data = buffer.getvalue()
            return path
        return save_figure(fig, path, dpi=110)
    finally:
        _pyplot().close(fig)


def _check(ds, what: str):
    """`ds` if it is a sweep Dataset (xarray.Dataset with tmafm_kind); InputTypeError or
    InputError otherwise."""
    from .._namelist import shown
    from ..errors import InputError, InputTypeError
    try:
        import xarray as xr
    except ImportError:
        xr = None
    if xr is None or not isinstance(ds, xr.Dataset):
        raise InputTypeError(f"{what}: ds must be an xarray.Dataset of a sweep, not "
                             f"{type(ds).__name__}")
    kind = ds.attrs.get("tmafm_kind")
    if kind not in _BY_KIND or "period" not in ds:
        raise InputError(f"{what}: not a tmafm sweep dataset (tmafm_kind = {shown(kind)})")
    return ds


def _continuation_panels(ds, path, names):
    plt = _pyplot()
    key = ds.attrs["swept_key"]
    x, xlabel = _shown(ds, key)
    curve_dims = [d for d in ds["amplitude"].dims if d not in ("direction", key)]
    fig, axes = plt.subplots(len(names), 1, figsize=(6.4, 1.9 * len(names) + 0.6), sharex=True)
    styles = {0: dict(marker="o", ms=3, lw=1.2), 1: dict(marker="x", ms=4, lw=1.0, ls="--")}
    for ax, name in zip(np.atleast_1d(axes), names):
        values, ylabel = _shown(ds, name)
        data = ds[name].copy(data=values)
        stacked = data.stack(curve=curve_dims) if curve_dims else data.expand_dims(curve=[0])
        jump = ds["jump"].stack(curve=curve_dims) if curve_dims else ds["jump"].expand_dims(
            curve=[0])
        for c in range(stacked.sizes["curve"]):
            for d, direction in enumerate(ds["direction"].values):
                y = stacked.isel(direction=d, curve=c).transpose(key).values
                curve_label = ""
                if curve_dims:
                    value = stacked["curve"].values[c]
                    curve_label = _curve_label(ds, curve_dims[0],
                                               value if np.isscalar(value) else value[0])
                line, = ax.plot(x, y, label=f"{direction}{curve_label}", **styles[d % 2])
                flags = jump.isel(direction=d, curve=c).transpose(key).values.astype(bool)
                if flags.any():
                    ax.plot(x[flags], y[flags], ls="none", marker="s", mfc="none", ms=9,
                            color=line.get_color())
        ax.set_ylabel(ylabel, fontsize=8)
        ax.grid(alpha=0.3)
        ax.tick_params(labelsize=7)
        if name == "amplitude" and "free_amplitude" in ds.attrs:
            _setpoint_axis(ax, ds)
    axes = np.atleast_1d(axes)
    axes[-1].set_xlabel(xlabel)
    axes[0].legend(fontsize=7, loc="best")
    title = f"{ds.attrs.get('tmafm_kind', '')}: {_title_base(ds)}"
    if "free_amplitude" in ds.attrs:
        title += f", A0 = {float(ds.attrs['free_amplitude']):.3g} nm"
    axes[0].set_title(f"{title} (squares: jumps)", fontsize=9)
    fig.tight_layout()
    return _save(fig, path)


def _curve_label(ds, dim: str, value) -> str:
    """', Z = 15 nm' for a curve of a physical key (its unit as _SHOWN shows it), ', key = value'
    for a dimensionless one."""
    unit = ds[dim].attrs.get("units", "")
    factor, shown = _SHOWN.get(unit, (1.0, unit))
    text = f"{float(value) * factor:g}" + (f" {shown}" if shown and shown != "1" else "")
    return f", {_NAMES.get(dim, dim)} = {text}"


def _setpoint_axis(ax, ds) -> None:
    """A right-hand axis on the amplitude panel in A/A0 (the setpoint)."""
    a0 = float(ds.attrs["free_amplitude"])
    right = ax.secondary_yaxis("right", functions=(lambda a: a / a0, lambda s: s * a0))
    right.set_ylabel("A/A0", fontsize=8)
    right.tick_params(labelsize=7)


def plot_approach(ds, path):
    """Amplitude (and A/A0 when the scene has a free amplitude A0), phase, peak force,
    indentation (-min_gap when < 0) and the power dissipated in the tip-sample contact against
    Z (or delta_hat), both
    branches, jumps marked by squares (the panels of the observables the sweep computed)."""
    _check(ds, "plot_approach")
    ds = ds.copy()
    if "min_gap" in ds and "indentation" not in ds:   # a dataset written before it held one
        ds["indentation"] = (-ds["min_gap"]).clip(min=0)
        ds["indentation"].attrs = dict(ds["min_gap"].attrs, long_name="indentation")
    return _continuation_panels(ds, path, [name for name in (
        "amplitude", "phase", "peak_force", "indentation", "tip_sample_power") if name in ds])


def plot_frequency(ds, path):
    """Amplitude and phase against the drive frequency, up and down sweeps, jumps marked."""
    _check(ds, "plot_frequency")
    return _continuation_panels(ds, path, ["amplitude", "phase"])


def plot_bifurcation(ds, path, variable="vt"):
    """Poincaré points (`variable`, default V_T at the section) against the swept key."""
    from .._namelist import shown
    from ..errors import InputError
    _check(ds, "plot_bifurcation")
    if not isinstance(variable, str) or variable not in ds or "swept_key" not in ds.attrs:
        raise InputError(f"plot_bifurcation: variable {shown(variable)} is not in the dataset")
    plt = _pyplot()
    key = ds.attrs["swept_key"]
    fig, axes = plt.subplots(2, 1, figsize=(6.4, 5.2), sharex=True)
    xs, xlabel = _shown(ds, key)
    for ax, name in zip(axes, [variable, "a1"]):
        y, ylabel = _shown(ds, name)
        x = np.broadcast_to(xs[:, None], y.shape)
        ax.plot(x.ravel(), y.ravel(), "k.", ms=1.5, ls="none")
        unit = ds[name].attrs.get("units", "")
        ax.set_ylabel(f"{name} at the section" + (f" [{unit}]" if unit and unit != "1" else ""),
                      fontsize=8)
        ax.grid(alpha=0.3)
        _tidy_ticks(ax)
    axes[-1].set_xlabel(xlabel)
    axes[0].set_title(f"bifurcation diagram: {_title_base(ds)}", fontsize=9)
    fig.tight_layout()
    return _save(fig, path)


def plot_basin(ds, path):
    """The basin map: attractor labels over (a1(0), a1'(0)), and the period."""
    _check(ds, "plot_basin")
    plt = _pyplot()
    from matplotlib.colors import ListedColormap
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.2))
    a1, adot1 = ds["a1"].values, ds["adot1"].values
    extent = [adot1[0], adot1[-1], a1[0], a1[-1]]
    labels = ds["attractor"].values
    n = int(max(labels.max(), 0)) + 2
    colours = ["#bbbbbb"] + [plt.get_cmap("tab10")(k % 10) for k in range(n - 1)]
    image = axes[0].imshow(labels + 1, origin="lower", extent=extent, aspect="auto",
                           cmap=ListedColormap(colours), vmin=-0.5, vmax=n - 0.5,
                           interpolation="nearest")
    bar = fig.colorbar(image, ax=axes[0], ticks=range(n))
    bar.ax.set_yticklabels(["none"] + [str(k) for k in range(n - 1)])
    axes[0].set_title(f"attractor ({ds.attrs.get('attractors', '?')} found)", fontsize=9)
    # The period is an integer: one colour per value found (a discrete bar), 0 (none) grey.
    periods = ds["period"].values
    found = [int(k) for k in np.unique(periods)]
    index = np.searchsorted(found, periods)
    colours = [("#bbbbbb" if k == 0 else plt.get_cmap("tab10")(j % 10))
               for j, k in enumerate(found)]
    image = axes[1].imshow(index, origin="lower", extent=extent, aspect="auto",
                           interpolation="nearest", cmap=ListedColormap(colours),
                           vmin=-0.5, vmax=len(found) - 0.5)
    bar = fig.colorbar(image, ax=axes[1], ticks=range(len(found)))
    bar.ax.set_yticklabels([str(k) if k else "none" for k in found])
    axes[1].set_title("period by the steady-state test (0: none found)", fontsize=9)
    for ax in axes:
        ax.set_xlabel("a1'(0)")
        ax.set_ylabel("a1(0)")
        _tidy_ticks(ax)
    fig.suptitle(f"basin map: {_title_base(ds)}", fontsize=10)
    fig.tight_layout()
    return _save(fig, path)


def plot_grid(ds, path, names=("amplitude", "phase", "peak_force", "min_gap")):
    """A grid sweep: lines against its one key, or maps over its two keys (the `names` the
    sweep computed; its steady period when it computed none of them)."""
    from .._namelist import shown
    from ..errors import InputTypeError
    _check(ds, "plot_grid")
    if isinstance(names, str) or not isinstance(names, (list, tuple)) \
            or not all(isinstance(name, str) for name in names):
        raise InputTypeError(f"plot_grid names = {shown(names)}: must be a list of variable names")
    plt = _pyplot()
    names = [name for name in names if name in ds] or ["period"]
    dims = ds["period"].dims
    fig, axes = plt.subplots(len(names), 1, figsize=(6.4, 2.1 * len(names)), squeeze=False)
    for ax, name in zip(axes[:, 0], names):
        values, label = _shown(ds, name)
        if len(dims) == 1:
            x, xlabel = _shown(ds, dims[0])
            ax.plot(x, values, "o-", ms=3)
            ax.set_xlabel(xlabel, fontsize=8)
        else:
            x, xlabel = _shown(ds, dims[1])
            y, ylabel = _shown(ds, dims[0])
            grid = ds[name].transpose(dims[0], dims[1], ...)
            image = ax.pcolormesh(x, y, _shown(ds.assign({name: grid}), name)[0],
                                  shading="auto")
            bar = fig.colorbar(image, ax=ax)
            bar.ax.tick_params(labelsize=7)
            bar.formatter.set_powerlimits((-3, 4))
            bar.update_ticks()
            ax.set_xlabel(xlabel, fontsize=8)
            ax.set_ylabel(ylabel, fontsize=8)
        _tidy_ticks(ax)
        ax.set_title(label, fontsize=8)
    fig.tight_layout()
    return _save(fig, path)


def _tidy_ticks(ax) -> None:
    """At most 5 ticks per axis, small, in scientific notation when the values are small or
    large: tick labels that do not run into each other."""
    from matplotlib.ticker import MaxNLocator
    ax.xaxis.set_major_locator(MaxNLocator(5))
    ax.yaxis.set_major_locator(MaxNLocator(5))
    ax.tick_params(labelsize=7)
    for axis in (ax.xaxis, ax.yaxis):
        formatter = axis.get_major_formatter()
        if hasattr(formatter, "set_powerlimits"):
            formatter.set_powerlimits((-3, 4))


_BY_KIND = {"approach": plot_approach, "frequency_sweep": plot_frequency,
            "bifurcation": plot_bifurcation, "basin": plot_basin, "sweep": plot_grid}


def plot(ds, path):
    """Draw the plot of a sweep Dataset's kind (its 'tmafm_kind' attribute) to `path`."""
    from .._safefile import as_path
    _check(ds, "plot")
    return _BY_KIND[ds.attrs["tmafm_kind"]](ds, as_path(path, "plot file"))


def render(ds, suffix: str = ".png") -> bytes:
    """The plot of plot(ds, ...) as the bytes of a file of that suffix (PNG when matplotlib
    knows no such format), drawn in memory: nothing is written."""
    _check(ds, "render")
    _pyplot()
    from matplotlib.figure import Figure
    fig_formats = Figure().canvas.get_supported_filetypes()
    name = str(suffix).lower().lstrip(".")
    target = _Memory(name if name in fig_formats else "png")
    _BY_KIND[ds.attrs["tmafm_kind"]](ds, target)
    return target.data

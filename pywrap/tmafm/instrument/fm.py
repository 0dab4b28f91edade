"""FM-AFM (docs/instrument.md, "FM-AFM"): the cantilever driven at its own resonance by a
phase-locked loop and an amplitude controller, and the FM approach curve in Z.

The loops run in the core (fortran/src/instrument/tmafm_fm.f90), once per drive period from the
period's exact lock-in amplitude and phase; this module only names what comes back.
"""

from __future__ import annotations

import numpy as np

from .. import _fortran
from .._extras import require
from .._run import Config
from .._safefile import save_figure
from ..errors import InputError, raise_for
from ._schedule import distances

__all__ = ["FM_COLUMNS", "fm_approach", "plot_fm_approach"]

#: The core's per-point values (tmafm_fm's columns fm_*, in order): name, unit, meaning.
FM_COLUMNS = (
    ("z", "nm", "the tip's rest distance Z"),
    ("df", "Hz", "frequency shift: the PLL's drive frequency minus f0"),
    ("drive", "nm", "the base drive amplitude the amplitude controller sets"),
    ("drive_ratio", "1", "the drive over the free cantilever's drive at the same amplitude"),
    ("dissipation", "aJ", "the drive's rise as energy per period: E_free (drive_ratio - 1)"),
    ("drive_work", "aJ", "the drive's work per period (tmafm.observe's drive_work)"),
    ("dissipated", "aJ", "energy dissipated per period, beam and sample (dissipated_energy)"),
    ("dissipated_beam", "aJ", "the beam's viscous part of it"),
    ("dissipated_tip_sample", "aJ", "the tip-sample part: dissipated - dissipated_beam"),
    ("amplitude", "nm", "the tip's lock-in amplitude A"),
    ("phase", "deg", "the tip's lock-in phase against the drive"),
    ("phase_error", "deg", "phase minus the setpoint (the PLL's error)"),
    ("peak_force", "nN", "the period's largest tip-sample force"),
    ("min_gap", "nm", "the period's closest approach"),
    ("mean_deflection", "nm", "the tip's mean deflection"),
    ("df_spread", "Hz", "max - min of df over the average window (how settled)"),
    ("contact_normal_work", "aJ", "the tip-sample force's work on the modes per period "
     "(drive_work + it - dissipated = 0 when steady)"),
)
#: The per-period trace's columns.
_TRACE = (("df", "Hz"), ("drive", "nm"), ("amplitude", "nm"), ("phase", "deg"))


def _count(name, value, low):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not value >= low:
        raise InputError(f"fm {name} = {value!r}: must be an integer >= {low}")
    return int(value)


def _positive(name, value):
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not np.isfinite(value) or not value > 0:
        raise InputError(f"fm {name} = {value!r}: must be a finite number > 0")
    return float(value)


def fm_approach(base, z, amplitude, *, pll_bandwidth=1000.0, amplitude_bandwidth=500.0,
                settle_periods=1000, average_periods=100, free_distance=1.0e-6, **overrides):
    """An FM-AFM approach curve: the FM loop of ``base`` (an input with a &physical scene; its
    drive frequency is the free resonance f0 the PLL starts at; ``overrides`` patch it) at each
    tip-sample distance of ``z`` (m, in the order given), each point warm-started from the last
    one's loop state (frequency, drive, cantilever state), holding the amplitude ``amplitude`` (m).

    ``pll_bandwidth`` and ``amplitude_bandwidth`` (Hz) are the loops' closed-loop bandwidths;
    each point runs ``settle_periods`` drive periods, then averages ``average_periods``; the
    free reference is taken at Z = ``free_distance`` (m).  Returns an xarray Dataset over ``z``
    (nm) with the columns of FM_COLUMNS (units in each variable's attrs), the per-period
    ``trace_*`` over (z, period), and attrs: f0 (Hz), the phase setpoint (deg), the free drive
    (nm) and drive work (aJ), the loops' response time (s) and settings.  Needs the 'sweep'
    extra (xarray)."""
    xr = require("xarray", "tmafm.instrument.fm_approach")
    z = distances(z)
    amplitude = _positive("amplitude", amplitude)
    pll_bandwidth = _positive("pll_bandwidth", pll_bandwidth)
    amplitude_bandwidth = _positive("amplitude_bandwidth", amplitude_bandwidth)
    free_distance = _positive("free_distance", free_distance)
    settle_periods = _count("settle_periods", settle_periods, 0)
    average_periods = _count("average_periods", average_periods, 1)
    config = base if isinstance(base, Config) and not overrides else Config(base, **overrides)
    per_point = settle_periods + average_periods
    if z.size * per_point > 50_000_000:
        raise InputError(f"fm settle_periods + average_periods = {per_point}: {z.size} points of it "
                         f"are over 50000000 periods (the trace would not fit in memory)")
    values = np.zeros((z.size, len(FM_COLUMNS)), order="F")
    trace = np.zeros((z.size * per_point, len(_TRACE)), order="F")
    reference = np.zeros(5)
    done, ierr, errmsg = _fortran.api_fm.fm_approach_run(
        config._f, z, amplitude, pll_bandwidth, amplitude_bandwidth, settle_periods,
        average_periods, free_distance, _fortran.polls(), values, trace, reference)
    raise_for(ierr, errmsg)
    assert done == z.size
    data = {name: ("z", values[:, j].copy(), {"units": unit, "long_name": meaning})
            for j, (name, unit, meaning) in enumerate(FM_COLUMNS) if name != "z"}
    for j, (name, unit) in enumerate(_TRACE):
        data[f"trace_{name}"] = (("z", "period"), trace[:, j].reshape(z.size, per_point).copy(),
                                 {"units": unit})
    attrs = {"kind": "fm_approach", "f0_Hz": reference[0], "phase_setpoint_deg": reference[1],
             "free_drive_nm": reference[2] * 1e9, "free_drive_work_aJ": reference[3],
             "response_time_s": reference[4], "amplitude_m": amplitude,
             "pll_bandwidth_Hz": pll_bandwidth, "amplitude_bandwidth_Hz": amplitude_bandwidth,
             "settle_periods": settle_periods, "average_periods": average_periods,
             "free_distance_m": free_distance, "n_modes": config.n_modes,
             "controllers": "PI, updated once per drive period from the period's lock-in values"}
    coords = {"z": ("z", values[:, 0].copy(), {"units": "nm"}),
              "period": ("period", np.arange(per_point))}
    return xr.Dataset(data, coords=coords, attrs=attrs)


def plot_fm_approach(data, path=None, *, reference=None):
    """Δf and the dissipation against Z (two panels) of an fm_approach Dataset; ``reference``
    (optional: (z in nm, Δf in Hz)) is drawn as a line over Δf (e.g. the Sader-Jarvis integral).
    Saves to ``path`` if given; returns the figure.  Needs the 'plot' extra."""
    plt = require("matplotlib.pyplot", "tmafm.instrument.plot_fm_approach")
    fig, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(6, 6))
    top.plot(data.z, data.df, "o", ms=4, label="FM loop")
    if reference is not None:
        top.plot(reference[0], reference[1], "-", label="Sader-Jarvis integral of the force")
        top.legend()
    top.set_ylabel("Δf (Hz)")
    bottom.plot(data.z, data.dissipation, "o", ms=4, label="from the drive: E_free (drive/drive_free - 1)")
    bottom.plot(data.z, data.dissipated_tip_sample, "-", label="tip-sample dissipation (observer)")
    bottom.set_ylabel("dissipation per period (aJ)")
    bottom.set_xlabel("Z (nm)")
    bottom.legend()
    top.set_title(f"FM approach: A = {data.attrs['amplitude_m'] * 1e9:g} nm, "
                  f"f0 = {data.attrs['f0_Hz'] / 1e3:g} kHz")
    fig.tight_layout()
    if path is not None:
        save_figure(fig, path)
    return fig

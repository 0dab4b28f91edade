"""The generated f90wrap layer, imported in one place: ``api`` (module tmafm_api) and the classes,
the core's limits (``LIMITS``) and its observable table (``OBSERVABLE_TABLE``)."""

import threading

from . import _objects

#: The in-memory entry points (fortran/src/api/tmafm_api.f90).
api = _objects.tmafm_api

#: The instrument's entry points (fortran/src/api/tmafm_api_instrument.f90).
api_instrument = _objects.tmafm_api_instrument
#: The FM-AFM loop's entry points (fortran/src/api/tmafm_api_fm.f90).
api_fm = _objects.tmafm_api_fm

#: A new, empty config_t handle (filled by api.config_from_text(s)).
config_t = _objects.tmafm_config.config_t

#: A new, empty batch_t handle (filled by api.batch_add, run by api.batch_run).
batch_t = _objects.tmafm_api.batch_t


def text(value) -> str:
    """A blank-padded character result of the core as a str."""
    if isinstance(value, (bytes, bytearray)):
        value = value.decode("ascii")
    return str(value).rstrip()


def _limits() -> dict:
    limits = {}
    for k in range(1, int(api.limit_count()) + 1):
        name, value = api.limit_entry(k)
        limits[text(name)] = int(value) if float(value).is_integer() else float(value)
    return limits


#: The core's limits that Python checks against before it calls the core (tmafm_api
#: limit_entry): max_modes, max_samples, max_trajectory_bytes, max_max_steps, max_mode_horizon,
#: max_harmonics, max_p_max, max_observed_periods.
LIMITS = _limits()


#: The widths of tmafm_api observable_entry's texts: a text that fills its field may have been cut.
_OBSERVABLE_WIDTHS = {"name": 32, "group": 16, "unit": 16, "si_unit": 8, "scale": 16, "kind": 16}


def _observables() -> tuple:
    rows = []
    for k in range(1, int(api.observable_count()) + 1):
        name, group, bit, unit, si_unit, scale, kind, index = api.observable_entry(k)
        row = {"name": text(name), "group": text(group), "bit": int(bit), "unit": text(unit),
               "si_unit": text(si_unit), "scale": text(scale), "kind": text(kind),
               "index": int(index)}
        if any(len(row[f]) >= width for f, width in _OBSERVABLE_WIDTHS.items()):
            raise ImportError(f"tmafm: observable {k} of the core's table has a text as long as its "
                              f"field in tmafm_api observable_entry: widen the field ({row['name']})")
        rows.append(row)
    return tuple(rows)


#: The core's observable table (fortran/src/solve/tmafm_observable_table.f90, read through
#: tmafm_api observable_entry), one dict per row: name, group ('lockin', 'extrema',
#: 'peak_force', 'energy', 'always'), bit (the group's bit of observer_t%groups; 0 for always),
#: unit (model), si_unit ('' for none), scale (the tmafm_units scales_t component that converts
#: it, 'one' or ''), kind ('column', 'harmonic', 'extremum', 'modal', 'points') and index (its
#: obs_* column or ext_* index; 0 else).  tmafm.observe's tables are built from it.
OBSERVABLE_TABLE = _observables()


def polls() -> bool:
    """Whether a call into the core should poll for Ctrl-C (the entry points' ``poll``): only on
    Python's main thread, where signal handlers run.  Elsewhere a poll could never stop the run
    and would only wait for the GIL (docs/model-notes.md, item 12)."""
    return threading.current_thread() is threading.main_thread()

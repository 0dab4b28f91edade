"""The instrument around the cantilever (docs/instrument.md): runs stepped drive period by drive
period while the instrument's setting changes between periods.

``z_schedule`` is the building block in the open: one period per entry of a Z schedule, each
period's observables exact to the run's accuracy (as ``tmafm.observe``'s).  The controllers (the
AM Z feedback, the FM loops) are built on the same core stepper (fortran/src/instrument).
"""

from ._schedule import ZSchedule, z_schedule
from .fm import FM_COLUMNS, fm_approach, plot_fm_approach
from .scan import MATERIAL_KEYS, plot_scan, scan_line

__all__ = ["ZSchedule", "z_schedule"]
__all__ += ["FM_COLUMNS", "fm_approach", "plot_fm_approach"]
__all__ += ["MATERIAL_KEYS", "plot_scan", "scan_line"]

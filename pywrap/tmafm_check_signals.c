/* The poll of runs started from Python (fortran/src/api/tmafm_api_poll.f90): a run releases
 * the GIL, so Python's SIGINT handler only notes a Ctrl-C; the core calls this at a run's first
 * update and then at most every poll_interval_ms of wall time (progress_t in
 * fortran/src/solve/tmafm_trajectory.f90), only for runs started on Python's main thread.
 *
 * It takes the GIL (the calling thread has a thread state: it released the GIL in the f2py
 * wrapper), runs the pending signal handlers and gives the GIL back.  It returns 1 when a
 * handler raised: that exception (KeyboardInterrupt, or a user's own) stays set, the run ends
 * with err_interrupted, and the f2py wrapper, which checks PyErr_Occurred() after the call,
 * raises it.  Off the main thread PyErr_CheckSignals runs no handler and this returns 0 (the
 * Python layer does not pass the poll there).  On Python >= 3.12 it may also run a scheduled
 * cyclic GC (docs/model-notes.md, item 12).  No
 * longjmp, no handler installed, no state kept. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

int tmafm_check_signals(void)
{
    PyGILState_STATE gil = PyGILState_Ensure();
    int raised = PyErr_CheckSignals() != 0;
    PyGILState_Release(gil);
    return raised;
}

/* The poll of runs started from Python (fortran/src/api/tmafm_api_poll.f90): a run releases
 * the GIL, so Python's SIGINT handler only notes a Ctrl-C; the core calls this at a run's first
 * step and every poll_every steps (fortran/src/run/tmafm_trajectory.f90).
 *
 * It takes the GIL (the calling thread has a thread state: it released the GIL in the f2py
 * wrapper), runs the pending signal handlers and gives the GIL back.  It returns 1 when a
 * handler raised: that exception (KeyboardInterrupt, or a user's own) stays set, the run ends
 * with err_interrupted, and the f2py wrapper, which checks PyErr_Occurred() after the call,
 * raises it.  Off the main thread PyErr_CheckSignals does nothing and this returns 0.  No
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

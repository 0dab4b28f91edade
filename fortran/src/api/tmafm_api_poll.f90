!> The poll that runs started from Python give the core (tmafm_trajectory stop_poll), so that
!> Ctrl-C stops them.
!>
!> A run from Python releases the GIL, so Python's own SIGINT handler only notes the signal. The
!> run loops ask python_interrupted at their first update and then at most every
!> poll_interval_ms of wall time (tmafm_trajectory progress_t); it calls tmafm_check_signals
!> (pywrap/tmafm_check_signals.c, linked into each extension), which takes the GIL, runs the
!> pending signal handlers (PyErr_CheckSignals) and gives the GIL back. When a handler raised
!> (KeyboardInterrupt, or whatever a user's handler raises), that exception stays set, the run
!> ends with err_interrupted and no result, and the f2py wrapper, which checks PyErr_Occurred()
!> after the call, raises it. A handler that does not raise lets the run go on. Off Python's
!> main thread PyErr_CheckSignals does nothing (signal handlers run only there), so the entry
!> points pass this poll only when Python says it calls from its main thread (their `poll`
!> flag), and runs on other threads never take the GIL. Nothing here holds state: the core gets
!> the poll as a procedure argument.
module tmafm_api_poll
   use, intrinsic :: iso_c_binding, only: c_int
   implicit none
   private

   public :: python_interrupted

   interface
      !> 1 if a Python signal handler raised (its exception is then set), else 0.
      function check_signals() result(raised) bind(c, name='tmafm_check_signals')
         import :: c_int
         integer(c_int) :: raised
      end function check_signals
   end interface

contains

   !> The stop_poll of runs started from Python: .true. once a Python signal handler raised.
   logical function python_interrupted()
      python_interrupted = check_signals() /= 0
   end function python_interrupted

end module tmafm_api_poll

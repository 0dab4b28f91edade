!> Error codes shared by the library, the executable and the Python layer.
!>
!> The library never stops: every fallible routine returns an integer code
!> `ierr` (zero on success) and a one-line message `errmsg`.  The executable
!> turns the code into its exit status; Python turns it into a typed exception.
module tmafm_errors
   implicit none
   private

   public :: ok, err_input, err_file, err_blowup, err_runtime, err_interrupted, errmsg_len

   !> Success.
   integer, parameter :: ok = 0
   !> A value in the input is out of range, of the wrong type, or unknown.
   integer, parameter :: err_input = 2
   !> A file could not be opened, read or written.
   integer, parameter :: err_file = 3
   !> The integration blew up (NaN, Inf or a runaway amplitude).
   integer, parameter :: err_blowup = 4
   !> Any other failure inside a run (for example a singular matrix).
   integer, parameter :: err_runtime = 5
   !> The caller's poll asked the run to stop (Ctrl-C in Python); nothing is kept.
   integer, parameter :: err_interrupted = 6
   !> Length of every error message buffer.
   integer, parameter :: errmsg_len = 1024

end module tmafm_errors

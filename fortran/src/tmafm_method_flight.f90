!> `flight_exact`: placeholder module, filled in below.
module tmafm_method_flight
   use tmafm_kinds, only: dp
   use tmafm_errors, only: err_input
   use tmafm_model, only: model_t
   use tmafm_settings, only: run_settings_t
   use tmafm_trajectory, only: trajectory_t, progress_t
   implicit none
   private
   public :: run_flight_exact
contains
   subroutine run_flight_exact(model, settings, y0, traj, ierr, errmsg, progress)
      type(model_t), intent(in) :: model
      type(run_settings_t), intent(in) :: settings
      real(dp), intent(in) :: y0(:)
      type(trajectory_t), intent(inout) :: traj
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(progress_t), intent(inout) :: progress
      ierr = err_input
      errmsg = 'flight_exact is not built yet'
   end subroutine run_flight_exact
end module tmafm_method_flight

!> The run driver: builds the trajectory and hands the integration to the chosen method.
module tmafm_driver
   use tmafm_kinds, only: dp
   use tmafm_errors, only: ok, err_input
   use tmafm_model, only: model_t
   use tmafm_settings, only: run_settings_t, known_methods, method_rk4_paper, method_rk4_event, &
      method_dopri5, method_dop853, method_flight_exact
   use tmafm_trajectory, only: trajectory_t, init_trajectory, progress_t, stop_poll
   use tmafm_method_paper, only: run_rk4_paper
   use tmafm_method_event, only: run_rk4_event
   use tmafm_method_adaptive, only: run_adaptive, pair_dopri5, pair_dop853
   use tmafm_method_flight, only: run_flight_exact
   use tmafm_observers, only: observer_t
   implicit none
   private

   public :: run_trajectory

contains

   !> Integrate `model` from (a0, adot0) at tau = 0 and sample it; ierr /= 0 on failure.
   subroutine run_trajectory(model, settings, a0, adot0, traj, ierr, errmsg, progress_unit, observer, poll)
      type(model_t), intent(in) :: model
      type(run_settings_t), intent(in) :: settings
      real(dp), intent(in) :: a0(:)
      real(dp), intent(in) :: adot0(:)
      type(trajectory_t), intent(out) :: traj
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      !> If present, a progress line is written to this unit every tenth of the run.
      integer, intent(in), optional :: progress_unit
      !> If present (every method but rk4_event), computes the per-period observables.
      type(observer_t), intent(inout), optional :: observer
      !> If present, asked at the first step and every poll_every steps (tmafm_trajectory)
      !> whether to stop: the run then ends with err_interrupted.
      procedure(stop_poll), optional :: poll
      type(progress_t) :: progress

      if (present(progress_unit)) progress%unit = progress_unit
      if (present(poll)) progress%poll => poll
      call init_trajectory(traj, settings, model%n_modes)
      select case (trim(settings%method))
      case (method_rk4_paper)
         call run_rk4_paper(model, settings, [a0, adot0], traj, ierr, errmsg, progress, observer)
      case (method_rk4_event)
         call run_rk4_event(model, settings, [a0, adot0], traj, ierr, errmsg, progress)
      case (method_dopri5)
         call run_adaptive(pair_dopri5, model, settings, [a0, adot0], traj, ierr, errmsg, progress, &
                           observer)
      case (method_dop853)
         call run_adaptive(pair_dop853, model, settings, [a0, adot0], traj, ierr, errmsg, progress, &
                           observer)
      case (method_flight_exact)
         call run_flight_exact(model, settings, [a0, adot0], traj, ierr, errmsg, progress, observer)
      case default
         ierr = err_input
         errmsg = '&solver method = '''//trim(settings%method)//''': must be one of '//known_methods
      end select
   end subroutine run_trajectory

end module tmafm_driver

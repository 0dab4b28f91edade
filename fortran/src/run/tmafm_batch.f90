!> Observed runs: one configuration integrated period by period with an observer
!> (tmafm_observers), and a batch of independent configurations run with OpenMP, each
!> thread with its own model, integrator state and observer.
module tmafm_batch
   use tmafm_kinds, only: dp
   use tmafm_errors, only: ok, err_input
   use tmafm_config, only: config_t
   use tmafm_model, only: model_t
   use tmafm_settings, only: run_settings_t, method_rk4_paper, method_dopri5, method_dop853, &
      method_flight_exact, check_run_size
   use tmafm_trajectory, only: trajectory_t
   use tmafm_driver, only: run_trajectory
   use tmafm_simulation, only: prepare_model
   use tmafm_observers, only: observer_t
   use tmafm_units, only: scales_t, scales_from_physical
   use tmafm_text, only: int_text, real_text
   implicit none
   private

   public :: observe_options_t, observe_config, observe_batch, config_scales, max_observed_periods

   !> Most periods one observed run may integrate.
   integer, parameter :: max_observed_periods = 10000000
   !> Most harmonics and largest steady period looked for.
   integer, parameter :: max_harmonics = 64, max_p_max = 1000

   !> What an observed run computes and when it stops.
   type :: observe_options_t
      !> Periods to integrate at most.
      integer :: max_periods = 100
      !> Largest steady period looked for.
      integer :: p_max = 8
      !> Tolerance of the Poincare repeats, relative to the orbit's size.
      real(dp) :: tol = 1.0e-6_dp
      !> Repeats in a row that confirm a steady period.
      integer :: repeats = 3
      !> Harmonics of V_T reported (1 = the fundamental only).
      integer :: harmonics = 3
      !> Stop at the first steady state found.
      logical :: stop_at_steady = .true.
   end type observe_options_t

contains

   !> Refuse options out of range; the message names the option and its value.
   subroutine check_options(options, ierr, errmsg)
      type(observe_options_t), intent(in) :: options
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      ierr = err_input
      errmsg = ''
      if (options%max_periods < 1 .or. options%max_periods > max_observed_periods) then
         errmsg = 'observe max_periods = '//int_text(options%max_periods)//': must be 1 to '// &
                  int_text(max_observed_periods)
      else if (options%p_max < 1 .or. options%p_max > max_p_max) then
         errmsg = 'observe p_max = '//int_text(options%p_max)//': must be 1 to '//int_text(max_p_max)
      else if (.not. (options%tol > 0 .and. options%tol < 1)) then
         errmsg = 'observe steady_tol = '//real_text(options%tol)//': must be > 0 and < 1'
      else if (options%repeats < 1 .or. options%repeats > max_observed_periods) then
         errmsg = 'observe steady_repeats = '//int_text(options%repeats)//': must be >= 1'
      else if (options%harmonics < 1 .or. options%harmonics > max_harmonics) then
         errmsg = 'observe harmonics = '//int_text(options%harmonics)//': must be 1 to '// &
                  int_text(max_harmonics)
      else
         ierr = ok
      end if
   end subroutine check_options

   !> The SI scales of a configuration (known only when it came from &physical).
   pure function config_scales(config) result(scales)
      type(config_t), intent(in) :: config
      type(scales_t) :: scales
      if (config%from_physical) scales = scales_from_physical(config%physical)
   end function config_scales

   !> Integrate a configuration from tau = 0 for at most options%max_periods drive periods,
   !> filling `observer` (its N already chosen, or chosen here).  Every method but rk4_event
   !> (whose restarted steps have no single dense output to feed).
   subroutine observe_config(config, options, observer, ierr, errmsg)
      type(config_t), intent(in) :: config
      type(observe_options_t), intent(in) :: options
      type(observer_t), intent(inout) :: observer
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(config_t) :: chosen
      type(model_t) :: model
      type(run_settings_t) :: settings
      type(trajectory_t) :: traj
      real(dp) :: period
      integer :: n

      call check_options(options, ierr, errmsg)
      if (ierr /= ok) return
      select case (trim(config%solver%method))
      case (method_rk4_paper, method_dopri5, method_dop853, method_flight_exact)
      case default
         ierr = err_input
         errmsg = '&solver method = '''//trim(config%solver%method)//''': observables are '// &
                  'computed for ''rk4_paper'', ''dopri5'', ''dop853'' and ''flight_exact'''
         return
      end select
      if (.not. (config%scene%omega > 0)) then
         ierr = err_input
         errmsg = '&scene omega = '//real_text(config%scene%omega)//': observables need a drive '// &
                  'period (omega > 0)'
         return
      end if
      call prepare_model(config, chosen, model, ierr, errmsg)
      if (ierr /= ok) return
      n = chosen%n_modes
      period = 2*acos(-1.0_dp)/model%scene%omega
      settings = chosen%solver
      ! No samples kept: the run ends at the last period boundary, or when the observer stops it.
      settings%tau_end = options%max_periods*period
      settings%sample_dtau = settings%tau_end
      call check_run_size(settings, n, ierr, errmsg)
      if (ierr /= ok) return
      call observer%init(model, options%max_periods, options%harmonics, options%p_max, options%tol, &
                         options%repeats, options%stop_at_steady, [chosen%a0(1:n), chosen%adot0(1:n)])
      call run_trajectory(model, settings, chosen%a0(1:n), chosen%adot0(1:n), traj, ierr, errmsg, &
                          observer=observer)
   end subroutine observe_config

   !> Observe every configuration, on `threads` OpenMP threads (0: the OpenMP default);
   !> ierr(k), errmsg(k) belong to configs(k).  Results do not depend on the thread count.
   subroutine observe_batch(configs, options, observers, ierr, errmsg, threads)
      type(config_t), intent(in) :: configs(:)
      type(observe_options_t), intent(in) :: options
      type(observer_t), intent(inout) :: observers(:)
      integer, intent(out) :: ierr(:)
      character(len=*), intent(out) :: errmsg(:)
      integer, intent(in) :: threads
      integer :: k
      if (threads > 0) then
         !$omp parallel do schedule(dynamic) num_threads(threads)
         do k = 1, size(configs)
            call observe_config(configs(k), options, observers(k), ierr(k), errmsg(k))
         end do
         !$omp end parallel do
      else
         !$omp parallel do schedule(dynamic)
         do k = 1, size(configs)
            call observe_config(configs(k), options, observers(k), ierr(k), errmsg(k))
         end do
         !$omp end parallel do
      end if
   end subroutine observe_batch

end module tmafm_batch

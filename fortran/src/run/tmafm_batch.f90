!> Observed runs: one configuration integrated period by period with an observer
!> (tmafm_observers), and a batch of independent configurations run with OpenMP, each
!> thread with its own model, integrator state and observer.
!>
!> A caller's poll (tmafm_trajectory stop_poll) is asked only on the calling thread (OpenMP
!> thread 0: Python's GIL can sensibly be taken only there), by the runs it takes; once it asks
!> to stop, that run ends with err_interrupted and every input not yet started is skipped with
!> err_interrupted by every thread (the runs other threads are in go on to their end).
module tmafm_batch
   use tmafm_kinds, only: dp
   use tmafm_errors, only: ok, err_input, err_interrupted
   use tmafm_config, only: config_t
   use tmafm_model, only: model_t
   use tmafm_settings, only: run_settings_t, method_rk4_paper, method_dopri5, method_dop853, &
      method_flight_exact, check_run_size
   use tmafm_trajectory, only: trajectory_t, stop_poll
   use tmafm_driver, only: run_trajectory
   use tmafm_simulation, only: prepare_model, refuse_instrument
   use tmafm_observers, only: observer_t, group_all
   use tmafm_steady_state, only: jitter_t, jitter_init, adaptive_factor, steady_harmonic
   use tmafm_units, only: scales_t, scales_from_physical
   use tmafm_text, only: int_text, real_text
   use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
   !$ use omp_lib, only: omp_get_thread_num
   implicit none
   private

   public :: observe_options_t, observe_config, observe_batch, observe_states, config_scales, &
      max_observed_periods, max_harmonics, max_p_max, steady_harmonics, steady_evidence, steady_window

   !> Most periods one observed run may integrate.
   integer, parameter :: max_observed_periods = 10000000
   !> Latest time an observed run may reach: the largest &solver tau_end (tmafm_keys).
   real(dp), parameter :: max_observed_tau = 1.0e7_dp
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
      !> The observable groups computed (bits tmafm_observers::group_*).
      integer :: groups = group_all
      !> Known attractors (none when unallocated or size(attractor_first) < 2): orbit k is
      !> attractor_points(:, attractor_first(k):attractor_first(k+1)-1), one column per
      !> Poincare point (2N rows); `confirm` points in a row within capture (relative to the
      !> orbit's size) of one, each closer than the one before, label the run.
      real(dp), allocatable :: attractor_points(:, :)
      integer, allocatable :: attractor_first(:)
      integer :: confirm = 3
      real(dp) :: capture = 1.0e-6_dp
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
      else if (options%groups < 0 .or. options%groups > group_all) then
         errmsg = 'observe groups = '//int_text(options%groups)//': must be 0 to '//int_text(group_all)
      else if (options%confirm < 1 .or. options%confirm > max_observed_periods) then
         errmsg = 'observe confirm = '//int_text(options%confirm)//': must be >= 1'
      else if (.not. (options%capture > 0 .and. options%capture < 1)) then
         errmsg = 'observe capture = '//real_text(options%capture)//': must be > 0 and < 1'
      else if (.not. attractors_valid(options)) then
         errmsg = 'observe attractors: attractor_first must rise from 1 to the number of points + 1, '// &
                  'and every point must be finite'
      else
         ierr = ok
      end if
   end subroutine check_options

   !> .true. when the known attractors are absent or well formed: offsets rising from 1 to the
   !> number of columns + 1, finite points.
   pure logical function attractors_valid(options)
      type(observe_options_t), intent(in) :: options
      integer :: k
      attractors_valid = .true.
      if (.not. allocated(options%attractor_first)) return
      if (size(options%attractor_first) < 2) return
      attractors_valid = .false.
      if (.not. allocated(options%attractor_points)) return
      if (options%attractor_first(1) /= 1) return
      if (options%attractor_first(size(options%attractor_first)) /= size(options%attractor_points, 2) + 1) return
      do k = 1, size(options%attractor_first) - 1
         if (options%attractor_first(k + 1) <= options%attractor_first(k)) return
      end do
      if (.not. all(abs(options%attractor_points) <= huge(1.0_dp))) return
      attractors_valid = .true.
   end function attractors_valid

   !> The SI scales of a configuration (known only when it came from &physical).
   pure function config_scales(config) result(scales)
      type(config_t), intent(in) :: config
      type(scales_t) :: scales
      if (config%from_physical) scales = scales_from_physical(config%physical)
   end function config_scales

   !> Integrate a configuration from tau = 0 for at most options%max_periods drive periods,
   !> filling `observer` (its N already chosen, or chosen here).  Every method but rk4_event
   !> (whose restarted steps have no single dense output to feed).
   subroutine observe_config(config, options, observer, ierr, errmsg, poll)
      type(config_t), intent(in) :: config
      type(observe_options_t), intent(in) :: options
      type(observer_t), intent(inout) :: observer
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      !> If present, the run (and the comparison runs of an automatic N) poll it.
      procedure(stop_poll), optional :: poll
      type(config_t) :: chosen
      type(model_t) :: model
      type(run_settings_t) :: settings
      integer :: n

      call prepare_observed(config, options, chosen, model, settings, ierr, errmsg, poll)
      if (ierr /= ok) return
      n = chosen%n_modes
      call observe_prepared(model, settings, options, [chosen%a0(1:n), chosen%adot0(1:n)], observer, &
                            ierr, errmsg, poll)
   end subroutine observe_config

   !> The checks, the model and the run settings of an observed run of `config`.
   subroutine prepare_observed(config, options, chosen, model, settings, ierr, errmsg, poll)
      type(config_t), intent(in) :: config
      type(observe_options_t), intent(in) :: options
      type(config_t), intent(out) :: chosen
      type(model_t), intent(out) :: model
      type(run_settings_t), intent(out) :: settings
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      !> If present, the comparison runs of an automatic N poll it.
      procedure(stop_poll), optional :: poll
      real(dp) :: period

      call check_options(options, ierr, errmsg)
      if (ierr /= ok) return
      call refuse_instrument(config, 'an observed run', ierr, errmsg)
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
      call prepare_model(config, chosen, model, ierr, errmsg, poll)
      if (ierr /= ok) return
      ! The period of the drive: the common period of its tones (one tone: 2 pi/Omega).
      period = 2*acos(-1.0_dp)/model%drive%fundamental
      settings = chosen%solver
      ! No samples kept: the run ends at the last period boundary, or when the observer stops it.
      settings%tau_end = options%max_periods*period
      ! The same bound as &solver tau_end's: omega = 1e-300 made a run to tau = 6E+302 that
      ! never returned (issue 27, F10).
      if (.not. (settings%tau_end <= max_observed_tau)) then
         ierr = err_input
         errmsg = '&scene omega = '//real_text(config%scene%omega)//': observe max_periods = '// &
                  int_text(options%max_periods)//' drive periods would run to tau = '// &
                  real_text(settings%tau_end)//', beyond the largest &solver tau_end, '// &
                  real_text(max_observed_tau)//' (raise omega or lower max_periods)'
         return
      end if
      settings%sample_dtau = settings%tau_end
      ! Observables are of the whole run: an output window is for the samples only.
      settings%first_sample = 0
      call check_run_size(settings, chosen%n_modes, ierr, errmsg)
   end subroutine prepare_observed

   !> One observed run of a prepared model from the state y0 = [a0, adot0] at tau = 0.
   subroutine observe_prepared(model, settings, options, y0, observer, ierr, errmsg, poll)
      type(model_t), intent(in) :: model
      type(run_settings_t), intent(in) :: settings
      type(observe_options_t), intent(in) :: options
      real(dp), intent(in) :: y0(:)
      type(observer_t), intent(inout) :: observer
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      !> If present, the run polls it.
      procedure(stop_poll), optional :: poll
      type(trajectory_t) :: traj
      type(jitter_t) :: jitter
      real(dp) :: tol
      ! The run's state: y0, and a viscoelastic sample's dashpot at rest (run_trajectory).
      real(dp) :: y_run(model%n_state)
      integer :: n

      n = size(y0)/2
      ierr = ok
      errmsg = ''
      y_run = 0
      y_run(1:2*n) = y0(1:2*n)
      call steady_tolerance(model, settings, options%tol, tol, jitter)
      call observer%init(model, options%max_periods, options%harmonics, options%p_max, tol, &
                         options%repeats, options%stop_at_steady, y_run, options%groups, jitter)
      if (allocated(options%attractor_first)) then
         if (size(options%attractor_first) >= 2) then
            if (size(options%attractor_points, 1) /= 2*n) then
               ierr = err_input
               errmsg = 'observe attractors: points have '//int_text(size(options%attractor_points, 1))// &
                        ' components, the run''s state has '//int_text(2*n)
               return
            end if
            call observer%set_attractors(options%attractor_points, options%attractor_first, options%confirm, &
                                         options%capture)
         end if
      end if
      call run_trajectory(model, settings, y0(1:n), y0(n + 1:2*n), traj, ierr, errmsg, &
                          observer=observer, poll=poll)
   end subroutine observe_prepared

   !> The steady test of a run follows its method's accuracy (docs/observables.md, "Steady
   !> state"): rk4_paper's points repeat only to the jitter of its unlocated switches, whose
   !> level (tmafm_steady_state jitter_level, from dtau and dtau/contact_refine) floors the
   !> repeats; an adaptive method's relative tolerance is at least adaptive_factor * rtol.
   subroutine steady_tolerance(model, settings, steady_tol, tol, jitter)
      type(model_t), intent(in) :: model
      type(run_settings_t), intent(in) :: settings
      real(dp), intent(in) :: steady_tol
      real(dp), intent(out) :: tol
      type(jitter_t), intent(out) :: jitter
      tol = steady_tol
      select case (trim(settings%method))
      case (method_rk4_paper)
         jitter = jitter_init(model, .true., settings%dtau, settings%dtau/settings%contact_refine)
      case default
         jitter = jitter_init(model, .false., 0.0_dp, 0.0_dp)
         tol = min(max(tol, adaptive_factor*settings%rtol), 0.5_dp)
      end select
   end subroutine steady_tolerance

   !> How many of an observed run's last periods its steady values average: the period found,
   !> or with none the lag of the closest repeat (the best candidate: a double-tap orbit that
   !> did not settle within steady_tol alternates, and its last period alone gave a negative
   !> dissipated_viscoelastic; issue 27), or 1; never more than the periods run (0 if none).
   pure integer function steady_window(observer) result(last)
      type(observer_t), intent(in) :: observer
      last = observer%found_period
      if (last < 1) last = observer%closest_lag
      last = min(max(last, 1), observer%n_periods)
   end function steady_window

   !> The steady harmonics of an observed run: for each harmonic k, the harmonic of V_T over
   !> its last steady_window periods (tmafm_steady_state steady_harmonic: the mean of the
   !> per-period Fourier coefficients, its phase free of the wrap at +-180); NaN when no
   !> period was run.
   subroutine steady_harmonics(observer, amplitude, phase)
      type(observer_t), intent(in) :: observer
      real(dp), intent(out) :: amplitude(:)
      real(dp), intent(out) :: phase(:)
      integer :: m, last, k
      amplitude = ieee_value(1.0_dp, ieee_quiet_nan)
      phase = amplitude
      m = observer%n_periods
      last = steady_window(observer)
      if (last < 1) return
      do k = 1, min(size(amplitude), observer%harmonics)
         call steady_harmonic(observer%harmonic_amplitude(m - last + 1:m, k), &
                              observer%harmonic_phase(m - last + 1:m, k), amplitude(k), phase(k))
      end do
   end subroutine steady_harmonics

   !> The steady test's evidence of an observed run: [reason (tmafm_steady_state unsteady_*,
   !> 0 when steady), the closest repeat relative to the orbit's size, its lag, the relative
   !> tolerance used, the jitter level of the last point relative to the orbit's size].
   pure function steady_evidence(observer) result(evidence)
      type(observer_t), intent(in) :: observer
      real(dp) :: evidence(5)
      real(dp) :: size_orbit
      integer :: m
      m = observer%n_periods
      size_orbit = maxval(abs(observer%poincare(:, max(0, m - observer%p_max - observer%repeats):m)))
      if (.not. (size_orbit > 0)) size_orbit = tiny(1.0_dp)
      evidence = [real(observer%reason, dp), observer%closest, real(observer%closest_lag, dp), observer%tol, &
                  observer%jitter_floor(m)/size_orbit]
      if (observer%closest >= huge(1.0_dp)) evidence(2) = ieee_value(1.0_dp, ieee_quiet_nan)
   end function steady_evidence

   !> Observe every configuration, on `threads` OpenMP threads (0: the OpenMP default);
   !> ierr(k), errmsg(k) belong to configs(k).  Results do not depend on the thread count.
   !> With a poll, the calling thread's runs poll it; once one is stopped, the inputs not yet
   !> started get err_interrupted (see the module's doc).
   subroutine observe_batch(configs, options, observers, ierr, errmsg, threads, poll)
      type(config_t), intent(in) :: configs(:)
      type(observe_options_t), intent(in) :: options
      type(observer_t), intent(inout) :: observers(:)
      integer, intent(out) :: ierr(:)
      character(len=*), intent(out) :: errmsg(:)
      integer, intent(in) :: threads
      procedure(stop_poll), optional :: poll
      logical :: stopped
      integer :: k
      stopped = .false.
      if (threads > 0) then
         !$omp parallel do schedule(dynamic) num_threads(threads) shared(stopped)
         do k = 1, size(configs)
            call batch_input(stopped, ierr(k), errmsg(k), config=configs(k), options=options, &
                             observer=observers(k), poll=poll)
         end do
         !$omp end parallel do
      else
         !$omp parallel do schedule(dynamic) shared(stopped)
         do k = 1, size(configs)
            call batch_input(stopped, ierr(k), errmsg(k), config=configs(k), options=options, &
                             observer=observers(k), poll=poll)
         end do
         !$omp end parallel do
      end if
   end subroutine observe_batch

   !> One input of a batch, on whichever OpenMP thread took it: skipped with err_interrupted
   !> once `stopped` (shared by the threads) is set; else observe_config(config, ...) or, with
   !> y0, observe_prepared(model, settings, ..., y0, ...), passing the poll only on thread 0
   !> (the caller's thread), and setting `stopped` when that run was interrupted.
   subroutine batch_input(stopped, ierr, errmsg, config, model, settings, y0, options, observer, poll)
      logical, intent(inout) :: stopped
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(config_t), intent(in), optional :: config
      type(model_t), intent(in), optional :: model
      type(run_settings_t), intent(in), optional :: settings
      real(dp), intent(in), optional :: y0(:)
      type(observe_options_t), intent(in) :: options
      type(observer_t), intent(inout) :: observer
      procedure(stop_poll), optional :: poll
      logical :: skip, caller
      !$omp atomic read
      skip = stopped
      if (skip) then
         ierr = err_interrupted
         errmsg = 'observe: not run, an earlier run of the batch was interrupted (Ctrl-C)'
         return
      end if
      caller = .true.
      !$ caller = omp_get_thread_num() == 0
      if (present(y0)) then
         if (caller .and. present(poll)) then
            call observe_prepared(model, settings, options, y0, observer, ierr, errmsg, poll)
         else
            call observe_prepared(model, settings, options, y0, observer, ierr, errmsg)
         end if
      else
         if (caller .and. present(poll)) then
            call observe_config(config, options, observer, ierr, errmsg, poll)
         else
            call observe_config(config, options, observer, ierr, errmsg)
         end if
      end if
      if (ierr == err_interrupted) then
         !$omp atomic write
         stopped = .true.
      end if
   end subroutine batch_input

   !> Observe one configuration from many initial states, states(:, k) = [a0, adot0] of run k
   !> (2N rows, N the configuration's, already chosen), on `threads` OpenMP threads (0: the
   !> OpenMP default): the configuration is checked and its model built once, and shared.
   !> ierr = err_input (and nothing runs) for a bad configuration, options or state (each
   !> component finite with |value| <= 1, as &initial); run k's failure is run_ierr(k),
   !> run_errmsg(k).  Results equal observe_batch's on the same inputs.
   subroutine observe_states(config, states, options, observers, ierr, errmsg, run_ierr, run_errmsg, &
                             threads, poll)
      type(config_t), intent(in) :: config
      real(dp), intent(in) :: states(:, :)
      type(observe_options_t), intent(in) :: options
      type(observer_t), intent(inout) :: observers(:)
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      integer, intent(out) :: run_ierr(:)
      character(len=*), intent(out) :: run_errmsg(:)
      integer, intent(in) :: threads
      !> If present, polled as observe_batch does (the comparison runs of an automatic N too).
      procedure(stop_poll), optional :: poll
      type(config_t) :: chosen
      type(model_t) :: model
      type(run_settings_t) :: settings
      logical :: stopped
      integer :: k, j

      run_ierr = ok
      run_errmsg = ''
      stopped = .false.
      call prepare_observed(config, options, chosen, model, settings, ierr, errmsg, poll)
      if (ierr /= ok) return
      if (size(states, 1) /= 2*chosen%n_modes) then
         ierr = err_input
         errmsg = 'observe states: '//int_text(size(states, 1))//' components per state, the input''s '// &
                  'N = '//int_text(chosen%n_modes)//' needs '//int_text(2*chosen%n_modes)
         return
      end if
      do k = 1, size(states, 2)
         do j = 1, size(states, 1)
            if (.not. (abs(states(j, k)) <= 1)) then
               ierr = err_input
               errmsg = 'observe state '//int_text(k)//' component '//int_text(j)//' = '// &
                        real_text(states(j, k))//': must be finite with |value| <= 1 (gap units)'
               return
            end if
         end do
      end do
      if (threads > 0) then
         !$omp parallel do schedule(dynamic) num_threads(threads) shared(stopped)
         do k = 1, size(states, 2)
            call batch_input(stopped, run_ierr(k), run_errmsg(k), model=model, settings=settings, &
                             y0=states(:, k), options=options, observer=observers(k), poll=poll)
         end do
         !$omp end parallel do
      else
         !$omp parallel do schedule(dynamic) shared(stopped)
         do k = 1, size(states, 2)
            call batch_input(stopped, run_ierr(k), run_errmsg(k), model=model, settings=settings, &
                             y0=states(:, k), options=options, observer=observers(k), poll=poll)
         end do
         !$omp end parallel do
      end if
      ! An interrupted batch fails as a whole: its runs' results are not kept.
      if (stopped) then
         ierr = err_interrupted
         errmsg = run_errmsg(findloc(run_ierr, err_interrupted, 1))
      end if
   end subroutine observe_states

end module tmafm_batch

!> From a resolved configuration to a sampled trajectory: chooses N when asked, builds the
!> model, then runs it.
module tmafm_simulation
   use tmafm_kinds, only: dp
   use tmafm_errors, only: ok, err_input
   use tmafm_modes, only: max_modes
   use tmafm_contact, only: law_hertz, law_dmt
   use tmafm_model, only: model_t, init_model
   use tmafm_driver, only: run_trajectory
   use tmafm_trajectory, only: trajectory_t, stop_poll
   use tmafm_config, only: config_t
   use tmafm_settings, only: method_dopri5, check_run_size
   use tmafm_namelist, only: config_errata, read_config
   use tmafm_text, only: int_text, real_text, short_real_text
   implicit none
   private

   public :: build_model, prepare_model, simulate, choose_mode_count, load_model

   !> Tolerances of the runs that compare N and N+1.
   real(dp), parameter :: comparison_rtol = 1.0e-10_dp, comparison_atol = 1.0e-16_dp

contains

   !> The model a configuration describes.
   subroutine build_model(config, model, ierr, errmsg)
      type(config_t), intent(in) :: config
      type(model_t), intent(out) :: model
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      integer :: law
      law = law_hertz
      if (trim(config%contact_law) == 'dmt') law = law_dmt
      call init_model(model, config%n_modes, config%scene, law, config_errata(config), ierr, errmsg)
   end subroutine build_model

   !> The model of a namelist file, for callers that already know N (n_modes > 0): an input
   !> asking for another fixed N is an error; an automatic one takes n_modes.
   subroutine load_model(path, n_modes, model, ierr, errmsg)
      character(len=*), intent(in) :: path
      integer, intent(in) :: n_modes
      type(model_t), intent(out) :: model
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(config_t) :: config

      call read_config(path, config, ierr, errmsg)
      if (ierr /= ok) return
      if (config%auto_modes) then
         config%auto_modes = .false.
         config%n_modes = n_modes
      else if (config%n_modes /= n_modes) then
         ierr = err_input
         write (errmsg, '(a,i0,a,i0)') 'n_modes = ', n_modes, ' of the call does not match '// &
            '&model n_modes = ', config%n_modes
         return
      end if
      call build_model(config, model, ierr, errmsg)
   end subroutine load_model

   !> For &model n_modes = 0: the smallest N, counting from N = 1, whose V_T over mode_horizon
   !> agrees with N+1's within mode_tol (relative to the range of V_T); never fewer than the
   !> last mode with a nonzero &initial value, so no given initial value is dropped (the
   !> comparison runs at smaller N start from the first N values: the initial state projected
   !> on those modes).  Sets config%n_modes and the evidence (one difference per N compared).
   !> The comparison runs use dopri5 at tight tolerances, whatever the run's own method, so
   !> that integration error (or a fixed step past RK4's stability limit) cannot decide N.
   recursive subroutine choose_mode_count(config, ierr, errmsg, progress_unit, poll)
      type(config_t), intent(inout) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      !> If present, one line per comparison goes to this unit.
      integer, intent(in), optional :: progress_unit
      !> If present, every comparison run polls it (run_trajectory) and stops when asked.
      procedure(stop_poll), optional :: poll
      type(config_t) :: trial
      type(trajectory_t) :: lower, upper
      real(dp) :: difference
      integer :: n

      ierr = ok
      errmsg = ''
      if (.not. config%auto_modes .or. config%n_mode_differences > 0) return
      trial = config
      trial%auto_modes = .false.
      trial%solver%tau_end = config%mode_horizon
      trial%solver%sample_dtau = min(config%solver%sample_dtau, config%mode_horizon/100)
      trial%solver%method = method_dopri5
      trial%solver%rtol = comparison_rtol
      trial%solver%atol = comparison_atol
      config%n_mode_differences = 0
      n = 1
      trial%n_modes = n
      call simulate(trial, lower, ierr, errmsg, poll=poll)
      if (ierr /= ok) return
      do while (n < max_modes)
         trial%n_modes = n + 1
         call simulate(trial, upper, ierr, errmsg, poll=poll)
         if (ierr /= ok) return
         difference = maxval(abs(upper%vt - lower%vt))/max(tiny(1.0_dp), &
                                                           maxval(upper%vt) - minval(upper%vt))
         config%n_mode_differences = config%n_mode_differences + 1
         config%mode_differences(config%n_mode_differences) = difference
         if (present(progress_unit)) then
            write (progress_unit, '(a)') 'tmafm: choosing N: N = '//int_text(n)//' against '// &
               int_text(n + 1)//' over mode_horizon = '//real_text(config%mode_horizon)// &
               ': max|dV_T|/range = '//short_real_text(difference, 3)//' (mode_tol = '// &
               real_text(config%mode_tol)//')'
            flush (progress_unit)
         end if
         if (difference <= config%mode_tol) exit
         call move_alloc(upper%vt, lower%vt)
         n = n + 1
      end do
      config%n_modes = max(n, last_nonzero(config%a0), last_nonzero(config%adot0))
   end subroutine choose_mode_count

   !> Index of the last nonzero entry (0 if none).
   pure integer function last_nonzero(values)
      real(dp), intent(in) :: values(:)
      integer :: j
      last_nonzero = 0
      do j = size(values), 1, -1
         if (values(j) /= 0) then
            last_nonzero = j
            return
         end if
      end do
   end function last_nonzero

   !> The configuration with N chosen (when &model n_modes = 0), and the model it describes:
   !> the common first step of every run.
   recursive subroutine prepare_model(config, chosen, model, ierr, errmsg, poll)
      type(config_t), intent(in) :: config
      type(config_t), intent(out) :: chosen
      type(model_t), intent(out) :: model
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      !> If present, the comparison runs of an automatic N poll it (choose_mode_count).
      procedure(stop_poll), optional :: poll
      chosen = config
      call choose_mode_count(chosen, ierr, errmsg, poll=poll)
      if (ierr /= ok) return
      call build_model(chosen, model, ierr, errmsg)
   end subroutine prepare_model

   !> Run a configuration; `traj` holds the samples when ierr == ok.
   recursive subroutine simulate(config, traj, ierr, errmsg, progress_unit, poll)
      type(config_t), intent(in) :: config
      type(trajectory_t), intent(out) :: traj
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      !> If present, progress lines go to this unit.
      integer, intent(in), optional :: progress_unit
      !> If present, the run (and the comparison runs of an automatic N) ask it at the first
      !> step and every poll_every steps whether to stop: ierr = err_interrupted then.
      procedure(stop_poll), optional :: poll
      type(model_t) :: model
      type(config_t) :: chosen
      integer :: n

      call prepare_model(config, chosen, model, ierr, errmsg, poll)
      if (ierr /= ok) return
      n = chosen%n_modes
      ! Every run (the comparison runs of an automatic N included) obeys the size limits.
      call check_run_size(chosen%solver, n, ierr, errmsg)
      if (ierr /= ok) return
      call run_trajectory(model, chosen%solver, chosen%a0(1:n), chosen%adot0(1:n), traj, ierr, &
                          errmsg, progress_unit, poll=poll)
   end subroutine simulate

end module tmafm_simulation

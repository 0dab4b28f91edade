!> The run driver: builds the trajectory and hands the integration to the chosen method.
module tmafm_driver
   use tmafm_kinds, only: dp
   use tmafm_errors, only: ok, err_input, err_blowup
   use tmafm_model, only: model_t
   use tmafm_settings, only: run_settings_t, known_methods, method_rk4_paper, method_rk4_event, &
      method_dopri5, method_dop853, method_flight_exact
   use tmafm_trajectory, only: trajectory_t, init_trajectory, progress_t, stop_poll
   use tmafm_method_paper, only: run_rk4_paper
   use tmafm_method_event, only: run_rk4_event
   use tmafm_method_adaptive, only: run_adaptive, pair_dopri5, pair_dop853
   use tmafm_method_flight, only: run_flight_exact
   use tmafm_observers, only: observer_t
   use tmafm_events, only: initial_phase
   use tmafm_text, only: real_text, int_text
   implicit none
   private

   public :: run_trajectory

contains

   !> Integrate `model` from (a0, adot0) at tau = 0 and sample it; ierr /= 0 on failure.
   subroutine run_trajectory(model, settings, a0, adot0, traj, ierr, errmsg, progress_unit, observer, poll, &
                             tail)
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
      !> If present, the state's components past (a, a'): a viscoelastic sample's dashpot w and
      !> a capillary meniscus's flag (a run continued from another's end, tmafm_period_stepper).
      real(dp), intent(in), optional :: tail(:)
      type(progress_t) :: progress
      real(dp) :: y0(model%n_state)

      ! The state: (a, a'), and with a viscoelastic sample its dashpot at rest, w = 0.
      y0 = 0
      y0(1:size(a0)) = a0
      y0(size(a0) + 1:size(a0) + size(adot0)) = adot0
      if (present(tail)) then
         if (size(tail) /= model%n_state - size(a0) - size(adot0)) then
            ierr = err_input
            errmsg = 'run_trajectory: the state''s tail has '//int_text(size(tail))//' components, the model''s '// &
                     int_text(model%n_state - size(a0) - size(adot0))
            return
         end if
         y0(size(a0) + size(adot0) + 1:) = tail
      end if
      if (model%sls%on .and. (settings%method == method_rk4_paper .or. settings%method == method_rk4_event)) then
         ierr = err_input
         errmsg = '&solver method = '''//trim(settings%method)//''': a viscoelastic sample (&scene '// &
                  'sls_relaxation_time > 0) needs dopri5, dop853 or flight_exact'
         return
      end if
      call check_initial_phase(model, settings, y0, ierr, errmsg)
      if (ierr /= ok) return
      if (present(progress_unit)) progress%unit = progress_unit
      if (present(poll)) progress%poll => poll
      call init_trajectory(traj, settings, model%n_modes, with_dashpot=model%sls%on, &
                           with_meniscus=model%meniscus%on)
      if (model%hysteretic .and. (trim(settings%method) == method_rk4_paper &
                                  .or. trim(settings%method) == method_rk4_event)) then
         ! The input check refuses this first (tmafm_namelist check_jkr, check_capillary); a model
         ! built otherwise too.
         ierr = err_input
         if (model%meniscus%on) then
            errmsg = "&solver method = '"//trim(settings%method)//"': does not support a capillary meniscus "// &
                     "(it breaks above the surface, a switch its loops do not locate; use dop853, dopri5 "// &
                     "or flight_exact)"
         else
            errmsg = "&solver method = '"//trim(settings%method)//"': does not support &model contact_law = "// &
                     "'jkr' (its neck breaks above the surface, a switch its loops do not locate; use dop853, "// &
                     "dopri5 or flight_exact)"
         end if
         return
      end if
      if (settings%thermal_noise == 1 .and. .not. (trim(settings%method) == method_dopri5 &
                                                     .or. trim(settings%method) == method_dop853 &
                                                     .or. trim(settings%method) == method_flight_exact)) then
         ! The input check refuses this first (tmafm_namelist check_thermal).
         ierr = err_input
         errmsg = "&solver thermal_noise = 1: needs method 'dop853', 'dopri5' or 'flight_exact' (method = '"// &
                  trim(settings%method)//"')"
         return
      end if
      select case (trim(settings%method))
      case (method_rk4_paper)
         call run_rk4_paper(model, settings, y0, traj, ierr, errmsg, progress, observer)
      case (method_rk4_event)
         call run_rk4_event(model, settings, y0, traj, ierr, errmsg, progress)
      case (method_dopri5)
         call run_adaptive(pair_dopri5, model, settings, y0, traj, ierr, errmsg, progress, &
                           observer)
      case (method_dop853)
         call run_adaptive(pair_dop853, model, settings, y0, traj, ierr, errmsg, progress, &
                           observer)
      case (method_flight_exact)
         call run_flight_exact(model, settings, y0, traj, ierr, errmsg, progress, observer)
      case default
         ierr = err_input
         errmsg = '&solver method = '''//trim(settings%method)//''': must be one of '//known_methods
      end select
      if (ierr == ok) call check_reported(settings, traj, ierr, errmsg, observer)
   end subroutine run_trajectory

   !> &initial in_contact against the start state: in contact (1) needs V_T at most where the phase
   !> ends (0, or a JKR neck's pull-off gap), in flight (0) needs V_T >= 0; the fixed-step
   !> methods take the phase from V_T's sign, so a given phase must be that one there.
   subroutine check_initial_phase(model, settings, y0, ierr, errmsg)
      type(model_t), intent(in) :: model
      type(run_settings_t), intent(in) :: settings
      real(dp), intent(in) :: y0(:)
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      real(dp) :: vt, offset, offset_rate
      character(len=:), allocatable :: given
      ierr = ok
      errmsg = ''
      if (settings%initial_contact < 0) return
      given = '&initial in_contact = '//int_text(settings%initial_contact)
      vt = model%tip_gap(0.0_dp, y0)
      call model%switch_offset(y0, .true., vt, 0.0_dp, offset, offset_rate)
      if (settings%initial_contact == 1 .and. vt > offset) then
         ierr = err_input
         errmsg = given//': the start state has V_T = '//real_text(vt)//', past where contact ends (V_T <= '// &
                  real_text(offset)//')'
      else if (settings%initial_contact == 0 .and. vt < 0) then
         ierr = err_input
         errmsg = given//': the start state has V_T = '//real_text(vt)//' < 0, the tip below the surface'
      else if ((settings%method == method_rk4_paper .or. settings%method == method_rk4_event) .and. &
               ((settings%initial_contact == 1) .neqv. initial_phase(model, 0.0_dp, y0))) then
         ierr = err_input
         errmsg = given//": &solver method = '"//trim(settings%method)//"' takes the start's phase from V_T's "// &
                  'sign, here the other phase (V_T = '//real_text(vt)//')'
      end if
   end subroutine check_initial_phase

   !> Fail with err_blowup when an |a_j| the run reports exceeds &solver blowup_limit: at an
   !> output sample, or in an observed run at a Poincare point or a located modal extremum.
   !> The methods check every step end (and flight_exact each flight's located maximum) as they
   !> go; the samples and extrema between step ends are checked here, once the run is done.
   subroutine check_reported(settings, traj, ierr, errmsg, observer)
      type(run_settings_t), intent(in) :: settings
      type(trajectory_t), intent(in) :: traj
      integer, intent(inout) :: ierr
      character(len=*), intent(inout) :: errmsg
      type(observer_t), intent(in), optional :: observer
      real(dp) :: limit, worst
      integer :: filled, i, j, n, m, e

      limit = settings%blowup_limit
      n = size(traj%a, 2)
      filled = traj%next_sample - 1
      do j = 1, n
         if (filled < 1) exit
         if (column_max(filled, traj%a(1:filled, j)) <= limit) cycle
         do i = 1, filled
            if (abs(traj%a(i, j)) > limit) exit
         end do
         ierr = err_blowup
         write (errmsg, '(a,es13.6e3,a,i0,a,es13.6e3,a,es10.3e3,a)') 'blow-up at tau = ', traj%tau(i), &
            ': |a_', j, '| = ', abs(traj%a(i, j)), ' > &solver blowup_limit = ', limit, &
            ' at an output sample, between step ends; check the scene (damping, drive, initial '// &
            'state), tighten &solver rtol, or raise &solver blowup_limit if larger amplitudes are expected'
         return
      end do
      if (.not. present(observer)) return
      m = observer%n_periods
      if (m < 1) return
      do j = 1, n
         worst = maxval(abs(observer%poincare(j, 1:m)))
         do e = 1, size(observer%modal_extrema, 3)
            ! NaN (a period without such a part, or extrema not asked for) counts as nothing.
            worst = max(worst, maxval(abs(observer%modal_extrema(1:m, j, e)), &
                                      mask=abs(observer%modal_extrema(1:m, j, e)) <= huge(1.0_dp)))
         end do
         if (worst <= limit) cycle
         ierr = err_blowup
         write (errmsg, '(a,i0,a,es13.6e3,a,es10.3e3,a)') 'blow-up: |a_', j, &
            '| reaches ', worst, ' > &solver blowup_limit = ', limit, &
            ' between step ends (located in the observed periods); check the scene (damping, drive, '// &
            'initial state), tighten &solver rtol, or raise &solver blowup_limit if larger amplitudes are expected'
         return
      end do
   end subroutine check_reported

   !> The largest |x(i)|, i = 1..count (a loop the compiler vectorises: about one instruction
   !> per sample, where maxval's NaN rules cost seven).
   pure real(dp) function column_max(count, x)
      integer, intent(in) :: count
      real(dp), intent(in) :: x(count)
      real(dp) :: lanes(4)
      integer :: i
      ! Four running maxima (lanes of a vector register), so the loop has no serial dependence.
      lanes = 0
      do i = 1, count - 3, 4
         lanes = max(lanes, abs(x(i:i + 3)))
      end do
      do i = 4*(count/4) + 1, count
         lanes(1) = max(lanes(1), abs(x(i)))
      end do
      column_max = maxval(lanes)
   end function column_max

end module tmafm_driver

!> `dopri5`: adaptive Dormand-Prince 5(4) under rtol/atol, with every switch V_T = 0,
!> grazing ones included, located to round-off on the dense output by a Brent search.
!> The run restarts at the switch in the new phase.  `advance_adaptive` is also the
!> in-contact integrator of `flight_exact`.
module tmafm_method_adaptive
   use tmafm_kinds, only: dp
   use tmafm_errors, only: ok, err_runtime
   use tmafm_model, only: model_t
   use tmafm_settings, only: run_settings_t
   use tmafm_trajectory, only: trajectory_t, check_blowup, progress_t
   use tmafm_dopri5, only: dopri5_stepper_t, step_controller_t, error_norm
   use tmafm_events, only: no_event, event_candidate, step_event_test, initial_phase, phase_sign, &
      switch_margin
   use tmafm_roots, only: bracketed_root_t
   implicit none
   private

   public :: run_dopri5, adaptive_state_t

   !> Where an adaptive integration stands: time, state, phase, next step, and registers.
   type :: adaptive_state_t
      !> Current time.
      real(dp) :: tau = 0
      !> Current state (a, a').
      real(dp), allocatable :: y(:)
      !> Current phase.
      logical :: in_contact = .false.
      !> Step to try next.
      real(dp) :: h = 0
      !> The stepper and its registers.
      type(dopri5_stepper_t) :: stepper
      !> The step-size controller.
      type(step_controller_t) :: controller
   contains
      !> Allocate for a state y0 at tau0 and set the first trial step.
      procedure :: init => adaptive_init
      !> Integrate, sampling into traj, until traj is complete or (if asked) the phase changes.
      procedure :: advance => adaptive_advance
   end type adaptive_state_t

contains

   !> Integrate from y0 at tau = 0 until every sample of traj is filled.
   subroutine run_dopri5(model, settings, y0, traj, ierr, errmsg, progress)
      type(model_t), intent(in) :: model
      type(run_settings_t), intent(in) :: settings
      real(dp), intent(in) :: y0(:)
      type(trajectory_t), intent(inout) :: traj
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(progress_t), intent(inout) :: progress
      type(adaptive_state_t) :: state

      call traj%store(model, y0)
      call state%init(model, settings, 0.0_dp, y0)
      call state%advance(model, settings, traj, .false., ierr, errmsg, progress)
   end subroutine run_dopri5

   subroutine adaptive_init(self, model, settings, tau0, y0)
      class(adaptive_state_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      type(run_settings_t), intent(in) :: settings
      real(dp), intent(in) :: tau0
      real(dp), intent(in) :: y0(:)
      if (.not. allocated(self%y)) then
         allocate (self%y(size(y0)))
         call self%stepper%init(size(y0))
      end if
      self%tau = tau0
      self%y = y0
      self%in_contact = initial_phase(model, tau0, y0)
      ! The first trial step; the controller corrects it within a few steps.
      self%h = settings%dtau
   end subroutine adaptive_init

   subroutine adaptive_advance(self, model, settings, traj, stop_at_switch, ierr, errmsg, progress)
      class(adaptive_state_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      type(run_settings_t), intent(in) :: settings
      type(trajectory_t), intent(inout) :: traj
      logical, intent(in) :: stop_at_switch
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(progress_t), intent(inout) :: progress

      type(bracketed_root_t) :: root
      real(dp), dimension(size(self%y)) :: f0, f_new, y_new, y_sample
      real(dp) :: h, norm, side, s_test, theta, step_taken, margin
      logical :: have_f0
      integer :: status

      ierr = ok
      errmsg = ''
      have_f0 = .false.
      associate (tau => self%tau, y => self%y, stepper => self%stepper, &
                 controller => self%controller)
         do while (.not. traj%complete())
            if (.not. have_f0) then
               call model%derivative(tau, y, self%in_contact, f0)
               traj%rhs_evaluations = traj%rhs_evaluations + 1
               have_f0 = .true.
            end if
            h = self%h
            if (h < controller%h_min_relative*max(1.0_dp, abs(tau))) then
               ierr = err_runtime
               write (errmsg, '(a,es12.5,a,es9.2,a)') 'step size underflow at tau = ', tau, &
                  ' (h = ', h, '): the tolerances cannot be met; loosen &solver rtol or atol'
               return
            end if
            call stepper%step(model, tau, y, h, self%in_contact, f0, y_new, f_new)
            traj%rhs_evaluations = traj%rhs_evaluations + 6
            norm = error_norm(stepper%error, y, y_new, settings%rtol, settings%atol)
            self%h = controller%next_step(h, norm)
            if (.not. (norm <= 1)) then
               traj%rejected_steps = traj%rejected_steps + 1
               cycle
            end if
            call stepper%prepare_dense(y, y_new, h, f0, f_new)

            side = phase_sign(self%in_contact)
            margin = switch_margin(model, tau, y)
            call step_event_test(side*model%tip_gap(tau, y) + margin, &
                                 side*model%tip_gap_rate(tau, y), &
                                 side*model%tip_gap(tau + h, y_new) + margin, &
                                 side*model%tip_gap_rate(tau + h, y_new), h, self%in_contact, &
                                 status, s_test)
            if (status == event_candidate) then
               call stepper%dense(s_test/h, y_sample)
               if (side*model%tip_gap(tau + s_test, y_sample) + margin > 0) status = no_event
            end if
            step_taken = h
            if (status /= no_event) then
               ! G(theta) = side V_T + margin on the dense output: positive at 0, not at s_test/h.
               call stepper%dense(s_test/h, y_sample)
               call root%start(0.0_dp, side*model%tip_gap(tau, y) + margin, s_test/h, &
                               side*model%tip_gap(tau + s_test, y_sample) + margin, &
                               4*epsilon(1.0_dp)*abs(tau)/h)
               do while (.not. root%converged())
                  call root%next_point(theta)
                  call stepper%dense(theta, y_sample)
                  call root%update(side*model%tip_gap(tau + theta*h, y_sample) + margin)
               end do
               call root%end_with_sign(-1.0_dp, theta)
               step_taken = theta*h
               call stepper%dense(theta, y_new)
            end if

            traj%steps = traj%steps + 1
            if (self%in_contact) traj%contact_steps = traj%contact_steps + 1
            call check_blowup(model, settings, tau + step_taken, step_taken, self%in_contact, &
                              y_new, ierr, errmsg)
            if (ierr /= ok) return
            do while (traj%next_time() <= tau + step_taken)
               call stepper%dense((traj%next_time() - tau)/h, y_sample)
               call traj%store(model, y_sample)
            end do
            tau = tau + step_taken
            y = y_new
            call progress%update(tau, settings%tau_end)
            if (status == no_event) then
               f0 = f_new
            else
               self%in_contact = .not. self%in_contact
               call traj%add_switch(tau)
               have_f0 = .false.
               if (stop_at_switch) return
            end if
         end do
      end associate
   end subroutine adaptive_advance

end module tmafm_method_adaptive

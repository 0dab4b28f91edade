!> `rk4_event`: the paper's steps (dtau free, dtau/contact_refine in contact), but every
!> switch V_T = 0 inside a step, grazing ones included, is located to round-off by a
!> bracketed Brent search on the step length, and the run restarts there in the new phase.
!> Each trial length costs one RK4 step, so the switch state is the RK4 solution itself and
!> fourth order survives the switches.
module tmafm_method_event
   use tmafm_kinds, only: dp
   use tmafm_errors, only: ok
   use tmafm_model, only: model_t
   use tmafm_settings, only: run_settings_t
   use tmafm_trajectory, only: trajectory_t, check_blowup, progress_t
   use tmafm_rk4, only: rk4_stepper_t
   use tmafm_interpolation, only: hermite_cubic
   use tmafm_events, only: no_event, event_candidate, step_event_test, initial_phase, phase_sign, &
      switch_margin
   use tmafm_roots, only: bracketed_root_t
   implicit none
   private

   public :: run_rk4_event

contains

   !> Integrate from y0 at tau = 0 until every sample of traj is filled.
   subroutine run_rk4_event(model, settings, y0, traj, ierr, errmsg, progress)
      type(model_t), intent(in) :: model
      type(run_settings_t), intent(in) :: settings
      real(dp), intent(in) :: y0(:)
      type(trajectory_t), intent(inout) :: traj
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(progress_t), intent(inout) :: progress

      type(rk4_stepper_t) :: stepper
      type(bracketed_root_t) :: root
      real(dp), dimension(size(y0)) :: y, y_new, f0, f_end, y_sample
      real(dp) :: tau, h, s_test, s, side, margin
      logical :: in_contact, have_f_end
      integer :: status

      ierr = ok
      errmsg = ''
      call stepper%init(size(y0))
      tau = 0
      y = y0
      call traj%store(model, y)
      in_contact = initial_phase(model, tau, y)
      have_f_end = .false.

      do while (.not. traj%complete())
         if (in_contact) then
            h = settings%dtau/settings%contact_refine
         else
            h = settings%dtau
         end if
         if (have_f_end) then
            f0 = f_end
         else
            call model%derivative(tau, y, in_contact, f0)
            traj%rhs_evaluations = traj%rhs_evaluations + 1
         end if
         call traj%charge(settings, tau, 1, ierr, errmsg)
         if (ierr /= ok) return
         call stepper%step(model, tau, y, h, in_contact, f0, y_new)
         traj%rhs_evaluations = traj%rhs_evaluations + 3
         ! A step past the stability limit shows in the full step, before a switch located
         ! inside it could cut it short (and, step after step, hide the instability).
         call check_blowup(model, settings, tau + h, h, in_contact, y_new, ierr, errmsg)
         if (ierr /= ok) return

         side = phase_sign(in_contact)
         margin = switch_margin(model, y)
         call step_event_test(side*model%tip_gap(tau, y) + margin, side*model%tip_gap_rate(tau, y), &
                              side*model%tip_gap(tau + h, y_new) + margin, &
                              side*model%tip_gap_rate(tau + h, y_new), h, in_contact, status, s_test)
         if (status == event_candidate) then
            ! Is the dip of the interpolant real?  Check the RK4 solution there.
            call stepper%step(model, tau, y, s_test, in_contact, f0, y_new)
            traj%rhs_evaluations = traj%rhs_evaluations + 3
            if (side*model%tip_gap(tau + s_test, y_new) + margin > 0) then
               status = no_event
               call stepper%step(model, tau, y, h, in_contact, f0, y_new)
               traj%rhs_evaluations = traj%rhs_evaluations + 3
            end if
         end if

         if (status /= no_event) then
            ! G(s) = side V_T(tau + s, RK4(y, s)) + margin: positive at 0, not at s_test.
            call root%start(0.0_dp, side*model%tip_gap(tau, y) + margin, s_test, &
                            side*model%tip_gap(tau + s_test, y_new) + margin, &
                            4*epsilon(1.0_dp)*abs(tau))
            do while (.not. root%converged())
               call traj%charge(settings, tau, 1, ierr, errmsg)
               if (ierr /= ok) return
               call root%next_point(s)
               call stepper%step(model, tau, y, s, in_contact, f0, y_new)
               traj%rhs_evaluations = traj%rhs_evaluations + 3
               call root%update(side*model%tip_gap(tau + s, y_new) + margin)
            end do
            ! Take the bracket end that already lies in the new phase.
            call root%end_with_sign(-1.0_dp, h)
            call stepper%step(model, tau, y, h, in_contact, f0, y_new)
            traj%rhs_evaluations = traj%rhs_evaluations + 3
         end if

         traj%steps = traj%steps + 1
         if (in_contact) traj%contact_steps = traj%contact_steps + 1
         call check_blowup(model, settings, tau + h, h, in_contact, y_new, ierr, errmsg)
         if (ierr /= ok) return

         call model%derivative(tau + h, y_new, in_contact, f_end)
         traj%rhs_evaluations = traj%rhs_evaluations + 1
         do while (traj%next_time() <= tau + h)
            call hermite_cubic(y, f0, y_new, f_end, h, (traj%next_time() - tau)/h, y_sample)
            call traj%store(model, y_sample)
         end do

         tau = tau + h
         y = y_new
         have_f_end = status == no_event
         if (status /= no_event) then
            in_contact = .not. in_contact
            call traj%add_switch(tau, settings%dtau, ierr, errmsg)
            if (ierr /= ok) return
         end if
         call progress%update(tau, settings%tau_end, ierr, errmsg)
         if (ierr /= ok) return
      end do
   end subroutine run_rk4_event

end module tmafm_method_event

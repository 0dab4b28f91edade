!> The paper's scheme `rk4_paper`, docs/model.md §9: classical RK4 with step dtau out of
!> contact and dtau/contact_refine in contact, the phase decided from V_T <= 0 at each step
!> start and frozen over the step, no switch location, cubic Hermite output.
module tmafm_method_paper
   use tmafm_kinds, only: dp
   use tmafm_errors, only: ok
   use tmafm_model, only: model_t
   use tmafm_settings, only: run_settings_t
   use tmafm_trajectory, only: trajectory_t, check_blowup, progress_t
   use tmafm_rk4, only: rk4_stepper_t
   use tmafm_interpolation, only: hermite_cubic
   use tmafm_observers, only: observer_t, stop_requested
   implicit none
   private

   public :: run_rk4_paper

contains

   !> Integrate from y0 at tau = 0 until every sample of traj is filled.
   subroutine run_rk4_paper(model, settings, y0, traj, ierr, errmsg, progress, observer)
      type(model_t), intent(in) :: model
      type(run_settings_t), intent(in) :: settings
      real(dp), intent(in) :: y0(:)
      type(trajectory_t), intent(inout) :: traj
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(progress_t), intent(inout) :: progress
      !> If present, fed every step through its cubic Hermite interpolant (tmafm_observers).
      type(observer_t), intent(inout), optional :: observer

      type(rk4_stepper_t) :: stepper
      real(dp) :: y(size(y0)), y_new(size(y0)), f0(size(y0)), f_end(size(y0)), y_sample(size(y0))
      real(dp) :: tau, tau_new, h, sin_phase, cos_phase
      logical :: in_contact, was_in_contact, have_f_end, f_end_contact

      ierr = ok
      errmsg = ''
      call stepper%init(size(y0))
      tau = 0
      y = y0
      call traj%store(model, y)
      have_f_end = .false.
      f_end_contact = .false.
      was_in_contact = model%tip_gap(tau, y) <= 0

      do while (.not. traj%complete())
         in_contact = model%tip_gap(tau, y) <= 0
         if (in_contact) then
            h = settings%dtau/settings%contact_refine
            traj%contact_steps = traj%contact_steps + 1
         else
            h = settings%dtau
         end if
         if (in_contact .neqv. was_in_contact) then
            call traj%add_switch(tau, settings%dtau, ierr, errmsg)
            if (ierr /= ok) return
            if (present(observer) .and. in_contact) call observer%contact_start(tau)
         end if
         was_in_contact = in_contact
         call traj%charge(settings, tau, 1, ierr, errmsg)
         if (ierr /= ok) return

         ! The end derivative of the last step is this step's first stage if the phase held.
         if (have_f_end .and. (f_end_contact .eqv. in_contact)) then
            f0 = f_end
         else
            call model%phase(tau, sin_phase, cos_phase)
            call model%derivative_at_phase(y, in_contact, sin_phase, cos_phase, f0)
            traj%rhs_evaluations = traj%rhs_evaluations + 1
         end if
         call stepper%step(model, tau, y, h, in_contact, f0, y_new)
         traj%rhs_evaluations = traj%rhs_evaluations + 3
         traj%steps = traj%steps + 1
         tau_new = tau + h
         have_f_end = .false.

         call check_blowup(model, settings, tau_new, h, in_contact, y_new, ierr, errmsg)
         if (ierr /= ok) return

         do while (traj%next_time() <= tau_new .or. present(observer))
            if (.not. have_f_end) then
               call model%phase(tau_new, sin_phase, cos_phase)
               call model%derivative_at_phase(y_new, in_contact, sin_phase, cos_phase, f_end)
               traj%rhs_evaluations = traj%rhs_evaluations + 1
               have_f_end = .true.
               f_end_contact = in_contact
            end if
            if (traj%next_time() > tau_new) exit
            call hermite_cubic(y, f0, y_new, f_end, h, (traj%next_time() - tau)/h, y_sample)
            call traj%store(model, y_sample)
         end do
         if (present(observer)) call observer%hermite_step(model, tau, h, y, f0, y_new, f_end, in_contact)

         tau = tau_new
         y = y_new
         call progress%update(tau, settings%tau_end, ierr, errmsg)
         if (ierr /= ok) return
         if (stop_requested(observer)) return
      end do
   end subroutine run_rk4_paper

end module tmafm_method_paper

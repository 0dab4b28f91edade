!> The run driver: integrates a model from an initial state, samples the state at a
!> fixed output interval by dense output, and stops with an error on blow-up.
!>
!> Memory is O(samples): the trajectory holds only the samples, never the steps.
module tmafm_driver
   use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
   use tmafm_kinds, only: dp, i8
   use tmafm_errors, only: ok, err_blowup, err_input
   use tmafm_model, only: model_t
   use tmafm_rk4, only: rk4_stepper_t
   use tmafm_interpolation, only: hermite_cubic
   implicit none
   private

   public :: run_settings_t, trajectory_t, run_trajectory, sample_count
   public :: method_rk4_paper, known_methods

   !> The paper's scheme: RK4, dtau out of contact, dtau/contact_refine in contact.
   character(len=*), parameter :: method_rk4_paper = 'rk4_paper'
   !> Every method name the driver accepts, for validation messages.
   character(len=*), parameter :: known_methods = "'rk4_paper'"

   !> How to integrate and sample a run.
   type :: run_settings_t
      !> Integration method name.
      character(len=64) :: method = method_rk4_paper
      !> Step out of contact.
      real(dp) :: dtau = 2.0e-3_dp
      !> In-contact step is dtau/contact_refine.
      integer :: contact_refine = 16
      !> End of the run.
      real(dp) :: tau_end = 100.0_dp
      !> Output interval.
      real(dp) :: sample_dtau = 0.01_dp
      !> A run stops with an error once some |a_j| exceeds this (units of the gap d).
      real(dp) :: blowup_limit = 1.0_dp
   end type run_settings_t

   !> The sampled trajectory and the work counters of one run.
   type :: trajectory_t
      !> Sample times tau_k = (k-1) sample_dtau.
      real(dp), allocatable :: tau(:)
      !> Tip gap V_T at the samples.
      real(dp), allocatable :: vt(:)
      !> Tip gap rate dV_T/dtau at the samples.
      real(dp), allocatable :: vtdot(:)
      !> 1 where V_T <= 0 (in contact) at the sample, else 0.
      integer, allocatable :: contact(:)
      !> Modal amplitudes, samples x N.
      real(dp), allocatable :: a(:, :)
      !> Modal velocities, samples x N.
      real(dp), allocatable :: adot(:, :)
      !> Steps taken, in all and in contact.
      integer(i8) :: steps = 0, contact_steps = 0
      !> Right-hand-side evaluations.
      integer(i8) :: rhs_evaluations = 0
      !> Changes of phase between consecutive steps.
      integer(i8) :: phase_switches = 0
   end type trajectory_t

contains

   !> Number of output samples for a run: tau = 0, sample_dtau, ..., up to tau_end.
   pure function sample_count(settings) result(n)
      type(run_settings_t), intent(in) :: settings
      integer :: n
      n = floor(settings%tau_end/settings%sample_dtau*(1.0_dp + 4*epsilon(1.0_dp))) + 1
   end function sample_count

   !> Integrate `model` from (a0, adot0) at tau = 0 and sample it; ierr /= 0 on blow-up.
   subroutine run_trajectory(model, settings, a0, adot0, traj, ierr, errmsg, progress_unit)
      type(model_t), intent(in) :: model
      type(run_settings_t), intent(in) :: settings
      real(dp), intent(in) :: a0(:)
      real(dp), intent(in) :: adot0(:)
      type(trajectory_t), intent(out) :: traj
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      !> If present, a progress line is written to this unit every tenth of the run.
      integer, intent(in), optional :: progress_unit

      integer :: n, n_samples

      ierr = ok
      errmsg = ''
      n = model%n_modes
      n_samples = sample_count(settings)
      allocate (traj%tau(n_samples), traj%vt(n_samples), traj%vtdot(n_samples), &
                traj%contact(n_samples), traj%a(n_samples, n), traj%adot(n_samples, n))

      select case (trim(settings%method))
      case (method_rk4_paper)
         call run_rk4_paper(model, settings, [a0, adot0], traj, ierr, errmsg, progress_unit)
      case default
         ierr = err_input
         errmsg = '&solver method = '''//trim(settings%method)//''': must be one of '//known_methods
      end select
   end subroutine run_trajectory

   !> The paper's scheme, spec section 6: the phase is decided from V_T at each step start.
   subroutine run_rk4_paper(model, settings, y0, traj, ierr, errmsg, progress_unit)
      type(model_t), intent(in) :: model
      type(run_settings_t), intent(in) :: settings
      real(dp), intent(in) :: y0(:)
      type(trajectory_t), intent(inout) :: traj
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      integer, intent(in), optional :: progress_unit

      type(rk4_stepper_t) :: stepper
      real(dp) :: y(size(y0)), y_new(size(y0)), f0(size(y0)), f_end(size(y0)), y_sample(size(y0))
      real(dp) :: tau, tau_new, h, t_sample
      logical :: in_contact, was_in_contact, have_f_end, f_end_contact
      integer :: n_samples, next, progress_mark

      ierr = ok
      n_samples = size(traj%tau)
      call stepper%init(size(y0))
      tau = 0
      y = y0
      call store_sample(model, 1, tau, y, traj)
      next = 2
      have_f_end = .false.
      f_end_contact = .false.
      was_in_contact = model%tip_gap(tau, y) <= 0
      progress_mark = 1

      do while (next <= n_samples)
         in_contact = model%tip_gap(tau, y) <= 0
         if (in_contact) then
            h = settings%dtau/settings%contact_refine
            traj%contact_steps = traj%contact_steps + 1
         else
            h = settings%dtau
         end if
         if (in_contact .neqv. was_in_contact) traj%phase_switches = traj%phase_switches + 1
         was_in_contact = in_contact

         ! The end derivative of the last step is this step's first stage if the phase held.
         if (have_f_end .and. (f_end_contact .eqv. in_contact)) then
            f0 = f_end
         else
            call model%derivative(tau, y, in_contact, f0)
            traj%rhs_evaluations = traj%rhs_evaluations + 1
         end if
         call stepper%step(model, tau, y, h, in_contact, f0, y_new)
         traj%rhs_evaluations = traj%rhs_evaluations + 3
         traj%steps = traj%steps + 1
         tau_new = tau + h
         have_f_end = .false.

         call check_blowup(model, settings, tau_new, h, in_contact, y_new, ierr, errmsg)
         if (ierr /= ok) return

         do while (next <= n_samples)
            t_sample = (next - 1)*settings%sample_dtau
            if (t_sample > tau_new) exit
            if (.not. have_f_end) then
               call model%derivative(tau_new, y_new, in_contact, f_end)
               traj%rhs_evaluations = traj%rhs_evaluations + 1
               have_f_end = .true.
               f_end_contact = in_contact
            end if
            call hermite_cubic(y, f0, y_new, f_end, h, (t_sample - tau)/h, y_sample)
            call store_sample(model, next, t_sample, y_sample, traj)
            next = next + 1
         end do

         tau = tau_new
         y = y_new
         if (present(progress_unit)) call report_progress(progress_unit, tau, settings%tau_end, &
                                                         progress_mark)
      end do
   end subroutine run_rk4_paper

   !> Record the state y at sample k and time tau.
   pure subroutine store_sample(model, k, tau, y, traj)
      type(model_t), intent(in) :: model
      integer, intent(in) :: k
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: y(:)
      type(trajectory_t), intent(inout) :: traj
      integer :: n
      n = model%n_modes
      traj%tau(k) = tau
      traj%a(k, :) = y(1:n)
      traj%adot(k, :) = y(n + 1:2*n)
      traj%vt(k) = model%tip_gap(tau, y)
      traj%vtdot(k) = model%tip_gap_rate(tau, y)
      traj%contact(k) = merge(1, 0, traj%vt(k) <= 0)
   end subroutine store_sample

   !> Fail with err_blowup if the new state is not finite or an amplitude ran away.
   subroutine check_blowup(model, settings, tau, h, in_contact, y, ierr, errmsg)
      type(model_t), intent(in) :: model
      type(run_settings_t), intent(in) :: settings
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: h
      logical, intent(in) :: in_contact
      real(dp), intent(in) :: y(:)
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      character(len=64) :: what
      character(len=*), parameter :: phase_name(2) = ['free   ', 'contact']

      ierr = ok
      if (all(ieee_is_finite(y))) then
         if (maxval(abs(y(1:model%n_modes))) <= settings%blowup_limit) return
         write (what, '(a,es9.2,a,es9.2)') 'max|a_j| = ', maxval(abs(y(1:model%n_modes))), &
            ' > &solver blowup_limit = ', settings%blowup_limit
      else
         what = 'the state is NaN or Inf'
      end if
      ierr = err_blowup
      write (errmsg, '(a,es12.5,4a,es9.2,3a)') 'blow-up at tau = ', tau, ': ', trim(what), &
         ', after a ', 'step of ', h, ' (', trim(phase_name(merge(2, 1, in_contact))), &
         ' phase); the step is past the stability limit: reduce &solver dtau'
   end subroutine check_blowup

   !> Write one line per tenth of the run to `unit`.
   subroutine report_progress(unit, tau, tau_end, mark)
      integer, intent(in) :: unit
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: tau_end
      integer, intent(inout) :: mark
      if (tau >= mark*tau_end/10) then
         write (unit, '(a,i0,a,g0.6,a,g0.6)') 'tmafm: ', 10*mark, '% tau = ', tau, ' of ', tau_end
         flush (unit)
         mark = mark + 1
      end if
   end subroutine report_progress

end module tmafm_driver

!> The classical fourth-order Runge-Kutta step, docs/model.md §9, paper Sec. 2 ("a Fortran
!> program of the fourth-order Runge-Kutta integration").
!>
!> The phase (contact or free) is an argument: it is frozen for all four stages, as the
!> paper's scheme requires.  Stage registers are allocated once by `init`; a step
!> allocates nothing.  Step-size and phase decisions belong to the caller.
module tmafm_rk4
   use tmafm_kinds, only: dp
   use tmafm_model, only: model_t
   use tmafm_embedded_pair, only: stage_phases
   implicit none
   private

   public :: rk4_stepper_t

   !> The distinct nodes of stages 2-4 (stages 2 and 3 are both at c = 1/2).
   real(dp), parameter :: step_nodes(2) = [0.5_dp, 1.0_dp]

   !> Stage registers of one classical RK4 integrator.
   type :: rk4_stepper_t
      !> Stage derivatives 2-4 and the stage state (stage 1 is the caller's f0).
      real(dp), allocatable :: k2(:), k3(:), k4(:), stage(:)
   contains
      !> Allocate the registers for a state of size n_state.
      procedure :: init => rk4_init
      !> Advance y by h from tau in a frozen phase, given f0 = f(tau, y).
      procedure :: step => rk4_step
   end type rk4_stepper_t

contains

   subroutine rk4_init(self, n_state)
      class(rk4_stepper_t), intent(inout) :: self
      integer, intent(in) :: n_state
      allocate (self%k2(n_state), self%k3(n_state), self%k4(n_state), self%stage(n_state))
   end subroutine rk4_init

   subroutine rk4_step(self, model, tau, y, h, in_contact, f0, y_new)
      class(rk4_stepper_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: y(:)
      real(dp), intent(in) :: h
      logical, intent(in) :: in_contact
      real(dp), intent(in) :: f0(:)
      real(dp), intent(out) :: y_new(:)
      real(dp) :: sin_phase(size(step_nodes)), cos_phase(size(step_nodes))

      call stage_phases(model, tau, h, step_nodes, sin_phase, cos_phase)
      associate (k2 => self%k2, k3 => self%k3, k4 => self%k4, stage => self%stage)
         stage = y + 0.5_dp*h*f0
         call model%derivative_at_phase(stage, in_contact, sin_phase(1), cos_phase(1), k2)
         stage = y + 0.5_dp*h*k2
         call model%derivative_at_phase(stage, in_contact, sin_phase(1), cos_phase(1), k3)
         stage = y + h*k3
         call model%derivative_at_phase(stage, in_contact, sin_phase(2), cos_phase(2), k4)
         y_new = y + (h/6)*(f0 + 2*k2 + 2*k3 + k4)
      end associate
   end subroutine rk4_step

end module tmafm_rk4

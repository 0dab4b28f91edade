!> The Dormand-Prince 5(4) pair with its fourth-order dense output (Hairer, Norsett and
!> Wanner, Solving ODEs I, Sec. II.5-6), as an embedded_pair_t.
!>
!> The phase is frozen over a step, as in every tmafm stepper; switches are found by the
!> caller on the dense output.  Registers are allocated once by `init`.  The controller
!> exponent 1/5 is taken as exp(-log(norm)/5): one log and one exp, no real power.
module tmafm_dopri5
   use tmafm_kinds, only: dp
   use tmafm_model, only: model_t
   use tmafm_error_scale, only: error_scale_t
   use tmafm_embedded_pair, only: embedded_pair_t, time_map_t, stage_clock
   implicit none
   private

   public :: dopri5_pair_t

   ! Butcher tableau.
   real(dp), parameter :: c2 = 1.0_dp/5, c3 = 3.0_dp/10, c4 = 4.0_dp/5, c5 = 8.0_dp/9
   !> The distinct nodes of stages 2-7 (stages 6 and 7 are both at c = 1).
   real(dp), parameter :: step_nodes(5) = [c2, c3, c4, c5, 1.0_dp]
   real(dp), parameter :: a21 = 1.0_dp/5
   real(dp), parameter :: a31 = 3.0_dp/40, a32 = 9.0_dp/40
   real(dp), parameter :: a41 = 44.0_dp/45, a42 = -56.0_dp/15, a43 = 32.0_dp/9
   real(dp), parameter :: a51 = 19372.0_dp/6561, a52 = -25360.0_dp/2187, &
                          a53 = 64448.0_dp/6561, a54 = -212.0_dp/729
   real(dp), parameter :: a61 = 9017.0_dp/3168, a62 = -355.0_dp/33, a63 = 46732.0_dp/5247, &
                          a64 = 49.0_dp/176, a65 = -5103.0_dp/18656
   real(dp), parameter :: a71 = 35.0_dp/384, a73 = 500.0_dp/1113, a74 = 125.0_dp/192, &
                          a75 = -2187.0_dp/6784, a76 = 11.0_dp/84
   ! Error weights: fifth-order minus embedded fourth-order solution.
   real(dp), parameter :: e1 = 71.0_dp/57600, e3 = -71.0_dp/16695, e4 = 71.0_dp/1920, &
                          e5 = -17253.0_dp/339200, e6 = 22.0_dp/525, e7 = -1.0_dp/40
   ! Dense output (Shampine's continuous extension, as in Hairer's DOPRI5).
   real(dp), parameter :: d1 = -12715105075.0_dp/11282082432.0_dp, d3 = 87487479700.0_dp/32700410799.0_dp, &
                          d4 = -10690763975.0_dp/1880347072.0_dp, d5 = 701980252875.0_dp/199316789632.0_dp, &
                          d6 = -1453857185.0_dp/822651844.0_dp, d7 = 69997945.0_dp/29380423.0_dp

   !> Stage registers and the dense-output coefficients of the last step.
   type, extends(embedded_pair_t) :: dopri5_pair_t
      !> Stage derivatives 2-6 (1 and 7 are the caller's f0 and f_new), the stage state, and
      !> the error estimate of the last step.
      real(dp), allocatable :: k2(:), k3(:), k4(:), k5(:), k6(:), stage(:), error(:)
      !> Dense output: y(theta) = r1 + theta (r2 + (1-theta) (r3 + theta (r4 + (1-theta) r5))).
      real(dp), allocatable :: r1(:), r2(:), r3(:), r4(:), r5(:)
   contains
      !> Allocate the registers for a state of size n_state.
      procedure :: init => dopri5_init
      !> One step over a time map in a frozen phase; f0 = dy/ds in, f_new = dy/ds at y_new out.
      procedure :: step => dopri5_step
      !> The error norm of the last step.
      procedure :: error_norm => dopri5_error_norm
      !> norm^(-1/5).
      procedure :: growth => dopri5_growth
      !> Prepare the dense output of the last step (call after accepting it).
      procedure :: prepare_dense => dopri5_prepare_dense
      !> The dense-output state at fraction theta of the last step.
      procedure :: dense => dopri5_dense
   end type dopri5_pair_t

contains

   subroutine dopri5_init(self, n_state)
      class(dopri5_pair_t), intent(inout) :: self
      integer, intent(in) :: n_state
      self%stage_evaluations = 6
      self%dense_evaluations = 0
      ! Hairer's DOPRI5 defaults.
      self%shrink_limit = 0.2_dp
      self%grow_limit = 10.0_dp
      if (allocated(self%k2)) return
      allocate (self%k2(n_state), self%k3(n_state), self%k4(n_state), self%k5(n_state), &
                self%k6(n_state), self%stage(n_state), self%error(n_state), self%r1(n_state), &
                self%r2(n_state), self%r3(n_state), self%r4(n_state), self%r5(n_state))
   end subroutine dopri5_init

   subroutine dopri5_step(self, model, map, y, in_contact, f0, y_new, f_new)
      class(dopri5_pair_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      type(time_map_t), intent(in) :: map
      real(dp), intent(in), contiguous :: y(:)
      logical, intent(in) :: in_contact
      real(dp), intent(in), contiguous :: f0(:)
      real(dp), intent(out), contiguous :: y_new(:)
      real(dp), intent(out), contiguous :: f_new(:)
      real(dp) :: sin_phase(size(step_nodes)), cos_phase(size(step_nodes)), factor(size(step_nodes))
      real(dp) :: h

      self%map = map
      h = map%h
      call stage_clock(model, map, step_nodes, sin_phase, cos_phase, factor)
      self%sin_end = sin_phase(5)
      self%cos_end = cos_phase(5)
      associate (k2 => self%k2, k3 => self%k3, k4 => self%k4, k5 => self%k5, k6 => self%k6, &
                 stage => self%stage)
         stage = y + h*a21*f0
         call model%derivative_at_phase(stage, in_contact, sin_phase(1), cos_phase(1), k2)
         if (map%warped) k2 = factor(1)*k2
         stage = y + h*(a31*f0 + a32*k2)
         call model%derivative_at_phase(stage, in_contact, sin_phase(2), cos_phase(2), k3)
         if (map%warped) k3 = factor(2)*k3
         stage = y + h*(a41*f0 + a42*k2 + a43*k3)
         call model%derivative_at_phase(stage, in_contact, sin_phase(3), cos_phase(3), k4)
         if (map%warped) k4 = factor(3)*k4
         stage = y + h*(a51*f0 + a52*k2 + a53*k3 + a54*k4)
         call model%derivative_at_phase(stage, in_contact, sin_phase(4), cos_phase(4), k5)
         if (map%warped) k5 = factor(4)*k5
         stage = y + h*(a61*f0 + a62*k2 + a63*k3 + a64*k4 + a65*k5)
         call model%derivative_at_phase(stage, in_contact, sin_phase(5), cos_phase(5), k6)
         if (map%warped) k6 = factor(5)*k6
         y_new = y + h*(a71*f0 + a73*k3 + a74*k4 + a75*k5 + a76*k6)
         call model%derivative_and_gap(y_new, in_contact, sin_phase(5), cos_phase(5), f_new, self%vt_end, &
                                       self%rate_end)
         if (map%warped) f_new = factor(5)*f_new
      end associate
   end subroutine dopri5_step

   pure subroutine dopri5_error_norm(self, h, f0, f_new, scale, norm)
      class(dopri5_pair_t), intent(inout) :: self
      real(dp), intent(in) :: h
      real(dp), intent(in), contiguous :: f0(:)
      real(dp), intent(in), contiguous :: f_new(:)
      type(error_scale_t), intent(in) :: scale
      real(dp), intent(out) :: norm
      self%error = h*(e1*f0 + e3*self%k3 + e4*self%k4 + e5*self%k5 + e6*self%k6 + e7*f_new)
      norm = sqrt(scale%sum_of_squares(self%error))
   end subroutine dopri5_error_norm

   pure function dopri5_growth(self, norm) result(ratio)
      class(dopri5_pair_t), intent(in) :: self
      real(dp), intent(in) :: norm
      real(dp) :: ratio
      ratio = exp(-0.2_dp*log(norm))
   end function dopri5_growth

   !> Shampine's continuous extension needs no new stage: model and in_contact are unused.
   subroutine dopri5_prepare_dense(self, model, y, y_new, in_contact, f0, f_new)
      class(dopri5_pair_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      real(dp), intent(in), contiguous :: y(:)
      real(dp), intent(in), contiguous :: y_new(:)
      logical, intent(in) :: in_contact
      real(dp), intent(in), contiguous :: f0(:)
      real(dp), intent(in), contiguous :: f_new(:)
      real(dp) :: h
      h = self%map%h
      self%r1 = y
      self%r2 = y_new - y
      self%r3 = h*f0 - self%r2
      self%r4 = self%r2 - h*f_new - self%r3
      self%r5 = h*(d1*f0 + d3*self%k3 + d4*self%k4 + d5*self%k5 + d6*self%k6 + d7*f_new)
   end subroutine dopri5_prepare_dense

   pure subroutine dopri5_dense(self, theta, y)
      class(dopri5_pair_t), intent(in) :: self
      real(dp), intent(in) :: theta
      real(dp), intent(out), contiguous :: y(:)
      real(dp) :: rest
      rest = 1 - theta
      y = self%r1 + theta*(self%r2 + rest*(self%r3 + theta*(self%r4 + rest*self%r5)))
   end subroutine dopri5_dense

end module tmafm_dopri5

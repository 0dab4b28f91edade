!> What `rtol` and `atol` mean for the adaptive methods: the weights of the error norm.
!>
!> A step is accepted when the root-sum-square of its weighted local error estimates is at
!> most 1, over 2N + 1 components:
!>
!>   e(a_j)    / (atol + rtol S_j)            the displacement of mode j,
!>   e(a'_j)   / (omega_j (atol + rtol S_j))  its velocity, in displacement units,
!>   e(V_T)    / (atol + rtol S_V)            the tip gap, e(V_T) = p . e(a),
!>
!> with omega_j = beta_j^2 the free frequency of mode j, S_j the largest max(|a_j|,
!> |a'_j|/omega_j) seen so far in the run (the mode's own amplitude, not its value at the
!> instant, which passes through zero twice a cycle), and S_V = max(alpha2, largest |p . a|
!> so far) the size of the motion of the tip.  So atol is an absolute error in gap units,
!> rtol an error relative to the amplitude of each mode and of the tip, and every accepted
!> step has |e(V_T)| <= atol + rtol S_V.  A mode of amplitude 1e-6 is not held to 1e-14
!> absolute: its own scale sets its share.
!>
!> The scales only grow, and are updated from each accepted state (and at the end of each
!> exact flight), so the norm costs O(N) per step and allocates nothing.
module tmafm_error_scale
   use tmafm_kinds, only: dp
   use tmafm_model, only: model_t
   implicit none
   private

   public :: error_scale_t

   ! The tightest tolerance a mode is held to, as a fraction of the tip's, atol + rtol S_V:
   ! sqrt(epsilon) = 1.5e-8.  A mode whose error is that far below the tip's tolerance cannot
   ! change whether V_T meets it, and a mode at rest (S_j = 0) held to a tiny absolute atol
   ! cannot be stepped at all: its first error estimate is round-off, about epsilon h |f|,
   ! so atol = 1e-300 failed with a step size underflow at tau = 0 where atol = 0 ran.  Only
   ! runs with atol below about 1.5e-8 rtol S_V (atol = 0 included) see the floor.
   real(dp), parameter :: mode_floor_fraction = 2.0_dp**(-26)

   !> Running amplitudes and the inverse weights of the error norm.
   type :: error_scale_t
      !> Number of modes N.
      integer :: n_modes = 0
      !> The tolerances.
      real(dp) :: rtol = 0, atol = 0
      !> Free frequencies omega_j = beta_j^2.
      real(dp), allocatable :: omega(:)
      !> Tip vector p (V_T = p . a + drive).
      real(dp), allocatable :: tip(:)
      !> Running amplitudes S_j of the modes.
      real(dp), allocatable :: amplitude(:)
      !> Running size S_V of the tip motion.
      real(dp) :: tip_amplitude = 0
      !> Inverse weights of the 2N state components.
      real(dp), allocatable :: weight(:)
      !> Inverse weight of the V_T component.
      real(dp) :: tip_weight = 0
      !> A viscoelastic sample's dashpot coordinate w = y(2N + 1) (tmafm_viscoelastic), when the
      !> state (a, a', w, 0) has it: its running size (at least 1, the Hertz variable at A = 1),
      !> weighed 1/(rtol size) as weight(2N + 1) (weight(2N + 2) = 0 for the pad).
      logical :: has_dashpot = .false.
      real(dp) :: dashpot_amplitude = 1
      !> Half the state's length: N, or N + 1 with the dashpot (the sums run over 2 n_half
      !> components, and over tip(1:n_half), zero past N).
      integer :: n_half = 0
   contains
      !> Set up for a model and tolerances, with the amplitudes of the initial state y0.
      procedure :: init => scale_init
      !> Grow the running amplitudes with an accepted state y and refresh the weights.
      procedure :: update => scale_update
      !> Sum over the 2N + 1 components of (weight * error)^2 for a state-sized error e.
      procedure :: sum_of_squares => scale_sum_of_squares
      !> The sums of squares of two error estimates of one step (dop853's e5 and e3), in one pass.
      procedure :: sums_of_squares => scale_sums_of_squares
   end type error_scale_t

contains

   subroutine scale_init(self, model, rtol, atol, y0)
      class(error_scale_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: rtol
      real(dp), intent(in) :: atol
      real(dp), intent(in) :: y0(:)
      integer :: n
      n = model%n_modes
      self%n_modes = n
      self%rtol = rtol
      self%atol = atol
      self%has_dashpot = size(y0) > 2*n
      self%n_half = size(y0)/2
      if (allocated(self%omega)) deallocate (self%omega, self%tip, self%amplitude, self%weight)
      allocate (self%omega(n), self%tip(self%n_half), self%amplitude(n), self%weight(2*self%n_half))
      self%omega = model%beta**2
      self%tip = 0
      self%tip(1:n) = model%tip
      self%weight = 0
      self%dashpot_amplitude = 1
      self%amplitude = 0
      self%tip_amplitude = model%drive%size
      call self%update(y0)
      ! Whether or not y0 moved an amplitude.
      call refresh_weights(self)
   end subroutine scale_init

   !> The weights are refreshed only when an amplitude grew (after the first periods of a run
   !> almost no step moves them): the same values as recomputing them at every step.
   pure subroutine scale_update(self, y)
      class(error_scale_t), intent(inout) :: self
      real(dp), intent(in), contiguous :: y(:)
      logical :: grew
      call grow_amplitudes(self%n_modes, self%tip, self%omega, y, self%tip_amplitude, self%amplitude, grew)
      if (grew) call refresh_weights(self)
      if (self%has_dashpot) then
         if (abs(y(2*self%n_modes + 1)) > self%dashpot_amplitude) then
            self%dashpot_amplitude = abs(y(2*self%n_modes + 1))
            call refresh_weights(self)
         end if
      end if
   end subroutine scale_update

   !> The running amplitudes grown with a state y (explicit shapes: no descriptors); grew tells
   !> whether any changed.
   pure subroutine grow_amplitudes(n, tip, omega, y, tip_amplitude, amplitude, grew)
      integer, intent(in) :: n
      real(dp), intent(in) :: tip(n)
      real(dp), intent(in) :: omega(n)
      real(dp), intent(in) :: y(2*n)
      real(dp), intent(inout) :: tip_amplitude
      real(dp), intent(inout) :: amplitude(n)
      logical, intent(out) :: grew
      real(dp) :: tip_size, size_j
      integer :: j
      tip_size = max(tip_amplitude, abs(dot_product(tip, y(1:n))))
      ! /= rather than >, so that a NaN amplitude refreshes the weights, as it always did.
      grew = tip_size /= tip_amplitude
      tip_amplitude = tip_size
      do j = 1, n
         size_j = max(abs(y(j)), abs(y(n + j))/omega(j))
         if (size_j > amplitude(j)) then
            amplitude(j) = size_j
            grew = .true.
         end if
      end do
   end subroutine grow_amplitudes

   !> The inverse weights from the running amplitudes.
   pure subroutine refresh_weights(self)
      type(error_scale_t), intent(inout) :: self
      real(dp) :: tip_tolerance, tolerance, mode_floor
      integer :: j, n
      n = self%n_modes
      ! Floored so that atol = 0 with a tip at rest (and no drive) cannot divide by zero.
      tip_tolerance = max(self%atol + self%rtol*self%tip_amplitude, tiny(1.0_dp))
      self%tip_weight = 1/tip_tolerance
      mode_floor = max(mode_floor_fraction*tip_tolerance, tiny(1.0_dp))
      do j = 1, n
         ! No mode is held tighter than mode_floor_fraction of the tip's tolerance (a mode at
         ! rest with atol = 0 or a tiny atol): a floor, so atol -> 0+ is continuous with 0.
         tolerance = self%atol + self%rtol*self%amplitude(j)
         if (.not. (tolerance >= mode_floor)) tolerance = mode_floor
         self%weight(j) = 1/tolerance
         self%weight(n + j) = 1/(self%omega(j)*tolerance)
      end do
      if (self%has_dashpot) self%weight(2*n + 1) = 1/max(self%rtol*self%dashpot_amplitude, tiny(1.0_dp))
   end subroutine refresh_weights

   pure function scale_sum_of_squares(self, e) result(total)
      class(error_scale_t), intent(in) :: self
      real(dp), intent(in) :: e(:)
      real(dp) :: total
      integer :: n
      n = self%n_half
      total = sum((self%weight*e)**2) + (self%tip_weight*dot_product(self%tip, e(1:n)))**2
   end function scale_sum_of_squares

   !> Both sums in one pass over the weights; each is summed in the order of
   !> scale_sum_of_squares (components 1..2N, then V_T), so the two agree to the last bit.
   pure subroutine scale_sums_of_squares(self, e1, e2, total1, total2)
      class(error_scale_t), intent(in) :: self
      real(dp), intent(in), contiguous :: e1(:)
      real(dp), intent(in), contiguous :: e2(:)
      real(dp), intent(out) :: total1
      real(dp), intent(out) :: total2
      call pair_sums(self%n_half, self%weight, self%tip, self%tip_weight, e1, e2, total1, total2)
   end subroutine scale_sums_of_squares

   !> scale_sums_of_squares on explicit-shape arrays (no descriptors, unit strides).
   pure subroutine pair_sums(n, weight, tip, tip_weight, e1, e2, total1, total2)
      integer, intent(in) :: n
      real(dp), intent(in) :: weight(2*n)
      real(dp), intent(in) :: tip(n)
      real(dp), intent(in) :: tip_weight
      real(dp), intent(in) :: e1(2*n)
      real(dp), intent(in) :: e2(2*n)
      real(dp), intent(out) :: total1
      real(dp), intent(out) :: total2
      real(dp) :: tip1, tip2
      integer :: i
      total1 = 0
      total2 = 0
      do i = 1, 2*n
         total1 = total1 + (weight(i)*e1(i))**2
         total2 = total2 + (weight(i)*e2(i))**2
      end do
      tip1 = 0
      tip2 = 0
      do i = 1, n
         tip1 = tip1 + tip(i)*e1(i)
         tip2 = tip2 + tip(i)*e2(i)
      end do
      total1 = total1 + (tip_weight*tip1)**2
      total2 = total2 + (tip_weight*tip2)**2
   end subroutine pair_sums

end module tmafm_error_scale

!> The instrument's signal processing, updated once per drive period (docs/instrument.md): a
!> lock-in's output filter and a PI controller.
!>
!> The lock-in's mixing and its average over one drive period are the period's exact lock-in
!> observables (tmafm_observers: amplitude and phase at the drive); its output filter is a
!> first-order low pass of bandwidth B (the -3 dB frequency, Hz), here sampled at the period's
!> end: y_k = y_(k-1) + (1 - exp(-2 pi B T_k)) (x_k - y_(k-1)), the exact response of the
!> continuous filter to an input held over the period T_k (zero-order hold), so its step
!> response is 1 - exp(-2 pi B t) at the period ends, whatever T_k.
!> The PI controller's output is u_k = K_p e_k + I_k with I_k = I_(k-1) + K_i T_k e_k (K_i per
!> second), held within [lower, upper]: while the output is saturated the integrator does not
!> grow further in that direction (anti-windup by conditional integration).
module tmafm_controllers
   use tmafm_kinds, only: dp
   implicit none
   private

   public :: lowpass_t, pi_controller_t

   real(dp), parameter :: pi = acos(-1.0_dp)

   !> A first-order low pass of bandwidth B (Hz), sampled once per drive period.
   type :: lowpass_t
      !> The -3 dB bandwidth B (Hz); 0 passes the input through unfiltered.
      real(dp) :: bandwidth = 0
      !> The output y.
      real(dp) :: value = 0
      !> .false. until the first input, which the output takes as it is (the filter starts
      !> settled at its first input, as a lock-in started on a steady signal).
      logical :: started = .false.
   contains
      !> Filter one input x held over a period of length `period` (s); returns the new output.
      procedure :: update => lowpass_update
   end type lowpass_t

   !> A PI controller, updated once per drive period.
   type :: pi_controller_t
      !> The proportional gain K_p (output units per error unit).
      real(dp) :: proportional = 0
      !> The integral gain K_i (output units per error unit and second).
      real(dp) :: integral = 0
      !> The output's limits.
      real(dp) :: lower = -huge(1.0_dp), upper = huge(1.0_dp)
      !> The integrator I, and the last output u.
      real(dp) :: integrator = 0, output = 0
   contains
      !> One update with the error e over a period of length `period` (s); returns the output.
      procedure :: update => pi_update
   end type pi_controller_t

contains

   !> y += (1 - exp(-2 pi B T)) (x - y); the first input sets y.
   real(dp) function lowpass_update(self, x, period) result(y)
      class(lowpass_t), intent(inout) :: self
      real(dp), intent(in) :: x
      real(dp), intent(in) :: period
      if (.not. self%started .or. .not. (self%bandwidth > 0)) then
         self%value = x
         self%started = .true.
      else
         self%value = self%value - expm1(-2*pi*self%bandwidth*period)*(x - self%value)
      end if
      y = self%value
   end function lowpass_update

   !> u = K_p e + I, I += K_i T e unless that drives a saturated output further out.
   real(dp) function pi_update(self, error, period) result(u)
      class(pi_controller_t), intent(inout) :: self
      real(dp), intent(in) :: error
      real(dp), intent(in) :: period
      real(dp) :: trial
      trial = self%integrator + self%integral*period*error
      u = self%proportional*error + trial
      if (u > self%upper) then
         if (trial <= self%integrator) self%integrator = trial
         u = self%upper
      else if (u < self%lower) then
         if (trial >= self%integrator) self%integrator = trial
         u = self%lower
      else
         self%integrator = trial
      end if
      self%output = u
   end function pi_update

   !> exp(x) - 1 without cancellation for small |x|.
   elemental real(dp) function expm1(x)
      real(dp), intent(in) :: x
      if (abs(x) < 1.0e-5_dp) then
         expm1 = x*(1 + x/2*(1 + x/3))
      else
         expm1 = exp(x) - 1
      end if
   end function expm1

end module tmafm_controllers

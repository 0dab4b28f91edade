!> Clamped-free (cantilever) beam modes, docs/model.md §4, paper Eqs. (14), (25).
!>
!> The textbook form cosh - cos - sigma (sinh - sin) cancels two terms of size
!> exp(beta xi)/2 and loses every digit from mode 13 on.  Here every term is O(1):
!>
!>   phi = exp(-b xi) - cos(b xi) + sigma sin(b xi) + k (exp(b (xi-1)) - exp(-b (xi+1)))
!>
!> with e = exp(-b), sigma = (1 + e^2 + 2e cos b)/(1 - e^2 + 2e sin b) and
!> k = (sin b - cos b - e)/(1 - e^2 + 2e sin b).  The roots solve cos b + sech b = 0,
!> which cannot overflow.  Normalisation: int phi^2 = 1 and phi_j(1) = 2 (-1)^(j+1).
module tmafm_modes
   use tmafm_kinds, only: dp
   implicit none
   private

   public :: max_modes, beam_roots, mode_sigma, mode_shape

   !> Largest number of modes tmafm supports (accuracy is tested up to here).
   integer, parameter :: max_modes = 30

contains

   !> The first n roots beta_j of 1 + cos(beta) cosh(beta) = 0.
   pure function beam_roots(n) result(beta)
      integer, intent(in) :: n
      real(dp) :: beta(n)
      real(dp), parameter :: pi = acos(-1.0_dp)
      real(dp) :: b, f, df, step
      integer :: j, iter

      do j = 1, n
         select case (j)
         case (1)
            b = 1.8751_dp
         case (2)
            b = 4.6941_dp
         case default
            b = real(2*j - 1, dp)*pi/2
         end select
         do iter = 1, 60
            f = cos(b) + 1.0_dp/cosh(b)
            df = -sin(b) - tanh(b)/cosh(b)
            step = f/df
            b = b - step
            if (abs(step) <= 4*epsilon(b)*b) exit
         end do
         beta(j) = b
      end do
   end function beam_roots

   !> The mode coefficient sigma = (cosh b + cos b)/(sinh b + sin b), in overflow-free form.
   elemental function mode_sigma(beta) result(sigma)
      real(dp), intent(in) :: beta
      real(dp) :: sigma
      real(dp) :: e
      e = exp(-beta)
      sigma = (1.0_dp + e*e + 2*e*cos(beta))/(1.0_dp - e*e + 2*e*sin(beta))
   end function mode_sigma

   !> The derivative of order `order` (0 to 4) of the mode with root `beta`, at `xi` in [0, 1].
   elemental function mode_shape(beta, xi, order) result(value)
      real(dp), intent(in) :: beta
      real(dp), intent(in) :: xi
      integer, intent(in) :: order
      real(dp) :: value
      real(dp) :: e, den, sigma, k, bx, c, s, grow, decay, scale

      e = exp(-beta)
      den = 1.0_dp - e*e + 2*e*sin(beta)
      sigma = (1.0_dp + e*e + 2*e*cos(beta))/den
      k = (sin(beta) - cos(beta) - e)/den
      bx = beta*xi
      grow = exp(beta*(xi - 1.0_dp))
      decay = exp(-beta*(xi + 1.0_dp))
      c = cos(bx)
      s = sin(bx)
      scale = beta**order

      ! d^n/dx^n of cos(bx) is b^n cos(bx + n pi/2); the phase is applied exactly.
      select case (modulo(order, 4))
      case (0)
         value = exp(-bx) - c + sigma*s + k*(grow - decay)
      case (1)
         value = -exp(-bx) + s + sigma*c + k*(grow + decay)
      case (2)
         value = exp(-bx) + c - sigma*s + k*(grow - decay)
      case default
         value = -exp(-bx) - s - sigma*c + k*(grow + decay)
      end select
      value = scale*value
   end function mode_shape

end module tmafm_modes

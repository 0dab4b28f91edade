!> Gauss-Legendre quadrature, used for Galerkin integrals that have no closed form
!> (an axial span ending before the free end, E2) and to cross-check the closed forms.
module tmafm_quadrature
   use tmafm_kinds, only: dp
   implicit none
   private

   public :: gauss_legendre, composite_gauss_legendre

contains

   !> Nodes and weights of the n-point Gauss-Legendre rule on [-1, 1].
   pure subroutine gauss_legendre(n, nodes, weights)
      integer, intent(in) :: n
      real(dp), intent(out) :: nodes(n)
      real(dp), intent(out) :: weights(n)
      real(dp), parameter :: pi = acos(-1.0_dp)
      real(dp) :: x, p0, p1, p2, dp_dx, step
      integer :: i, k, iter

      do i = 1, (n + 1)/2
         x = cos(pi*(real(i, dp) - 0.25_dp)/(real(n, dp) + 0.5_dp))
         do iter = 1, 100
            p0 = 1.0_dp
            p1 = x
            do k = 2, n
               p2 = ((2*k - 1)*x*p1 - (k - 1)*p0)/k
               p0 = p1
               p1 = p2
            end do
            if (n == 1) p0 = 1.0_dp
            dp_dx = n*(x*p1 - p0)/(x*x - 1.0_dp)
            step = p1/dp_dx
            x = x - step
            if (abs(step) <= 2*epsilon(x)) exit
         end do
         ! Re-evaluate the derivative at the converged node for the weight.
         p0 = 1.0_dp
         p1 = x
         do k = 2, n
            p2 = ((2*k - 1)*x*p1 - (k - 1)*p0)/k
            p0 = p1
            p1 = p2
         end do
         if (n == 1) p0 = 1.0_dp
         dp_dx = n*(x*p1 - p0)/(x*x - 1.0_dp)
         nodes(i) = -x
         nodes(n + 1 - i) = x
         weights(i) = 2.0_dp/((1.0_dp - x*x)*dp_dx*dp_dx)
         weights(n + 1 - i) = weights(i)
      end do
   end subroutine gauss_legendre

   !> Nodes and weights of n_panels equal panels of an n_points rule on [lower, upper].
   pure subroutine composite_gauss_legendre(lower, upper, n_panels, n_points, nodes, weights)
      real(dp), intent(in) :: lower
      real(dp), intent(in) :: upper
      integer, intent(in) :: n_panels
      integer, intent(in) :: n_points
      real(dp), intent(out) :: nodes(n_panels*n_points)
      real(dp), intent(out) :: weights(n_panels*n_points)
      real(dp) :: x(n_points), w(n_points), width, left
      integer :: panel, first

      call gauss_legendre(n_points, x, w)
      width = (upper - lower)/n_panels
      do panel = 1, n_panels
         left = lower + (panel - 1)*width
         first = (panel - 1)*n_points
         nodes(first + 1:first + n_points) = left + 0.5_dp*width*(x + 1.0_dp)
         weights(first + 1:first + n_points) = 0.5_dp*width*w
      end do
   end subroutine composite_gauss_legendre

end module tmafm_quadrature

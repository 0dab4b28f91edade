!> Dense output between step points: the cubic Hermite interpolant of docs/model.md §9.
module tmafm_interpolation
   use tmafm_kinds, only: dp
   implicit none
   private

   public :: hermite_cubic

contains

   !> The cubic through (y0, f0) at theta = 0 and (y1, f1) at theta = 1, for a step of length h.
   pure subroutine hermite_cubic(y0, f0, y1, f1, h, theta, y)
      real(dp), intent(in) :: y0(:)
      real(dp), intent(in) :: f0(:)
      real(dp), intent(in) :: y1(:)
      real(dp), intent(in) :: f1(:)
      real(dp), intent(in) :: h
      real(dp), intent(in) :: theta
      real(dp), intent(out) :: y(:)
      real(dp) :: h00, h10, h01, h11, t2, t3
      t2 = theta*theta
      t3 = t2*theta
      h00 = 2*t3 - 3*t2 + 1
      h10 = t3 - 2*t2 + theta
      h01 = -2*t3 + 3*t2
      h11 = t3 - t2
      y = h00*y0 + h10*h*f0 + h01*y1 + h11*h*f1
   end subroutine hermite_cubic

end module tmafm_interpolation

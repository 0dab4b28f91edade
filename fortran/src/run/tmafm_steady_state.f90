!> Steady-state classification of a sequence of Poincare points (the state at each drive
!> period boundary): a pure function, testable on synthetic sequences.
module tmafm_steady_state
   use tmafm_kinds, only: dp
   implicit none
   private

   public :: steady_period

contains

   !> The smallest period p in 1..p_max such that the last `repeats` points each repeat the
   !> point p periods earlier: max_i |P_j(i) - P_(j-p)(i)| <= tol * size for j = m-repeats+1..m,
   !> where size = max |P(i)| over the points compared (the orbit's size); 0 when none.
   !> points(:, 1:m) are the points in order; m < p + repeats leaves p untested.
   pure function steady_period(points, p_max, tol, repeats) result(period)
      real(dp), intent(in) :: points(:, :)
      integer, intent(in) :: p_max
      real(dp), intent(in) :: tol
      integer, intent(in) :: repeats
      integer :: period
      integer :: m, p, j, first
      real(dp) :: size_orbit, worst
      logical :: repeating

      period = 0
      m = size(points, 2)
      do p = 1, p_max
         if (m < p + max(repeats, 1) + 0) exit
         first = m - max(repeats, 1) + 1
         size_orbit = maxval(abs(points(:, first - p:m)))
         if (.not. (size_orbit > 0)) size_orbit = tiny(1.0_dp)
         repeating = .true.
         do j = first, m
            worst = maxval(abs(points(:, j) - points(:, j - p)))
            if (.not. (worst <= tol*size_orbit)) then
               repeating = .false.
               exit
            end if
         end do
         if (repeating) then
            period = p
            return
         end if
      end do
   end function steady_period

end module tmafm_steady_state

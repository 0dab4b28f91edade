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
   !> where size = max |P(i)| over the points compared (the orbit's size), and, for p > 1, the
   !> orbit's p points are distinct: for every proper divisor q of p, each of those points is
   !> more than sqrt(tol) * size from the point q periods earlier (a decaying flip transient,
   !> P_j - P_(j-1) ~ (-r)^j, repeats every 2 periods long before it repeats every period, but
   !> its points are not distinct).  0 when none.  points(:, 1:m) are the points in order.
   pure function steady_period(points, p_max, tol, repeats) result(period)
      real(dp), intent(in) :: points(:, :)
      integer, intent(in) :: p_max
      real(dp), intent(in) :: tol
      integer, intent(in) :: repeats
      integer :: period
      integer :: m, p, q, first, k
      real(dp) :: size_orbit
      logical :: distinct

      period = 0
      m = size(points, 2)
      k = max(repeats, 1)
      do p = 1, p_max
         if (m < p + k) exit
         first = m - k + 1
         size_orbit = maxval(abs(points(:, first - p:m)))
         if (.not. (size_orbit > 0)) size_orbit = tiny(1.0_dp)
         if (.not. (largest_step(points, first, m, p) <= tol*size_orbit)) cycle
         distinct = .true.
         do q = 1, p - 1
            if (mod(p, q) /= 0) cycle
            if (.not. (smallest_step(points, first, m, q) > sqrt(tol)*size_orbit)) then
               distinct = .false.
               exit
            end if
         end do
         if (distinct) then
            period = p
            return
         end if
      end do
   end function steady_period

   !> max over j = first..last of max_i |P_j(i) - P_(j-lag)(i)|.
   pure real(dp) function largest_step(points, first, last, lag)
      real(dp), intent(in) :: points(:, :)
      integer, intent(in) :: first
      integer, intent(in) :: last
      integer, intent(in) :: lag
      integer :: j
      largest_step = 0
      do j = first, last
         largest_step = max(largest_step, maxval(abs(points(:, j) - points(:, j - lag))))
      end do
   end function largest_step

   !> min over j = first..last of max_i |P_j(i) - P_(j-lag)(i)|.
   pure real(dp) function smallest_step(points, first, last, lag)
      real(dp), intent(in) :: points(:, :)
      integer, intent(in) :: first
      integer, intent(in) :: last
      integer, intent(in) :: lag
      integer :: j
      smallest_step = huge(1.0_dp)
      do j = first, last
         smallest_step = min(smallest_step, maxval(abs(points(:, j) - points(:, j - lag))))
      end do
   end function smallest_step

end module tmafm_steady_state

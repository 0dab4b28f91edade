!> Brent's bracketed root finder in reverse-communication form: the caller evaluates the
!> function, so the solver needs no callback and allocates nothing.
!>
!>   call root%start(a, fa, b, fb, xtol)
!>   do while (.not. root%converged())
!>      call root%next_point(x);  call root%update(f(x))
!>   end do
!>
!> The final bracket [b, c] keeps a sign change, so the caller can take the end on the side
!> it needs (for a contact switch, the end that lies in the new phase).
module tmafm_roots
   use tmafm_kinds, only: dp
   implicit none
   private

   public :: bracketed_root_t

   !> State of one bracketed root search (Brent 1973, "zeroin").
   type :: bracketed_root_t
      !> Brent's points: b the best estimate, [b, c] the bracket, a the previous b; their values;
      !> d and e the last two steps.
      real(dp) :: a = 0, b = 0, c = 0, fa = 0, fb = 0, fc = 0, d = 0, e = 0
      !> Absolute tolerance on the root.
      real(dp) :: xtol = 0
      !> Function evaluations used.
      integer :: evaluations = 0
      !> .true. once the bracket is within tolerance.
      logical :: done = .false.
   contains
      !> Start from a bracket with fa * fb <= 0.
      procedure :: start => root_start
      !> .true. once the bracket is within tolerance.
      procedure :: converged => root_converged
      !> The next point x at which the caller must evaluate the function (then call update).
      procedure :: next_point => root_point
      !> Give the function value at point().
      procedure :: update => root_update
      !> The bracket end whose value has the sign of `side` (or is zero).
      procedure :: end_with_sign => root_end_with_sign
   end type bracketed_root_t

   !> Most iterations allowed; Brent needs far fewer for a bracket of doubles.
   integer, parameter :: max_evaluations = 200

contains

   pure subroutine root_start(self, a, fa, b, fb, xtol)
      class(bracketed_root_t), intent(inout) :: self
      real(dp), intent(in) :: a, fa, b, fb
      real(dp), intent(in) :: xtol
      self%a = a
      self%fa = fa
      self%b = b
      self%fb = fb
      self%c = a
      self%fc = fa
      self%d = b - a
      self%e = self%d
      self%xtol = xtol
      self%evaluations = 0
      self%done = .false.
      call arrange(self)
   end subroutine root_start

   !> Keep b the best estimate and [b, c] a bracket; decide convergence.
   pure subroutine arrange(self)
      class(bracketed_root_t), intent(inout) :: self
      real(dp) :: tol
      if (sign(1.0_dp, self%fb)*sign(1.0_dp, self%fc) > 0 .and. self%fb /= 0) then
         self%c = self%a
         self%fc = self%fa
         self%d = self%b - self%a
         self%e = self%d
      end if
      if (abs(self%fc) < abs(self%fb)) then
         self%a = self%b
         self%b = self%c
         self%c = self%a
         self%fa = self%fb
         self%fb = self%fc
         self%fc = self%fa
      end if
      tol = 2*epsilon(1.0_dp)*abs(self%b) + 0.5_dp*self%xtol
      self%done = abs(0.5_dp*(self%c - self%b)) <= tol .or. self%fb == 0 &
                  .or. self%evaluations >= max_evaluations
   end subroutine arrange

   pure function root_converged(self) result(done)
      class(bracketed_root_t), intent(in) :: self
      logical :: done
      done = self%done
   end function root_converged

   pure subroutine root_point(self, x)
      class(bracketed_root_t), intent(inout) :: self
      real(dp), intent(out) :: x
      real(dp) :: tol, xm, p, q, r, s
      tol = 2*epsilon(1.0_dp)*abs(self%b) + 0.5_dp*self%xtol
      xm = 0.5_dp*(self%c - self%b)
      if (abs(self%e) >= tol .and. abs(self%fa) > abs(self%fb)) then
         ! Inverse quadratic interpolation, or the secant when only two points are known.
         s = self%fb/self%fa
         if (self%a == self%c) then
            p = 2*xm*s
            q = 1 - s
         else
            q = self%fa/self%fc
            r = self%fb/self%fc
            p = s*(2*xm*q*(q - r) - (self%b - self%a)*(r - 1))
            q = (q - 1)*(r - 1)*(s - 1)
         end if
         if (p > 0) then
            q = -q
         else
            p = -p
         end if
         if (2*p < min(3*xm*q - abs(tol*q), abs(self%e*q))) then
            self%e = self%d
            self%d = p/q
         else
            self%d = xm
            self%e = self%d
         end if
      else
         self%d = xm
         self%e = self%d
      end if
      self%a = self%b
      self%fa = self%fb
      if (abs(self%d) > tol) then
         x = self%b + self%d
      else
         x = self%b + sign(tol, xm)
      end if
      self%b = x
   end subroutine root_point

   pure subroutine root_update(self, fx)
      class(bracketed_root_t), intent(inout) :: self
      real(dp), intent(in) :: fx
      self%fb = fx
      self%evaluations = self%evaluations + 1
      call arrange(self)
   end subroutine root_update

   pure subroutine root_end_with_sign(self, side, x)
      class(bracketed_root_t), intent(in) :: self
      real(dp), intent(in) :: side
      real(dp), intent(out) :: x
      if (self%fb == 0 .or. sign(1.0_dp, self%fb) == sign(1.0_dp, side)) then
         x = self%b
      else
         x = self%c
      end if
   end subroutine root_end_with_sign

end module tmafm_roots

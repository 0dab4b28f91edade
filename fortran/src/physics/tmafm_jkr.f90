!> The JKR contact law: an adhesive neck that forms at contact and breaks at the JKR pull-off, past
!> the undeformed surface (docs/model.md §18; K. L. Johnson, K. Kendall and A. D. Roberts,
!> Proc. R. Soc. Lond. A 324, 301 (1971); D. Maugis, Contact, Adhesion and Rupture of Elastic
!> Solids (2000), ch. 5).
!>
!> In SI, with a the contact radius, w the work of adhesion (here the adhesion energy gamma),
!> E* the reduced modulus and R the tip radius, the normal indentation and the force are
!>   delta = a^2/R - sqrt(2 pi w a/E*),   F = 4 E* a^3/(3 R) - sqrt(8 pi w E* a^3).
!> In the contact's units (force 1.5 pi gamma R, radius A as in §6: Hertz is D = A^2, f = A^3,
!> with D = delta_n/(beta d) = -V_T sin(theta1)/beta) they read
!>   D = A^2 - (4/3) sqrt(A),   f = A^3 - 2 A^(3/2),
!> and the stable branch (dD/dA > 0) is A >= A_c = 3^(-2/3): the neck breaks under the
!> cantilever's displacement at D_c = -3^(-1/3) (delta_c = -(3/4)(pi^2 w^2 R/E*^2)^(1/3)), where
!> f = -5/9 (F = -(5/6) pi w R); at D = 0, where it formed, f = -8/9 (F = -(4/3) pi w R).
module tmafm_jkr
   use tmafm_kinds, only: dp
   implicit none
   private

   public :: law_jkr, jkr_pull_off_depth, jkr_pull_off_radius, jkr_radius, jkr_force_group

   !> The JKR law (the laws of tmafm_contact are 1 and 2, 'dmt_vdw' 3).
   integer, parameter :: law_jkr = 4
   !> A_c = 3^(-2/3): the contact radius at pull-off, where dD/dA = 0.
   real(dp), parameter :: jkr_pull_off_radius = 3.0_dp**(-2.0_dp/3.0_dp)
   !> D_c = -3^(-1/3): the normal indentation (in units of beta d) at which the neck breaks.
   real(dp), parameter :: jkr_pull_off_depth = -3.0_dp**(-1.0_dp/3.0_dp)

contains

   !> The contact radius A on the stable branch at normal indentation D (units of beta d): the
   !> root x = sqrt(A) >= x_c of x^4 - (4/3) x - D = 0 by Newton's method from the right (the
   !> function is convex and increasing there, so the iterates fall monotonically to the root);
   !> below D_c (a stage that overshoots the pull-off) the branch's end A_c.
   elemental function jkr_radius(depth) result(radius)
      real(dp), intent(in) :: depth
      real(dp) :: radius, x, step
      real(dp), parameter :: x_c = 3.0_dp**(-1.0_dp/3.0_dp)
      integer :: k
      if (.not. (depth > jkr_pull_off_depth)) then
         radius = jkr_pull_off_radius
         return
      end if
      ! h(1.2 + u) > 0 for u = max(D, 0)^(1/4): a start right of the root.
      x = 1.2_dp + sqrt(sqrt(max(depth, 0.0_dp)))
      do k = 1, 200
         step = (x**4 - (4.0_dp/3.0_dp)*x - depth)/(4*x**3 - 4.0_dp/3.0_dp)
         x = max(x - step, x_c)
         if (abs(step) <= 4*epsilon(1.0_dp)*x) exit
      end do
      radius = x*x
   end function jkr_radius

   !> The normal-force group f = A^3 - 2 A^(3/2) at contact radius A.
   elemental function jkr_force_group(radius) result(normal)
      real(dp), intent(in) :: radius
      real(dp) :: normal
      normal = radius**3 - 2*radius*sqrt(radius)
   end function jkr_force_group

end module tmafm_jkr

!> Tip-sample contact kinematics and forces, docs/model.md §6, paper Eqs. (3)-(7), (11), (13).
!>
!> All quantities are dimensionless.  The indentation is -V_T (V_T <= 0 in contact);
!> A = sqrt(-V_T sin(theta1)/beta) is the contact radius, f_c the normal-force group
!> (Hertz A^3, DMT A^3 - 4/3), h = A (-V_T cos theta1) the Mindlin friction group, and
!> P1, P2 the transverse and axial brackets of Eq. (11) with scales kappa5, kappa6.
module tmafm_contact
   use tmafm_kinds, only: dp
   implicit none
   private

   public :: law_hertz, law_dmt, dmt_adhesion
   public :: contact_angle, contact_radius, normal_force_group, friction_group
   public :: contact_brackets_t, contact_brackets
   public :: contact_angle_sin_cos, contact_forces

   !> Non-adhesive Hertz contact.
   integer, parameter :: law_hertz = 1
   !> Adhesive DMT contact: Hertz plus the constant pull-off.
   integer, parameter :: law_dmt = 2
   !> The DMT pull-off in units of the Hertz force scale: f_c = A^3 - 4/3.
   real(dp), parameter :: dmt_adhesion = 4.0_dp/3.0_dp

   !> Contact state at one instant: angle, radius, force groups and the two brackets.
   type :: contact_brackets_t
      !> Contact angle theta1 (rad).
      real(dp) :: theta1 = 0
      !> Dimensionless contact radius A.
      real(dp) :: radius = 0
      !> Normal-force group f_c.
      real(dp) :: normal = 0
      !> Friction group h = A (-V_T cos theta1).
      real(dp) :: friction = 0
      !> Transverse bracket P1 = kappa5 f_c sin(theta1) + kappa6 h cos(theta1).
      real(dp) :: transverse = 0
      !> Axial bracket P2 = -kappa5 f_c cos(theta1) + kappa6 h sin(theta1).
      real(dp) :: axial = 0
   end type contact_brackets_t

contains

   !> Contact angle theta1 for tilt theta and tip slope (d/L) dW/dxi; Eq. (3), or E7 if signed.
   elemental function contact_angle(theta, scaled_slope, signed_slope) result(theta1)
      real(dp), intent(in) :: theta
      real(dp), intent(in) :: scaled_slope
      logical, intent(in) :: signed_slope
      real(dp) :: theta1
      real(dp), parameter :: half_pi = acos(-1.0_dp)/2
      if (signed_slope) then
         ! E7: a positive slope lifts the free end against the tilt.
         theta1 = half_pi - theta + atan(scaled_slope)
      else
         theta1 = half_pi - theta - atan(abs(scaled_slope))
      end if
   end function contact_angle

   !> Contact radius A = sqrt(-V_T sin(theta1)/beta), zero when the tip is above the surface.
   elemental function contact_radius(vt, theta1, beta) result(radius)
      real(dp), intent(in) :: vt
      real(dp), intent(in) :: theta1
      real(dp), intent(in) :: beta
      real(dp) :: radius
      radius = sqrt(max(-vt, 0.0_dp)*sin(theta1)/beta)
   end function contact_radius

   !> Normal-force group f_c: A^3 (Hertz) or A^3 - 4/3 (DMT).
   elemental function normal_force_group(radius, law) result(normal)
      real(dp), intent(in) :: radius
      integer, intent(in) :: law
      real(dp) :: normal
      normal = radius**3
      if (law == law_dmt) normal = normal - dmt_adhesion
   end function normal_force_group

   !> Friction group h = A (-V_T cos theta1), the no-slip Mindlin spring of Eq. (6).
   elemental function friction_group(radius, vt, theta1) result(friction)
      real(dp), intent(in) :: radius
      real(dp), intent(in) :: vt
      real(dp), intent(in) :: theta1
      real(dp) :: friction
      friction = radius*(-min(vt, 0.0_dp)*cos(theta1))
   end function friction_group

   !> sin and cos of the contact angle theta1 from those of the tilt and the scaled slope, with no
   !> atan: theta1 = pi/2 - (theta + atan t), t = |slope| (Eq. 3) or -slope (E7), so
   !> sin(theta1) = (cos(theta) - t sin(theta))/sqrt(1 + t^2), cos(theta1) = (sin(theta) + t cos(theta))/sqrt(1 + t^2).
   elemental subroutine contact_angle_sin_cos(sin_theta, cos_theta, scaled_slope, signed_slope, &
         sin1, cos1)
      real(dp), intent(in) :: sin_theta
      real(dp), intent(in) :: cos_theta
      real(dp), intent(in) :: scaled_slope
      logical, intent(in) :: signed_slope
      real(dp), intent(out) :: sin1
      real(dp), intent(out) :: cos1
      real(dp) :: t, scale
      if (signed_slope) then
         t = -scaled_slope
      else
         t = abs(scaled_slope)
      end if
      if (abs(t) <= 1) then
         scale = 1/sqrt(1 + t*t)
         sin1 = (cos_theta - t*sin_theta)*scale
         cos1 = (sin_theta + t*cos_theta)*scale
      else
         ! The same with 1/t, so that a huge slope does not overflow t*t.
         t = 1/t
         scale = 1/sqrt(1 + t*t)
         sin1 = sign(scale, t)*(t*cos_theta - sin_theta)
         cos1 = sign(scale, t)*(t*sin_theta + cos_theta)
      end if
   end subroutine contact_angle_sin_cos

   !> The two brackets of Eq. (11) from the gap and sin, cos of the contact angle:
   !> P1 = kappa5 f_c sin(theta1) + kappa6 h cos(theta1), P2 = -kappa5 f_c cos(theta1) + kappa6 h sin(theta1).
   elemental subroutine contact_forces(vt, sin1, cos1, beta, law, kappa5, kappa6, transverse, axial, &
         radius, normal, friction)
      real(dp), intent(in) :: vt
      real(dp), intent(in) :: sin1
      real(dp), intent(in) :: cos1
      real(dp), intent(in) :: beta
      integer, intent(in) :: law
      real(dp), intent(in) :: kappa5
      real(dp), intent(in) :: kappa6
      real(dp), intent(out) :: transverse
      real(dp), intent(out) :: axial
      real(dp), intent(out) :: radius
      real(dp), intent(out) :: normal
      real(dp), intent(out) :: friction
      real(dp) :: depth
      depth = max(-vt, 0.0_dp)
      ! depth/beta first: the division does not wait for the contact angle.
      radius = sqrt((depth/beta)*sin1)
      normal = radius*radius*radius
      if (law == law_dmt) normal = normal - dmt_adhesion
      friction = radius*(depth*cos1)
      transverse = kappa5*normal*sin1 + kappa6*friction*cos1
      axial = -kappa5*normal*cos1 + kappa6*friction*sin1
   end subroutine contact_forces

   !> Everything the equations of motion need from the contact at one instant.
   pure function contact_brackets(vt, scaled_slope, theta, beta, law, kappa5, kappa6, &
         signed_slope) result(state)
      real(dp), intent(in) :: vt
      real(dp), intent(in) :: scaled_slope
      real(dp), intent(in) :: theta
      real(dp), intent(in) :: beta
      integer, intent(in) :: law
      real(dp), intent(in) :: kappa5
      real(dp), intent(in) :: kappa6
      logical, intent(in) :: signed_slope
      type(contact_brackets_t) :: state
      real(dp) :: sin1, cos1

      state%theta1 = contact_angle(theta, scaled_slope, signed_slope)
      call contact_angle_sin_cos(sin(theta), cos(theta), scaled_slope, signed_slope, sin1, cos1)
      call contact_forces(vt, sin1, cos1, beta, law, kappa5, kappa6, state%transverse, state%axial, &
                          state%radius, state%normal, state%friction)
   end function contact_brackets

end module tmafm_contact

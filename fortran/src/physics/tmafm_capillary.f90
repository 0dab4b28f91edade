!> The capillary meniscus of ambient air (docs/model.md §19): a water neck that forms when the tip
!> touches the sample and breaks at a rupture distance on the way out, so that its force is
!> hysteretic and takes an energy from the cantilever at every tap.  Off by default.
!>
!> In the circular (toroidal) approximation of a small meniscus between a sphere of radius R and
!> a plane, both wetted at the contact angle theta_w, with a Kelvin radius r_K << R, the Laplace
!> pressure gamma_w/r_K acts on the wetted area pi x^2, x^2 = 2 R (D - g), D = 2 r_K cos(theta_w):
!>
!>   F(g) = -F0 (1 - g/D),   F0 = 4 pi R gamma_w cos(theta_w),   0 <= g <= D,
!>
!> g the normal gap from contact (Israelachvili, Intermolecular and Surface Forces, 3rd ed.,
!> §17.7; the linear form of L. Zitzler, S. Herminghaus, F. Mugele, Phys. Rev. B 66, 155436
!> (2002), and M. Kober et al., which VEDA uses).  In contact the neck pulls with F0.  The neck
!> forms at contact and breaks at g = D, where its force has dropped to zero: the force is
!> continuous, but the neck does work only on the way out, F0 D/2 a tap.  D is given
!> (&physical meniscus_rupture_distance) or the equilibrium one of the humidity RH,
!> r_K = gamma_w V_m/(R_g T ln(1/RH)) (Kelvin).
!>
!> In the units of the contact's force 1.5 pi gamma R (docs/model.md §6) the group the meniscus
!> adds to the normal force is -c_C in contact and -c_C (1 - g/D) in flight while it holds, with
!> c_C = (8/3) gamma_w cos(theta_w)/gamma and g, D in units of the gap d.
module tmafm_capillary
   use tmafm_kinds, only: dp
   implicit none
   private

   public :: capillary_t, meniscus_force_group, water_molar_volume

   !> The molar volume of liquid water at 25 °C (m^3/mol), for the Kelvin radius.
   real(dp), parameter :: water_molar_volume = 1.8069e-5_dp

   !> The meniscus of a scene, in the units above; off when its strength is 0.
   type :: capillary_t
      !> .true. when the meniscus is modelled.
      logical :: on = .false.
      !> c_C: the neck's pull in contact, in units of 1.5 pi gamma R.
      real(dp) :: strength = 0
      !> D/d: the normal gap at which the neck breaks.
      real(dp) :: rupture_gap = 1
   end type capillary_t

contains

   !> The normal-force group of a meniscus that holds at normal gap g (units of d): -c_C in
   !> contact (g <= 0), -c_C (1 - g/D) above.
   pure real(dp) function meniscus_force_group(meniscus, gap) result(force)
      type(capillary_t), intent(in) :: meniscus
      real(dp), intent(in) :: gap
      force = -meniscus%strength*(1 - max(gap, 0.0_dp)/meniscus%rupture_gap)
   end function meniscus_force_group

end module tmafm_capillary

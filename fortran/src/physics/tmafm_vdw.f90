!> Van der Waals attraction out of contact and DMT adhesion in contact: the tip-sample law
!> 'dmt_vdw' (docs/model.md §6a; Hamaker 1937; Garcia & San Paulo, Phys. Rev. B 61, R13381
!> (2000) and Ultramicroscopy 82, 79 (2000)).
!>
!> In SI: at a normal separation s >= a0 the sphere-plane force is F = -H R/(6 s^2); in contact
!> (V_T <= 0) it is the DMT force 4 E* a^3/(3 R) - H R/(6 a0^2), so the two meet at s = a0
!> (the DMT-M convention: contact is V_T = 0, where s = a0).  Out of contact the normal
!> separation is s = a0 + d V_T sin(theta1) (the contact's normal indentation -V_T sin(theta1)
!> continued above the surface).  In the units of the contact (force scale 1.5 pi gamma R,
!> docs/model.md §6) the normal-force group is
!>
!>   f_c = A^3 - c_H                          (V_T <= 0)
!>   f_c = -c_H/(1 + V_T sin(theta1)/eps)^2   (V_T >  0)
!>
!> with c_H = H/(9 pi gamma a0^2) (&scene vdw_adhesion) and eps = a0/d (&scene vdw_range).
!> Out of contact there is no friction (h = 0): the Mindlin spring needs a contact area.  The
!> force enters the beam through the same brackets P1, P2 as the contact force (Eq. 7).
module tmafm_vdw
   use tmafm_kinds, only: dp
   use tmafm_contact, only: contact_brackets_t, contact_angle, contact_angle_sin_cos, contact_forces, &
      law_hertz
   implicit none
   private

   public :: law_dmt_vdw, vdw_forces, vdw_brackets, vdw_normal_group

   !> DMT contact with van der Waals attraction out of contact.
   integer, parameter :: law_dmt_vdw = 3

contains

   !> The normal-force group f_c of the law at gap V_T: A^3 - c_H in contact (radius A given),
   !> -c_H/(1 + V_T sin(theta1)/eps)^2 out of contact.  The phase, not the sign of V_T, picks the
   !> branch, so that each phase's force is smooth across the stages of a step that overshoot
   !> the switch (a stage above the surface in contact has A = 0; one below it in flight sees
   !> the tail continued, its separation kept >= a0/2).
   elemental function vdw_normal_group(in_contact, vt, sin1, radius, adhesion, range) result(normal)
      logical, intent(in) :: in_contact
      real(dp), intent(in) :: vt
      real(dp), intent(in) :: sin1
      real(dp), intent(in) :: radius
      real(dp), intent(in) :: adhesion
      real(dp), intent(in) :: range
      real(dp) :: normal, ratio
      if (in_contact) then
         normal = radius*radius*radius - adhesion
      else
         ! s/a0.  A contact angle past pi/2 (sin(theta1) < 0, a beam bent beyond the tilt) would
         ! put the apex below the plane: the normal separation then counts as zero.
         ratio = max(1 + vt*max(sin1, 0.0_dp)/range, 0.5_dp)
         normal = -adhesion/(ratio*ratio)
      end if
   end function vdw_normal_group

   !> The brackets of Eq. (11) under 'dmt_vdw' from the gap and sin, cos of the contact angle:
   !> in contact the Hertz force and friction with the vdW adhesion c_H; out of contact the
   !> attraction alone (no friction, A = 0).
   elemental subroutine vdw_forces(in_contact, vt, sin1, cos1, beta, kappa5, kappa6, adhesion, range, &
         transverse, axial, radius, normal, friction)
      logical, intent(in) :: in_contact
      real(dp), intent(in) :: vt
      real(dp), intent(in) :: sin1
      real(dp), intent(in) :: cos1
      real(dp), intent(in) :: beta
      real(dp), intent(in) :: kappa5
      real(dp), intent(in) :: kappa6
      real(dp), intent(in) :: adhesion
      real(dp), intent(in) :: range
      real(dp), intent(out) :: transverse
      real(dp), intent(out) :: axial
      real(dp), intent(out) :: radius
      real(dp), intent(out) :: normal
      real(dp), intent(out) :: friction
      if (in_contact) then
         call contact_forces(vt, sin1, cos1, beta, law_hertz, kappa5, kappa6, transverse, axial, &
                             radius, normal, friction)
         normal = normal - adhesion
         transverse = transverse - kappa5*adhesion*sin1
         axial = axial + kappa5*adhesion*cos1
      else
         radius = 0
         friction = 0
         normal = vdw_normal_group(.false., vt, sin1, radius, adhesion, range)
         transverse = kappa5*normal*sin1
         axial = -kappa5*normal*cos1
      end if
   end subroutine vdw_forces

   !> contact_brackets under 'dmt_vdw': angle, radius, force groups and brackets at one instant
   !> in a phase (in contact or in flight).
   pure function vdw_brackets(in_contact, vt, scaled_slope, theta, beta, kappa5, kappa6, signed_slope, adhesion, &
         range) result(state)
      logical, intent(in) :: in_contact
      real(dp), intent(in) :: vt
      real(dp), intent(in) :: scaled_slope
      real(dp), intent(in) :: theta
      real(dp), intent(in) :: beta
      real(dp), intent(in) :: kappa5
      real(dp), intent(in) :: kappa6
      logical, intent(in) :: signed_slope
      real(dp), intent(in) :: adhesion
      real(dp), intent(in) :: range
      type(contact_brackets_t) :: state
      real(dp) :: sin1, cos1

      state%theta1 = contact_angle(theta, scaled_slope, signed_slope)
      call contact_angle_sin_cos(sin(theta), cos(theta), scaled_slope, signed_slope, sin1, cos1)
      call vdw_forces(in_contact, vt, sin1, cos1, beta, kappa5, kappa6, adhesion, range, state%transverse, &
                      state%axial, state%radius, state%normal, state%friction)
   end function vdw_brackets

end module tmafm_vdw

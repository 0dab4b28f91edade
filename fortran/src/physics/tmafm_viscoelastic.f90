!> A viscoelastic sample: the standard linear solid (three-element, Zener) under the Hertz law,
!> docs/model.md §14.  Off by default (relaxation time 0): the contact is then elastic, as in §6.
!>
!> The sample's stress relaxes as psi(t) = E_inf + (E_0 - E_inf) exp(-t/T).  By the
!> correspondence principle (Lee-Radok) the Hertz force is then the SLS acting on the Hertz
!> variable X = A^3 (the force group of the instantaneous modulus E_0, §6):
!>   f = X_s - (1 - r) w,   dw/dtau = (X_s - w)/T,   r = E*_inf/E*_0,
!> with w the Maxwell arm's dashpot coordinate (in units of X) and X_s the sample's own
!> Hertz strain: the tip's X while the tip presses on the sample, the free surface's (1 - r) w
!> when the sample has not come back to meet the tip.  So X_s = max(X, (1 - r) w) and the force
!> is never tensile: f = max(X - (1 - r) w, 0).  With the tip away (X = 0) the surface
!> recovers in closed form, w(tau0 + s) = w(tau0) exp(-r s/T): at the retardation (creep)
!> time T/r.  T -> 0 gives the relaxed elastic law X r, T -> infinity the instantaneous one X.
module tmafm_viscoelastic
   use tmafm_kinds, only: dp
   implicit none
   private

   public :: sls_t, sls_force_group, sls_rate, sls_free_relaxation, sls_viscoelastic_part

   !> The standard linear solid of a scene; off (the elastic contact) when relaxation_time = 0.
   type :: sls_t
      !> .true. when the sample is viscoelastic (relaxation_time > 0).
      logical :: on = .false.
      !> T: the stress relaxation time of the contact at fixed indentation, in units of tau.
      real(dp) :: relaxation_time = 0
      !> r = E*_inf/E*_0: the relaxed over the instantaneous reduced modulus, in (0, 1].
      real(dp) :: modulus_ratio = 1
      !> 1 - r: the share of the instantaneous modulus that relaxes.
      real(dp) :: relaxing = 0
      !> 1/T.
      real(dp) :: rate = 0
   end type sls_t

   interface sls_t
      module procedure make_sls
   end interface sls_t

contains

   !> The sample of relaxation time T (0: off) and modulus ratio r.
   pure function make_sls(relaxation_time, modulus_ratio) result(sls)
      real(dp), intent(in) :: relaxation_time
      real(dp), intent(in) :: modulus_ratio
      type(sls_t) :: sls
      sls%on = relaxation_time > 0
      sls%relaxation_time = relaxation_time
      sls%modulus_ratio = modulus_ratio
      sls%relaxing = 1 - modulus_ratio
      if (sls%on) sls%rate = 1/relaxation_time
   end function make_sls

   !> The normal-force group of the sample, f = max(X - (1 - r) w, 0), from the Hertz variable
   !> X = A^3 (>= 0) and the dashpot coordinate w (>= 0).
   elemental function sls_force_group(sls, hertz, w) result(force)
      type(sls_t), intent(in) :: sls
      real(dp), intent(in) :: hertz
      real(dp), intent(in) :: w
      real(dp) :: force
      force = max(hertz - sls%relaxing*w, 0.0_dp)
   end function sls_force_group

   !> dw/dtau = (max(X, (1 - r) w) - w)/T: the dashpot follows the sample's strain.
   elemental function sls_rate(sls, hertz, w) result(rate)
      type(sls_t), intent(in) :: sls
      real(dp), intent(in) :: hertz
      real(dp), intent(in) :: w
      real(dp) :: rate
      rate = (max(hertz, sls%relaxing*w) - w)*sls%rate
   end function sls_rate

   !> w after a time s with the tip away from the sample: w exp(-r s/T), exact.
   elemental function sls_free_relaxation(sls, w, s) result(w_after)
      type(sls_t), intent(in) :: sls
      real(dp), intent(in) :: w
      real(dp), intent(in) :: s
      real(dp) :: w_after
      w_after = w*exp(-sls%modulus_ratio*sls%rate*s)
   end function sls_free_relaxation

   !> The viscoelastic part of the force group, f - X = -min(X, (1 - r) w): what the sample's
   !> delay takes from the instantaneous elastic force X.
   elemental function sls_viscoelastic_part(sls, hertz, w) result(part)
      type(sls_t), intent(in) :: sls
      real(dp), intent(in) :: hertz
      real(dp), intent(in) :: w
      real(dp) :: part
      part = -min(hertz, sls%relaxing*w)
   end function sls_viscoelastic_part

end module tmafm_viscoelastic

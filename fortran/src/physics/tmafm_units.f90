!> The scales of Eq. (12) that turn the dimensionless observables into SI-derived units, in
!> one place: lengths in units of the gap d, time in units of t0 = sqrt(m L^4/(E1 I)), the
!> contact forces (kappa5 f_c, P1, P2) in units of E1 I/L^2, and modal energies in units of
!> E1 I d^2/L^3 (the beam equation divided by E1 I d/L^4 makes w'''' + w_tautau = F L^3/(E1 I d)).
module tmafm_units
   use tmafm_kinds, only: dp
   use tmafm_scene, only: physical_t, beam_rigidity, beam_mass_per_length
   implicit none
   private

   public :: scales_t, scales_from_physical

   !> SI scales of a physical scene; `known` is .false. for a scene given dimensionless.
   type :: scales_t
      !> .true. when the scales come from &physical.
      logical :: known = .false.
      !> Length scale: the gap d (m).
      real(dp) :: length = 1
      !> Time scale t0 = sqrt(m L^4/(E1 I)) with m = rho b h (s).
      real(dp) :: time = 1
      !> Force scale of the contact forces: E1 I/L^2 (N).
      real(dp) :: force = 1
      !> Energy scale of the modal energy and the powers integrated over tau: E1 I d^2/L^3 (J).
      real(dp) :: energy = 1
      !> Scale of a contact force times a length (the virial): E1 I d/L^2 (J).
      real(dp) :: force_length = 1
   end type scales_t

contains

   !> The scales of a physical scene (Eq. (10) and (12)).
   pure function scales_from_physical(phys) result(scales)
      type(physical_t), intent(in) :: phys
      type(scales_t) :: scales
      real(dp) :: rigidity, mass_per_length
      ! The geometry's E1 I as this module always computed it (last bits kept), or the calibration's.
      rigidity = phys%youngs_modulus_tip*phys%width*phys%thickness**3/12
      if (phys%by_calibration) rigidity = beam_rigidity(phys)
      mass_per_length = beam_mass_per_length(phys)
      scales%known = .true.
      scales%length = phys%gap
      scales%time = sqrt(mass_per_length*phys%length**4/rigidity)
      scales%force = rigidity/phys%length**2
      scales%energy = rigidity*phys%gap**2/phys%length**3
      scales%force_length = scales%force*phys%gap
   end function scales_from_physical

end module tmafm_units

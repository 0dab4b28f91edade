!> Forces at a distance that add to any contact law (docs/model.md §17): the electrostatic force
!> of a biased tip over a grounded conducting sample, and the electrical double layer in an
!> electrolyte.  Both are off by default and act along the sample's normal.
!>
!> They are functions of the tip-sample separation s, in units of the gap d, s_hat = s/d:
!> in flight s_hat = eps + V_T sin(theta1) (eps = a0/d, &scene vdw_range: the separation at
!> contact), kept >= eps/2 as tmafm_vdw keeps it; in contact s_hat = eps, so each force is
!> continuous at the switch and constant in contact.  In the units of the contact's normal
!> force (1.5 pi gamma R, docs/model.md §6) the normal-force group they add is
!>
!>   f_E  = -c_E [ rho b/(s (s + b)) + k^2 (ln(eta/(s + b)) - 1 + c/(s + b)) ]   (Hudlet et al.)
!>   f_DL =  c_DL exp(-s/lambda)                                                (Butt 1991)
!>
!> with c_E = eps_r eps0 V^2/(1.5 gamma R), V = tip_bias - contact_potential, rho = R/d,
!> b = rho (1 - sin theta0), c = rho cos^2(theta0)/sin(theta0), eta = g0/d (the cone's height is
!> the tip's length), k^2 = 1/ln^2(tan(theta0/2)) for a cone of half-angle theta0; and
!> c_DL = 8 eps_r eps0 psi_t psi_s/(3 gamma lambda_D), lambda = lambda_D/d.  The apex term is the
!> sphere-plane force -pi eps0 V^2 R/s for s << R (1 - sin theta0); for s >> R the cone's
!> -pi eps0 V^2 k^2 (ln(H/s) - 1) remains.  References: S. Hudlet, M. Saint Jean, C. Guthmann,
!> J. Berger, Eur. Phys. J. B 2, 5 (1998); H.-J. Butt, Biophys. J. 60, 1438 (1991); J.
!> Israelachvili, Intermolecular and Surface Forces (3rd ed., 2011), ch. 14.
module tmafm_surface_forces
   use tmafm_kinds, only: dp
   implicit none
   private

   public :: surface_forces_t, surface_force_group, surface_force_slope, flight_separation

   !> The forces at a distance of a scene, in the units above; off when both strengths are 0.
   type :: surface_forces_t
      !> .true. when either force is on.
      logical :: on = .false.
      !> c_E: the electrostatic strength (0: off).
      real(dp) :: electrostatic = 0
      !> rho b = R^2 (1 - sin theta0)/d^2: the apex term's numerator.
      real(dp) :: apex_area = 0
      !> b = R (1 - sin theta0)/d: the apex's offset.
      real(dp) :: apex_offset = 0
      !> k^2 = 1/ln^2(tan(theta0/2)): the cone's factor.
      real(dp) :: cone_factor = 0
      !> eta = g0/d: the cone's height over the gap.
      real(dp) :: cone_height = 0
      !> c = R cos^2(theta0)/(sin(theta0) d): the cone's shoulder term.
      real(dp) :: cone_shoulder = 0
      !> c_DL: the double layer's strength at zero separation (0: off).
      real(dp) :: double_layer = 0
      !> 1/lambda = d/lambda_D: the double layer's decay rate per gap.
      real(dp) :: double_layer_rate = 0
      !> eps = a0/d: the separation at contact.
      real(dp) :: contact_separation = 0
   end type surface_forces_t

   interface surface_forces_t
      module procedure make_surface_forces
   end interface surface_forces_t

contains

   !> The forces of strengths c_E and c_DL, apex radius rho = R/d, cone half-angle theta0 (rad),
   !> cone height eta = g0/d, Debye length lambda = lambda_D/d and contact separation eps = a0/d.
   pure function make_surface_forces(electrostatic, radius, half_angle, height, double_layer, &
                                     debye_length, contact_separation) result(forces)
      real(dp), intent(in) :: electrostatic
      real(dp), intent(in) :: radius
      real(dp), intent(in) :: half_angle
      real(dp), intent(in) :: height
      real(dp), intent(in) :: double_layer
      real(dp), intent(in) :: debye_length
      real(dp), intent(in) :: contact_separation
      type(surface_forces_t) :: forces
      real(dp) :: s0
      forces%contact_separation = contact_separation
      if (electrostatic > 0) then
         s0 = sin(half_angle)
         forces%electrostatic = electrostatic
         forces%apex_offset = radius*(1 - s0)
         forces%apex_area = radius*forces%apex_offset
         forces%cone_factor = 1/log(tan(half_angle/2))**2
         forces%cone_height = height
         forces%cone_shoulder = radius*cos(half_angle)**2/s0
      end if
      if (double_layer /= 0 .and. debye_length > 0) then
         forces%double_layer = double_layer
         forces%double_layer_rate = 1/debye_length
      end if
      forces%on = forces%electrostatic > 0 .or. forces%double_layer /= 0
   end function make_surface_forces

   !> The separation s_hat in flight at gap vt and sin(theta1): eps + vt max(sin(theta1), 0), kept
   !> >= eps/2 (a stage of a step that overshoots the switch sees the force continued).
   elemental function flight_separation(forces, vt, sin1) result(separation)
      type(surface_forces_t), intent(in) :: forces
      real(dp), intent(in) :: vt
      real(dp), intent(in) :: sin1
      real(dp) :: separation
      separation = max(forces%contact_separation + vt*max(sin1, 0.0_dp), forces%contact_separation/2)
   end function flight_separation

   !> The normal-force group f_E + f_DL at separation s_hat.
   elemental function surface_force_group(forces, separation) result(normal)
      type(surface_forces_t), intent(in) :: forces
      real(dp), intent(in) :: separation
      real(dp) :: normal, shifted
      normal = 0
      if (forces%electrostatic > 0) then
         shifted = separation + forces%apex_offset
         normal = -forces%electrostatic*(forces%apex_area/(separation*shifted) &
                                         + forces%cone_factor*(log(forces%cone_height/shifted) - 1 &
                                                               + forces%cone_shoulder/shifted))
      end if
      if (forces%double_layer /= 0) &
         normal = normal + forces%double_layer*exp(-separation*forces%double_layer_rate)
   end function surface_force_group

   !> d(f_E + f_DL)/ds_hat at separation s_hat.
   elemental function surface_force_slope(forces, separation) result(slope)
      type(surface_forces_t), intent(in) :: forces
      real(dp), intent(in) :: separation
      real(dp) :: slope, shifted
      slope = 0
      if (forces%electrostatic > 0) then
         shifted = separation + forces%apex_offset
         slope = forces%electrostatic*(forces%apex_area*(2*separation + forces%apex_offset) &
                                       /(separation*shifted)**2 &
                                       + forces%cone_factor*(1 + forces%cone_shoulder/shifted)/shifted)
      end if
      if (forces%double_layer /= 0) &
         slope = slope - forces%double_layer*forces%double_layer_rate &
                 *exp(-separation*forces%double_layer_rate)
   end function surface_force_slope

end module tmafm_surface_forces

!> The dimensionless scene (docs/model.md §2, paper Eqs. (10), (12), (24)) and its
!> conversion from physical SI inputs.
!>
!> Defaults are the paper's Sec. 3 values.  The physical defaults describe the same
!> scene: a silicon cantilever on polystyrene, with the tip mass, damping, drive
!> amplitude and frequency chosen so that alpha1 = 0.05, alpha3 = alpha4 = 0.4,
!> alpha2 = 5e-4 and Omega = 2.
module tmafm_scene
   use tmafm_kinds, only: dp
   implicit none
   private

   public :: scene_t, physical_t, scene_from_physical
   public :: scene_names, scene_values, physical_names, physical_values, scene_depends_on

   real(dp), parameter :: pi = acos(-1.0_dp)

   !> Dimensionless groups that define a scene.
   type :: scene_t
      !> alpha1 = M/(m L): tip mass over beam mass.
      real(dp) :: alpha1 = 0.05_dp
      !> alpha2 = f/d: drive amplitude over gap.
      real(dp) :: alpha2 = 5.0e-4_dp
      !> alpha3: beam viscous damping.
      real(dp) :: alpha3 = 0.4_dp
      !> alpha4: contact (Kelvin-Voigt) damping.
      real(dp) :: alpha4 = 0.4_dp
      !> alpha5 = 3 pi gamma R L^2/(E1 I): normal-force scale (Eq. 12).
      real(dp) :: alpha5 = 6.7665e-5_dp
      !> alpha6: friction scale (Eq. 12).
      real(dp) :: alpha6 = 0.7413_dp
      !> beta: contact-radius scale (Eq. 11).
      real(dp) :: beta = 1.128e-4_dp
      !> Omega: drive frequency in units of sqrt(E1 I/(m L^4)).
      real(dp) :: omega = 2.0_dp
      !> theta: tilt of the cantilever (rad).
      real(dp) :: theta = pi/12
      !> L/d: beam length over gap.
      real(dp) :: l_over_d = 60.0_dp
      !> g0/d: tip length over gap.
      real(dp) :: g0_over_d = 1.0_dp
      !> delta_hat = delta/(d cos theta): static tip-sample offset over gap.
      real(dp) :: delta_hat = 0.0_dp
      !> xi0 = x0/L: tip position along the beam.
      real(dp) :: xi0 = 1.0_dp
      !> alpha2_2 = f_2/d: the second drive tone's amplitude over gap (0: one tone; tmafm_drive).
      real(dp) :: alpha2_2 = 0.0_dp
      !> Omega_2: the second tone's frequency, commensurate with Omega (tmafm_drive).
      real(dp) :: omega_2 = 0.0_dp
      !> phi_1, phi_2: the tones' phases (rad): Y = alpha2 sin(Omega tau + phi_1) + ...
      real(dp) :: drive_phase = 0.0_dp
      real(dp) :: drive_phase_2 = 0.0_dp
   end type scene_t

   !> Physical inputs in SI units; converted to a scene_t by Eq. (12).
   type :: physical_t
      !> Beam length L (m).
      real(dp) :: length = 300.0e-6_dp
      !> Beam width b (m).
      real(dp) :: width = 30.0e-6_dp
      !> Beam thickness h (m).
      real(dp) :: thickness = 3.0e-6_dp
      !> Beam mass density rho (kg/m^3); sets m = rho b h and the time scale.
      real(dp) :: density = 2330.0_dp
      !> Young's modulus E1 of the beam and tip (Pa).
      real(dp) :: youngs_modulus_tip = 130.0e9_dp
      !> Poisson ratio nu1 of the beam and tip.
      real(dp) :: poisson_ratio_tip = 0.27_dp
      !> Young's modulus E2 of the sample (Pa).
      real(dp) :: youngs_modulus_sample = 1.2e9_dp
      !> Poisson ratio nu2 of the sample.
      real(dp) :: poisson_ratio_sample = 0.3_dp
      !> Tip radius R (m).
      real(dp) :: tip_radius = 20.0e-9_dp
      !> Adhesion energy gamma (J/m^2).
      real(dp) :: adhesion_energy = 0.035_dp
      !> Tilt theta of the cantilever (rad).
      real(dp) :: tilt = pi/12
      !> Gap d between beam axis and sample (m).
      real(dp) :: gap = 5.0e-6_dp
      !> Tip length g0 (m).
      real(dp) :: tip_length = 5.0e-6_dp
      !> Static tip-sample offset delta (m); d = g0 + delta/cos(theta) must hold.
      real(dp) :: static_offset = 0.0_dp
      !> Tip position x0 along the beam, from the clamp (m).
      real(dp) :: tip_position = 300.0e-6_dp
      !> Tip mass M (kg).
      real(dp) :: tip_mass = 3.1455e-12_dp
      !> Beam viscous damping C per unit length (N s/m^2).
      real(dp) :: beam_damping = 6.028930253369996e-3_dp
      !> Tip-sample contact damping C1 (N s/m).
      real(dp) :: contact_damping = 1.8086790760109988e-6_dp
      !> Base drive amplitude f (m).
      real(dp) :: drive_amplitude = 2.5e-9_dp
      !> Base drive angular frequency omega (rad/s).
      real(dp) :: drive_angular_frequency = 143751.31743848347_dp
      !> The second drive tone's amplitude f_2 (m; 0: one tone) and angular frequency omega_2
      !> (rad/s), and the tones' phases (rad).
      real(dp) :: drive_amplitude_2 = 0.0_dp
      real(dp) :: drive_angular_frequency_2 = 0.0_dp
      real(dp) :: drive_phase = 0.0_dp
      real(dp) :: drive_phase_2 = 0.0_dp
   end type physical_t

   !> The &scene keys, in the order of scene_values (their ranges: config/tmafm_keys.f90).
   character(len=*), parameter :: scene_names(17) = [character(len=13) :: 'alpha1', 'alpha2', &
      'alpha3', 'alpha4', 'alpha5', 'alpha6', 'beta', 'omega', 'theta', 'l_over_d', 'g0_over_d', &
      'delta_hat', 'xi0', 'alpha2_2', 'omega_2', 'drive_phase', 'drive_phase_2']
   !> The &physical keys, in the order of physical_values.
   character(len=*), parameter :: physical_names(24) = [character(len=25) :: 'length', 'width', &
      'thickness', 'density', 'youngs_modulus_tip', 'poisson_ratio_tip', 'youngs_modulus_sample', &
      'poisson_ratio_sample', 'tip_radius', 'adhesion_energy', 'tilt', 'gap', 'tip_length', &
      'static_offset', 'tip_position', 'tip_mass', 'beam_damping', 'contact_damping', &
      'drive_amplitude', 'drive_angular_frequency', 'drive_amplitude_2', 'drive_angular_frequency_2', &
      'drive_phase', 'drive_phase_2']

contains

   !> The groups of a scene as an array, in the order of scene_names.
   pure function scene_values(scene) result(values)
      type(scene_t), intent(in) :: scene
      real(dp) :: values(17)
      values = [scene%alpha1, scene%alpha2, scene%alpha3, scene%alpha4, scene%alpha5, &
                scene%alpha6, scene%beta, scene%omega, scene%theta, scene%l_over_d, &
                scene%g0_over_d, scene%delta_hat, scene%xi0, scene%alpha2_2, scene%omega_2, &
                scene%drive_phase, scene%drive_phase_2]
   end function scene_values

   !> The physical inputs as an array, in the order of physical_names.
   pure function physical_values(phys) result(values)
      type(physical_t), intent(in) :: phys
      real(dp) :: values(24)
      values = [phys%length, phys%width, phys%thickness, phys%density, phys%youngs_modulus_tip, &
                phys%poisson_ratio_tip, phys%youngs_modulus_sample, phys%poisson_ratio_sample, &
                phys%tip_radius, phys%adhesion_energy, phys%tilt, phys%gap, phys%tip_length, &
                phys%static_offset, phys%tip_position, phys%tip_mass, phys%beam_damping, &
                phys%contact_damping, phys%drive_amplitude, phys%drive_angular_frequency, &
                phys%drive_amplitude_2, phys%drive_angular_frequency_2, phys%drive_phase, &
                phys%drive_phase_2]
   end function physical_values

   !> Which &physical keys (indices into physical_names) scene group k depends on by Eq. (12).
   pure function scene_depends_on(k) result(keys)
      integer, intent(in) :: k
      integer, allocatable :: keys(:)
      ! 1 length, 2 width, 3 thickness, 4 density, 5 E1, 6 nu1, 7 E2, 8 nu2, 9 R, 10 gamma,
      ! 11 tilt, 12 gap, 13 g0, 14 delta, 15 x0, 16 M, 17 C, 18 C1, 19 f, 20 omega, 21 f_2,
      ! 22 omega_2, 23 phi_1, 24 phi_2.
      select case (k)
      case (1)
         keys = [16, 4, 2, 3, 1]
      case (2)
         keys = [19, 12]
      case (3)
         keys = [17, 1, 5, 2, 3, 4]
      case (4)
         keys = [18, 1, 5, 2, 3, 4]
      case (5)
         keys = [10, 9, 1, 5, 2, 3]
      case (6)
         keys = [5, 6, 7, 8, 12, 9, 10, 1, 2, 3]
      case (7)
         keys = [10, 5, 6, 7, 8, 12, 9]
      case (8)
         keys = [20, 4, 2, 3, 1, 5]
      case (9)
         keys = [11]
      case (10)
         keys = [1, 12]
      case (11)
         keys = [13, 12]
      case (12)
         keys = [14, 12, 11]
      case (13)
         keys = [15, 1]
      case (14)
         keys = [21, 12]
      case (15)
         keys = [22, 4, 2, 3, 1, 5]
      case (16)
         keys = [23]
      case default
         keys = [24]
      end select
   end function scene_depends_on

   !> The dimensionless groups of Eq. (10)-(12) for a physical scene (E8 corrected in alpha4).
   pure function scene_from_physical(phys) result(scene)
      type(physical_t), intent(in) :: phys
      type(scene_t) :: scene
      real(dp) :: inertia, mass_per_length, rigidity, e_star, g_tip, g_sample, g_star
      real(dp) :: damping_scale, time_unit, d

      d = phys%gap
      inertia = phys%width*phys%thickness**3/12
      mass_per_length = phys%density*phys%width*phys%thickness
      rigidity = phys%youngs_modulus_tip*inertia
      e_star = 1.0_dp/((1 - phys%poisson_ratio_tip**2)/phys%youngs_modulus_tip &
                     + (1 - phys%poisson_ratio_sample**2)/phys%youngs_modulus_sample)
      g_tip = phys%youngs_modulus_tip/(2*(1 + phys%poisson_ratio_tip))
      g_sample = phys%youngs_modulus_sample/(2*(1 + phys%poisson_ratio_sample))
      g_star = 1.0_dp/((2 - phys%poisson_ratio_tip)/g_tip + (2 - phys%poisson_ratio_sample)/g_sample)
      ! tau = t/time_unit (Eq. 10); the damping groups carry sqrt(L^4/(E1 I m)) (Eq. 12).
      time_unit = sqrt(mass_per_length*phys%length**4/rigidity)
      damping_scale = sqrt(phys%length**4/(rigidity*mass_per_length))

      scene%alpha1 = phys%tip_mass/(mass_per_length*phys%length)
      scene%alpha2 = phys%drive_amplitude/d
      scene%alpha3 = phys%beam_damping*damping_scale
      scene%alpha4 = phys%contact_damping/phys%length*damping_scale
      scene%alpha5 = 3*pi*phys%adhesion_energy*phys%tip_radius*phys%length**2/rigidity
      scene%alpha6 = 8*g_star*d*phys%tip_radius*phys%length**2/rigidity &
                     *(9*pi*phys%adhesion_energy/(e_star*phys%tip_radius))**(1.0_dp/3)
      scene%beta = ((9*pi/8)*phys%adhesion_energy/(e_star*d))**(2.0_dp/3) &
                   *(phys%tip_radius/d)**(1.0_dp/3)
      scene%omega = phys%drive_angular_frequency*time_unit
      scene%theta = phys%tilt
      scene%l_over_d = phys%length/d
      scene%g0_over_d = phys%tip_length/d
      scene%delta_hat = phys%static_offset/(d*cos(phys%tilt))
      scene%xi0 = phys%tip_position/phys%length
      scene%alpha2_2 = phys%drive_amplitude_2/d
      scene%omega_2 = phys%drive_angular_frequency_2*time_unit
      scene%drive_phase = phys%drive_phase
      scene%drive_phase_2 = phys%drive_phase_2
   end function scene_from_physical

end module tmafm_scene

!> The dimensionless scene (docs/model.md §2, paper Eqs. (10), (12), (24)) and its
!> conversion from physical SI inputs.
!>
!> Defaults are the paper's Sec. 3 values.  The physical defaults describe the same
!> scene: a silicon cantilever on polystyrene, with the tip mass, damping, drive
!> amplitude and frequency chosen so that alpha1 = 0.05, alpha3 = alpha4 = 0.4,
!> alpha2 = 5e-4 and Omega = 2.
module tmafm_scene
   use tmafm_kinds, only: dp
   use tmafm_capillary, only: water_molar_volume
   implicit none
   private

   public :: scene_t, physical_t, scene_from_physical
   public :: scene_names, scene_values, physical_names, physical_values, scene_depends_on
   public :: scene_from_values, physical_from_values
   public :: beam_rigidity, beam_mass_per_length, debye_length_of, meniscus_rupture_distance_of

   real(dp), parameter :: pi = acos(-1.0_dp)
   !> The vacuum permittivity eps0 (F/m, CODATA 2022), Boltzmann's constant k_B (J/K), the
   !> elementary charge e (C) and Avogadro's number N_A (1/mol; the last three exact in SI).
   real(dp), parameter :: vacuum_permittivity = 8.8541878188e-12_dp, boltzmann = 1.380649e-23_dp, &
      elementary_charge = 1.602176634e-19_dp, avogadro = 6.02214076e23_dp

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
      !> mu0 = pi rho_f b/(4 rho h): a liquid's added mass per length over the beam's, per unit
      !> Gamma_r (docs/model.md, A liquid environment); 0 = vacuum, no liquid.
      real(dp) :: medium_mass = 0.0_dp
      !> R0 = rho_f b^2/(4 eta t0): the liquid's Reynolds number at Omega = 1 (Re = R0 omega).
      real(dp) :: medium_reynolds = 0.0_dp
      !> vdw_adhesion = H/(9 pi gamma a0^2): the 'dmt_vdw' adhesion H R/(6 a0^2) in units of
      !> 1.5 pi gamma R (4/3 when gamma = H/(12 pi a0^2)).
      real(dp) :: vdw_adhesion = 4.0_dp/3.0_dp
      !> vdw_range = a0/d: the intermolecular distance over the gap.
      real(dp) :: vdw_range = 3.3e-5_dp
      !> The viscoelastic sample (tmafm_viscoelastic, docs/model.md §14): the contact's stress
      !> relaxation time T in units of tau (0: an elastic sample, the default).
      real(dp) :: sls_relaxation_time = 0.0_dp
      !> The relaxed over the instantaneous reduced modulus, E*_inf/E*_0, in (0, 1].
      real(dp) :: sls_modulus_ratio = 1.0_dp
      !> alpha2_2 = f_2/d: the second drive tone's amplitude over gap (0: one tone; tmafm_drive).
      real(dp) :: alpha2_2 = 0.0_dp
      !> Omega_2: the second tone's frequency, commensurate with Omega (tmafm_drive).
      real(dp) :: omega_2 = 0.0_dp
      !> phi_1, phi_2: the tones' phases (rad): Y = alpha2 sin(Omega tau + phi_1) + ...
      real(dp) :: drive_phase = 0.0_dp
      real(dp) :: drive_phase_2 = 0.0_dp
      !> c_E = eps_r eps0 V^2/(1.5 gamma R): the electrostatic force's strength in units of the
      !> contact's force scale (tmafm_surface_forces, docs/model.md §17); 0: off.
      real(dp) :: electrostatic_strength = 0.0_dp
      !> R/d: the tip's apex radius over the gap (the electrostatic force's sphere).
      real(dp) :: electrostatic_radius = 0.004_dp
      !> theta0: the half-angle of the tip's cone (rad), for the electrostatic force.
      real(dp) :: cone_half_angle = pi/9
      !> c_DL = 8 eps_r eps0 psi_t psi_s/(3 gamma lambda_D): the double layer's strength at zero
      !> separation in units of the contact's force scale; 0: off.
      real(dp) :: double_layer_strength = 0.0_dp
      !> lambda_D/d: the Debye length over the gap.
      real(dp) :: double_layer_range = 2.0e-4_dp
      !> c_C = (8/3) gamma_w cos(theta_w)/gamma: the capillary meniscus's pull in contact in units
      !> of the contact's force scale (tmafm_capillary, docs/model.md §19); 0: off.
      real(dp) :: capillary_strength = 0.0_dp
      !> D/d: the normal gap at which the meniscus breaks, over the gap.
      real(dp) :: capillary_range = 4.0e-4_dp
      !> theta = k_B T L^3/(E1 I d^2): the thermal energy in units of E1 I d^2/L^3, for the
      !> Langevin force of &solver thermal_noise (tmafm_thermal, docs/model.md §21).
      real(dp) :: thermal_energy = 0.0_dp
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
      !> Mass density rho_f of the liquid around the beam (kg/m^3); 0 = vacuum.
      real(dp) :: medium_density = 0.0_dp
      !> Dynamic viscosity eta of the liquid around the beam (Pa s); 0 = vacuum.
      real(dp) :: medium_viscosity = 0.0_dp
      !> Hamaker constant H of the tip-sample pair (J); used by contact_law = 'dmt_vdw'.  The
      !> default, 12 pi gamma a0^2 of the default gamma and a0, gives vdw_adhesion = 4/3: the
      !> contact adhesion H R/(6 a0^2) is then the DMT pull-off 2 pi gamma R.
      real(dp) :: hamaker = 3.592254119747249e-20_dp
      !> Intermolecular distance a0 (m): the separation at contact under 'dmt_vdw'.
      real(dp) :: intermolecular_distance = 0.165e-9_dp
      ! The cantilever by its calibration, the drive in Hz and by the free amplitude, and the
      ! tip-sample distance (docs/model.md section 12): alternatives to keys above, each used
      ! only where its flag below is set; the reader derives the keys they replace.
      !> Static spring constant k at the tip (N/m), with by_calibration.
      real(dp) :: spring_constant = 0
      !> First flexural resonance f0 with the tip mass (Hz), with by_calibration.
      real(dp) :: resonance_frequency = 0
      !> Quality factor Q of that resonance, with by_calibration.
      real(dp) :: quality_factor = 0
      !> Tip mass over beam mass M/(m L), with by_calibration.
      real(dp) :: tip_mass_ratio = 0
      !> Drive frequency omega/(2 pi) (Hz), with by_drive_frequency.
      real(dp) :: drive_frequency = 0
      !> Steady free amplitude of the tip's V_T (m), with by_free_amplitude.
      real(dp) :: free_amplitude = 0
      !> Tip-sample rest distance Z (m): static_offset = Z, gap = g0 + Z/cos(theta), with by_distance.
      real(dp) :: tip_sample_distance = 0
      !> .true. when the cantilever is given by spring_constant, resonance_frequency, quality_factor.
      logical :: by_calibration = .false.
      !> .true. when the drive is given by drive_frequency.
      logical :: by_drive_frequency = .false.
      !> .true. when the drive is given by free_amplitude.
      logical :: by_free_amplitude = .false.
      !> .true. when the gap is given by tip_sample_distance.
      logical :: by_distance = .false.
      !> E1 I derived by the calibration (N m^2); 0 with the geometry route.
      real(dp) :: rigidity = 0
      !> Mass per length m derived by the calibration (kg/m); 0 with the geometry route.
      real(dp) :: mass_per_length = 0
      !> The sample's stress relaxation time T2 (s) at fixed strain; 0: an elastic sample.
      real(dp) :: sample_relaxation_time = 0.0_dp
      !> The sample's relaxed Young's modulus E2_inf (Pa); 0: equal to youngs_modulus_sample.
      real(dp) :: sample_modulus_relaxed = 0.0_dp
      !> The second drive tone's amplitude f_2 (m; 0: one tone) and angular frequency omega_2
      !> (rad/s), and the tones' phases (rad).
      real(dp) :: drive_amplitude_2 = 0.0_dp
      real(dp) :: drive_angular_frequency_2 = 0.0_dp
      real(dp) :: drive_phase = 0.0_dp
      real(dp) :: drive_phase_2 = 0.0_dp
      !> The second tone's frequency omega_2/(2 pi) (Hz), with by_drive_frequency_2.
      real(dp) :: drive_frequency_2 = 0
      !> The tip's steady free amplitude at the second tone (m; V_T's lock-in there), with
      !> by_free_amplitude_2.
      real(dp) :: free_amplitude_2 = 0
      !> .true. when the second tone is given by drive_frequency_2.
      logical :: by_drive_frequency_2 = .false.
      !> .true. when the second tone is given by free_amplitude_2.
      logical :: by_free_amplitude_2 = .false.
      !> The tip's bias V_t (V) over the grounded sample (the electrostatic force; 0: off).
      real(dp) :: tip_bias = 0.0_dp
      !> The contact potential difference V_cpd (V): the force sees V = tip_bias - V_cpd.
      real(dp) :: contact_potential = 0.0_dp
      !> The half-angle theta0 of the tip's cone (rad).
      real(dp) :: cone_half_angle = pi/9
      !> The relative permittivity eps_r of the medium between tip and sample.
      real(dp) :: medium_permittivity = 1.0_dp
      !> The Debye length lambda_D (m); 0: from ionic_strength.
      real(dp) :: debye_length = 0.0_dp
      !> The ionic strength I of a 1:1 electrolyte (mol/m^3 = mM), for lambda_D.
      real(dp) :: ionic_strength = 0.0_dp
      !> The temperature T (K).
      real(dp) :: temperature = 298.15_dp
      !> The tip's and the sample's surface potentials psi_t, psi_s (V), for the double layer.
      real(dp) :: tip_surface_potential = 0.0_dp
      real(dp) :: sample_surface_potential = 0.0_dp
      !> The relative humidity RH in [0, 1) of the air (the capillary meniscus; 0: off).
      real(dp) :: relative_humidity = 0.0_dp
      !> The normal gap D (m) at which the meniscus breaks; 0: the Kelvin one of the humidity.
      real(dp) :: meniscus_rupture_distance = 0.0_dp
      !> The surface tension gamma_w of the meniscus's water (N/m).
      real(dp) :: water_surface_tension = 0.072_dp
      !> The contact angle theta_w (rad) of water on tip and sample.
      real(dp) :: water_contact_angle = 0.0_dp
   end type physical_t

   !> The &scene keys, in the order of scene_values (their ranges: config/tmafm_keys.f90).
   character(len=*), parameter :: scene_names(31) = [character(len=22) :: 'alpha1', 'alpha2', &
      'alpha3', 'alpha4', 'alpha5', 'alpha6', 'beta', 'omega', 'theta', 'l_over_d', 'g0_over_d', &
      'delta_hat', 'xi0', &
      'medium_mass', 'medium_reynolds', 'vdw_adhesion', 'vdw_range', 'sls_relaxation_time', &
      'sls_modulus_ratio', 'alpha2_2', 'omega_2', 'drive_phase', 'drive_phase_2', &
      'electrostatic_strength', 'electrostatic_radius', 'cone_half_angle', 'double_layer_strength', &
      'double_layer_range', 'capillary_strength', 'capillary_range', 'thermal_energy']
   !> The &physical keys, in the order of physical_values.
   character(len=*), parameter :: physical_names(52) = [character(len=25) :: 'length', 'width', &
      'thickness', 'density', 'youngs_modulus_tip', 'poisson_ratio_tip', 'youngs_modulus_sample', &
      'poisson_ratio_sample', 'tip_radius', 'adhesion_energy', 'tilt', 'gap', 'tip_length', &
      'static_offset', 'tip_position', 'tip_mass', 'beam_damping', 'contact_damping', &
      'drive_amplitude', 'drive_angular_frequency', &
      'spring_constant', 'resonance_frequency', 'quality_factor', 'tip_mass_ratio', &
      'drive_frequency', 'free_amplitude', 'tip_sample_distance', &
      'medium_density', 'medium_viscosity', 'hamaker', 'intermolecular_distance', &
      'sample_relaxation_time', 'sample_modulus_relaxed', 'drive_amplitude_2', &
      'drive_angular_frequency_2', 'drive_phase', 'drive_phase_2', 'drive_frequency_2', 'free_amplitude_2', &
      'tip_bias', 'contact_potential', 'cone_half_angle', 'medium_permittivity', 'debye_length', &
      'ionic_strength', 'temperature', 'tip_surface_potential', 'sample_surface_potential', &
      'relative_humidity', 'meniscus_rupture_distance', 'water_surface_tension', 'water_contact_angle']

contains

   !> The groups of a scene as an array, in the order of scene_names.
   pure function scene_values(scene) result(values)
      type(scene_t), intent(in) :: scene
      real(dp) :: values(size(scene_names))
      values = [scene%alpha1, scene%alpha2, scene%alpha3, scene%alpha4, scene%alpha5, &
                scene%alpha6, scene%beta, scene%omega, scene%theta, scene%l_over_d, &
                scene%g0_over_d, scene%delta_hat, scene%xi0, &
                scene%medium_mass, scene%medium_reynolds, scene%vdw_adhesion, scene%vdw_range, &
                scene%sls_relaxation_time, scene%sls_modulus_ratio, scene%alpha2_2, scene%omega_2, &
                scene%drive_phase, scene%drive_phase_2, scene%electrostatic_strength, scene%electrostatic_radius, &
                scene%cone_half_angle, scene%double_layer_strength, scene%double_layer_range, &
                scene%capillary_strength, scene%capillary_range, scene%thermal_energy]
   end function scene_values

   !> The physical inputs as an array, in the order of physical_names.
   pure function physical_values(phys) result(values)
      type(physical_t), intent(in) :: phys
      real(dp) :: values(size(physical_names))
      values = [phys%length, phys%width, phys%thickness, phys%density, phys%youngs_modulus_tip, &
                phys%poisson_ratio_tip, phys%youngs_modulus_sample, phys%poisson_ratio_sample, &
                phys%tip_radius, phys%adhesion_energy, phys%tilt, phys%gap, phys%tip_length, &
                phys%static_offset, phys%tip_position, phys%tip_mass, phys%beam_damping, &
                phys%contact_damping, phys%drive_amplitude, phys%drive_angular_frequency, &
                phys%spring_constant, phys%resonance_frequency, phys%quality_factor, &
                phys%tip_mass_ratio, phys%drive_frequency, phys%free_amplitude, phys%tip_sample_distance, &
                phys%medium_density, phys%medium_viscosity, phys%hamaker, phys%intermolecular_distance, &
                phys%sample_relaxation_time, phys%sample_modulus_relaxed, phys%drive_amplitude_2, &
                phys%drive_angular_frequency_2, phys%drive_phase, phys%drive_phase_2, phys%drive_frequency_2, &
                phys%free_amplitude_2, phys%tip_bias, phys%contact_potential, phys%cone_half_angle, &
                phys%medium_permittivity, phys%debye_length, phys%ionic_strength, phys%temperature, &
                phys%tip_surface_potential, phys%sample_surface_potential, phys%relative_humidity, &
                phys%meniscus_rupture_distance, phys%water_surface_tension, phys%water_contact_angle]
   end function physical_values

   !> The scene whose groups are `values`, in the order of scene_names (scene_values' inverse).
   pure function scene_from_values(values) result(scene)
      real(dp), intent(in) :: values(size(scene_names))
      type(scene_t) :: scene
      scene%alpha1 = values(1)
      scene%alpha2 = values(2)
      scene%alpha3 = values(3)
      scene%alpha4 = values(4)
      scene%alpha5 = values(5)
      scene%alpha6 = values(6)
      scene%beta = values(7)
      scene%omega = values(8)
      scene%theta = values(9)
      scene%l_over_d = values(10)
      scene%g0_over_d = values(11)
      scene%delta_hat = values(12)
      scene%xi0 = values(13)
      scene%medium_mass = values(14)
      scene%medium_reynolds = values(15)
      scene%vdw_adhesion = values(16)
      scene%vdw_range = values(17)
      scene%sls_relaxation_time = values(18)
      scene%sls_modulus_ratio = values(19)
      scene%alpha2_2 = values(20)
      scene%omega_2 = values(21)
      scene%drive_phase = values(22)
      scene%drive_phase_2 = values(23)
      scene%electrostatic_strength = values(24)
      scene%electrostatic_radius = values(25)
      scene%cone_half_angle = values(26)
      scene%double_layer_strength = values(27)
      scene%double_layer_range = values(28)
      scene%capillary_strength = values(29)
      scene%capillary_range = values(30)
      scene%thermal_energy = values(31)
   end function scene_from_values

   !> The physical inputs whose values are `v`, in the order of physical_names (physical_values'
   !> inverse).
   pure function physical_from_values(v) result(phys)
      real(dp), intent(in) :: v(size(physical_names))
      type(physical_t) :: phys
      phys%length = v(1)
      phys%width = v(2)
      phys%thickness = v(3)
      phys%density = v(4)
      phys%youngs_modulus_tip = v(5)
      phys%poisson_ratio_tip = v(6)
      phys%youngs_modulus_sample = v(7)
      phys%poisson_ratio_sample = v(8)
      phys%tip_radius = v(9)
      phys%adhesion_energy = v(10)
      phys%tilt = v(11)
      phys%gap = v(12)
      phys%tip_length = v(13)
      phys%static_offset = v(14)
      phys%tip_position = v(15)
      phys%tip_mass = v(16)
      phys%beam_damping = v(17)
      phys%contact_damping = v(18)
      phys%drive_amplitude = v(19)
      phys%drive_angular_frequency = v(20)
      phys%spring_constant = v(21)
      phys%resonance_frequency = v(22)
      phys%quality_factor = v(23)
      phys%tip_mass_ratio = v(24)
      phys%drive_frequency = v(25)
      phys%free_amplitude = v(26)
      phys%tip_sample_distance = v(27)
      phys%medium_density = v(28)
      phys%medium_viscosity = v(29)
      phys%hamaker = v(30)
      phys%intermolecular_distance = v(31)
      phys%sample_relaxation_time = v(32)
      phys%sample_modulus_relaxed = v(33)
      phys%drive_amplitude_2 = v(34)
      phys%drive_angular_frequency_2 = v(35)
      phys%drive_phase = v(36)
      phys%drive_phase_2 = v(37)
      phys%drive_frequency_2 = v(38)
      phys%free_amplitude_2 = v(39)
      phys%tip_bias = v(40)
      phys%contact_potential = v(41)
      phys%cone_half_angle = v(42)
      phys%medium_permittivity = v(43)
      phys%debye_length = v(44)
      phys%ionic_strength = v(45)
      phys%temperature = v(46)
      phys%tip_surface_potential = v(47)
      phys%sample_surface_potential = v(48)
      phys%relative_humidity = v(49)
      phys%meniscus_rupture_distance = v(50)
      phys%water_surface_tension = v(51)
      phys%water_contact_angle = v(52)
   end function physical_from_values

   !> Which &physical keys (indices into physical_names) scene group k depends on by Eq. (12).
   pure function scene_depends_on(k) result(keys)
      integer, intent(in) :: k
      integer, allocatable :: keys(:)
      ! 1 length, 2 width, 3 thickness, 4 density, 5 E1, 6 nu1, 7 E2, 8 nu2, 9 R, 10 gamma,
      ! 11 tilt, 12 gap, 13 g0, 14 delta, 15 x0, 16 M, 17 C, 18 C1, 19 f, 20 omega,
      ! 21 k, 22 f0, 23 Q, 24 M/(m L), 25 omega/(2 pi), 26 A0, 27 Z, 28 rho_f, 29 eta, 30 H, 31 a0,
      ! 32 T2, 33 E2_inf, 34 f_2, 35 omega_2, 36 phi_1, 37 phi_2, 38 omega_2/(2 pi), 39 A0_2,
      ! 40 V_t, 41 V_cpd, 42 theta0, 43 eps_r, 44 lambda_D, 45 I, 46 T, 47 psi_t, 48 psi_s,
      ! 49 RH, 50 D, 51 gamma_w, 52 theta_w.
      select case (k)
      case (1)
         keys = [16, 4, 2, 3, 1, 24]
      case (2)
         ! The drive's own keys first: they win a tie of keys whose default 0 means 'off'
         ! (free_amplitude_2 = 0.1 m named tip_sample_distance).
         keys = [19, 26, 12, 27]
      case (3)
         keys = [17, 1, 5, 2, 3, 4, 23]
      case (4)
         keys = [18, 1, 5, 2, 3, 4]
      case (5)
         keys = [10, 9, 1, 5, 2, 3]
      case (6)
         keys = [5, 6, 7, 8, 12, 9, 10, 1, 2, 3]
      case (7)
         keys = [10, 5, 6, 7, 8, 12, 9]
      case (8)
         keys = [20, 4, 2, 3, 1, 5, 25, 22]
      case (9)
         keys = [11]
      case (10)
         keys = [1, 12]
      case (11)
         keys = [13, 12]
      case (12)
         keys = [14, 12, 11, 27]
      case (13)
         keys = [15, 1]
      case (14)
         keys = [28, 4, 2, 3, 21, 22]
      case (15)
         keys = [29, 28, 2, 4, 3, 1, 5, 21, 22]
      case (16)
         keys = [30, 10, 31]
      case (17)
         keys = [31, 12, 27]
      case (18)
         keys = [32, 33, 7, 5, 6, 8, 4, 2, 3, 1, 21, 22]
      case (19)
         keys = [33, 7, 5, 6, 8]
      case (20)
         keys = [34, 39, 12, 27]
      case (21)
         keys = [35, 4, 2, 3, 1, 5, 21, 22, 38]
      case (22)
         keys = [36]
      case (23)
         keys = [37]
      case (24)
         keys = [40, 41, 43, 10, 9]
      case (25)
         keys = [9, 12, 27]
      case (26)
         keys = [42]
      case (27)
         keys = [47, 48, 44, 45, 46, 43, 10]
      case (28)
         keys = [44, 45, 46, 43, 12, 27]
      case (29)
         keys = [49, 50, 51, 52, 10]
      case (30)
         keys = [50, 49, 51, 52, 46, 12, 27]
      case default
         keys = [46, 5, 2, 3, 1, 21, 22, 12, 27]
      end select
   end function scene_depends_on

   !> E1 I of a physical scene (N m^2): from the calibration where it gave one, else E1 b h^3/12.
   pure real(dp) function beam_rigidity(phys)
      type(physical_t), intent(in) :: phys
      if (phys%by_calibration) then
         beam_rigidity = phys%rigidity
      else
         ! (the same operations, in the same order, as before the calibration existed)
         beam_rigidity = phys%youngs_modulus_tip*(phys%width*phys%thickness**3/12)
      end if
   end function beam_rigidity

   !> Mass per length m of a physical scene (kg/m): from the calibration, else rho b h.
   pure real(dp) function beam_mass_per_length(phys)
      type(physical_t), intent(in) :: phys
      if (phys%by_calibration) then
         beam_mass_per_length = phys%mass_per_length
      else
         beam_mass_per_length = phys%density*phys%width*phys%thickness
      end if
   end function beam_mass_per_length

   !> The dimensionless groups of Eq. (10)-(12) for a physical scene (E8 corrected in alpha4).
   pure function scene_from_physical(phys) result(scene)
      type(physical_t), intent(in) :: phys
      type(scene_t) :: scene
      real(dp) :: mass_per_length, rigidity, e_star, g_tip, g_sample, g_star
      real(dp) :: damping_scale, time_unit, d, e_star_relaxed, sample_relaxed, voltage, debye

      d = phys%gap
      mass_per_length = beam_mass_per_length(phys)
      rigidity = beam_rigidity(phys)
      e_star = 1.0_dp/((1 - phys%poisson_ratio_tip**2)/phys%youngs_modulus_tip &
                     + (1 - phys%poisson_ratio_sample**2)/phys%youngs_modulus_sample)
      g_tip = phys%youngs_modulus_tip/(2*(1 + phys%poisson_ratio_tip))
      g_sample = phys%youngs_modulus_sample/(2*(1 + phys%poisson_ratio_sample))
      g_star = 1.0_dp/((2 - phys%poisson_ratio_tip)/g_tip + (2 - phys%poisson_ratio_sample)/g_sample)
      ! tau = t/time_unit (Eq. 10); the damping groups carry sqrt(L^4/(E1 I m)) (Eq. 12).
      time_unit = sqrt(mass_per_length*phys%length**4/rigidity)
      damping_scale = sqrt(phys%length**4/(rigidity*mass_per_length))

      scene%alpha1 = phys%tip_mass/(mass_per_length*phys%length)
      ! The calibration gives the ratio itself (M was derived from it: no round trip).
      if (phys%by_calibration) scene%alpha1 = phys%tip_mass_ratio
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
      ! The liquid (docs/model.md, A liquid environment): mu0 = pi rho_f b/(4 rho h), R0 = rho_f b^2/(4 eta t0).
      scene%medium_mass = pi*phys%medium_density*phys%width**2/(4*mass_per_length)
      if (phys%medium_viscosity > 0) then
         scene%medium_reynolds = phys%medium_density*phys%width**2/(4*phys%medium_viscosity*time_unit)
      else
         scene%medium_reynolds = 0
      end if
      ! 'dmt_vdw': H R/(6 a0^2) over the force scale 1.5 pi gamma R, and a0 over the gap.
      scene%vdw_adhesion = phys%hamaker/(9*pi*phys%adhesion_energy*phys%intermolecular_distance**2)
      scene%vdw_range = phys%intermolecular_distance/d
      ! The viscoelastic sample (docs/model.md §14): the tip's compliance in series with the
      ! sample's SLS is an SLS with the sample's retardation time T2 E2/E2_inf, reduced moduli
      ! E*_0 = e_star and E*_inf, and the relaxation time (T2 E2/E2_inf) E*_inf/E*_0.
      sample_relaxed = phys%sample_modulus_relaxed
      if (sample_relaxed == 0) sample_relaxed = phys%youngs_modulus_sample
      e_star_relaxed = 1.0_dp/((1 - phys%poisson_ratio_tip**2)/phys%youngs_modulus_tip &
                               + (1 - phys%poisson_ratio_sample**2)/sample_relaxed)
      scene%sls_modulus_ratio = e_star_relaxed/e_star
      scene%sls_relaxation_time = phys%sample_relaxation_time*(phys%youngs_modulus_sample/sample_relaxed) &
                                  *scene%sls_modulus_ratio/time_unit
      scene%alpha2_2 = phys%drive_amplitude_2/d
      scene%omega_2 = phys%drive_angular_frequency_2*time_unit
      scene%drive_phase = phys%drive_phase
      scene%drive_phase_2 = phys%drive_phase_2
      ! The forces at a distance (docs/model.md §17), in the units of the contact's force
      ! 1.5 pi gamma R; their geometry only where they are on (else the &scene defaults stay).
      voltage = phys%tip_bias - phys%contact_potential
      scene%electrostatic_strength = phys%medium_permittivity*vacuum_permittivity*voltage**2 &
                                     /(1.5_dp*phys%adhesion_energy*phys%tip_radius)
      if (scene%electrostatic_strength > 0) then
         scene%electrostatic_radius = phys%tip_radius/d
         scene%cone_half_angle = phys%cone_half_angle
      end if
      debye = debye_length_of(phys)
      if (debye > 0 .and. phys%tip_surface_potential*phys%sample_surface_potential /= 0) then
         scene%double_layer_strength = 8*phys%medium_permittivity*vacuum_permittivity &
                                       *phys%tip_surface_potential*phys%sample_surface_potential &
                                       /(3*phys%adhesion_energy*debye)
         scene%double_layer_range = debye/d
      end if
      ! The capillary meniscus (docs/model.md §19): F0 = 4 pi R gamma_w cos(theta_w) over the
      ! force scale, and the rupture gap over d, given or 2 r_K cos(theta_w) (Kelvin).
      if (phys%relative_humidity > 0 .or. phys%meniscus_rupture_distance > 0) then
         scene%capillary_strength = 8*phys%water_surface_tension*cos(phys%water_contact_angle) &
                                    /(3*phys%adhesion_energy)
         scene%capillary_range = meniscus_rupture_distance_of(phys)/d
      end if
      ! The thermal energy k_B T in units of E1 I d^2/L^3 (docs/model.md §21); it acts only
      ! with &solver thermal_noise = 1.
      scene%thermal_energy = boltzmann*phys%temperature*phys%length**3/(rigidity*d**2)
   end function scene_from_physical

   !> The normal gap D (m) at which the meniscus of a physical scene breaks: the given one, else
   !> 2 r_K cos(theta_w) with the Kelvin radius r_K = gamma_w V_m/(N_A k_B T ln(1/RH)) of water.
   pure real(dp) function meniscus_rupture_distance_of(phys) result(distance)
      type(physical_t), intent(in) :: phys
      distance = phys%meniscus_rupture_distance
      if (distance > 0 .or. .not. (phys%relative_humidity > 0)) return
      distance = 2*cos(phys%water_contact_angle)*phys%water_surface_tension*water_molar_volume &
                 /(avogadro*boltzmann*phys%temperature*log(1/phys%relative_humidity))
   end function meniscus_rupture_distance_of

   !> The Debye length lambda_D (m) of a physical scene: debye_length where given, else that of a
   !> 1:1 electrolyte of ionic strength I at temperature T, sqrt(eps_r eps0 k_B T/(2 N_A e^2 I));
   !> 0 with neither.
   pure real(dp) function debye_length_of(phys) result(debye)
      type(physical_t), intent(in) :: phys
      debye = phys%debye_length
      if (debye > 0 .or. .not. (phys%ionic_strength > 0)) return
      debye = sqrt(phys%medium_permittivity*vacuum_permittivity*boltzmann*phys%temperature &
                   /(2*avogadro*elementary_charge**2*phys%ionic_strength))
   end function debye_length_of

end module tmafm_scene

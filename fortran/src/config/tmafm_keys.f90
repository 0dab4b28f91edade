!> The namelist keys, one row each: group, name, value type, allowed range (bounds, allowed
!> words or a rule), unit and one-line meaning; and the text of a key's value as the resolved
!> input writes it, so that a key's default is that text for a config_t given no input.
!>
!> This is the one list of keys.  The reader (tmafm_namelist) takes from it the groups and keys
!> it knows, the type and range it checks and the words of its messages; the writer the order
!> of the resolved text; Python (through tmafm_api) its key types, and README's input table is
!> written from it (tests/test_tables.py).  Adding a key is a row here, its field in config_t
!> (whose default initialisation is the default), its case in key_value_text below, and where
!> tmafm_namelist stores it (a key the reader does not store is refused as a tmafm bug).
module tmafm_keys
   use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
   use tmafm_kinds, only: dp, i8
   use tmafm_text, only: real_text, int_text
   use tmafm_float_format, only: shortest_text_padded
   use tmafm_modes, only: max_modes
   use tmafm_scene, only: physical_t, scene_names, physical_names, scene_values, physical_values
   use tmafm_settings, only: method_names, max_max_steps
   use tmafm_config, only: config_t
   use tmafm_scan_settings, only: topography_flat, topography_step, topography_sphere
   implicit none
   private

   public :: key_t, keys, n_keys, key_groups
   public :: key_row, group_index, key_in_range, key_range_text, key_choices_text, key_is_word
   public :: group_keys_text, key_value_text, describe_key, range_text
   public :: max_mode_horizon, physical_key_given, n_material_keys, material_key_index

   !> Value types: an integer, a real (an integer or real literal), a quoted string, a list of
   !> reals (r*value repeats allowed).
   integer, parameter :: key_integer = 1, key_real = 2, key_string = 3, key_list = 4
   !> The names of the value types (Python's KEY_TYPES holds them).
   character(len=*), parameter :: kind_names(4) = [character(len=13) :: 'integer', 'real', 'string', &
      'list of reals']

   !> The namelist groups, in the order of the resolved text.
   character(len=*), parameter :: key_groups(8) = [character(len=8) :: 'model', 'scene', 'physical', &
      'initial', 'solver', 'output', 'scan', 'fm']

   !> Largest &model mode_horizon: the automatic-N search may run max_modes comparison runs of
   !> this length, and a Python call cannot be interrupted (README, Running; docs/reliability.md).
   real(dp), parameter :: max_mode_horizon = 100.0_dp
   real(dp), parameter :: half_pi = acos(-1.0_dp)/2

   !> The words of the string keys that take one from a fixed set.
   character(len=*), parameter :: contact_laws(*) = [character(len=8) :: 'hertz', 'dmt', 'dmt_vdw', 'jkr']
   character(len=*), parameter :: conventions(*) = [character(len=10) :: 'paper', 'consistent']
   !> The values &output format accepts: 'text' (columns after '#' header lines) or 'npy'.
   character(len=*), parameter :: output_formats(*) = [character(len=8) :: 'text', 'npy']
   !> The topographies &scan topography knows (tmafm_scan_settings).
   character(len=*), parameter :: topographies(*) = [character(len=8) :: topography_flat, topography_step, &
      topography_sphere]
   !> Every allowed word, the sets one after the other (key_t%first_word, last_word).
   character(len=*), parameter :: words(*) = [character(len=16) :: contact_laws, conventions, &
      method_names, output_formats, topographies]
   integer, parameter :: law_words = 1, convention_words = law_words + size(contact_laws)
   integer, parameter :: method_words = convention_words + size(conventions)
   integer, parameter :: format_words = method_words + size(method_names)
   integer, parameter :: topography_words = format_words + size(output_formats)
   !> The &physical keys a second material of &scan may set, each as &scan b_<key> (Python's
   !> tmafm.instrument MATERIAL_KEYS), and their positions in physical_names.
   integer, parameter :: n_material_keys = 8
   integer, parameter :: material_key_index(n_material_keys) = [7, 8, 10, 18, 30, 31, 32, 33]

   !> One key.
   type :: key_t
      !> Its group (without the &) and name.
      character(len=8) :: group = ''
      character(len=25) :: name = ''
      !> key_integer, key_real, key_string or key_list.
      integer :: kind = 0
      !> Numbers (a list's every value): lower and upper bound; an integer key's are whole.
      real(dp) :: lower = 0
      real(dp) :: upper = 0
      !> .true. where the lower bound is allowed (>=), .false. where it is not (>).
      logical :: lower_closed = .true.
      !> .true. where the upper bound is excluded (<), .false. where it is allowed (<=).
      logical :: upper_open = .false.
      !> An integer key that also takes 0 (with `rule` saying what 0 means).
      logical :: zero_too = .false.
      !> The key whose value is the upper bound (instead of `upper`), or blank.
      character(len=8) :: upper_key = ''
      !> A string key from a fixed set: its words are words(first_word:last_word).
      integer :: first_word = 1
      integer :: last_word = 0
      !> What the bounds and words do not say (a string's form, a list's length, a rule
      !> across keys), or blank.
      character(len=120) :: rule = ''
      !> Unit: '1' a pure number, 'd' gap units, 'tau' dimensionless time (README: Input),
      !> SI units in &physical, '-' for a name.
      character(len=8) :: unit = ''
      !> One line: what it means.
      character(len=200) :: meaning = ''
      !> A switch of optional physics: the resolved text leaves the key out while it has its
      !> default (off), so that a scene without it writes the text it always wrote.
      logical :: omit_default = .false.
   end type key_t

   type(key_t), parameter :: model_rows(*) = [ &
      key_t('model', 'n_modes', key_integer, 1, max_modes, zero_too=.true., &
            rule='or 0 to choose N by mode_tol', unit='1', &
            meaning='Galerkin modes N; 0 lets tmafm choose N by mode_tol'), &
      key_t('model', 'mode_tol', key_real, 0, 1, .false., unit='1', &
            meaning="with n_modes = 0: the smallest N whose V_T agrees with N+1's within this fraction of the "// &
            "V_T range, on the search's own grid (never sample_dtau)"), &
      key_t('model', 'mode_horizon', key_real, 0, max_mode_horizon, .false., unit='tau', &
            meaning='with n_modes = 0: length of the runs that compare N and N+1'), &
      key_t('model', 'contact_law', key_string, first_word=law_words, last_word=law_words + 3, unit='-', &
            rule="'jkr' with method dop853, dopri5 or flight_exact", &
            meaning="Hertz or DMT contact, 'dmt_vdw': DMT with van der Waals attraction out of contact "// &
            "(docs/model.md 6a), or 'jkr': JKR adhesion with its neck and pull-off (docs/model.md 18)"), &
      key_t('model', 'convention', key_string, first_word=convention_words, last_word=convention_words + 1, &
            unit='-', meaning="'paper' (the printed equations) or 'consistent' (errata corrected)"), &
      key_t('model', 'errata', key_string, unit='-', &
            rule="'convention', 'all', 'none' or a comma-separated list of distinct E1,E2,E3,E4,E6,E7", &
            meaning="corrections applied; 'convention': all for 'consistent', none for 'paper' (docs/errata.md)")]

   type(key_t), parameter :: scene_rows(*) = [ &
      key_t('scene', 'alpha1', key_real, 0, 1.0e3_dp, unit='1', meaning='tip mass / beam mass, M/(m L)'), &
      key_t('scene', 'alpha2', key_real, 0, 1, unit='1', meaning='drive amplitude / gap, f/d'), &
      key_t('scene', 'alpha3', key_real, 0, 1.0e4_dp, unit='1', meaning='beam viscous damping'), &
      key_t('scene', 'alpha4', key_real, 0, 1.0e4_dp, unit='1', meaning='contact (Kelvin-Voigt) damping'), &
      key_t('scene', 'alpha5', key_real, 0, 1.0e6_dp, unit='1', meaning='normal-force scale (Eq. 12)'), &
      key_t('scene', 'alpha6', key_real, 0, 1.0e6_dp, unit='1', meaning='friction scale (Eq. 12)'), &
      key_t('scene', 'beta', key_real, 0, 1.0e6_dp, .false., unit='1', meaning='contact-radius scale (Eq. 11)'), &
      key_t('scene', 'omega', key_real, 0, 1.0e6_dp, unit='1', &
            meaning='drive frequency Omega, in units of sqrt(E1 I/(m L^4))'), &
      key_t('scene', 'theta', key_real, 0, half_pi, upper_open=.true., unit='rad', &
            meaning='tilt of the cantilever'), &
      key_t('scene', 'l_over_d', key_real, 0, 1.0e9_dp, .false., unit='1', meaning='beam length / gap, L/d'), &
      key_t('scene', 'g0_over_d', key_real, 0, 1.0e9_dp, unit='1', meaning='tip length / gap, g0/d'), &
      key_t('scene', 'delta_hat', key_real, -1.0e3_dp, 1.0e3_dp, unit='1', &
            meaning='static tip-sample offset, delta/(d cos theta)'), &
      key_t('scene', 'xi0', key_real, 0, 1, .false., unit='1', meaning='tip position along the beam, x0/L'), &
      key_t('scene', 'medium_mass', key_real, 0, 1.0e3_dp, unit='1', omit_default=.true., &
            rule='> 0 with medium_reynolds > 0 (a liquid), or both 0 (vacuum)', &
            meaning='liquid: pi rho_f b/(4 rho h), the added mass per Gamma_r (docs/model.md); 0 = vacuum'), &
      key_t('scene', 'medium_reynolds', key_real, 0, 1.0e12_dp, unit='1', omit_default=.true., &
            rule='> 0 with medium_mass > 0, or both 0', &
            meaning='liquid: rho_f b^2/(4 eta t0), the Reynolds number at Omega = 1 (Re = this times omega)'), &
      key_t('scene', 'vdw_adhesion', key_real, 0, 1.0e6_dp, unit='1', omit_default=.true., &
            rule="> 0 with contact_law = 'dmt_vdw'", &
            meaning="'dmt_vdw' adhesion H R/(6 a0^2) over 1.5 pi gamma R, H/(9 pi gamma a0^2)"), &
      key_t('scene', 'vdw_range', key_real, 0, 1.0e3_dp, .false., unit='1', omit_default=.true., &
            meaning="'dmt_vdw': intermolecular distance over gap, a0/d"), &
      key_t('scene', 'sls_relaxation_time', key_real, 0, 1.0e12_dp, unit='tau', omit_default=.true., &
            meaning='viscoelastic (standard linear solid) sample: stress relaxation time T of the contact; '// &
            '0 = elastic sample (docs/model.md, section 14)'), &
      key_t('scene', 'sls_modulus_ratio', key_real, 0, 1, .false., unit='1', omit_default=.true., &
            meaning='viscoelastic sample: relaxed over instantaneous reduced modulus, E*_inf/E*_0'), &
      key_t('scene', 'alpha2_2', key_real, 0, 1, unit='1', &
            meaning='second drive tone: amplitude / gap, f_2/d (0: the one tone alpha2; docs/model.md section 15)'), &
      key_t('scene', 'omega_2', key_real, 0, 1.0e6_dp, unit='1', &
            rule='with alpha2_2 > 0: > 0 and omega_2/omega = p/q, q <= 64, p <= 4096 (to 1e-9)', &
            meaning='second drive tone: frequency Omega_2, in units of sqrt(E1 I/(m L^4))'), &
      key_t('scene', 'drive_phase', key_real, -2*half_pi, 2*half_pi, unit='rad', &
            meaning='phase phi_1 of the drive tone alpha2 sin(Omega tau + phi_1)'), &
      key_t('scene', 'drive_phase_2', key_real, -2*half_pi, 2*half_pi, unit='rad', &
            meaning='phase phi_2 of the second tone alpha2_2 sin(Omega_2 tau + phi_2)'), &
      key_t('scene', 'electrostatic_strength', key_real, 0, 1.0e6_dp, unit='1', omit_default=.true., &
            meaning='electrostatic force of a biased tip: eps_r eps0 V^2/(1.5 gamma R); 0 = off '// &
            '(docs/model.md section 17)'), &
      key_t('scene', 'electrostatic_radius', key_real, 0, 1.0e3_dp, .false., unit='1', omit_default=.true., &
            meaning="electrostatic force: the tip apex's radius over gap, R/d"), &
      key_t('scene', 'cone_half_angle', key_real, 0, half_pi, .false., upper_open=.true., unit='rad', &
            omit_default=.true., meaning="electrostatic force: half-angle theta0 of the tip's cone "// &
            '(its height is g0)'), &
      key_t('scene', 'double_layer_strength', key_real, -1.0e6_dp, 1.0e6_dp, unit='1', omit_default=.true., &
            rule='with double_layer_range > 0', &
            meaning='electrical double layer: 8 eps_r eps0 psi_t psi_s/(3 gamma lambda_D), its force at '// &
            'zero separation; 0 = off (docs/model.md section 17)'), &
      key_t('scene', 'double_layer_range', key_real, 0, 1.0e3_dp, .false., unit='1', omit_default=.true., &
            meaning='electrical double layer: Debye length over gap, lambda_D/d'), &
      key_t('scene', 'capillary_strength', key_real, 0, 1.0e6_dp, unit='1', omit_default=.true., &
            rule="not with contact_law = 'jkr' or a liquid; method dop853, dopri5 or flight_exact", &
            meaning='capillary meniscus: its pull in contact, 4 pi R gamma_w cos(theta_w)/(1.5 pi gamma R); '// &
            '0 = off (docs/model.md section 19)'), &
      key_t('scene', 'capillary_range', key_real, 0, 1.0e3_dp, .false., unit='1', omit_default=.true., &
            meaning='capillary meniscus: the normal gap at which it breaks, over gap, D/d'), &
      key_t('scene', 'thermal_energy', key_real, 0, 1.0e6_dp, unit='1', omit_default=.true., &
            rule='> 0 with &solver thermal_noise = 1; from &physical: k_B temperature L^3/(E1 I d^2)', &
            meaning='thermal noise: k_B T L^3/(E1 I d^2), the thermal energy in the model units '// &
            '(docs/model.md section 21)')]

   type(key_t), parameter :: physical_rows(*) = [ &
      key_t('physical', 'length', key_real, 0, 1, .false., unit='m', meaning='beam length L'), &
      key_t('physical', 'width', key_real, 0, 1, .false., unit='m', meaning='beam width b'), &
      key_t('physical', 'thickness', key_real, 0, 1, .false., unit='m', meaning='beam thickness h'), &
      key_t('physical', 'density', key_real, 0, 1.0e5_dp, .false., unit='kg/m^3', &
            meaning='beam mass density rho; sets m = rho b h and the time scale'), &
      key_t('physical', 'youngs_modulus_tip', key_real, 0, 1.0e13_dp, .false., unit='Pa', &
            meaning="Young's modulus E1 of the beam and tip"), &
      key_t('physical', 'poisson_ratio_tip', key_real, -1, 0.5_dp, .false., unit='1', &
            meaning='Poisson ratio nu1 of the beam and tip'), &
      key_t('physical', 'youngs_modulus_sample', key_real, 0, 1.0e13_dp, .false., unit='Pa', &
            meaning="Young's modulus E2 of the sample"), &
      key_t('physical', 'poisson_ratio_sample', key_real, -1, 0.5_dp, .false., unit='1', &
            meaning='Poisson ratio nu2 of the sample'), &
      key_t('physical', 'tip_radius', key_real, 0, 1.0e-2_dp, .false., unit='m', meaning='tip radius R'), &
      key_t('physical', 'adhesion_energy', key_real, 0, 1.0e3_dp, .false., unit='J/m^2', &
            meaning='adhesion energy gamma'), &
      key_t('physical', 'tilt', key_real, 0, half_pi, upper_open=.true., unit='rad', &
            meaning='tilt theta of the cantilever'), &
      key_t('physical', 'gap', key_real, 0, 1, .false., unit='m', &
            rule='equal to tip_length + static_offset/cos(tilt)', meaning='gap d between beam axis and sample'), &
      key_t('physical', 'tip_length', key_real, 0, 1, unit='m', meaning='tip length g0'), &
      key_t('physical', 'static_offset', key_real, -1, 1, unit='m', meaning='static tip-sample offset delta'), &
      key_t('physical', 'tip_position', key_real, 0, 1, .false., unit='m', rule='<= length', &
            meaning='tip position x0 along the beam, from the clamp (default: length, the free end)'), &
      key_t('physical', 'tip_mass', key_real, 0, 1, unit='kg', meaning='tip mass M'), &
      key_t('physical', 'beam_damping', key_real, 0, 1.0e6_dp, unit='N s/m^2', &
            meaning='beam viscous damping C per unit length'), &
      key_t('physical', 'contact_damping', key_real, 0, 1.0e6_dp, unit='N s/m', &
            meaning='tip-sample contact damping C1'), &
      key_t('physical', 'drive_amplitude', key_real, 0, 1, unit='m', meaning='base drive amplitude f'), &
      key_t('physical', 'drive_angular_frequency', key_real, 0, 1.0e12_dp, unit='rad/s', &
            meaning='base drive angular frequency omega'), &
      key_t('physical', 'spring_constant', key_real, 0, 1.0e6_dp, .false., unit='N/m', &
            rule='with resonance_frequency, quality_factor (tip_mass_ratio: 0), instead of thickness, '// &
            'density, tip_mass, beam_damping', &
            meaning="the cantilever by its calibration: the model's static tip stiffness k (docs/model.md "// &
            "section 12)"), &
      key_t('physical', 'resonance_frequency', key_real, 0, 1.0e12_dp, .false., unit='Hz', &
            rule='with spring_constant', &
            meaning="the model's first resonance f0 = |lambda1|/(2 pi), with the tip mass"), &
      key_t('physical', 'quality_factor', key_real, 0.5_dp, 1.0e9_dp, .false., unit='1', &
            rule='with spring_constant', meaning="the model's Q = |lambda1|/(2 |Re lambda1|) of that resonance"), &
      key_t('physical', 'tip_mass_ratio', key_real, 0, 1.0e3_dp, unit='1', &
            rule='with spring_constant; 0 if not given', &
            meaning='tip mass / beam mass M/(m L) of the calibrated cantilever (alpha1)'), &
      key_t('physical', 'drive_frequency', key_real, 0, 1.0e12_dp, unit='Hz', &
            rule='instead of drive_angular_frequency', meaning='drive frequency omega/(2 pi)'), &
      key_t('physical', 'free_amplitude', key_real, 0, 1, unit='m', rule='instead of drive_amplitude', &
            meaning="the tip's steady amplitude far from the sample (V_T's first harmonic); sets "// &
            "drive_amplitude"), &
      key_t('physical', 'tip_sample_distance', key_real, -1, 1, unit='m', &
            rule='instead of gap and static_offset', &
            meaning='tip-sample rest distance Z: static_offset = Z, gap = tip_length + Z/cos(tilt)'), &
      key_t('physical', 'medium_density', key_real, 0, 1.0e5_dp, unit='kg/m^3', omit_default=.true., &
            rule='> 0 with medium_viscosity > 0 (a liquid), or both 0 (vacuum)', &
            meaning='mass density rho_f of the liquid around the beam (docs/model.md); 0 = vacuum'), &
      key_t('physical', 'medium_viscosity', key_real, 0, 1.0e3_dp, unit='Pa s', omit_default=.true., &
            rule='> 0 with medium_density > 0, or both 0', &
            meaning='dynamic viscosity eta of the liquid around the beam; 0 = vacuum'), &
      key_t('physical', 'hamaker', key_real, 0, 1.0e-15_dp, unit='J', omit_default=.true., &
            rule="> 0 with contact_law = 'dmt_vdw'", &
            meaning="Hamaker constant H of the tip-sample pair ('dmt_vdw')"), &
      key_t('physical', 'intermolecular_distance', key_real, 0, 1.0e-6_dp, .false., unit='m', omit_default=.true., &
            meaning="intermolecular distance a0, the separation at contact ('dmt_vdw')"), &
      key_t('physical', 'sample_relaxation_time', key_real, 0, 1.0e3_dp, unit='s', omit_default=.true., &
            meaning='viscoelastic (standard linear solid) sample: its stress relaxation time T2; '// &
            '0 = elastic sample (docs/model.md, section 14)'), &
      key_t('physical', 'sample_modulus_relaxed', key_real, 0, 1.0e13_dp, unit='Pa', omit_default=.true., &
            rule='0 (= youngs_modulus_sample) or <= youngs_modulus_sample', &
            meaning="viscoelastic sample: its relaxed Young's modulus E2_inf"), &
      key_t('physical', 'drive_amplitude_2', key_real, 0, 1, unit='m', &
            meaning='second drive tone: amplitude f_2 (0: the one tone; docs/model.md section 15)'), &
      key_t('physical', 'drive_angular_frequency_2', key_real, 0, 1.0e12_dp, unit='rad/s', &
            rule='with drive_amplitude_2 > 0: > 0 and omega_2/omega = p/q, q <= 64, p <= 4096 (to 1e-9)', &
            meaning='second drive tone: angular frequency omega_2'), &
      key_t('physical', 'drive_phase', key_real, -2*half_pi, 2*half_pi, unit='rad', &
            meaning='phase phi_1 of the drive tone f sin(omega t + phi_1)'), &
      key_t('physical', 'drive_phase_2', key_real, -2*half_pi, 2*half_pi, unit='rad', &
            meaning='phase phi_2 of the second tone f_2 sin(omega_2 t + phi_2)'), &
      key_t('physical', 'drive_frequency_2', key_real, 0, 1.0e12_dp, unit='Hz', &
            rule='instead of drive_angular_frequency_2', meaning='second drive tone: frequency omega_2/(2 pi)'), &
      key_t('physical', 'free_amplitude_2', key_real, 0, 1, unit='m', rule='instead of drive_amplitude_2', &
            meaning="the tip's steady amplitude at the second tone far from the sample (V_T's lock-in "// &
            "there); sets drive_amplitude_2"), &
      key_t('physical', 'tip_bias', key_real, -1.0e3_dp, 1.0e3_dp, unit='V', omit_default=.true., &
            meaning='electrostatic force: the bias V_t of the tip over the grounded sample '// &
            '(docs/model.md section 17)'), &
      key_t('physical', 'contact_potential', key_real, -10, 10, unit='V', omit_default=.true., &
            meaning='electrostatic force: the contact potential difference V_cpd; the force sees '// &
            '(tip_bias - contact_potential)^2'), &
      key_t('physical', 'cone_half_angle', key_real, 0, half_pi, .false., upper_open=.true., unit='rad', &
            omit_default=.true., meaning="electrostatic force: half-angle theta0 of the tip's cone "// &
            '(its height is tip_length)'), &
      key_t('physical', 'medium_permittivity', key_real, 1, 1.0e3_dp, unit='1', omit_default=.true., &
            meaning='relative permittivity eps_r of the medium between tip and sample (1 = vacuum, '// &
            '78.4 = water at 25 C)'), &
      key_t('physical', 'debye_length', key_real, 0, 1.0e-3_dp, unit='m', omit_default=.true., &
            rule='0 (= from ionic_strength) or > 0; not with ionic_strength', &
            meaning='electrical double layer: the Debye length lambda_D'), &
      key_t('physical', 'ionic_strength', key_real, 0, 1.0e4_dp, unit='mol/m^3', omit_default=.true., &
            rule='instead of debye_length', &
            meaning='electrical double layer: ionic strength I of a 1:1 electrolyte (mol/m^3 = mM), '// &
            'lambda_D = sqrt(eps_r eps0 k_B T/(2 N_A e^2 I))'), &
      key_t('physical', 'temperature', key_real, 0, 1.0e4_dp, .false., unit='K', omit_default=.true., &
            meaning='temperature T (of the electrolyte, for lambda_D; of the air, for the Kelvin radius)'), &
      key_t('physical', 'tip_surface_potential', key_real, -10, 10, unit='V', omit_default=.true., &
            rule='with sample_surface_potential and a Debye length', &
            meaning="electrical double layer: the tip's surface potential psi_t"), &
      key_t('physical', 'sample_surface_potential', key_real, -10, 10, unit='V', omit_default=.true., &
            rule='with tip_surface_potential and a Debye length', &
            meaning="electrical double layer: the sample's surface potential psi_s"), &
      key_t('physical', 'relative_humidity', key_real, 0, 1, upper_open=.true., unit='1', omit_default=.true., &
            rule='not with meniscus_rupture_distance', &
            meaning='capillary meniscus: relative humidity RH of the air; its rupture gap is the Kelvin '// &
            '2 r_K cos(theta_w), r_K = gamma_w V_m/(R_g T ln(1/RH)); 0 = off (docs/model.md section 19)'), &
      key_t('physical', 'meniscus_rupture_distance', key_real, 0, 1.0e-6_dp, unit='m', omit_default=.true., &
            rule='not with relative_humidity', &
            meaning='capillary meniscus: the normal gap D at which it breaks, given; 0 = off or from '// &
            'relative_humidity'), &
      key_t('physical', 'water_surface_tension', key_real, 0, 1, .false., unit='N/m', omit_default=.true., &
            meaning='capillary meniscus: surface tension gamma_w of its water (0.072 at 25 C)'), &
      key_t('physical', 'water_contact_angle', key_real, 0, half_pi, upper_open=.true., unit='rad', &
            omit_default=.true., meaning='capillary meniscus: contact angle theta_w of water on tip and sample')]

   type(key_t), parameter :: initial_rows(*) = [ &
      key_t('initial', 'a0', key_list, -1, 1, unit='d', &
            meaning='initial modal amplitudes, the rest zero (with n_modes = 0, N is at least the last nonzero)'), &
      key_t('initial', 'adot0', key_list, -1, 1, unit='d/tau', meaning='initial modal velocities, as a0'), &
      key_t('initial', 'in_contact', key_integer, -1, 1, unit='1', omit_default=.true., &
            rule='1 needs V_T <= 0 (under jkr: below the pull-off gap), 0 needs V_T >= 0', &
            meaning="the phase at the start: -1 by V_T's sign, 0 in flight, 1 in contact (a JKR neck "// &
            "stretched above the surface, to restart a run in it; docs/model.md section 18)")]

   type(key_t), parameter :: solver_rows(*) = [ &
      key_t('solver', 'method', key_string, first_word=method_words, last_word=format_words - 1, unit='-', &
            meaning='integration method (README: Methods)'), &
      key_t('solver', 'dtau', key_real, 0, 10, .false., unit='tau', &
            meaning='fixed-step methods: the step out of contact (adaptive methods: the first trial step)'), &
      key_t('solver', 'contact_refine', key_integer, 1, 100000, unit='1', &
            meaning='fixed-step methods: the step in contact is dtau/contact_refine'), &
      key_t('solver', 'rtol', key_real, 1.0e-15_dp, 1.0e-1_dp, unit='1', &
            meaning='adaptive methods: relative tolerance of each step'), &
      key_t('solver', 'atol', key_real, 0, 1, unit='d', meaning='adaptive methods: absolute tolerance of each step'), &
      key_t('solver', 'tau_end', key_real, 0, 1.0e7_dp, .false., unit='tau', &
            meaning='end of the run: the last output sample k sample_dtau <= tau_end'), &
      key_t('solver', 'blowup_limit', key_real, 0, 1.0e10_dp, .false., unit='d', &
            meaning='the run stops with an error once some |a_j| exceeds this'), &
      key_t('solver', 'max_steps', key_integer, 1, real(max_max_steps, dp), unit='1', &
            meaning='work budget of one run: steps tried, switch-search iterations, flight-scan points'), &
      key_t('solver', 'thermal_noise', key_integer, 0, 1, unit='1', omit_default=.true., &
            rule='1 needs method dopri5 or dop853, and &scene thermal_energy > 0 (from &physical: temperature)', &
            meaning='1: a Langevin force on each mode at the temperature (fluctuation-dissipation; '// &
            'docs/model.md section 21); 0: none'), &
      key_t('solver', 'noise_seed', key_integer, 0, 2147483647.0_dp, unit='1', omit_default=.true., &
            meaning='thermal noise: the seed of its realisation (the same seed, the same force on every method)'), &
      key_t('solver', 'noise_step', key_real, 0, 10, unit='tau', omit_default=.true., &
            rule='or 0: the fastest free mode period/32', &
            meaning='thermal noise: the grid on which the force is held constant (zero-order hold)')]

   type(key_t), parameter :: output_rows(*) = [ &
      key_t('output', 'file', key_string, unit='-', &
            rule="a file name, with no blank at either end, not '-'", &
            meaning="output file (the executable's -o overrides it)"), &
      key_t('output', 'sample_dtau', key_real, 0, 0, .false., upper_key='tau_end', unit='tau', &
            meaning='output interval: samples at tau = k sample_dtau, k = 0, 1, ...'), &
      key_t('output', 'format', key_string, first_word=format_words, last_word=topography_words - 1, unit='-', &
            meaning="'text' (columns after # header lines) or 'npy' (a .npz archive)"), &
      key_t('output', 'sample_from', key_real, 0, 0, upper_key='tau_end', unit='tau', omit_default=.true., &
            rule='keeps at least one sample; not with last_periods', &
            meaning='output window: keep only the samples at tau >= sample_from (the run still starts at 0); '// &
            '0 keeps all'), &
      key_t('output', 'last_periods', key_integer, 1, 1.0e9_dp, zero_too=.true., unit='1', omit_default=.true., &
            rule='or 0 for all; needs omega > 0, at most the periods in tau_end; not with sample_from', &
            meaning='output window: keep only the samples of the last this many drive periods, '// &
            'tau >= tau_end - last_periods 2 pi/Omega')]

   !> &scan: one AM-AFM scan line (docs/instrument.md, "AM imaging"); the ranges of every key
   !> alone, the rules across keys (and the drive period) checked by check_scan_settings.
   type(key_t), parameter :: scan_rows(*) = [ &
      key_t('scan', 'scan_length', key_real, 0, 1.0e-3_dp, .false., unit='m', &
            meaning='the line length L, scanned from x = 0 to x = L'), &
      key_t('scan', 'pixels', key_integer, 1, 100000, unit='1', &
            meaning='pixels along the line, each the mean over its drive periods'), &
      key_t('scan', 'line_rate', key_real, 0, 1.0e12_dp, .false., unit='Hz', &
            rule='at least one drive period per pixel', &
            meaning='line rate: trace and retrace take 1/line_rate together (the trace alone with retrace = 0)'), &
      key_t('scan', 'retrace', key_integer, 0, 1, unit='1', meaning='1: trace and retrace; 0: the trace only'), &
      key_t('scan', 'setpoint', key_real, 0, 1, unit='m', rule='exactly one of setpoint, setpoint_ratio > 0', &
            meaning='the amplitude setpoint A_set (0: given as setpoint_ratio)'), &
      key_t('scan', 'setpoint_ratio', key_real, 0, 1, upper_open=.true., unit='1', &
            meaning='the setpoint as A_set/A0, A0 the free amplitude the engage measures (0: given as setpoint)'), &
      key_t('scan', 'lockin_bandwidth', key_real, 0, 1.0e12_dp, .false., unit='Hz', &
            rule='<= half the drive frequency', meaning="the lock-in's output filter bandwidth (first order, -3 dB)"), &
      key_t('scan', 'feedback_bandwidth', key_real, 0, 1.0e12_dp, unit='Hz', &
            rule='<= lockin_bandwidth/2; exactly one of feedback_bandwidth, integral_gain > 0', &
            meaning="the Z feedback's designed closed-loop bandwidth (0: the gains are given)"), &
      key_t('scan', 'proportional_gain', key_real, 0, 1.0e12_dp, unit='1', rule='0 with feedback_bandwidth', &
            meaning="the PI's proportional gain K_p (m of Z per m of amplitude error)"), &
      key_t('scan', 'integral_gain', key_real, 0, 1.0e12_dp, unit='1/s', &
            meaning="the PI's integral gain K_i (m of Z per s and m of amplitude error)"), &
      key_t('scan', 'topography', key_string, first_word=topography_words, last_word=size(words), unit='-', &
            meaning='the topography h(x) under the tip'), &
      key_t('scan', 'step_height', key_real, -1.0e-6_dp, 1.0e-6_dp, unit='m', &
            meaning="'step': its height H (may be negative), h = H for x >= step_position"), &
      key_t('scan', 'step_position', key_real, 0, 1.0e-3_dp, unit='m', rule='<= scan_length', &
            meaning="'step': where it is"), &
      key_t('scan', 'sphere_radius', key_real, 0, 1.0e-6_dp, unit='m', rule="> 0 with topography = 'sphere'", &
            meaning="'sphere': its radius R_s (resting on the plane)"), &
      key_t('scan', 'sphere_position', key_real, 0, 1.0e-3_dp, unit='m', rule='<= scan_length', &
            meaning="'sphere': its centre's x"), &
      key_t('scan', 'material_boundary', key_real, 0, 1.0e-3_dp, unit='m', &
            rule='<= scan_length; > 0 only with a b_ key', &
            meaning='a second material (the b_ keys) lies at x >= material_boundary'), &
      key_t('scan', 'b_'//physical_rows(7)%name, key_real, physical_rows(7)%lower, &
            physical_rows(7)%upper, physical_rows(7)%lower_closed, physical_rows(7)%upper_open, &
            unit=physical_rows(7)%unit, omit_default=.true., &
            meaning='the second material: its '//physical_rows(7)%name), &
      key_t('scan', 'b_'//physical_rows(8)%name, key_real, physical_rows(8)%lower, &
            physical_rows(8)%upper, physical_rows(8)%lower_closed, physical_rows(8)%upper_open, &
            unit=physical_rows(8)%unit, omit_default=.true., &
            meaning='the second material: its '//physical_rows(8)%name), &
      key_t('scan', 'b_'//physical_rows(10)%name, key_real, physical_rows(10)%lower, &
            physical_rows(10)%upper, physical_rows(10)%lower_closed, physical_rows(10)%upper_open, &
            unit=physical_rows(10)%unit, omit_default=.true., &
            meaning='the second material: its '//physical_rows(10)%name), &
      key_t('scan', 'b_'//physical_rows(18)%name, key_real, physical_rows(18)%lower, &
            physical_rows(18)%upper, physical_rows(18)%lower_closed, physical_rows(18)%upper_open, &
            unit=physical_rows(18)%unit, omit_default=.true., &
            meaning='the second material: its '//physical_rows(18)%name), &
      key_t('scan', 'b_'//physical_rows(30)%name, key_real, physical_rows(30)%lower, &
            physical_rows(30)%upper, physical_rows(30)%lower_closed, physical_rows(30)%upper_open, &
            unit=physical_rows(30)%unit, omit_default=.true., &
            meaning='the second material: its '//physical_rows(30)%name), &
      key_t('scan', 'b_'//physical_rows(31)%name, key_real, physical_rows(31)%lower, &
            physical_rows(31)%upper, physical_rows(31)%lower_closed, physical_rows(31)%upper_open, &
            unit=physical_rows(31)%unit, omit_default=.true., &
            meaning='the second material: its '//physical_rows(31)%name), &
      key_t('scan', 'b_'//physical_rows(32)%name, key_real, physical_rows(32)%lower, &
            physical_rows(32)%upper, physical_rows(32)%lower_closed, physical_rows(32)%upper_open, &
            unit=physical_rows(32)%unit, omit_default=.true., &
            meaning='the second material: its '//physical_rows(32)%name), &
      key_t('scan', 'b_'//physical_rows(33)%name, key_real, physical_rows(33)%lower, &
            physical_rows(33)%upper, physical_rows(33)%lower_closed, physical_rows(33)%upper_open, &
            unit=physical_rows(33)%unit, omit_default=.true., &
            meaning='the second material: its '//physical_rows(33)%name)]

   !> &fm: an FM-AFM approach (docs/instrument.md, "FM-AFM"); the bandwidths' bound f0/10 is
   !> checked by check_fm_settings when the loop starts.
   type(key_t), parameter :: fm_rows(*) = [ &
      key_t('fm', 'amplitude', key_real, 0, 1.0e-6_dp, .false., unit='m', &
            meaning="the amplitude setpoint A the amplitude controller holds"), &
      key_t('fm', 'pll_bandwidth', key_real, 0, 1.0e12_dp, .false., unit='Hz', rule='<= f0/10', &
            meaning="the phase-locked loop's closed-loop bandwidth"), &
      key_t('fm', 'amplitude_bandwidth', key_real, 0, 1.0e12_dp, .false., unit='Hz', rule='<= f0/10', &
            meaning="the amplitude controller's closed-loop bandwidth"), &
      key_t('fm', 'settle_periods', key_integer, 0, 10000000, unit='1', &
            meaning='drive periods each Z point runs before its average'), &
      key_t('fm', 'average_periods', key_integer, 1, 10000000, unit='1', &
            meaning='drive periods each Z point averages'), &
      key_t('fm', 'free_distance', key_real, 0, 1.0e-3_dp, .false., unit='m', &
            meaning="the tip-sample distance of the free cantilever's reference"), &
      key_t('fm', 'z_start', key_real, -1.0e-3_dp, 1.0e-3_dp, unit='m', &
            meaning="the approach's first tip-sample distance Z"), &
      key_t('fm', 'z_end', key_real, -1.0e-3_dp, 1.0e-3_dp, unit='m', &
            meaning="its last (with z_points > 1)"), &
      key_t('fm', 'z_points', key_integer, 1, 100000, unit='1', &
            meaning='Z points, evenly spaced from z_start to z_end, each settled from the last')]

   !> Every key, group by group in the order of key_groups, each group's keys in the order of
   !> the resolved text.
   type(key_t), parameter :: keys(*) = [model_rows, scene_rows, physical_rows, initial_rows, solver_rows, &
      output_rows, scan_rows, fm_rows]
   !> Number of keys.
   integer, parameter :: n_keys = size(keys)

   ! The &scene and &physical rows follow scene_names and physical_names (the order of
   ! scene_values and physical_values), checked at compile time: a mismatch divides by zero.
   integer, parameter :: rows_follow_names = 1/merge(1, 0, all(scene_rows%name == scene_names) .and. &
      all(physical_rows%name == physical_names))

contains

   !> .true. when &physical key k (index into physical_names) is one the scene was given by:
   !> the keys of the route in use (the calibration, drive_frequency, free_amplitude or
   !> tip_sample_distance, or the keys they replace); the resolved text writes these only.
   pure logical function physical_key_given(phys, k)
      type(physical_t), intent(in) :: phys
      integer, intent(in) :: k
      select case (trim(physical_names(k)))
      case ('thickness', 'density', 'tip_mass', 'beam_damping')
         physical_key_given = .not. phys%by_calibration
      case ('spring_constant', 'resonance_frequency', 'quality_factor', 'tip_mass_ratio')
         physical_key_given = phys%by_calibration
      case ('drive_angular_frequency')
         physical_key_given = .not. phys%by_drive_frequency
      case ('drive_frequency')
         physical_key_given = phys%by_drive_frequency
      case ('drive_amplitude')
         physical_key_given = .not. phys%by_free_amplitude
      case ('free_amplitude')
         physical_key_given = phys%by_free_amplitude
      case ('gap', 'static_offset')
         physical_key_given = .not. phys%by_distance
      case ('tip_sample_distance')
         physical_key_given = phys%by_distance
      case ('drive_angular_frequency_2')
         physical_key_given = .not. phys%by_drive_frequency_2
      case ('drive_frequency_2')
         physical_key_given = phys%by_drive_frequency_2
      case ('drive_amplitude_2')
         physical_key_given = .not. phys%by_free_amplitude_2
      case ('free_amplitude_2')
         physical_key_given = phys%by_free_amplitude_2
      case default
         physical_key_given = .true.
      end select
   end function physical_key_given

   !> The row of key `name` of group `group` (blank-padded comparison), 0 if there is none.
   pure integer function key_row(group, name)
      character(len=*), intent(in) :: group
      character(len=*), intent(in) :: name
      do key_row = 1, n_keys
         if (keys(key_row)%group == group .and. keys(key_row)%name == name) return
      end do
      key_row = 0
   end function key_row

   !> Position of row `row` inside its group (1 for the group's first key).
   pure integer function group_index(row)
      integer, intent(in) :: row
      group_index = count(keys(1:row)%group == keys(row)%group)
   end function group_index

   !> The keys of `group` as text, 'a, b, c' (for the unknown-key message).
   subroutine group_keys_text(group, text)
      character(len=*), intent(in) :: group
      character(len=:), allocatable, intent(out) :: text
      integer :: row
      text = ''
      do row = 1, n_keys
         if (keys(row)%group /= group) cycle
         if (len(text) > 0) text = text//', '
         text = text//trim(keys(row)%name)
      end do
   end subroutine group_keys_text

   !> .true. when `value` lies in the range of numeric row `row` (an integer key's 0 too, where
   !> it takes 0); `upper` replaces the row's upper bound where it names another key's value.
   pure logical function key_in_range(row, value, upper)
      integer, intent(in) :: row
      real(dp), intent(in) :: value
      real(dp), intent(in), optional :: upper
      type(key_t) :: k
      k = keys(row)
      if (present(upper)) then
         key_in_range = in_range(value, k%lower, upper, k%lower_closed, k%upper_open)
      else
         key_in_range = in_range(value, k%lower, k%upper, k%lower_closed, k%upper_open)
      end if
      if (k%zero_too) key_in_range = key_in_range .or. value == 0
   end function key_in_range

   !> .true. when value is finite and in the range (lower_closed: >= lower, else >; upper_open:
   !> < upper, else <=).
   pure logical function in_range(value, lower_bound, upper_bound, lower_closed, upper_open)
      real(dp), intent(in) :: value, lower_bound, upper_bound
      logical, intent(in) :: lower_closed, upper_open
      in_range = ieee_is_finite(value)
      if (.not. in_range) return
      if (lower_closed) then
         in_range = value >= lower_bound
      else
         in_range = value > lower_bound
      end if
      if (upper_open) then
         in_range = in_range .and. value < upper_bound
      else
         in_range = in_range .and. value <= upper_bound
      end if
   end function in_range

   !> A real range as the messages say it: 'finite, >= 0.0E+000 and < 1.0E+000'.
   pure function range_text(lower_bound, upper_bound, lower_closed, upper_open) result(text)
      real(dp), intent(in) :: lower_bound, upper_bound
      logical, intent(in) :: lower_closed, upper_open
      character(len=len('finite, ') + merge(2, 1, lower_closed) + 1 + len(real_text(lower_bound)) + &
                len(' and ') + merge(1, 2, upper_open) + 1 + len(real_text(upper_bound))) :: text
      text = 'finite, '//trim(merge('>=', '> ', lower_closed))//' '//real_text(lower_bound)// &
             ' and '//trim(merge('< ', '<=', upper_open))//' '//real_text(upper_bound)
   end function range_text

   !> What row `row` allows, as its range messages say it: an integer range '1..30', a real
   !> range (range_text; a rule across keys is checked and said apart), the allowed words, or
   !> the rule of a string; `upper`, where given, is the value of the key that bounds it.
   subroutine key_range_text(row, text, upper)
      integer, intent(in) :: row
      character(len=:), allocatable, intent(out) :: text
      real(dp), intent(in), optional :: upper
      type(key_t) :: k
      k = keys(row)
      select case (k%kind)
      case (key_integer)
         text = int_text(int(k%lower, i8))//'..'//int_text(int(k%upper, i8))
         if (k%zero_too) text = text//' ('//trim(k%rule)//')'
      case (key_real)
         if (present(upper)) then
            text = range_text(k%lower, upper, k%lower_closed, k%upper_open)
         else if (k%upper_key /= '') then
            ! The bound is another key's value: the text names the key.
            text = 'finite, '//trim(merge('>=', '> ', k%lower_closed))//' '//real_text(k%lower)// &
                   ' and '//trim(merge('< ', '<=', k%upper_open))//' &'// &
                   trim(key_groups(group_of(k%upper_key)))//' '//trim(k%upper_key)
         else
            text = range_text(k%lower, k%upper, k%lower_closed, k%upper_open)
         end if
      case (key_string)
         if (k%last_word >= k%first_word) then
            call key_choices_text(row, text)
         else
            text = trim(k%rule)
         end if
      case default
         text = 'none, or exactly n_modes values (up to '//int_text(max_modes)//' with n_modes = 0); each '// &
                range_text(k%lower, k%upper, k%lower_closed, k%upper_open)
      end select
   contains
      !> The group of the key named `name` (the first row of that name).
      pure integer function group_of(name)
         character(len=*), intent(in) :: name
         integer :: r
         group_of = 1
         do r = 1, n_keys
            if (keys(r)%name == name) then
               group_of = findloc(key_groups, keys(r)%group, 1)
               return
            end if
         end do
      end function group_of
   end subroutine key_range_text

   !> The allowed words of a string row as text: "'a', 'b' or 'c'".
   subroutine key_choices_text(row, text)
      integer, intent(in) :: row
      character(len=:), allocatable, intent(out) :: text
      integer :: w
      type(key_t) :: k
      k = keys(row)
      text = ''''//trim(words(k%first_word))//''''
      do w = k%first_word + 1, k%last_word
         if (w == k%last_word) then
            text = text//' or '''//trim(words(w))//''''
         else
            text = text//', '''//trim(words(w))//''''
         end if
      end do
   end subroutine key_choices_text

   !> .true. when `word` (lower case) is one of the words of string row `row`.
   pure logical function key_is_word(row, word)
      integer, intent(in) :: row
      character(len=*), intent(in) :: word
      key_is_word = any(words(keys(row)%first_word:keys(row)%last_word) == word)
   end function key_is_word

   !> The value of key `row` in `config` as the resolved text writes it (after 'key = ').
   subroutine key_value_text(config, row, text)
      type(config_t), intent(in) :: config
      integer, intent(in) :: row
      character(len=:), allocatable, intent(out) :: text

      select case (keys(row)%group)
      case ('scene')
         associate (v => scene_values(config%scene))
            text = real_value(v(group_index(row)))
         end associate
         return
      case ('physical')
         ! An alternative key that was not given (tmafm_namelist physical_key_given): 'none'.
         if (.not. physical_key_given(config%physical, group_index(row))) then
            text = 'none'
            return
         end if
         associate (v => physical_values(config%physical))
            text = real_value(v(group_index(row)))
         end associate
         return
      end select
      select case (keys(row)%group)
      case ('scan')
         call scan_value_text(config, row, text)
         return
      case ('fm')
         call fm_value_text(config, row, text)
         return
      end select
      select case (keys(row)%name)
      case ('n_modes')
         ! An automatic N keeps its request, so that the text reruns the choice.
         text = int_text(merge(0, config%n_modes, config%auto_modes))
      case ('mode_tol')
         text = real_value(config%mode_tol)
      case ('mode_horizon')
         text = real_value(config%mode_horizon)
      case ('contact_law')
         text = quoted(config%contact_law)
      case ('convention')
         text = quoted(config%convention)
      case ('errata')
         text = quoted(config%errata)
      case ('a0')
         text = list_text(config%a0(1:modal_count()))
      case ('adot0')
         text = list_text(config%adot0(1:modal_count()))
      case ('in_contact')
         text = int_text(config%solver%initial_contact)
      case ('method')
         text = quoted(config%solver%method)
      case ('dtau')
         text = real_value(config%solver%dtau)
      case ('contact_refine')
         text = int_text(config%solver%contact_refine)
      case ('rtol')
         text = real_value(config%solver%rtol)
      case ('atol')
         text = real_value(config%solver%atol)
      case ('tau_end')
         text = real_value(config%solver%tau_end)
      case ('blowup_limit')
         text = real_value(config%solver%blowup_limit)
      case ('max_steps')
         text = int_text(config%solver%max_steps)
      case ('thermal_noise')
         text = int_text(config%solver%thermal_noise)
      case ('noise_seed')
         text = int_text(config%solver%noise_seed)
      case ('noise_step')
         text = real_value(config%solver%noise_step)
      case ('file')
         text = quoted(config%output_file)
      case ('sample_dtau')
         text = real_value(config%solver%sample_dtau)
      case ('format')
         text = quoted(config%output_format)
      case ('sample_from')
         text = real_value(config%solver%sample_from)
      case ('last_periods')
         text = int_text(config%solver%last_periods)
      case default
         ! A row without a case here: tests/test_tables.py finds it by its empty default.
         text = ''
      end select
   contains
      !> The number of &initial values written: N, or with an automatic N the values given
      !> (at least one).
      pure integer function modal_count()
         modal_count = config%n_modes
         if (config%auto_modes) modal_count = max(1, config%n_initial)
      end function modal_count
   end subroutine key_value_text

   !> The value of &scan key `row` in `config` (key_value_text); a b_ key not given: 'none'.
   subroutine scan_value_text(config, row, text)
      type(config_t), intent(in) :: config
      integer, intent(in) :: row
      character(len=:), allocatable, intent(out) :: text
      integer :: k
      associate (s => config%scan)
         select case (keys(row)%name)
         case ('scan_length')
            text = real_value(s%scan_length)
         case ('pixels')
            text = int_text(s%pixels)
         case ('line_rate')
            text = real_value(s%line_rate)
         case ('retrace')
            text = int_text(merge(1, 0, s%retrace))
         case ('setpoint')
            text = real_value(s%setpoint)
         case ('setpoint_ratio')
            text = real_value(s%setpoint_ratio)
         case ('lockin_bandwidth')
            text = real_value(s%lockin_bandwidth)
         case ('feedback_bandwidth')
            text = real_value(s%feedback_bandwidth)
         case ('proportional_gain')
            text = real_value(s%proportional_gain)
         case ('integral_gain')
            text = real_value(s%integral_gain)
         case ('topography')
            text = quoted(s%topography)
         case ('step_height')
            text = real_value(s%step_height)
         case ('step_position')
            text = real_value(s%step_position)
         case ('sphere_radius')
            text = real_value(s%sphere_radius)
         case ('sphere_position')
            text = real_value(s%sphere_position)
         case ('material_boundary')
            text = real_value(s%material_boundary)
         case default
            text = ''
            do k = 1, n_material_keys
               if (keys(row)%name /= 'b_'//physical_names(material_key_index(k))) cycle
               if (config%material_b_given(k)) then
                  text = real_value(config%material_b(k))
               else
                  text = 'none'
               end if
            end do
         end select
      end associate
   end subroutine scan_value_text

   !> The value of &fm key `row` in `config` (key_value_text).
   subroutine fm_value_text(config, row, text)
      type(config_t), intent(in) :: config
      integer, intent(in) :: row
      character(len=:), allocatable, intent(out) :: text
      associate (f => config%fm)
         select case (keys(row)%name)
         case ('amplitude')
            text = real_value(f%amplitude)
         case ('pll_bandwidth')
            text = real_value(f%pll_bandwidth)
         case ('amplitude_bandwidth')
            text = real_value(f%amplitude_bandwidth)
         case ('settle_periods')
            text = int_text(f%settle_periods)
         case ('average_periods')
            text = int_text(f%average_periods)
         case ('free_distance')
            text = real_value(f%free_distance)
         case ('z_start')
            text = real_value(config%fm_z_start)
         case ('z_end')
            text = real_value(config%fm_z_end)
         case ('z_points')
            text = int_text(config%fm_z_points)
         case default
            text = ''
         end select
      end associate
   end subroutine fm_value_text

   !> Everything about row `row`, as text: its group, name, value type, range (key_range_text,
   !> and a real's rule across keys), default (key_value_text of a config_t given no input),
   !> unit and meaning.
   subroutine describe_key(row, group, name, kind, range, default, unit, meaning)
      integer, intent(in) :: row
      character(len=:), allocatable, intent(out) :: group, name, kind, range, default, unit, meaning
      type(config_t) :: defaults
      group = trim(keys(row)%group)
      name = trim(keys(row)%name)
      kind = trim(kind_names(keys(row)%kind))
      call key_range_text(row, range)
      if (keys(row)%kind == key_real .and. keys(row)%rule /= '') range = range//', '//trim(keys(row)%rule)
      call key_value_text(defaults, row, default)
      unit = trim(keys(row)%unit)
      meaning = trim(keys(row)%meaning)
   end subroutine describe_key

   !> A real as the resolved text writes it: the shortest text that reads back exactly.
   pure function real_value(value) result(text)
      real(dp), intent(in) :: value
      character(len=len_trim(shortest_text_padded(value))) :: text
      text = shortest_text_padded(value)
   end function real_value

   !> A string value in quotes, inner quotes doubled.
   pure function quoted(value) result(text)
      character(len=*), intent(in) :: value
      character(len=len_trim(value) + count_quotes(value) + 2) :: text
      integer :: k, n
      text(1:1) = ''''
      n = 1
      do k = 1, len_trim(value)
         if (value(k:k) == '''') then
            text(n + 1:n + 2) = ''''''
            n = n + 2
         else
            text(n + 1:n + 1) = value(k:k)
            n = n + 1
         end if
      end do
      text(n + 1:n + 1) = ''''
   end function quoted

   !> Number of quotes (') in `value`.
   pure integer function count_quotes(value)
      character(len=*), intent(in) :: value
      integer :: k
      count_quotes = 0
      do k = 1, len(value)
         if (value(k:k) == '''') count_quotes = count_quotes + 1
      end do
   end function count_quotes

   !> Reals as the resolved text writes a list: 'x1, x2, ...'.
   pure function list_text(values) result(text)
      real(dp), intent(in) :: values(:)
      character(len=list_length(values)) :: text
      character(len=40) :: one
      integer :: j, n
      text = shortest_text_padded(values(1))
      n = len_trim(text)
      do j = 2, size(values)
         one = shortest_text_padded(values(j))
         text(n + 1:) = ', '//one
         n = n + 2 + len_trim(one)
      end do
   end function list_text

   !> Length of list_text(values).
   pure integer function list_length(values)
      real(dp), intent(in) :: values(:)
      integer :: j
      list_length = 2*(size(values) - 1)
      do j = 1, size(values)
         list_length = list_length + len_trim(shortest_text_padded(values(j)))
      end do
   end function list_length

end module tmafm_keys

!> The fully resolved input of a run: every namelist key, defaults included (a field's default
!> initialisation is its key's default; tmafm_keys has the keys).
module tmafm_config
   use tmafm_kinds, only: dp
   use tmafm_modes, only: max_modes
   use tmafm_scene, only: scene_t, physical_t
   use tmafm_settings, only: run_settings_t
   use tmafm_scan_settings, only: scan_settings_t
   use tmafm_fm_settings, only: fm_settings_t
   implicit none
   private

   public :: config_t, path_len

   !> Longest file path tmafm accepts.
   integer, parameter :: path_len = 1024

   !> One run's input: &model, &scene or &physical, &initial, &solver and &output, and for the
   !> instrument (docs/instrument.md) &scan or &fm.
   type :: config_t
      !> &model n_modes: number of Galerkin modes, 1 to max_modes (the chosen N when automatic).
      integer :: n_modes = 4
      !> .true. when &model n_modes = 0 asked tmafm to choose N.
      logical :: auto_modes = .false.
      !> &model mode_tol: automatic N stops when V_T(N) and V_T(N+1) differ by at most this
      !> fraction of the V_T range over the horizon.
      real(dp) :: mode_tol = 1.0e-2_dp
      !> &model mode_horizon: length of the runs that compare N and N+1.
      real(dp) :: mode_horizon = 20.0_dp
      !> Evidence of the automatic choice: the relative differences for N = 1, 2, ...
      real(dp) :: mode_differences(max_modes) = 0
      !> Number of entries of mode_differences in use.
      integer :: n_mode_differences = 0
      !> Number of initial values given in &initial (leading modes; the rest are zero).
      integer :: n_initial = 0
      !> &model contact_law: 'hertz' or 'dmt'.
      character(len=64) :: contact_law = 'hertz'
      !> &model convention: 'paper' (printed equations) or 'consistent' (corrected; the default,
      !> so that SI scenes report physical forces: docs/model.md section 8).
      character(len=64) :: convention = 'consistent'
      !> &model errata: corrections applied, resolved to a list such as 'E1,E3' or 'none'.
      character(len=64) :: errata = 'convention'
      !> .true. when the scene was given in SI units (&physical) and converted.
      logical :: from_physical = .false.
      !> The dimensionless scene (given, or derived from &physical).
      type(scene_t) :: scene
      !> The physical inputs, when from_physical.
      type(physical_t) :: physical
      !> &initial a0: initial modal amplitudes (first n_modes used).
      real(dp) :: a0(max_modes) = 0
      !> &initial adot0: initial modal velocities (first n_modes used).
      real(dp) :: adot0(max_modes) = 0
      !> &solver settings, plus &output sample_dtau.
      type(run_settings_t) :: solver
      !> &output file: where the executable writes the trajectory.
      character(len=path_len) :: output_file = 'tmafm_output.dat'
      !> &output format: 'text' (default) or 'npy'.
      character(len=16) :: output_format = 'text'
      !> .true. when the input has &scan: the executable scans a line (AM imaging).
      logical :: has_scan = .false.
      !> &scan: the scan line's settings.
      type(scan_settings_t) :: scan
      !> &scan b_<key>: the second material's &physical sample keys (tmafm_keys material_key_index)
      !> and which of them were given (the rest are the first material's).
      real(dp) :: material_b(8) = 0
      logical :: material_b_given(8) = .false.
      !> .true. when the input has &fm: the executable runs an FM approach.
      logical :: has_fm = .false.
      !> &fm: the FM loops' settings.
      type(fm_settings_t) :: fm
      !> &fm z_start, z_end (m) and z_points: the approach's Z points, evenly spaced from
      !> z_start to z_end (z_start alone for one point).
      real(dp) :: fm_z_start = 0
      real(dp) :: fm_z_end = 0
      integer :: fm_z_points = 1
   end type config_t

end module tmafm_config

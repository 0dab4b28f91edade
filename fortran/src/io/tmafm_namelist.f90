!> Namelist input: read, validate and echo the groups &model, &scene, &physical,
!> &initial, &solver and &output.
!>
!> Each group is read into locals that start at the defaults of config_t, after a
!> rewind, so groups may come in any order and any may be absent.  Every key is then
!> validated once, here, with a one-line message naming the group, key, value and range.
module tmafm_namelist
   use, intrinsic :: iso_fortran_env, only: iostat_end
   use, intrinsic :: ieee_arithmetic, only: ieee_is_finite, ieee_value, ieee_quiet_nan, ieee_is_nan
   use tmafm_kinds, only: dp
   use tmafm_errors, only: ok, err_input, err_file
   use tmafm_modes, only: max_modes
   use tmafm_scene, only: scene_t, physical_t, scene_from_physical
   use tmafm_settings, only: run_settings_t, method_rk4_paper, method_rk4_event, method_dopri5, &
      method_dop853, method_flight_exact, known_methods, sample_count
   use tmafm_errata, only: errata_t, errata_for_convention, parse_errata, errata_label
   use tmafm_config, only: config_t
   implicit none
   private

   public :: read_config, write_config, config_errata, real_text

   !> The namelist groups tmafm knows.
   character(len=*), parameter :: known_groups(6) = &
      [character(len=8) :: 'model', 'scene', 'physical', 'initial', 'solver', 'output']
   !> The most output samples one run may ask for.
   integer, parameter :: max_samples = 50000000

contains

   !> Read and validate the namelist file `path` into `config`.
   subroutine read_config(path, config, ierr, errmsg)
      character(len=*), intent(in) :: path
      type(config_t), intent(out) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      logical :: exists, present_groups(size(known_groups))
      integer :: unit, iostat

      ierr = ok
      errmsg = ''
      inquire (file=path, exist=exists)
      if (.not. exists) then
         ierr = err_file
         errmsg = 'input file '''//trim(path)//''' not found'
         return
      end if
      open (newunit=unit, file=path, status='old', action='read', iostat=iostat)
      if (iostat /= 0) then
         ierr = err_file
         errmsg = 'input file '''//trim(path)//''' cannot be opened'
         return
      end if

      call scan_groups(unit, path, present_groups, ierr, errmsg)
      if (ierr == ok) call read_model(unit, path, config, ierr, errmsg)
      if (ierr == ok) then
         if (present_groups(2) .and. present_groups(3)) then
            ierr = err_input
            errmsg = trim(path)//': give either &scene or &physical, not both'
         end if
      end if
      if (ierr == ok .and. present_groups(3)) then
         call read_physical(unit, path, config, ierr, errmsg)
      else if (ierr == ok) then
         call read_scene(unit, path, config, ierr, errmsg)
      end if
      if (ierr == ok) call read_initial(unit, path, config, ierr, errmsg)
      if (ierr == ok) call read_solver(unit, path, config, ierr, errmsg)
      if (ierr == ok) call read_output(unit, path, config, ierr, errmsg)
      close (unit)
   end subroutine read_config

   !> The corrections a config asks for (its resolved &model errata list).
   pure function config_errata(config) result(errata)
      type(config_t), intent(in) :: config
      type(errata_t) :: errata
      integer :: ierr
      character(len=64) :: bad
      call parse_errata(config%errata, errata, ierr, bad)
   end function config_errata

   !> Find every group name in the file; an unknown or repeated group is an error.
   subroutine scan_groups(unit, path, present_groups, ierr, errmsg)
      integer, intent(in) :: unit
      character(len=*), intent(in) :: path
      logical, intent(out) :: present_groups(:)
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      character(len=4096) :: line
      character(len=64) :: name
      integer :: iostat, first, last, k, line_number

      ierr = ok
      present_groups = .false.
      line_number = 0
      do
         read (unit, '(a)', iostat=iostat) line
         if (iostat /= 0) exit
         line_number = line_number + 1
         line = adjustl(line)
         if (line(1:1) /= '&' .and. line(1:1) /= '$') cycle
         first = 2
         last = scan(line(first:), ' ,/!'//achar(9))
         if (last == 0) then
            last = len_trim(line)
         else
            last = first + last - 2
         end if
         name = lower(line(first:last))
         if (name == 'end' .or. len_trim(name) == 0) cycle
         k = findloc(known_groups, trim(name), dim=1)
         if (k == 0) then
            ierr = err_input
            write (errmsg, '(5a,i0,a)') trim(path), ': unknown namelist group &', trim(name), &
               ' (known: &model, &scene, &physical, &initial, &solver, &output)', &
               ' at line ', line_number, ''
            return
         end if
         if (present_groups(k)) then
            ierr = err_input
            errmsg = trim(path)//': namelist group &'//trim(name)//' appears twice'
            return
         end if
         present_groups(k) = .true.
      end do
      rewind (unit)
   end subroutine scan_groups

   !> Turn a namelist read status into ierr/errmsg; an absent group (end of file) is fine.
   subroutine check_read(iostat, iomsg, path, group, ierr, errmsg)
      integer, intent(in) :: iostat
      character(len=*), intent(in) :: iomsg
      character(len=*), intent(in) :: path
      character(len=*), intent(in) :: group
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      ierr = ok
      errmsg = ''
      if (iostat == 0 .or. iostat == iostat_end) return
      ierr = err_input
      errmsg = trim(path)//': &'//group//': '//trim(iomsg)// &
               ' (unknown key, or a value of the wrong type)'
   end subroutine check_read

   subroutine read_model(unit, path, config, ierr, errmsg)
      integer, intent(in) :: unit
      character(len=*), intent(in) :: path
      type(config_t), intent(inout) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      integer :: n_modes, iostat
      real(dp) :: mode_tol, mode_horizon
      character(len=64) :: contact_law, convention, errata
      character(len=256) :: iomsg
      type(errata_t) :: parsed
      character(len=64) :: bad
      namelist /model/ n_modes, contact_law, convention, errata, mode_tol, mode_horizon

      n_modes = config%n_modes
      mode_tol = config%mode_tol
      mode_horizon = config%mode_horizon
      contact_law = config%contact_law
      convention = config%convention
      errata = config%errata
      rewind (unit)
      read (unit, nml=model, iostat=iostat, iomsg=iomsg)
      call check_read(iostat, iomsg, path, 'model', ierr, errmsg)
      if (ierr /= ok) return

      contact_law = lower(adjustl(contact_law))
      convention = lower(adjustl(convention))
      call check_range(path, 'model', 'mode_tol', mode_tol, 0.0_dp, 1.0_dp, .false., ierr, errmsg)
      call check_range(path, 'model', 'mode_horizon', mode_horizon, 0.0_dp, 1.0e4_dp, .false., &
                       ierr, errmsg)
      if (ierr /= ok) return
      if (n_modes < 0 .or. n_modes > max_modes) then
         write (errmsg, '(2a,i0,a,i0,a)') trim(path), ': &model n_modes = ', n_modes, &
            ': must be in 1..', max_modes, ' (or 0 to choose N by mode_tol)'
         ierr = err_input
      else if (contact_law /= 'hertz' .and. contact_law /= 'dmt') then
         call choice_error(path, 'model', 'contact_law', contact_law, "'hertz' or 'dmt'", ierr, errmsg)
      else if (convention /= 'paper' .and. convention /= 'consistent') then
         call choice_error(path, 'model', 'convention', convention, "'paper' or 'consistent'", &
                           ierr, errmsg)
      end if
      if (ierr /= ok) return

      if (lower(adjustl(errata)) == 'convention') then
         parsed = errata_for_convention(convention)
      else
         call parse_errata(errata, parsed, ierr, bad)
         if (ierr /= ok) then
            call choice_error(path, 'model', 'errata', errata, &
               "'convention', 'all', 'none' or a list of E1,E2,E3,E4,E6,E7", ierr, errmsg)
            return
         end if
      end if
      config%n_modes = n_modes
      config%auto_modes = n_modes == 0
      config%mode_tol = mode_tol
      config%mode_horizon = mode_horizon
      config%contact_law = contact_law
      config%convention = convention
      config%errata = errata_label(parsed)
   end subroutine read_model

   subroutine read_scene(unit, path, config, ierr, errmsg)
      integer, intent(in) :: unit
      character(len=*), intent(in) :: path
      type(config_t), intent(inout) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      real(dp) :: alpha1, alpha2, alpha3, alpha4, alpha5, alpha6, beta, omega, theta
      real(dp) :: l_over_d, g0_over_d, delta_hat, xi0
      real(dp), parameter :: half_pi = acos(-1.0_dp)/2
      integer :: iostat
      character(len=256) :: iomsg
      namelist /scene/ alpha1, alpha2, alpha3, alpha4, alpha5, alpha6, beta, omega, theta, &
         l_over_d, g0_over_d, delta_hat, xi0

      associate (s => config%scene)
         alpha1 = s%alpha1; alpha2 = s%alpha2; alpha3 = s%alpha3; alpha4 = s%alpha4
         alpha5 = s%alpha5; alpha6 = s%alpha6; beta = s%beta; omega = s%omega
         theta = s%theta; l_over_d = s%l_over_d; g0_over_d = s%g0_over_d
         delta_hat = s%delta_hat; xi0 = s%xi0
      end associate
      rewind (unit)
      read (unit, nml=scene, iostat=iostat, iomsg=iomsg)
      call check_read(iostat, iomsg, path, 'scene', ierr, errmsg)
      if (ierr /= ok) return

      call check_range(path, 'scene', 'alpha1', alpha1, 0.0_dp, 1.0e3_dp, .true., ierr, errmsg)
      call check_range(path, 'scene', 'alpha2', alpha2, 0.0_dp, 1.0_dp, .true., ierr, errmsg)
      call check_range(path, 'scene', 'alpha3', alpha3, 0.0_dp, 1.0e4_dp, .true., ierr, errmsg)
      call check_range(path, 'scene', 'alpha4', alpha4, 0.0_dp, 1.0e4_dp, .true., ierr, errmsg)
      call check_range(path, 'scene', 'alpha5', alpha5, 0.0_dp, 1.0e6_dp, .true., ierr, errmsg)
      call check_range(path, 'scene', 'alpha6', alpha6, 0.0_dp, 1.0e6_dp, .true., ierr, errmsg)
      call check_range(path, 'scene', 'beta', beta, 0.0_dp, 1.0e6_dp, .false., ierr, errmsg)
      call check_range(path, 'scene', 'omega', omega, 0.0_dp, 1.0e6_dp, .true., ierr, errmsg)
      call check_range(path, 'scene', 'theta', theta, 0.0_dp, half_pi, .true., ierr, errmsg, &
                       upper_open=.true.)
      call check_range(path, 'scene', 'l_over_d', l_over_d, 0.0_dp, 1.0e9_dp, .false., ierr, errmsg)
      call check_range(path, 'scene', 'g0_over_d', g0_over_d, 0.0_dp, 1.0e9_dp, .true., ierr, errmsg)
      call check_range(path, 'scene', 'delta_hat', delta_hat, -1.0e3_dp, 1.0e3_dp, .true., ierr, &
                       errmsg)
      call check_range(path, 'scene', 'xi0', xi0, 0.0_dp, 1.0_dp, .false., ierr, errmsg)
      if (ierr /= ok) return
      config%scene = scene_t(alpha1, alpha2, alpha3, alpha4, alpha5, alpha6, beta, omega, theta, &
                             l_over_d, g0_over_d, delta_hat, xi0)
   end subroutine read_scene

   subroutine read_physical(unit, path, config, ierr, errmsg)
      integer, intent(in) :: unit
      character(len=*), intent(in) :: path
      type(config_t), intent(inout) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      real(dp) :: length, width, thickness, density, youngs_modulus_tip, poisson_ratio_tip
      real(dp) :: youngs_modulus_sample, poisson_ratio_sample, tip_radius, adhesion_energy, tilt
      real(dp) :: gap, tip_length, static_offset, tip_position, tip_mass, beam_damping
      real(dp) :: contact_damping, drive_amplitude, drive_angular_frequency, mismatch
      real(dp), parameter :: half_pi = acos(-1.0_dp)/2
      integer :: iostat
      character(len=256) :: iomsg
      type(physical_t) :: phys
      namelist /physical/ length, width, thickness, density, youngs_modulus_tip, &
         poisson_ratio_tip, youngs_modulus_sample, poisson_ratio_sample, tip_radius, &
         adhesion_energy, tilt, gap, tip_length, static_offset, tip_position, tip_mass, &
         beam_damping, contact_damping, drive_amplitude, drive_angular_frequency

      associate (p => config%physical)
         length = p%length; width = p%width; thickness = p%thickness; density = p%density
         youngs_modulus_tip = p%youngs_modulus_tip; poisson_ratio_tip = p%poisson_ratio_tip
         youngs_modulus_sample = p%youngs_modulus_sample
         poisson_ratio_sample = p%poisson_ratio_sample
         tip_radius = p%tip_radius; adhesion_energy = p%adhesion_energy; tilt = p%tilt
         gap = p%gap; tip_length = p%tip_length; static_offset = p%static_offset
         tip_position = p%tip_position; tip_mass = p%tip_mass; beam_damping = p%beam_damping
         contact_damping = p%contact_damping; drive_amplitude = p%drive_amplitude
         drive_angular_frequency = p%drive_angular_frequency
      end associate
      rewind (unit)
      read (unit, nml=physical, iostat=iostat, iomsg=iomsg)
      call check_read(iostat, iomsg, path, 'physical', ierr, errmsg)
      if (ierr /= ok) return

      call check_range(path, 'physical', 'length', length, 0.0_dp, 1.0_dp, .false., ierr, errmsg)
      call check_range(path, 'physical', 'width', width, 0.0_dp, 1.0_dp, .false., ierr, errmsg)
      call check_range(path, 'physical', 'thickness', thickness, 0.0_dp, 1.0_dp, .false., ierr, errmsg)
      call check_range(path, 'physical', 'density', density, 0.0_dp, 1.0e5_dp, .false., ierr, errmsg)
      call check_range(path, 'physical', 'youngs_modulus_tip', youngs_modulus_tip, 0.0_dp, &
                       1.0e13_dp, .false., ierr, errmsg)
      call check_range(path, 'physical', 'poisson_ratio_tip', poisson_ratio_tip, -1.0_dp, &
                       0.5_dp, .false., ierr, errmsg)
      call check_range(path, 'physical', 'youngs_modulus_sample', youngs_modulus_sample, 0.0_dp, &
                       1.0e13_dp, .false., ierr, errmsg)
      call check_range(path, 'physical', 'poisson_ratio_sample', poisson_ratio_sample, -1.0_dp, &
                       0.5_dp, .false., ierr, errmsg)
      call check_range(path, 'physical', 'tip_radius', tip_radius, 0.0_dp, 1.0e-2_dp, .false., &
                       ierr, errmsg)
      call check_range(path, 'physical', 'adhesion_energy', adhesion_energy, 0.0_dp, 1.0e3_dp, &
                       .false., ierr, errmsg)
      call check_range(path, 'physical', 'tilt', tilt, 0.0_dp, half_pi, .true., ierr, errmsg, &
                       upper_open=.true.)
      call check_range(path, 'physical', 'gap', gap, 0.0_dp, 1.0_dp, .false., ierr, errmsg)
      call check_range(path, 'physical', 'tip_length', tip_length, 0.0_dp, 1.0_dp, .true., ierr, &
                       errmsg)
      call check_range(path, 'physical', 'static_offset', static_offset, -1.0_dp, 1.0_dp, .true., &
                       ierr, errmsg)
      call check_range(path, 'physical', 'tip_position', tip_position, 0.0_dp, length, .false., &
                       ierr, errmsg)
      call check_range(path, 'physical', 'tip_mass', tip_mass, 0.0_dp, 1.0_dp, .true., ierr, errmsg)
      call check_range(path, 'physical', 'beam_damping', beam_damping, 0.0_dp, 1.0e6_dp, .true., &
                       ierr, errmsg)
      call check_range(path, 'physical', 'contact_damping', contact_damping, 0.0_dp, 1.0e6_dp, &
                       .true., ierr, errmsg)
      call check_range(path, 'physical', 'drive_amplitude', drive_amplitude, 0.0_dp, 1.0_dp, &
                       .true., ierr, errmsg)
      call check_range(path, 'physical', 'drive_angular_frequency', drive_angular_frequency, &
                       0.0_dp, 1.0e12_dp, .true., ierr, errmsg)
      if (ierr /= ok) return
      ! The paper's geometry: d = g0 + delta/cos(theta).
      mismatch = abs(gap - tip_length - static_offset/cos(tilt))
      if (mismatch > 1.0e-6_dp*gap) then
         ierr = err_input
         errmsg = trim(path)//': &physical gap = '//real_text(gap)//': must equal tip_length '// &
                  '+ static_offset/cos(tilt) = '//real_text(tip_length + static_offset/cos(tilt))
         return
      end if
      phys = physical_t(length, width, thickness, density, youngs_modulus_tip, poisson_ratio_tip, &
                        youngs_modulus_sample, poisson_ratio_sample, tip_radius, adhesion_energy, &
                        tilt, gap, tip_length, static_offset, tip_position, tip_mass, beam_damping, &
                        contact_damping, drive_amplitude, drive_angular_frequency)
      config%from_physical = .true.
      config%physical = phys
      config%scene = scene_from_physical(phys)
   end subroutine read_physical

   subroutine read_initial(unit, path, config, ierr, errmsg)
      integer, intent(in) :: unit
      character(len=*), intent(in) :: path
      type(config_t), intent(inout) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      real(dp) :: a0(max_modes), adot0(max_modes)
      integer :: iostat
      character(len=256) :: iomsg
      namelist /initial/ a0, adot0

      ! Unset entries stay NaN, so the number of values given can be counted.
      a0 = ieee_value(1.0_dp, ieee_quiet_nan)
      adot0 = a0
      rewind (unit)
      read (unit, nml=initial, iostat=iostat, iomsg=iomsg)
      call check_read(iostat, iomsg, path, 'initial', ierr, errmsg)
      if (ierr /= ok) return
      call take_modal_values(path, 'a0', a0, config%n_modes, config%a0, config%n_initial, ierr, &
                             errmsg)
      if (ierr /= ok) return
      call take_modal_values(path, 'adot0', adot0, config%n_modes, config%adot0, &
                             config%n_initial, ierr, errmsg)
   end subroutine read_initial

   !> Accept either no values (all zero) or exactly n_modes leading values; with n_modes = 0
   !> (automatic N) any number of leading values, the rest being zero.
   subroutine take_modal_values(path, key, given, n_modes, values, n_initial, ierr, errmsg)
      character(len=*), intent(in) :: path
      character(len=*), intent(in) :: key
      real(dp), intent(in) :: given(:)
      integer, intent(in) :: n_modes
      real(dp), intent(inout) :: values(:)
      integer, intent(inout) :: n_initial
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      integer :: count_given, j

      ierr = ok
      errmsg = ''
      count_given = count(.not. ieee_is_nan(given))
      if (count_given == 0) return
      if ((n_modes > 0 .and. count_given /= n_modes) &
          .or. any(ieee_is_nan(given(1:min(count_given, size(given)))))) then
         ierr = err_input
         write (errmsg, '(5a,i0,a,i0,a)') trim(path), ': &initial ', key, ': ', &
            'has ', count_given, ' values but &model n_modes = ', n_modes, &
            ' (give exactly n_modes values, or none for zeros)'
         return
      end if
      do j = 1, count_given
         if (.not. ieee_is_finite(given(j)) .or. abs(given(j)) > 1.0_dp) then
            ierr = err_input
            write (errmsg, '(5a,i0,3a)') trim(path), ': &initial ', key, ': ', 'value ', j, &
               ' = ', real_text(given(j)), ': must be finite with |value| <= 1 (gap units)'
            return
         end if
      end do
      values = 0
      values(1:count_given) = given(1:count_given)
      n_initial = max(n_initial, count_given)
   end subroutine take_modal_values

   subroutine read_solver(unit, path, config, ierr, errmsg)
      integer, intent(in) :: unit
      character(len=*), intent(in) :: path
      type(config_t), intent(inout) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      character(len=64) :: method
      real(dp) :: dtau, tau_end, blowup_limit, rtol, atol
      integer :: contact_refine, iostat
      character(len=256) :: iomsg
      namelist /solver/ method, dtau, contact_refine, rtol, atol, tau_end, blowup_limit

      method = config%solver%method
      dtau = config%solver%dtau
      contact_refine = config%solver%contact_refine
      tau_end = config%solver%tau_end
      blowup_limit = config%solver%blowup_limit
      rtol = config%solver%rtol
      atol = config%solver%atol
      rewind (unit)
      read (unit, nml=solver, iostat=iostat, iomsg=iomsg)
      call check_read(iostat, iomsg, path, 'solver', ierr, errmsg)
      if (ierr /= ok) return

      method = lower(adjustl(method))
      if (all(method /= [character(len=64) :: method_rk4_paper, method_rk4_event, method_dopri5, &
                         method_dop853, method_flight_exact])) then
         call choice_error(path, 'solver', 'method', method, known_methods, ierr, errmsg)
         return
      end if
      call check_range(path, 'solver', 'dtau', dtau, 0.0_dp, 10.0_dp, .false., ierr, errmsg)
      call check_range(path, 'solver', 'tau_end', tau_end, 0.0_dp, 1.0e7_dp, .false., ierr, errmsg)
      call check_range(path, 'solver', 'blowup_limit', blowup_limit, 0.0_dp, 1.0e10_dp, .false., &
                       ierr, errmsg)
      call check_range(path, 'solver', 'rtol', rtol, 1.0e-15_dp, 1.0e-1_dp, .true., ierr, errmsg)
      call check_range(path, 'solver', 'atol', atol, 0.0_dp, 1.0_dp, .true., ierr, errmsg)
      if (ierr /= ok) return
      if (contact_refine < 1 .or. contact_refine > 100000) then
         ierr = err_input
         write (errmsg, '(2a,i0,a)') trim(path), ': &solver contact_refine = ', contact_refine, &
            ': must be in 1..100000'
         return
      end if
      config%solver%method = method
      config%solver%dtau = dtau
      config%solver%contact_refine = contact_refine
      config%solver%tau_end = tau_end
      config%solver%blowup_limit = blowup_limit
      config%solver%rtol = rtol
      config%solver%atol = atol
   end subroutine read_solver

   subroutine read_output(unit, path, config, ierr, errmsg)
      integer, intent(in) :: unit
      character(len=*), intent(in) :: path
      type(config_t), intent(inout) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      character(len=len(config%output_file)) :: file
      real(dp) :: sample_dtau
      integer :: iostat
      character(len=256) :: iomsg
      namelist /output/ file, sample_dtau

      file = config%output_file
      sample_dtau = config%solver%sample_dtau
      rewind (unit)
      read (unit, nml=output, iostat=iostat, iomsg=iomsg)
      call check_read(iostat, iomsg, path, 'output', ierr, errmsg)
      if (ierr /= ok) return
      call check_range(path, 'output', 'sample_dtau', sample_dtau, 0.0_dp, &
                       config%solver%tau_end, .false., ierr, errmsg)
      if (ierr /= ok) return
      if (len_trim(file) == 0) then
         ierr = err_input
         errmsg = trim(path)//': &output file = '''': must name a file'
         return
      end if
      config%output_file = adjustl(file)
      config%solver%sample_dtau = sample_dtau
      if (sample_count(config%solver) > max_samples) then
         ierr = err_input
         write (errmsg, '(4a,i0,a)') trim(path), ': &output sample_dtau = ', real_text(sample_dtau), &
            ': gives more than ', max_samples, ' samples; raise it or lower &solver tau_end'
      end if
   end subroutine read_output

   !> Error unless lower < value < upper (or lower <= value if lower_closed); first error wins.
   subroutine check_range(path, group, key, value, lower, upper, lower_closed, ierr, errmsg, &
                          upper_open)
      character(len=*), intent(in) :: path
      character(len=*), intent(in) :: group
      character(len=*), intent(in) :: key
      real(dp), intent(in) :: value
      real(dp), intent(in) :: lower
      real(dp), intent(in) :: upper
      logical, intent(in) :: lower_closed
      integer, intent(inout) :: ierr
      character(len=*), intent(inout) :: errmsg
      logical, intent(in), optional :: upper_open
      logical :: good, open_top
      character(len=2) :: low_mark, high_mark

      if (ierr /= ok) return
      open_top = .false.
      if (present(upper_open)) open_top = upper_open
      good = ieee_is_finite(value)
      if (good) then
         if (lower_closed) then
            good = value >= lower
         else
            good = value > lower
         end if
         if (open_top) then
            good = good .and. value < upper
         else
            good = good .and. value <= upper
         end if
      end if
      if (good) return
      low_mark = merge('>=', '> ', lower_closed)
      high_mark = merge('< ', '<=', open_top)
      ierr = err_input
      errmsg = trim(path)//': &'//group//' '//key//' = '//real_text(value)//': must be finite, '// &
               trim(low_mark)//' '//real_text(lower)//' and '//trim(high_mark)//' '//real_text(upper)
   end subroutine check_range

   subroutine choice_error(path, group, key, value, allowed, ierr, errmsg)
      character(len=*), intent(in) :: path
      character(len=*), intent(in) :: group
      character(len=*), intent(in) :: key
      character(len=*), intent(in) :: value
      character(len=*), intent(in) :: allowed
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      ierr = err_input
      errmsg = trim(path)//': &'//group//' '//key//' = '''//trim(value)//''': must be '//allowed
   end subroutine choice_error

   !> Write the resolved configuration as namelist text, each line starting with `prefix`.
   subroutine write_config(unit, config, prefix)
      integer, intent(in) :: unit
      type(config_t), intent(in) :: config
      character(len=*), intent(in) :: prefix
      character(len=:), allocatable :: c
      integer :: n

      c = prefix
      n = config%n_modes
      write (unit, '(a)') c//'&model'
      if (config%auto_modes) then
         ! Keep the request, so the file reruns the choice; record the choice as a comment.
         write (unit, '(a)') c//'    n_modes = 0'
         write (unit, '(a,i0,a)') c//'    ! chosen n_modes = ', n, &
            ': max|V_T(N) - V_T(N+1)|/range(V_T) for N = 1, 2, ... = '// &
            list_text(config%mode_differences(1:config%n_mode_differences))
      else
         write (unit, '(a,i0)') c//'    n_modes = ', n
      end if
      call put(c, 'mode_tol', config%mode_tol)
      call put(c, 'mode_horizon', config%mode_horizon)
      write (unit, '(a)') c//'    contact_law = '''//trim(config%contact_law)//''''
      write (unit, '(a)') c//'    convention = '''//trim(config%convention)//''''
      write (unit, '(a)') c//'    errata = '''//trim(config%errata)//''''
      write (unit, '(a)') c//'/'
      if (config%from_physical) then
         associate (p => config%physical)
            write (unit, '(a)') c//'&physical'
            call put(c, 'length', p%length)
            call put(c, 'width', p%width)
            call put(c, 'thickness', p%thickness)
            call put(c, 'density', p%density)
            call put(c, 'youngs_modulus_tip', p%youngs_modulus_tip)
            call put(c, 'poisson_ratio_tip', p%poisson_ratio_tip)
            call put(c, 'youngs_modulus_sample', p%youngs_modulus_sample)
            call put(c, 'poisson_ratio_sample', p%poisson_ratio_sample)
            call put(c, 'tip_radius', p%tip_radius)
            call put(c, 'adhesion_energy', p%adhesion_energy)
            call put(c, 'tilt', p%tilt)
            call put(c, 'gap', p%gap)
            call put(c, 'tip_length', p%tip_length)
            call put(c, 'static_offset', p%static_offset)
            call put(c, 'tip_position', p%tip_position)
            call put(c, 'tip_mass', p%tip_mass)
            call put(c, 'beam_damping', p%beam_damping)
            call put(c, 'contact_damping', p%contact_damping)
            call put(c, 'drive_amplitude', p%drive_amplitude)
            call put(c, 'drive_angular_frequency', p%drive_angular_frequency)
            write (unit, '(a)') c//'/'
         end associate
         ! The derived groups, as comments, so the file stays a valid input.
         c = prefix//'! derived by Eq. (12): '
      end if
      associate (s => config%scene)
         write (unit, '(a)') c//'&scene'
         call put(c, 'alpha1', s%alpha1)
         call put(c, 'alpha2', s%alpha2)
         call put(c, 'alpha3', s%alpha3)
         call put(c, 'alpha4', s%alpha4)
         call put(c, 'alpha5', s%alpha5)
         call put(c, 'alpha6', s%alpha6)
         call put(c, 'beta', s%beta)
         call put(c, 'omega', s%omega)
         call put(c, 'theta', s%theta)
         call put(c, 'l_over_d', s%l_over_d)
         call put(c, 'g0_over_d', s%g0_over_d)
         call put(c, 'delta_hat', s%delta_hat)
         call put(c, 'xi0', s%xi0)
         write (unit, '(a)') c//'/'
      end associate
      c = prefix
      write (unit, '(a)') c//'&initial'
      if (config%auto_modes) n = max(1, config%n_initial)
      write (unit, '(a)') c//'    a0 = '//list_text(config%a0(1:n))
      write (unit, '(a)') c//'    adot0 = '//list_text(config%adot0(1:n))
      write (unit, '(a)') c//'/'
      write (unit, '(a)') c//'&solver'
      write (unit, '(a)') c//'    method = '''//trim(config%solver%method)//''''
      call put(c, 'dtau', config%solver%dtau)
      write (unit, '(a,i0)') c//'    contact_refine = ', config%solver%contact_refine
      call put(c, 'rtol', config%solver%rtol)
      call put(c, 'atol', config%solver%atol)
      call put(c, 'tau_end', config%solver%tau_end)
      call put(c, 'blowup_limit', config%solver%blowup_limit)
      write (unit, '(a)') c//'/'
      write (unit, '(a)') c//'&output'
      write (unit, '(a)') c//'    file = '''//trim(config%output_file)//''''
      call put(c, 'sample_dtau', config%solver%sample_dtau)
      write (unit, '(a)') c//'/'
   contains
      subroutine put(lead, key, value)
         character(len=*), intent(in) :: lead
         character(len=*), intent(in) :: key
         real(dp), intent(in) :: value
         write (unit, '(a)') lead//'    '//key//' = '//real_text(value)
      end subroutine put
   end subroutine write_config

   !> The shortest scientific text that reads back to exactly `value`.
   function real_text(value) result(text)
      real(dp), intent(in) :: value
      character(len=:), allocatable :: text
      character(len=40) :: buffer, fmt
      real(dp) :: back
      integer :: digits, iostat

      do digits = 1, 17
         write (fmt, '(a,i0,a,i0,a)') '(es', digits + 10, '.', digits, 'e3)'
         write (buffer, fmt) value
         read (buffer, *, iostat=iostat) back
         if (iostat == 0 .and. back == value) exit
      end do
      text = trim(adjustl(buffer))
   end function real_text

   function list_text(values) result(text)
      real(dp), intent(in) :: values(:)
      character(len=:), allocatable :: text
      integer :: j
      if (size(values) == 0) then
         text = 'none'
         return
      end if
      text = real_text(values(1))
      do j = 2, size(values)
         text = text//', '//real_text(values(j))
      end do
   end function list_text

   pure function lower(text) result(low)
      character(len=*), intent(in) :: text
      character(len=len(text)) :: low
      integer :: i, code
      low = text
      do i = 1, len(text)
         code = iachar(text(i:i))
         if (code >= iachar('A') .and. code <= iachar('Z')) low(i:i) = achar(code + 32)
      end do
   end function lower

end module tmafm_namelist

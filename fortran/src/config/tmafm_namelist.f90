!> Namelist input: read, type-check and validate the groups &model, &scene, &physical,
!> &initial, &solver, &output and the instrument's &scan or &fm; write the resolved input back as namelist text.
!>
!> No Fortran `read(nml=)`: the whole input is read into memory (tmafm_input_file), parsed
!> by tmafm_nml_syntax, and every entry is taken here with its type and range checked against
!> its key's row of the key table (tmafm_keys: an integer key takes only an integer, a real key
!> an integer or a real, a string key only a quoted string, a scalar key exactly one value).
!> Unknown, repeated or unused groups and keys are errors.  Each error is one line:
!>    <source>: &group key = <value as written>: <what is wrong> (line N)
!> After the keys, the derived quantities are checked before any run starts: the groups of
!> Eq. (12) from &physical, the sample count and trajectory memory, and the worst-case step
!> count of fixed-step methods against &solver max_steps.
module tmafm_namelist
   use, intrinsic :: ieee_arithmetic, only: ieee_is_finite, ieee_value, ieee_quiet_nan, &
      ieee_positive_inf, ieee_negative_inf
   use tmafm_kinds, only: dp, i8
   use tmafm_errors, only: ok, err_input
   use tmafm_text, only: real_text, real_text_padded, int_text, lower, short_real_text
   use tmafm_modes, only: max_modes
   use tmafm_scene, only: scene_t, physical_t, scene_from_physical, scene_names, scene_values, &
      physical_names, physical_values, scene_depends_on, scene_from_values, physical_from_values, &
      beam_rigidity, beam_mass_per_length
   use tmafm_settings, only: run_settings_t, check_run_size, comparison_intervals, comparison_points, &
      mode_digits, comparison_rtol, sls_method_refused, first_sample_at, sample_count_real
   use tmafm_errata, only: errata_t, errata_for_convention, parse_errata, errata_label
   use tmafm_drive, only: drive_t, init_drive
   use tmafm_config, only: config_t
   use tmafm_scan_settings, only: scan_settings_t, check_scan_settings
   use tmafm_fm_settings, only: fm_settings_t
   use tmafm_keys, only: keys, key_groups, key_row, group_index, key_in_range, key_range_text, &
      key_choices_text, key_is_word, group_keys_text, key_value_text, range_text, physical_key_given, &
      n_material_keys, material_key_index
   use tmafm_nml_syntax, only: nml_document_t, nml_group_t, nml_entry_t, nml_value_t, &
      patch_document, parse_namelist, value_integer, value_real, value_logical, value_string, value_word, &
      value_kind_name, value_other
   use tmafm_input_file, only: read_text_file
   use tmafm_calibration, only: calibrate_cantilever, drive_for_free_amplitude, physical_derived, &
      derived_names, derived_units, derived_meanings, n_derived
   use tmafm_float_format, only: shortest_text_padded
   implicit none
   private

   public :: read_config, read_config_text, read_config_document, write_config, config_text, &
             config_errata, real_text, material_b_physical, fm_z_points

   !> The shortest nonzero &scene sls_relaxation_time: 1/T must be a normal number (read_scene);
   !> a &physical scene's derived value is held to it too (check_derived).
   real(dp), parameter :: min_relaxation_time = 1.0e-12_dp

   !> What an error message needs to name the place: the source and the group.
   type :: place_t
      character(len=:), allocatable :: label
      character(len=:), allocatable :: group
   end type place_t

contains

   !> Read and validate the namelist file `path` into `config` (the whole file is read first;
   !> pipes work).  A file problem gives err_file, an input problem err_input.
   subroutine read_config(path, config, ierr, errmsg, notice_unit)
      character(len=*), intent(in) :: path
      type(config_t), intent(out) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      !> Where to say that tmafm waits for a FIFO's writer (tmafm_input_file; nowhere if absent).
      integer, intent(in), optional :: notice_unit
      character(len=:), allocatable :: text

      call read_text_file(path, text, ierr, errmsg, notice_unit)
      if (ierr /= ok) return
      call read_config_text(text, trim(path), config, ierr, errmsg)
   end subroutine read_config

   !> Parse and validate namelist `text` (lines separated by new_line('a')) into `config`;
   !> `source_label` names the input in messages (a path, or e.g. '<dict input>').
   subroutine read_config_text(text, source_label, config, ierr, errmsg)
      character(len=*), intent(in) :: text
      character(len=*), intent(in) :: source_label
      type(config_t), intent(out) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(nml_document_t) :: doc

      call parse_namelist(text, source_label, doc, ierr, errmsg)
      if (ierr /= ok) return
      call read_config_document(doc, source_label, config, ierr, errmsg)
   end subroutine read_config_text

   !> Type-check and validate a parsed namelist `doc` into `config` (read_config_text after
   !> the syntax; tmafm_api gives it a base document patched by overrides, whose entries say
   !> where they came from: a line of the base, or an override).
   recursive subroutine read_config_document(doc, source_label, config, ierr, errmsg)
      type(nml_document_t), intent(in) :: doc
      character(len=*), intent(in) :: source_label
      type(config_t), intent(out) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      ! found(k): the position in doc of group key_groups(k), 0 if absent.
      integer :: found(size(key_groups)), g, k
      character(len=:), allocatable :: known

      ierr = err_input
      found = 0
      do g = 1, doc%n_groups
         k = index_of(key_groups, doc%groups(g)%name)
         if (k == 0) then
            known = '&'//trim(key_groups(1))
            do k = 2, size(key_groups)
               known = known//', &'//trim(key_groups(k))
            end do
            errmsg = source_label//': unknown namelist group &'//doc%groups(g)%name//' at '// &
                     trim(line_text(doc%groups(g)%line))//' (known: '//known//')'
            return
         end if
         if (found(k) /= 0) then
            errmsg = source_label//': namelist group &'//doc%groups(g)%name//' appears twice '// &
                     '('//trim(line_text(doc%groups(found(k))%line))//' and '// &
                     trim(line_text(doc%groups(g)%line))//')'
            return
         end if
         found(k) = g
      end do
      if (doc%n_groups == 0) then
         errmsg = source_label//': no namelist group found (an empty input is refused; '// &
                  'write &model / to run every default)'
         return
      end if
      if (at('scene') /= 0 .and. at('physical') /= 0) then
         errmsg = source_label//': give either &scene or &physical, not both'
         return
      end if
      ierr = ok
      errmsg = ''

      if (at('model') /= 0) then
         call read_model(place('model'), doc%groups(at('model')), config, ierr, errmsg)
      else
         ! &model errata 'convention' resolved as read_model resolves it (the default convention's list).
         config%errata = errata_label(errata_for_convention(trim(config%convention)))
      end if
      if (ierr /= ok) return
      if (at('physical') /= 0) then
         call read_physical(place('physical'), doc%groups(at('physical')), config, ierr, errmsg)
      else if (at('scene') /= 0) then
         call read_scene(place('scene'), doc%groups(at('scene')), config, ierr, errmsg)
      end if
      if (ierr /= ok) return
      if (at('initial') /= 0) call read_initial(place('initial'), doc%groups(at('initial')), config, ierr, errmsg)
      if (ierr /= ok) return
      if (at('solver') /= 0) call read_solver(place('solver'), doc%groups(at('solver')), config, ierr, errmsg)
      if (ierr /= ok) return
      ! The thermal energy acts only with the noise on: a &physical scene without it has none, so
      ! that its scene, written as &scene, reads back as the same noiseless input.
      if (config%from_physical .and. config%solver%thermal_noise /= 1) config%scene%thermal_energy = 0
      if (at('output') /= 0) call read_output(place('output'), doc%groups(at('output')), config, ierr, errmsg)
      if (ierr /= ok) return
      call check_derived(source_label, doc, at('physical'), config, ierr, errmsg)
      if (ierr /= ok) return
      ! The instrument (docs/instrument.md): each key of &scan and &fm, then one of them, on a
      ! scene in SI units, and the scan's rules across keys and against the drive period.
      if (at('scan') /= 0) call read_scan(place('scan'), doc%groups(at('scan')), config, ierr, errmsg)
      if (ierr /= ok) return
      if (at('fm') /= 0) call read_fm(place('fm'), doc%groups(at('fm')), config, ierr, errmsg)
      if (ierr /= ok) return
      if (config%has_scan .or. config%has_fm) then
         ierr = err_input
         if (config%has_scan .and. config%has_fm) then
            errmsg = source_label//': give either &scan or &fm, not both (one measurement a run)'
            return
         else if (.not. config%from_physical) then
            errmsg = source_label//': &'//trim(merge('scan', 'fm  ', config%has_scan))// &
                     ' needs the scene in SI units (&physical), not &scene'
            return
         end if
         ierr = ok
      end if
      if (config%has_scan) then
         call check_scan_settings(config%scan, 2*acos(-1.0_dp)/config%physical%drive_angular_frequency, &
                                  ierr, errmsg)
         if (ierr /= ok) errmsg = source_label//': &'//trim(errmsg)
         if (ierr == ok .and. config%scan%two_materials) call read_material_b()
      end if
   contains
      !> The second material's scene: the input without &scan, its &physical patched by the
      !> b_ keys (as Python's scan_line patches it by material_b), read and checked as any.
      recursive subroutine read_material_b()
         type(nml_document_t) :: base, over, merged
         type(config_t) :: config_b
         integer :: j, n
         base%from_output_file = doc%from_output_file
         allocate (base%groups(doc%n_groups))
         do j = 1, doc%n_groups
            if (doc%groups(j)%name == 'scan') cycle
            base%n_groups = base%n_groups + 1
            base%groups(base%n_groups) = doc%groups(j)
         end do
         allocate (over%groups(1))
         over%n_groups = 1
         over%groups(1)%name = 'physical'
         associate (scan_group => doc%groups(at('scan')))
            allocate (over%groups(1)%entries(scan_group%n_entries))
            n = 0
            do j = 1, scan_group%n_entries
               if (scan_group%entries(j)%key(1:min(2, len(scan_group%entries(j)%key))) /= 'b_') cycle
               n = n + 1
               over%groups(1)%entries(n) = scan_group%entries(j)
               over%groups(1)%entries(n)%key = scan_group%entries(j)%key(3:)
            end do
         end associate
         over%groups(1)%n_entries = n
         call patch_document(base, over, merged)
         call read_config_document(merged, source_label, config_b, ierr, errmsg)
         if (ierr /= ok) then
            ! Its message names the source first: the second material goes after it.
            n = len(source_label) + 2
            if (errmsg(1:min(n, len(errmsg))) == source_label//': ') errmsg = errmsg(n + 1:)
            errmsg = source_label//': the second material (&scan b_ keys): '//trim(errmsg)
         end if
      end subroutine read_material_b
      !> The position in doc of group `group`, 0 if absent.
      pure integer function at(group)
         character(len=*), intent(in) :: group
         at = found(index_of(key_groups, group))
      end function at
      function place(group) result(p)
         character(len=*), intent(in) :: group
         type(place_t) :: p
         p%label = source_label
         p%group = group
      end function place
   end subroutine read_config_document

   !> Where an entry or group came from, for messages: 'line N', or 'override' for line 0 (an
   !> entry or group that a base input did not have: tmafm_api config_from_texts); blank-padded
   !> to 24 characters (trim it).
   pure function line_text(line) result(text)
      integer, intent(in) :: line
      character(len=24) :: text
      if (line <= 0) then
         text = 'override'
      else
         write (text, '(a,i0)') 'line ', line
      end if
   end function line_text

   !> The corrections a config asks for (its resolved &model errata list).
   pure function config_errata(config) result(errata)
      type(config_t), intent(in) :: config
      type(errata_t) :: errata
      integer :: ierr
      character(len=64) :: bad
      ! 'convention' (the default, kept when &model is absent) follows the convention.
      if (lower(trim(config%errata)) == 'convention') then
         errata = errata_for_convention(trim(config%convention))
         return
      end if
      call parse_errata(trim(config%errata), errata, ierr, bad)
   end function config_errata

   ! --- the groups -------------------------------------------------------------------------

   subroutine read_model(p, g, config, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_group_t), intent(in) :: g
      type(config_t), intent(inout) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      integer(i8) :: n_modes
      real(dp) :: mode_tol, mode_horizon
      character(len=:), allocatable :: contact_law, convention, errata, range
      type(errata_t) :: parsed
      character(len=160) :: bad
      integer :: k, row

      n_modes = config%n_modes
      mode_tol = config%mode_tol
      mode_horizon = config%mode_horizon
      contact_law = trim(config%contact_law)
      convention = trim(config%convention)
      errata = trim(config%errata)
      ierr = ok
      do k = 1, g%n_entries
         if (ierr /= ok) return
         associate (e => g%entries(k))
            row = key_row(p%group, e%key)
            select case (e%key)
            case ('n_modes')
               call take_integer(p, e, row, n_modes, ierr, errmsg)
            case ('mode_tol')
               call take_real(p, e, row, mode_tol, ierr, errmsg)
            case ('mode_horizon')
               call take_real(p, e, row, mode_horizon, ierr, errmsg)
               ! Why the bound: the search's cost grows with the horizon (docs/reliability.md).
               if (ierr /= ok .and. mode_horizon > keys(row)%upper .and. mode_horizon <= huge(1.0_dp)) then
                  call key_error(p, e, 'must be > 0 and <= '//real_text(keys(row)%upper)// &
                                 ': with n_modes = 0 the search for N may run '//int_text(max_modes)// &
                                 ' comparison runs of this length at rtol 1e-10', ierr, errmsg)
               end if
            case ('contact_law')
               call take_word(p, e, row, len(config%contact_law), contact_law, ierr, errmsg)
            case ('convention')
               call take_word(p, e, row, len(config%convention), convention, ierr, errmsg)
            case ('errata')
               call get_string(p, e, len(config%errata), errata, ierr, errmsg)
               if (ierr == ok .and. lower(errata) /= 'convention') then
                  call parse_errata(errata, parsed, ierr, bad)
                  call key_range_text(row, range)
                  if (ierr /= ok) call key_error(p, e, trim(bad)//': must be '//range, ierr, errmsg)
               end if
            case default
               call unknown_key(p, e, row, ierr, errmsg)
            end select
         end associate
      end do
      if (ierr == ok) call check_repeats(p, g, ierr, errmsg)
      if (ierr /= ok) return
      if (lower(errata) == 'convention') then
         parsed = errata_for_convention(convention)
      else
         call parse_errata(errata, parsed, ierr, bad)
      end if
      config%n_modes = int(n_modes)
      config%auto_modes = n_modes == 0
      config%mode_tol = mode_tol
      config%mode_horizon = mode_horizon
      config%contact_law = contact_law
      config%convention = convention
      config%errata = errata_label(parsed)
   end subroutine read_model

   !> Read a group whose keys are all reals (&scene, &physical) into `values`, each key at its
   !> place in the group's rows of the key table, checked against the table's range.
   subroutine read_real_group(p, g, values, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_group_t), intent(in) :: g
      real(dp), intent(inout) :: values(:)
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      integer :: k, row
      ierr = ok
      do k = 1, g%n_entries
         if (ierr /= ok) return
         associate (e => g%entries(k))
            row = key_row(p%group, e%key)
            if (row == 0) then
               call unknown_key(p, e, row, ierr, errmsg)
            else
               call take_real(p, e, row, values(group_index(row)), ierr, errmsg)
            end if
         end associate
      end do
      if (ierr == ok) call check_repeats(p, g, ierr, errmsg)
   end subroutine read_real_group

   subroutine read_scene(p, g, config, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_group_t), intent(in) :: g
      type(config_t), intent(inout) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      real(dp) :: values(size(scene_names))

      values = scene_values(config%scene)
      call read_real_group(p, g, values, ierr, errmsg)
      if (ierr /= ok) return
      ! A liquid takes both of its keys (docs/model.md, A liquid environment): one alone is refused, not ignored.
      call check_pair(p, g, 'medium_mass', values(14), 'medium_reynolds', values(15), ierr, errmsg)
      if (ierr /= ok) return
      ! A viscoelastic sample: T = 0 (off) or long enough that 1/T is a normal number; a shorter
      ! one is the relaxed elastic law (docs/model.md, section 14).
      if (values(18) > 0 .and. values(18) < min_relaxation_time) then
         call key_error(p, entry_or_default(g, 'sls_relaxation_time', values(18)), &
                        'must be 0 (an elastic sample) or >= '//real_text(min_relaxation_time), ierr, errmsg)
         return
      end if
      config%scene = scene_from_values(values)
   end subroutine read_scene

   !> The double layer's &physical keys v (in the order of physical_names): the two surface
   !> potentials together, with a Debye length from debye_length or ionic_strength (not both).
   subroutine check_double_layer(p, g, v, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_group_t), intent(in) :: g
      real(dp), intent(in) :: v(:)
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      real(dp) :: debye, ionic, tip_psi, sample_psi
      ierr = ok
      errmsg = ''
      debye = v(index_of(physical_names, 'debye_length'))
      ionic = v(index_of(physical_names, 'ionic_strength'))
      tip_psi = v(index_of(physical_names, 'tip_surface_potential'))
      sample_psi = v(index_of(physical_names, 'sample_surface_potential'))
      if (debye > 0 .and. ionic > 0) then
         call key_error(p, entry_or_default(g, 'ionic_strength', ionic), &
                        'give the Debye length once: debye_length or ionic_strength, not both', ierr, errmsg)
      else if ((tip_psi /= 0) .neqv. (sample_psi /= 0)) then
         if (tip_psi /= 0) then
            call key_error(p, entry_or_default(g, 'tip_surface_potential', tip_psi), &
                           'needs sample_surface_potential /= 0 too (the double layer)', ierr, errmsg)
         else
            call key_error(p, entry_or_default(g, 'sample_surface_potential', sample_psi), &
                           'needs tip_surface_potential /= 0 too (the double layer)', ierr, errmsg)
         end if
      else if (tip_psi /= 0 .and. .not. (debye > 0 .or. ionic > 0)) then
         call key_error(p, entry_or_default(g, 'tip_surface_potential', tip_psi), &
                        'needs a Debye length: debye_length > 0 or ionic_strength > 0', ierr, errmsg)
      end if
   end subroutine check_double_layer

   !> The meniscus's &physical keys v (in the order of physical_names): its rupture gap given once,
   !> by the humidity or as a distance.
   subroutine check_meniscus(p, g, v, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_group_t), intent(in) :: g
      real(dp), intent(in) :: v(:)
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      real(dp) :: humidity, rupture
      ierr = ok
      errmsg = ''
      humidity = v(index_of(physical_names, 'relative_humidity'))
      rupture = v(index_of(physical_names, 'meniscus_rupture_distance'))
      if (humidity > 0 .and. rupture > 0) &
         call key_error(p, entry_or_default(g, 'meniscus_rupture_distance', rupture), &
                        'give the rupture gap once: relative_humidity (Kelvin) or meniscus_rupture_distance, '// &
                        'not both', ierr, errmsg)
   end subroutine check_meniscus

   !> A pair of keys that are both > 0 or both 0 (a liquid's two keys): a one-line error on the
   !> key given > 0 without its partner.
   subroutine check_pair(p, g, name1, value1, name2, value2, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_group_t), intent(in) :: g
      character(len=*), intent(in) :: name1
      real(dp), intent(in) :: value1
      character(len=*), intent(in) :: name2
      real(dp), intent(in) :: value2
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(nml_entry_t) :: fixed
      ierr = ok
      errmsg = ''
      if ((value1 > 0) .eqv. (value2 > 0)) return
      if (value1 > 0) then
         fixed = entry_or_default(g, name1, value1)
         call key_error(p, fixed, 'needs '//name2//' > 0 too (a liquid), or 0 (vacuum)', ierr, errmsg)
      else
         fixed = entry_or_default(g, name2, value2)
         call key_error(p, fixed, 'needs '//name1//' > 0 too (a liquid), or 0 (vacuum)', ierr, errmsg)
      end if
   end subroutine check_pair

   subroutine read_physical(p, g, config, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_group_t), intent(in) :: g
      type(config_t), intent(inout) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      real(dp) :: v(size(physical_names)), mismatch
      type(nml_entry_t) :: fixed
      character(len=32) :: culprit
      type(physical_t) :: phys
      ! given(k): physical_names(k) is given (an override's alternative drops the base's keys).
      logical :: given(size(physical_names))
      character(len=*), parameter :: calibration(4) = [character(len=19) :: 'spring_constant', &
         'resonance_frequency', 'quality_factor', 'tip_mass_ratio']
      character(len=*), parameter :: geometry(4) = [character(len=12) :: 'thickness', 'density', &
         'tip_mass', 'beam_damping']
      integer :: i, j
      integer, allocatable :: dropped(:)

      v = physical_values(config%physical)
      call read_real_group(p, g, v, ierr, errmsg)
      if (ierr /= ok) return
      do i = 1, size(physical_names)
         given(i) = entry_at(trim(physical_names(i))) > 0
      end do
      ! The alternatives: each pair is refused in one line naming both keys.
      call exclusive('drive_frequency', 'drive_angular_frequency', '')
      call exclusive('free_amplitude', 'drive_amplitude', '')
      call exclusive('drive_frequency_2', 'drive_angular_frequency_2', '')
      call exclusive('free_amplitude_2', 'drive_amplitude_2', '')
      call exclusive('tip_sample_distance', 'gap', '')
      call exclusive('tip_sample_distance', 'static_offset', '')
      do i = 1, size(calibration)
         do j = 1, size(geometry)
            call exclusive(trim(calibration(i)), trim(geometry(j)), &
                           ' (the cantilever is given by its calibration spring_constant, resonance_frequency, '// &
                           'quality_factor, tip_mass_ratio or by its geometry and mass thickness, density, '// &
                           'tip_mass, beam_damping)')
         end do
      end do
      if (ierr /= ok) return
      if (given(21) .or. given(22) .or. given(23) .or. given(24)) then
         ! k, f0 and Q are what a calibration measures; tip_mass_ratio is 0 (no tip mass)
         ! unless given (issue 27: spring_constant without tip_mass_ratio was refused).
         do i = 1, size(calibration) - 1
            if (given(index_of(physical_names, calibration(i)))) cycle
            do j = 1, size(calibration)
               if (.not. given(index_of(physical_names, calibration(j)))) cycle
               call key_error(p, g%entries(entry_at(trim(calibration(j)))), 'needs '// &
                              trim(calibration(i))//' too: the calibration is spring_constant, '// &
                              'resonance_frequency and quality_factor (and tip_mass_ratio, 0 unless given)', &
                              ierr, errmsg)
               return
            end do
         end do
         if (.not. given(24)) v(24) = 0
      end if
      ! The tip sits at the free end unless tip_position says otherwise: a cantilever given with
      ! its own length and no tip_position was refused (the default x0 = 300e-6 m > L).
      if (.not. given(15)) v(15) = v(1)
      ! The calibration and the free amplitude are exact for the N modes that run.
      if (config%auto_modes) then
         do i = 1, 2
            j = index_of(physical_names, merge('spring_constant', 'free_amplitude ', i == 1))
            if (.not. given(j)) cycle
            call key_error(p, g%entries(entry_at(trim(physical_names(j)))), 'needs a fixed &model n_modes, '// &
                           'not n_modes = 0: it is computed exactly from the N-mode model that runs', ierr, errmsg)
            return
         end do
      end if
      ! tip_position lies on the beam: 0 < x0 <= L.
      if (v(15) > v(1)) then
         fixed = entry_or_default(g, 'tip_position', v(15))
         call key_error(p, fixed, 'must be <= length = '//real_text(v(1)), ierr, errmsg)
         return
      end if
      if (given(27)) then
         ! The gap follows the tip-sample distance Z (docs/model.md section 1).
         v(14) = v(27)
         v(12) = v(13) + v(27)/cos(v(11))
         if (.not. (v(12) > 0 .and. v(12) <= 1)) then
            call key_error(p, g%entries(entry_at('tip_sample_distance')), 'gives gap = tip_length + '// &
                           'tip_sample_distance/cos(tilt) = '//real_text(v(12))//': must be > 0 and <= 1', &
                           ierr, errmsg)
            return
         end if
      else
         ! The paper's geometry: d = g0 + delta/cos(theta).
         mismatch = abs(v(12) - v(13) - v(14)/cos(v(11)))
         if (mismatch > 1.0e-6_dp*v(12)) then
            fixed = entry_or_default(g, 'gap', v(12))
            call key_error(p, fixed, 'must equal tip_length + static_offset/cos(tilt) = '// &
                           real_text(v(13) + v(14)/cos(v(11))), ierr, errmsg)
            return
         end if
      end if
      call check_pair(p, g, 'medium_density', v(28), 'medium_viscosity', v(29), ierr, errmsg)
      if (ierr /= ok) return
      ! A viscoelastic sample relaxes to a modulus no higher than its instantaneous one.
      if (v(33) > v(7)) then
         fixed = entry_or_default(g, 'sample_modulus_relaxed', v(33))
         call key_error(p, fixed, 'must be 0 or <= youngs_modulus_sample = '//real_text(v(7)), ierr, errmsg)
         return
      end if
      ! The double layer (docs/model.md §17): both surface potentials, and one Debye length.
      call check_double_layer(p, g, v, ierr, errmsg)
      if (ierr /= ok) return
      ! The capillary meniscus (docs/model.md §19): one rupture gap.
      call check_meniscus(p, g, v, ierr, errmsg)
      if (ierr /= ok) return
      if (given(25)) v(20) = 2*acos(-1.0_dp)*v(25)
      if (given(38)) v(35) = 2*acos(-1.0_dp)*v(38)
      phys = physical_from_values(v)
      phys%by_calibration = given(21)
      phys%by_drive_frequency = given(25)
      phys%by_free_amplitude = given(26)
      phys%by_drive_frequency_2 = given(38)
      phys%by_free_amplitude_2 = given(39)
      phys%by_distance = given(27)
      if (phys%by_calibration) then
         call calibrate_cantilever(phys, config%n_modes, config_errata(config), ierr, errmsg, culprit)
         if (ierr /= ok) then
            ! (entry_or_default: the key at fault, tip_position say, may be left at its default)
            call key_error(p, entry_or_default(g, trim(culprit), v(index_of(physical_names, culprit))), &
                           trim(errmsg), ierr, errmsg)
            return
         end if
      end if
      if (phys%by_free_amplitude) then
         call drive_for_free_amplitude(phys, config%n_modes, config_errata(config), ierr, errmsg)
         if (ierr /= ok) then
            call key_error(p, g%entries(entry_at('free_amplitude')), trim(errmsg), ierr, errmsg)
            return
         end if
      end if
      if (phys%by_free_amplitude_2) then
         ! The second tone's free amplitude is its own linear response (superposition): it needs
         ! the tone's frequency, whatever the first tone does.
         if (.not. (phys%drive_angular_frequency_2 > 0)) then
            call key_error(p, g%entries(entry_at('free_amplitude_2')), 'needs the second tone''s '// &
                           'frequency: drive_frequency_2 or drive_angular_frequency_2 > 0', ierr, errmsg)
            return
         end if
         call drive_for_free_amplitude(phys, config%n_modes, config_errata(config), ierr, errmsg, tone=2)
         if (ierr /= ok) then
            call key_error(p, g%entries(entry_at('free_amplitude_2')), trim(errmsg), ierr, errmsg)
            return
         end if
      end if
      config%physical = phys
      config%from_physical = .true.
      config%scene = scene_from_physical(config%physical)
   contains
      !> Position in g of the given entry for `key` (0 if absent or dropped).
      integer function entry_at(key)
         character(len=*), intent(in) :: key
         integer :: k
         entry_at = 0
         do k = 1, g%n_entries
            if (g%entries(k)%key == key) entry_at = k
         end do
         if (entry_at > 0) then
            if (allocated(dropped)) then
               if (any(dropped == entry_at)) entry_at = 0
            end if
         end if
      end function entry_at
      !> Keys `a` and `b` exclude each other: both given is refused in one line, unless one is an
      !> override and the other comes from the base input (the base's key is then dropped).
      subroutine exclusive(a, b, why)
         character(len=*), intent(in) :: a, b, why
         integer :: ea, eb
         if (ierr /= ok) return
         ea = entry_at(a)
         eb = entry_at(b)
         if (ea == 0 .or. eb == 0) return
         if (g%entries(ea)%override .and. .not. g%entries(eb)%override) then
            call drop(eb, b)
         else if (g%entries(eb)%override .and. .not. g%entries(ea)%override) then
            call drop(ea, a)
         else
            call key_error(p, g%entries(ea), 'give '//a//' or '//b//', not both ('//b//' = '// &
                           g%entries(eb)%written//', '//trim(line_text(entry_line(g%entries(eb))))//')'//why, &
                           ierr, errmsg)
         end if
      end subroutine exclusive
      !> Forget base entry e (key `key`): an override gave its alternative.
      subroutine drop(e, key)
         integer, intent(in) :: e
         character(len=*), intent(in) :: key
         if (.not. allocated(dropped)) allocate (dropped(0))
         dropped = [dropped, e]
         given(index_of(physical_names, key)) = .false.
         ! The dropped key's value goes back to its default (a derived key is set below).
         v(index_of(physical_names, key)) = physical_values_default(index_of(physical_names, key))
      end subroutine drop
   end subroutine read_physical

   !> The default of &physical value k (index into physical_names).
   pure real(dp) function physical_values_default(k)
      integer, intent(in) :: k
      type(physical_t) :: defaults
      associate (values => physical_values(defaults))
         physical_values_default = values(k)
      end associate
   end function physical_values_default

   subroutine read_initial(p, g, config, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_group_t), intent(in) :: g
      type(config_t), intent(inout) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      integer :: k, row
      integer(i8) :: phase

      ierr = ok
      do k = 1, g%n_entries
         if (ierr /= ok) return
         associate (e => g%entries(k))
            row = key_row(p%group, e%key)
            select case (e%key)
            case ('a0')
               call take_modal_values(p, e, row, config%n_modes, config%a0, config%n_initial, ierr, &
                                      errmsg)
            case ('adot0')
               call take_modal_values(p, e, row, config%n_modes, config%adot0, config%n_initial, ierr, &
                                      errmsg)
            case ('in_contact')
               phase = config%solver%initial_contact
               call take_integer(p, e, row, phase, ierr, errmsg)
               config%solver%initial_contact = int(phase)
            case default
               call unknown_key(p, e, row, ierr, errmsg)
            end select
         end associate
      end do
      if (ierr == ok) call check_repeats(p, g, ierr, errmsg)
   end subroutine read_initial

   !> Exactly n_modes values (or, with n_modes = 0, any number up to max_modes of leading
   !> modes, the rest zero); each in the range of list row `row`.
   subroutine take_modal_values(p, e, row, n_modes, values, n_initial, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_entry_t), intent(in) :: e
      integer, intent(in) :: row
      integer, intent(in) :: n_modes
      real(dp), intent(inout) :: values(:)
      integer, intent(inout) :: n_initial
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      real(dp) :: given(max_modes)
      integer :: n, j

      call get_real_list(p, e, given, n, ierr, errmsg)
      if (ierr /= ok) return
      if (n_modes > 0 .and. n /= n_modes) then
         call key_error(p, e, 'has '//int_text(n)//' values but &model n_modes = '// &
                        int_text(n_modes)//' (give exactly n_modes values, or none for zeros)', &
                        ierr, errmsg)
         return
      end if
      do j = 1, n
         if (.not. key_in_range(row, given(j))) then
            call key_error(p, e, 'value '//int_text(j)//' = '//real_text(given(j))//': must be '// &
                           range_text(keys(row)%lower, keys(row)%upper, keys(row)%lower_closed, &
                                      keys(row)%upper_open), ierr, errmsg)
            return
         end if
      end do
      values = 0
      values(1:n) = given(1:n)
      n_initial = max(n_initial, n)
   end subroutine take_modal_values

   subroutine read_solver(p, g, config, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_group_t), intent(in) :: g
      type(config_t), intent(inout) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(run_settings_t) :: s
      character(len=:), allocatable :: method
      integer(i8) :: refine, noise
      integer :: k, row

      s = config%solver
      refine = s%contact_refine
      noise = s%thermal_noise
      method = trim(s%method)
      ierr = ok
      do k = 1, g%n_entries
         if (ierr /= ok) return
         associate (e => g%entries(k))
            row = key_row(p%group, e%key)
            select case (e%key)
            case ('method')
               call take_word(p, e, row, len(s%method), method, ierr, errmsg)
            case ('dtau')
               call take_real(p, e, row, s%dtau, ierr, errmsg)
            case ('contact_refine')
               call take_integer(p, e, row, refine, ierr, errmsg)
            case ('rtol')
               call take_real(p, e, row, s%rtol, ierr, errmsg)
            case ('atol')
               call take_real(p, e, row, s%atol, ierr, errmsg)
            case ('tau_end')
               call take_real(p, e, row, s%tau_end, ierr, errmsg)
            case ('blowup_limit')
               call take_real(p, e, row, s%blowup_limit, ierr, errmsg)
            case ('max_steps')
               call take_integer(p, e, row, s%max_steps, ierr, errmsg)
            case ('thermal_noise')
               call take_integer(p, e, row, noise, ierr, errmsg)
            case ('noise_seed')
               call take_integer(p, e, row, s%noise_seed, ierr, errmsg)
            case ('noise_step')
               call take_real(p, e, row, s%noise_step, ierr, errmsg)
            case default
               call unknown_key(p, e, row, ierr, errmsg)
            end select
         end associate
      end do
      if (ierr == ok) call check_repeats(p, g, ierr, errmsg)
      if (ierr /= ok) return
      s%method = method
      s%contact_refine = int(refine)
      s%thermal_noise = int(noise)
      config%solver = s
   end subroutine read_solver

   subroutine read_output(p, g, config, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_group_t), intent(in) :: g
      type(config_t), intent(inout) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      character(len=:), allocatable :: file, format
      real(dp) :: sample_dtau, sample_from
      integer(i8) :: last_periods
      type(nml_entry_t) :: other
      integer :: k, row

      file = trim(config%output_file)
      format = trim(config%output_format)
      sample_dtau = config%solver%sample_dtau
      sample_from = config%solver%sample_from
      last_periods = config%solver%last_periods
      ierr = ok
      do k = 1, g%n_entries
         if (ierr /= ok) return
         associate (e => g%entries(k))
            row = key_row(p%group, e%key)
            select case (e%key)
            case ('file')
               call get_string(p, e, len(config%output_file), file, ierr, errmsg)
               if (ierr == ok .and. len_trim(file) == 0) then
                  call key_error(p, e, 'must name a file', ierr, errmsg)
               else if (ierr == ok) then
                  ! A blank around the name would be dropped (Fortran strings): refused, not changed.
                  if (file(1:1) == ' ' .or. file(len(file):) == ' ') &
                     call key_error(p, e, 'begins or ends with a blank, which tmafm would not keep: '// &
                                    'remove it', ierr, errmsg)
                  ! '-' would be standard output to the executable and a file named '-' to
                  ! anything else: standard output is asked for on the command line only.
                  if (ierr == ok .and. file == '-') &
                     call key_error(p, e, "is ambiguous (standard output or a file named '-'): "// &
                                    "name a file; standard output is the executable's -o -", ierr, errmsg)
               end if
            case ('sample_dtau')
               ! Its upper bound is &solver tau_end (keys(row)%upper_key), read before &output.
               call take_real(p, e, row, sample_dtau, ierr, errmsg, upper=config%solver%tau_end)
            case ('format')
               call take_word(p, e, row, len(config%output_format), format, ierr, errmsg)
            case ('sample_from')
               call take_real(p, e, row, sample_from, ierr, errmsg, upper=config%solver%tau_end)
            case ('last_periods')
               call take_integer(p, e, row, last_periods, ierr, errmsg)
            case default
               call unknown_key(p, e, row, ierr, errmsg)
            end select
         end associate
      end do
      if (ierr == ok) call check_repeats(p, g, ierr, errmsg)
      if (ierr /= ok) return
      if (sample_from > 0 .and. last_periods > 0) then
         other = entry_or_default(g, 'sample_from', 0.0_dp)
         call key_error(p, entry_or_default(g, 'last_periods', 0.0_dp), 'cannot be given with sample_from = '// &
                        other%written//' (two output windows): give one', ierr, errmsg)
         return
      end if
      config%output_file = adjustl(file)
      config%output_format = format
      config%solver%sample_dtau = sample_dtau
      config%solver%sample_from = sample_from
      config%solver%last_periods = int(last_periods)
   end subroutine read_output

   !> &scan: the scan line (tmafm_scan_settings); each key's range from its row (the rules
   !> across keys and against the drive period: check_scan_settings, in read_config_document).
   subroutine read_scan(p, g, config, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_group_t), intent(in) :: g
      type(config_t), intent(inout) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(scan_settings_t) :: s
      character(len=:), allocatable :: topography
      integer(i8) :: pixels, retrace
      real(dp) :: values_b(n_material_keys)
      logical :: given_b(n_material_keys)
      integer :: k, row, j

      s = config%scan
      pixels = s%pixels
      retrace = merge(1, 0, s%retrace)
      topography = trim(s%topography)
      values_b = 0
      given_b = .false.
      ierr = ok
      do k = 1, g%n_entries
         if (ierr /= ok) return
         associate (e => g%entries(k))
            row = key_row(p%group, e%key)
            select case (e%key)
            case ('scan_length')
               call take_real(p, e, row, s%scan_length, ierr, errmsg)
            case ('pixels')
               call take_integer(p, e, row, pixels, ierr, errmsg)
            case ('line_rate')
               call take_real(p, e, row, s%line_rate, ierr, errmsg)
            case ('retrace')
               call take_integer(p, e, row, retrace, ierr, errmsg)
            case ('setpoint')
               call take_real(p, e, row, s%setpoint, ierr, errmsg)
            case ('setpoint_ratio')
               call take_real(p, e, row, s%setpoint_ratio, ierr, errmsg)
            case ('lockin_bandwidth')
               call take_real(p, e, row, s%lockin_bandwidth, ierr, errmsg)
            case ('feedback_bandwidth')
               call take_real(p, e, row, s%feedback_bandwidth, ierr, errmsg)
            case ('proportional_gain')
               call take_real(p, e, row, s%proportional_gain, ierr, errmsg)
            case ('integral_gain')
               call take_real(p, e, row, s%integral_gain, ierr, errmsg)
            case ('topography')
               call take_word(p, e, row, len(s%topography), topography, ierr, errmsg)
            case ('step_height')
               call take_real(p, e, row, s%step_height, ierr, errmsg)
            case ('step_position')
               call take_real(p, e, row, s%step_position, ierr, errmsg)
            case ('sphere_radius')
               call take_real(p, e, row, s%sphere_radius, ierr, errmsg)
            case ('sphere_position')
               call take_real(p, e, row, s%sphere_position, ierr, errmsg)
            case ('material_boundary')
               call take_real(p, e, row, s%material_boundary, ierr, errmsg)
            case default
               j = material_key_of(e%key)
               if (j > 0 .and. row > 0) then
                  call take_real(p, e, row, values_b(j), ierr, errmsg)
                  given_b(j) = .true.
               else
                  call unknown_key(p, e, row, ierr, errmsg)
               end if
            end select
         end associate
      end do
      if (ierr == ok) call check_repeats(p, g, ierr, errmsg)
      if (ierr /= ok) return
      s%pixels = int(pixels)
      s%retrace = retrace == 1
      s%topography = topography
      s%two_materials = any(given_b)
      if (s%material_boundary > 0 .and. .not. s%two_materials) then
         call key_error(p, entry_or_default(g, 'material_boundary', 0.0_dp), &
                        'needs the second material: give its b_ keys', ierr, errmsg)
         return
      end if
      config%scan = s
      config%has_scan = .true.
      config%material_b = values_b
      config%material_b_given = given_b
   contains
      !> The position in material_key_index of b_ key `key`, 0 if it is none.
      pure integer function material_key_of(key)
         character(len=*), intent(in) :: key
         do material_key_of = 1, n_material_keys
            if (key == 'b_'//trim(physical_names(material_key_index(material_key_of)))) return
         end do
         material_key_of = 0
      end function material_key_of
   end subroutine read_scan

   !> &fm: the FM loops' settings and the approach's Z points; each key's range from its row
   !> (the bandwidths' bound f0/10 is checked when the loop starts: check_fm_settings).
   subroutine read_fm(p, g, config, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_group_t), intent(in) :: g
      type(config_t), intent(inout) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(fm_settings_t) :: f
      integer(i8) :: settle, average, points
      real(dp) :: z_start, z_end
      logical :: has_start, has_end, has_amplitude
      integer :: k, row

      f = config%fm
      settle = f%settle_periods
      average = f%average_periods
      points = config%fm_z_points
      z_start = 0
      z_end = 0
      has_start = .false.
      has_end = .false.
      has_amplitude = .false.
      ierr = ok
      do k = 1, g%n_entries
         if (ierr /= ok) return
         associate (e => g%entries(k))
            row = key_row(p%group, e%key)
            select case (e%key)
            case ('amplitude')
               call take_real(p, e, row, f%amplitude, ierr, errmsg)
               has_amplitude = .true.
            case ('pll_bandwidth')
               call take_real(p, e, row, f%pll_bandwidth, ierr, errmsg)
            case ('amplitude_bandwidth')
               call take_real(p, e, row, f%amplitude_bandwidth, ierr, errmsg)
            case ('settle_periods')
               call take_integer(p, e, row, settle, ierr, errmsg)
            case ('average_periods')
               call take_integer(p, e, row, average, ierr, errmsg)
            case ('free_distance')
               call take_real(p, e, row, f%free_distance, ierr, errmsg)
            case ('z_start')
               call take_real(p, e, row, z_start, ierr, errmsg)
               has_start = .true.
            case ('z_end')
               call take_real(p, e, row, z_end, ierr, errmsg)
               has_end = .true.
            case ('z_points')
               call take_integer(p, e, row, points, ierr, errmsg)
            case default
               call unknown_key(p, e, row, ierr, errmsg)
            end select
         end associate
      end do
      if (ierr == ok) call check_repeats(p, g, ierr, errmsg)
      if (ierr /= ok) return
      ierr = err_input
      if (.not. has_amplitude) then
         errmsg = p%label//': &fm needs amplitude (m), the amplitude setpoint'
      else if (.not. has_start) then
         errmsg = p%label//': &fm needs z_start (m), the first Z point'
      else if (points > 1 .and. .not. has_end) then
         errmsg = p%label//': &fm z_points = '//int_text(points)//' needs z_end (m), the last Z point'
      else if (points == 1 .and. has_end .and. z_end /= z_start) then
         call key_error(p, entry_or_default(g, 'z_end', z_end), 'differs from z_start with z_points = 1 '// &
                        '(one point: give z_start alone)', ierr, errmsg)
      else if (int(settle + average)*points > 50000000_i8) then
         errmsg = p%label//': &fm (settle_periods + average_periods) z_points = '// &
                  int_text(int(settle + average)*points)//' periods: more than 50000000'
      else
         ierr = ok
      end if
      if (ierr /= ok) return
      if (points == 1) z_end = z_start
      f%settle_periods = int(settle)
      f%average_periods = int(average)
      config%fm = f
      config%fm_z_start = z_start
      config%fm_z_end = z_end
      config%fm_z_points = int(points)
      config%has_fm = .true.
   end subroutine read_fm

   !> The &physical scene of the second material of &scan: the first's with the b_ keys given.
   pure function material_b_physical(config) result(phys)
      type(config_t), intent(in) :: config
      type(physical_t) :: phys
      real(dp) :: v(size(physical_names))
      integer :: k
      phys = config%physical
      v = physical_values(phys)
      do k = 1, n_material_keys
         if (config%material_b_given(k)) v(material_key_index(k)) = config%material_b(k)
      end do
      phys%youngs_modulus_sample = v(7)
      phys%poisson_ratio_sample = v(8)
      phys%adhesion_energy = v(10)
      phys%contact_damping = v(18)
      phys%hamaker = v(30)
      phys%intermolecular_distance = v(31)
      phys%sample_relaxation_time = v(32)
      phys%sample_modulus_relaxed = v(33)
   end function material_b_physical

   !> The Z points of &fm (m): z_points evenly spaced from z_start to z_end, the last z_end.
   pure function fm_z_points(config) result(z)
      type(config_t), intent(in) :: config
      real(dp) :: z(config%fm_z_points)
      real(dp) :: step
      integer :: k
      if (config%fm_z_points == 1) then
         z = config%fm_z_start
         return
      end if
      ! As numpy.linspace: start + k step, the last point exactly z_end.
      step = (config%fm_z_end - config%fm_z_start)/(config%fm_z_points - 1)
      do k = 1, config%fm_z_points
         z(k) = config%fm_z_start + (k - 1)*step
      end do
      z(config%fm_z_points) = config%fm_z_end
   end function fm_z_points

   !> contact_law = 'dmt_vdw' needs an attraction (vdw_adhesion > 0, from &physical hamaker > 0).
   !> Every method integrates its flight (flight_exact by the Lawson form, tmafm_lawson).
   subroutine check_vdw(label, config, ierr, errmsg)
      character(len=*), intent(in) :: label
      type(config_t), intent(in) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      ierr = ok
      errmsg = ''
      if (trim(config%contact_law) /= 'dmt_vdw') return
      if (.not. (config%scene%vdw_adhesion > 0)) then
         ierr = err_input
         if (config%from_physical) then
            errmsg = label//': &physical hamaker = '//real_text(config%physical%hamaker)// &
                     ": must be > 0 with &model contact_law = 'dmt_vdw'"
         else
            errmsg = label//': &scene vdw_adhesion = '//real_text(config%scene%vdw_adhesion)// &
                     ": must be > 0 with &model contact_law = 'dmt_vdw'"
         end if
         return
      end if
   end subroutine check_vdw

   !> contact_law = 'jkr' (docs/model.md §18): its neck breaks above the surface, a switch off
   !> V_T = 0 that the adaptive pairs locate (dop853, dopri5, flight_exact's contacts) and the
   !> fixed-step loops do not; and the JKR law is elastic: a viscoelastic sample under it is not
   !> modelled (refused, not ignored).
   subroutine check_jkr(label, config, ierr, errmsg)
      character(len=*), intent(in) :: label
      type(config_t), intent(in) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      ierr = ok
      errmsg = ''
      if (trim(config%contact_law) /= 'jkr') return
      if (trim(config%solver%method) == 'rk4_paper' .or. trim(config%solver%method) == 'rk4_event') then
         ierr = err_input
         errmsg = label//": &solver method = '"//trim(config%solver%method)//"': does not support &model "// &
                  "contact_law = 'jkr' (its neck breaks above the surface, a switch its loops do not locate; "// &
                  "use dop853, dopri5 or flight_exact)"
      else if (config%scene%sls_relaxation_time > 0) then
         ierr = err_input
         if (config%from_physical) then
            errmsg = label//': &physical sample_relaxation_time = '// &
                     real_text(config%physical%sample_relaxation_time)
         else
            errmsg = label//': &scene sls_relaxation_time = '//real_text(config%scene%sls_relaxation_time)
         end if
         errmsg = trim(errmsg)//": a viscoelastic sample is not modelled under &model contact_law = 'jkr' "// &
                  "(the JKR law is elastic); use 'hertz', 'dmt' or 'dmt_vdw'"
      end if
   end subroutine check_jkr

   !> A capillary meniscus (docs/model.md §19) breaks above the surface, a switch off V_T = 0 that
   !> only the adaptive pairs locate, and is not modelled with a JKR neck.  The message names the
   !> key that turns it on, as the user wrote it.
   subroutine check_capillary(label, config, ierr, errmsg)
      character(len=*), intent(in) :: label
      type(config_t), intent(in) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      character(len=:), allocatable :: given
      ierr = ok
      errmsg = ''
      if (.not. (config%scene%capillary_strength > 0)) return
      if (.not. config%from_physical) then
         given = '&scene capillary_strength = '//real_text(config%scene%capillary_strength)
      else if (config%physical%relative_humidity > 0) then
         given = '&physical relative_humidity = '//real_text(config%physical%relative_humidity)
      else
         given = '&physical meniscus_rupture_distance = '//real_text(config%physical%meniscus_rupture_distance)
      end if
      if (trim(config%solver%method) == 'rk4_paper' .or. trim(config%solver%method) == 'rk4_event') then
         ierr = err_input
         errmsg = label//': '//given//": a capillary meniscus breaks above the surface, a switch &solver "// &
                  "method = '"//trim(config%solver%method)//"' does not locate; use dop853, dopri5 or flight_exact"
      else if (trim(config%contact_law) == 'jkr') then
         ierr = err_input
         errmsg = label//': '//given//": a capillary meniscus is not modelled with &model contact_law = "// &
                  "'jkr' (two necks); use 'hertz', 'dmt' or 'dmt_vdw'"
      else if (config%scene%medium_mass > 0) then
         ierr = err_input
         errmsg = label//': '//given//': a capillary meniscus forms in air, not in a liquid (&scene '// &
                  'medium_mass = '//real_text(config%scene%medium_mass)//')'
      end if
   end subroutine check_capillary

   !> Thermal noise (docs/model.md §21): &solver thermal_noise = 1 needs a thermal energy (from
   !> &physical temperature, or &scene thermal_energy > 0) and a method that integrates its
   !> piecewise-constant force (dopri5, dop853, flight_exact); its keys and a &scene thermal_energy are refused
   !> without it (nothing is silently ignored).
   subroutine check_thermal(label, config, ierr, errmsg)
      character(len=*), intent(in) :: label
      type(config_t), intent(in) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      ierr = ok
      errmsg = ''
      associate (s => config%solver)
         if (s%thermal_noise == 0) then
            if (s%noise_seed /= 0) then
               ierr = err_input
               errmsg = label//': &solver noise_seed = '//int_text(s%noise_seed)// &
                        ': needs &solver thermal_noise = 1 (it seeds the thermal noise)'
            else if (s%noise_step /= 0) then
               ierr = err_input
               errmsg = label//': &solver noise_step = '//real_text(s%noise_step)// &
                        ': needs &solver thermal_noise = 1 (it is the thermal noise grid)'
            else if (.not. config%from_physical .and. config%scene%thermal_energy > 0) then
               ierr = err_input
               errmsg = label//': &scene thermal_energy = '//real_text(config%scene%thermal_energy)// &
                        ': acts only with &solver thermal_noise = 1'
            end if
            return
         end if
         if (trim(s%method) /= 'dopri5' .and. trim(s%method) /= 'dop853' .and. trim(s%method) /= 'flight_exact') then
            ierr = err_input
            errmsg = label//": &solver thermal_noise = 1: needs method 'dop853', 'dopri5' or 'flight_exact' "// &
                     "(method = '"//trim(s%method)//"' does not integrate the noise grid; docs/model.md section 21)"
         else if (.not. (config%scene%thermal_energy > 0)) then
            ierr = err_input
            errmsg = label//': &solver thermal_noise = 1: needs &scene thermal_energy > 0 (the thermal energy '// &
                     'k_B T L^3/(E1 I d^2)), or &physical input with its temperature'
         else if (s%noise_step > 0 .and. s%tau_end/max(s%noise_step, tiny(1.0_dp)) > real(s%max_steps, dp)) then
            ! Each grid interval takes a step at least: a grid finer than the budget never ends.
            ierr = err_input
            errmsg = label//': &solver noise_step = '//real_text(s%noise_step)//': tau_end/noise_step = '// &
                     real_text(s%tau_end/s%noise_step)//' grid intervals, more than &solver max_steps = '// &
                     int_text(s%max_steps)//' steps'
         end if
      end associate
   end subroutine check_thermal

   !> A viscoelastic sample needs a method that carries the dashpot's state (dopri5, dop853,
   !> flight_exact).  With n_modes = 0 the configuration runs the automatic-N search as it is
   !> made (~7 s), and the run it serves would then be refused: refused here, before the search.
   !> With a fixed N nothing runs until the run, whose driver refuses the pair before its first
   !> step (tmafm_driver); such a configuration still gives its model (tmafm.Model, peers).
   subroutine check_sls_method(label, config, ierr, errmsg)
      character(len=*), intent(in) :: label
      type(config_t), intent(in) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      character(len=:), allocatable :: given
      ierr = ok
      errmsg = ''
      if (.not. config%auto_modes) return
      if (.not. (config%scene%sls_relaxation_time > 0 .and. sls_method_refused(config%solver%method))) return
      if (config%from_physical) then
         given = '&physical sample_relaxation_time = '//real_text(config%physical%sample_relaxation_time)
      else
         given = '&scene sls_relaxation_time = '//real_text(config%scene%sls_relaxation_time)
      end if
      ierr = err_input
      errmsg = label//": &solver method = '"//trim(config%solver%method)//"': a viscoelastic sample ("// &
               given//') needs dopri5, dop853 or flight_exact'
   end subroutine check_sls_method

   !> Checks across groups, before any run: sample_dtau within tau_end, the scene derived from
   !> &physical inside the &scene ranges, and the size of the run (and of the automatic-N
   !> comparison runs) inside the limits.
   subroutine check_derived(label, doc, physical_group, config, ierr, errmsg)
      character(len=*), intent(in) :: label
      type(nml_document_t), intent(in) :: doc
      !> The position of &physical in doc (0 if absent).
      integer, intent(in) :: physical_group
      !> Its output window's first sample is set here (check_window).
      type(config_t), intent(inout) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      real(dp) :: derived(size(scene_names)), phys(size(physical_names)), defaults(size(physical_names))
      real(dp) :: distance, best
      ! The &physical inputs (indices into physical_names) a derived group depends on.
      integer, allocatable :: inputs(:)
      integer :: k, j, culprit, row
      type(run_settings_t) :: trial
      type(nml_entry_t) :: e
      type(physical_t) :: default_physical
      type(drive_t) :: drive
      character(len=:), allocatable :: as_written, range, rule
      ! The positions of medium_mass and medium_reynolds in scene_names.
      integer, parameter :: medium(2) = [14, 15]
      ! The drive's keys and values as the input gave them (messages of init_drive).
      character(len=25) :: names(2)
      real(dp) :: shown(2)
      character(len=:), allocatable :: head
      ! beta_1^2 of the clamped-free beam (1.8751040687119611^2).
      real(dp), parameter :: first_root_squared = 3.5160152685001504_dp

      ierr = ok
      errmsg = ''
      if (.not. (config%solver%sample_dtau <= config%solver%tau_end)) then
         ierr = err_input
         errmsg = label//': &output sample_dtau = '//real_text(config%solver%sample_dtau)// &
                  ': must be <= &solver tau_end = '//real_text(config%solver%tau_end)
         return
      end if
      if (config%from_physical) then
         derived = scene_values(config%scene)
         phys = physical_values(config%physical)
         defaults = physical_values(default_physical)
         if (config%physical%by_calibration) then
            ! A calibrated beam's k and f0 are measured against the default beam's (their key
            ! defaults are 0, "not given"): k = 3 E1 I/L^3, f0 = beta_1^2/(2 pi t0).
            defaults(21) = 3*beam_rigidity(default_physical)/default_physical%length**3
            defaults(22) = first_root_squared/(2*acos(-1.0_dp))*sqrt(beam_rigidity(default_physical) &
                           /(beam_mass_per_length(default_physical)*default_physical%length**4))
         end if
         do k = 1, size(scene_names)
            row = key_row('scene', scene_names(k))
            ! The key's range, and the rules read_scene adds for a value written in &scene.
            rule = ''
            if (key_in_range(row, derived(k))) then
               select case (trim(scene_names(k)))
               case ('sls_relaxation_time')
                  if (derived(k) > 0 .and. derived(k) < min_relaxation_time) &
                     rule = '0 (an elastic sample) or >= '//real_text(min_relaxation_time)
               case ('medium_mass', 'medium_reynolds')
                  ! A liquid has both > 0 (check_pair); one may underflow to 0 alone.
                  if (derived(k) == 0 .and. any(derived(medium) > 0)) &
                     rule = '> 0, as the other of medium_mass and medium_reynolds (a liquid)'
               end select
               if (len(rule) == 0) cycle
            end if
            ! Name the input furthest from its default among those the group depends on and
            ! the route in use gives (not thickness or density for a calibrated beam).
            inputs = scene_depends_on(k)
            ! A group of E1 I or m (width, thickness) of a calibrated beam depends on the
            ! calibration: spring_constant, resonance_frequency, tip_position (tip_position =
            ! 1e-20 named length).
            if (config%physical%by_calibration .and. any(inputs == 2 .or. inputs == 3)) &
               inputs = [inputs, pack([21, 22, 15], [all(inputs /= 21), all(inputs /= 22), all(inputs /= 15)])]
            inputs = pack(inputs, [(physical_key_given(config%physical, inputs(j)), j=1, size(inputs))])
            if (size(inputs) == 0) inputs = scene_depends_on(k)
            culprit = inputs(1)
            best = -1
            do j = 1, size(inputs)
               distance = abs(phys(inputs(j)) - defaults(inputs(j)))/max(abs(defaults(inputs(j))), tiny(1.0_dp))
               ! A key whose default 0 means 'off' is equally far whatever its value: the group's
               ! own key, listed first by scene_depends_on, then wins the tie (a relaxed modulus
               ! of 0.4e9 Pa was 'further' than a relaxation time of 1e-20 s).
               if (defaults(inputs(j)) == 0) distance = merge(huge(1.0_dp), 0.0_dp, phys(inputs(j)) /= 0)
               if (phys(inputs(j)) > 0 .and. defaults(inputs(j)) > 0) then
                  distance = abs(log(phys(inputs(j))/defaults(inputs(j))))
               end if
               if (distance > best) then
                  best = distance
                  culprit = inputs(j)
               end if
            end do
            e = entry_or_default(doc%groups(physical_group), trim(physical_names(culprit)), phys(culprit))
            as_written = e%written
            if (len(rule) > 0) then
               range = rule
            else
               call key_range_text(row, range)
            end if
            ierr = err_input
            errmsg = label//': &physical '//trim(physical_names(culprit))//' = '//as_written// &
                     ' gives '//trim(scene_names(k))//' = '//real_text(derived(k))//' by Eq. (12): '// &
                     trim(scene_names(k))//' must be '//range//' (it depends on '// &
                     depends_text(inputs)//')'
            if (e%override) then
               errmsg = trim(errmsg)//' (override)'
            else if (e%line > 0) then
               errmsg = trim(errmsg)//' (line '//int_text(e%line)//')'
            end if
            return
         end do
      end if
      call check_vdw(label, config, ierr, errmsg)
      if (ierr /= ok) return
      call check_jkr(label, config, ierr, errmsg)
      if (ierr /= ok) return
      call check_capillary(label, config, ierr, errmsg)
      if (ierr /= ok) return
      call check_sls_method(label, config, ierr, errmsg)
      if (ierr /= ok) return
      call check_thermal(label, config, ierr, errmsg)
      if (ierr /= ok) return
      ! The drive's tones: a second tone needs a frequency commensurate with the first.
      if (config%from_physical) then
         ! The keys and values as the input gave them: drive_frequency_2 = 1e3 was named
         ! drive_angular_frequency_2 = 6.283185307179586E+003, without its line.
         associate (phys => config%physical)
            names(1) = merge('drive_frequency        ', 'drive_angular_frequency', phys%by_drive_frequency)
            names(2) = merge('drive_frequency_2        ', 'drive_angular_frequency_2', phys%by_drive_frequency_2)
            shown(1) = merge(phys%drive_frequency, phys%drive_angular_frequency, phys%by_drive_frequency)
            shown(2) = merge(phys%drive_frequency_2, phys%drive_angular_frequency_2, phys%by_drive_frequency_2)
         end associate
         call init_drive(config%scene, drive, ierr, errmsg, 'physical', shown, names)
         if (ierr /= ok .and. physical_group > 0) then
            do j = 1, 2
               head = '&physical '//trim(names(j))//' = '//real_text(shown(j))
               if (index(errmsg, head) /= 1) cycle
               e = entry_or_default(doc%groups(physical_group), trim(names(j)), shown(j))
               errmsg = '&physical '//trim(names(j))//' = '//e%written//trim(errmsg(len(head) + 1:))
               if (e%override) then
                  errmsg = trim(errmsg)//' (override)'
               else if (e%line > 0) then
                  errmsg = trim(errmsg)//' (line '//int_text(e%line)//')'
               end if
               exit
            end do
         end if
      else
         call init_drive(config%scene, drive, ierr, errmsg)
      end if
      if (ierr /= ok) then
         errmsg = label//': '//trim(errmsg)
         return
      end if
      call check_window(label, doc, drive, config%solver, ierr, errmsg)
      if (ierr /= ok) return
      call check_run_size(config%solver, max(config%n_modes, 1), ierr, errmsg)
      if (ierr /= ok) then
         errmsg = label//': '//trim(errmsg)
         return
      end if
      if (config%auto_modes) then
         ! The comparison runs of the automatic N, at the most modes the search may reach, on
         ! their finest grid (tmafm_settings comparison_intervals; not the output's samples).
         trial = config%solver
         trial%first_sample = 0
         trial%method = 'dopri5'
         trial%tau_end = config%mode_horizon
         trial%sample_dtau = config%mode_horizon/comparison_intervals(config%mode_horizon, max_modes, &
                                                                      drive%top_frequency)
         call check_run_size(trial, max_modes, ierr, errmsg)
         if (ierr /= ok) then
            errmsg = label//': the automatic-N comparison runs (&model mode_horizon = '// &
                     real_text(config%mode_horizon)//'): '//trim(errmsg)
            return
         end if
      end if
   contains
      pure function depends_text(inputs) result(text)
         integer, intent(in) :: inputs(:)
         character(len=names_length(physical_names(inputs))) :: text
         text = names_text(physical_names(inputs))
      end function depends_text
   end subroutine check_derived

   !> The output window (&output sample_from or last_periods) as the index of its first sample
   !> (settings%first_sample): it must hold a sample, and last_periods needs a drive whose
   !> periods (2 pi/fundamental) fit that many times in tau_end.
   subroutine check_window(label, doc, drive, settings, ierr, errmsg)
      character(len=*), intent(in) :: label
      type(nml_document_t), intent(in) :: doc
      type(drive_t), intent(in) :: drive
      type(run_settings_t), intent(inout) :: settings
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(place_t) :: p
      type(nml_group_t) :: none
      real(dp) :: start, period
      integer :: g, found
      ierr = ok
      errmsg = ''
      settings%first_sample = 0
      if (settings%sample_from <= 0 .and. settings%last_periods <= 0) return
      p%label = label
      p%group = 'output'
      found = 0
      do g = 1, doc%n_groups
         if (doc%groups(g)%name == 'output') found = g
      end do
      if (settings%last_periods > 0) then
         if (.not. (drive%fundamental > 0)) then
            call window_error('last_periods', 'needs a drive period, and &scene omega is 0: '// &
                              'give sample_from')
            return
         end if
         period = 2*acos(-1.0_dp)/drive%fundamental
         start = settings%tau_end - settings%last_periods*period
         if (start < -4*epsilon(1.0_dp)*settings%tau_end) then
            call window_error('last_periods', 'is '//real_text(settings%last_periods*period)// &
                              ' in tau (drive period '//real_text(period)//'), longer than &solver tau_end = '// &
                              real_text(settings%tau_end)//': lower it, or raise tau_end')
            return
         end if
         settings%first_sample = first_sample_at(settings, max(start, 0.0_dp))
      else
         settings%first_sample = first_sample_at(settings, settings%sample_from)
      end if
      if (.not. (sample_count_real(settings) >= 1)) then
         call window_error(merge('last_periods', 'sample_from ', settings%last_periods > 0), &
                           'keeps no sample: the last one is at tau = '// &
                           real_text(real(settings%first_sample - 1, dp)*settings%sample_dtau)// &
                           ' (&output sample_dtau = '//real_text(settings%sample_dtau)//')')
      end if
   contains
      subroutine window_error(key, what)
         character(len=*), intent(in) :: key
         character(len=*), intent(in) :: what
         if (found > 0) then
            call key_error(p, entry_or_default(doc%groups(found), trim(key), 0.0_dp), what, ierr, errmsg)
         else
            call key_error(p, entry_or_default(none, trim(key), 0.0_dp), what, ierr, errmsg)
         end if
      end subroutine window_error
   end subroutine check_window

   ! --- typed access to entries ------------------------------------------------------------

   !> The one value of a scalar key.
   subroutine get_scalar(p, e, value, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_entry_t), intent(in) :: e
      type(nml_value_t), intent(out) :: value
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      integer :: n, k

      ierr = ok
      n = 0
      do k = 1, size(e%values)
         if (e%values(k)%kind == value_other) then
            call key_error(p, e, e%values(k)%problem, ierr, errmsg)
            return
         end if
         n = n + e%values(k)%repeat
      end do
      if (n /= 1) then
         call key_error(p, e, 'takes one value, not '//int_text(n), ierr, errmsg)
         return
      end if
      value = e%values(1)
   end subroutine get_scalar

   subroutine get_real(p, e, x, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_entry_t), intent(in) :: e
      real(dp), intent(inout) :: x
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(nml_value_t) :: value

      call get_scalar(p, e, value, ierr, errmsg)
      if (ierr /= ok) return
      call value_to_real(p, e, value, x, ierr, errmsg)
   end subroutine get_real

   subroutine value_to_real(p, e, value, x, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_entry_t), intent(in) :: e
      type(nml_value_t), intent(in) :: value
      real(dp), intent(inout) :: x
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      character(len=:), allocatable :: low
      integer :: iostat

      ierr = ok
      if (value%kind /= value_integer .and. value%kind /= value_real) then
         call key_error(p, e, 'must be a number, not '//kind_phrase(value), ierr, errmsg)
         return
      end if
      low = lower(value%text)
      if (index(low, 'nan') > 0) then
         x = ieee_value(x, ieee_quiet_nan)
      else if (index(low, 'inf') > 0) then
         if (low(1:1) == '-') then
            x = ieee_value(x, ieee_negative_inf)
         else
            x = ieee_value(x, ieee_positive_inf)
         end if
      else
         read (low, *, iostat=iostat) x
         if (iostat /= 0) then
            call key_error(p, e, 'cannot be read as a real number', ierr, errmsg)
         else if (.not. ieee_is_finite(x)) then
            ! A finite literal beyond the largest double: never read as Infinity.
            call key_error(p, e, trim(value%text)//' overflows a double (largest '// &
                           real_text(huge(1.0_dp))//')', ierr, errmsg)
         else if (x == 0 .and. scan(mantissa(low), '123456789') > 0) then
            call key_error(p, e, trim(value%text)//' underflows to 0 in a double (smallest '// &
                           'normal '//real_text(tiny(1.0_dp))//'): write 0 or a normal number', ierr, errmsg)
         else if (x /= 0 .and. abs(x) < tiny(1.0_dp)) then
            call key_error(p, e, trim(value%text)//' is below the smallest normal double ('// &
                           real_text(tiny(1.0_dp))//'), a subnormal that keeps fewer digits: '// &
                           'write 0 or a normal number', ierr, errmsg)
         end if
      end if
   contains
      !> The digits before the exponent of a real literal (sign and point included).
      pure function mantissa(literal) result(digits)
         character(len=*), intent(in) :: literal
         character(len=merge(len(literal), scan(literal, 'ed') - 1, scan(literal, 'ed') == 0)) :: digits
         digits = literal(1:len(digits))
      end function mantissa
   end subroutine value_to_real

   subroutine get_integer(p, e, i, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_entry_t), intent(in) :: e
      integer(i8), intent(inout) :: i
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(nml_value_t) :: value
      integer :: iostat, n_digits

      call get_scalar(p, e, value, ierr, errmsg)
      if (ierr /= ok) return
      if (value%kind /= value_integer) then
         call key_error(p, e, 'must be an integer, not '//kind_phrase(value), ierr, errmsg)
         return
      end if
      n_digits = len(value%text)
      if (scan(value%text(1:1), '+-') > 0) n_digits = n_digits - 1
      if (n_digits > 18) then
         call key_error(p, e, 'is too large', ierr, errmsg)
         return
      end if
      read (value%text, *, iostat=iostat) i
      if (iostat /= 0) call key_error(p, e, 'cannot be read as an integer', ierr, errmsg)
   end subroutine get_integer

   !> A quoted string of at most max_len characters.
   subroutine get_string(p, e, max_len, text, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_entry_t), intent(in) :: e
      integer, intent(in) :: max_len
      character(len=:), allocatable, intent(inout) :: text
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(nml_value_t) :: value

      call get_scalar(p, e, value, ierr, errmsg)
      if (ierr /= ok) return
      if (value%kind == value_word .or. value%kind == value_logical) then
         call key_error(p, e, 'a string must be quoted: write '//e%key//' = '''//value%text//'''', &
                        ierr, errmsg)
      else if (value%kind /= value_string) then
         call key_error(p, e, 'must be a quoted string, not '//kind_phrase(value), ierr, errmsg)
      else if (len(value%text) > max_len) then
         call key_error(p, e, 'is '//int_text(len(value%text))//' characters long, more than the '// &
                        int_text(max_len)//' allowed', ierr, errmsg)
      else
         text = value%text
      end if
   end subroutine get_string

   !> A quoted name from a fixed set (`choices`, for the message), in lower case: get_string,
   !> and a blank anywhere in it is refused (' paper' is not read as 'paper').
   subroutine get_choice(p, e, max_len, choices, text, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_entry_t), intent(in) :: e
      integer, intent(in) :: max_len
      character(len=*), intent(in) :: choices
      character(len=:), allocatable, intent(inout) :: text
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg

      call get_string(p, e, max_len, text, ierr, errmsg)
      if (ierr /= ok) return
      if (scan(text, ' '//achar(9)) > 0) then
         call key_error(p, e, 'holds a blank: must be '//choices//', without blanks', ierr, errmsg)
         return
      end if
      text = lower(text)
   end subroutine get_choice

   !> A list of numbers (r*value repeats expanded), at most size(values) of them.
   subroutine get_real_list(p, e, values, n, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_entry_t), intent(in) :: e
      real(dp), intent(out) :: values(:)
      integer, intent(out) :: n
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      real(dp) :: x
      integer :: k, total

      ierr = ok
      n = 0
      values = 0
      total = 0
      do k = 1, size(e%values)
         if (e%values(k)%kind == value_other) then
            call key_error(p, e, e%values(k)%problem, ierr, errmsg)
            return
         end if
         total = total + min(e%values(k)%repeat, size(values) + 1)
      end do
      if (total > size(values)) then
         call key_error(p, e, 'takes at most '//int_text(size(values))//' values', ierr, errmsg)
         return
      end if
      do k = 1, size(e%values)
         x = 0
         call value_to_real(p, e, e%values(k), x, ierr, errmsg)
         if (ierr /= ok) return
         values(n + 1:n + e%values(k)%repeat) = x
         n = n + e%values(k)%repeat
      end do
   end subroutine get_real_list

   !> A real key: its one value, in the range of its row (`upper`, where given, is the value of
   !> the key that bounds it: keys(row)%upper_key).
   subroutine take_real(p, e, row, x, ierr, errmsg, upper)
      type(place_t), intent(in) :: p
      type(nml_entry_t), intent(in) :: e
      integer, intent(in) :: row
      real(dp), intent(inout) :: x
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      real(dp), intent(in), optional :: upper
      character(len=:), allocatable :: range

      call get_real(p, e, x, ierr, errmsg)
      if (ierr /= ok) return
      if (key_in_range(row, x, upper)) return
      call key_range_text(row, range, upper)
      call key_error(p, e, 'must be '//range, ierr, errmsg)
   end subroutine take_real

   !> An integer key: its one value, in the range of its row.
   subroutine take_integer(p, e, row, i, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_entry_t), intent(in) :: e
      integer, intent(in) :: row
      integer(i8), intent(inout) :: i
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      character(len=:), allocatable :: range

      call get_integer(p, e, i, ierr, errmsg)
      if (ierr /= ok) return
      if (key_in_range(row, real(i, dp))) return
      call key_range_text(row, range)
      call key_error(p, e, 'must be in '//range, ierr, errmsg)
   end subroutine take_integer

   !> A string key that takes one of its row's words: get_choice, then the word checked.
   subroutine take_word(p, e, row, max_len, text, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_entry_t), intent(in) :: e
      integer, intent(in) :: row
      integer, intent(in) :: max_len
      character(len=:), allocatable, intent(inout) :: text
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      character(len=:), allocatable :: choices

      call key_choices_text(row, choices)
      call get_choice(p, e, max_len, choices, text, ierr, errmsg)
      if (ierr /= ok) return
      if (.not. key_is_word(row, text)) call key_error(p, e, 'must be '//choices, ierr, errmsg)
   end subroutine take_word

   !> Every key appears once in its group.
   subroutine check_repeats(p, g, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_group_t), intent(in) :: g
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      integer :: k, j
      ierr = ok
      errmsg = ''
      do k = 2, g%n_entries
         do j = 1, k - 1
            if (g%entries(j)%key == g%entries(k)%key) then
               ierr = err_input
               errmsg = p%label//': &'//p%group//' '//g%entries(k)%key//' = '//g%entries(k)%written// &
                        ': the key is given twice ('//trim(line_text(entry_line(g%entries(j))))//' and '// &
                        trim(line_text(entry_line(g%entries(k))))//')'
               return
            end if
         end do
      end do
   end subroutine check_repeats

   !> The error for a key the group does not know (row 0), listing the group's keys; or, for a
   !> key of the table that the group's reader does not store (row > 0), a tmafm bug.
   subroutine unknown_key(p, e, row, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_entry_t), intent(in) :: e
      integer, intent(in) :: row
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      character(len=:), allocatable :: known
      if (row /= 0) then
         call key_error(p, e, 'is in the key table but not read (a tmafm bug)', ierr, errmsg)
         return
      end if
      call group_keys_text(p%group, known)
      call key_error(p, e, 'unknown key (&'//p%group//' keys: '//known//')', ierr, errmsg)
   end subroutine unknown_key

   !> ierr = err_input and the one-line message '<source>: &group key = <as written>: <what> (line N)'.
   subroutine key_error(p, e, what, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_entry_t), intent(in) :: e
      character(len=*), intent(in) :: what
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      character(len=:), allocatable :: written
      ierr = err_input
      written = e%written
      if (len(written) > 80) written = written(1:77)//'...'
      errmsg = p%label//': &'//p%group//' '//e%key//' = '//written//': '//what
      if (e%override) then
         errmsg = trim(errmsg)//' (override)'
      else if (e%line > 0) then
         errmsg = trim(errmsg)//' (line '//int_text(e%line)//')'
      end if
   end subroutine key_error

   !> The line of an entry for line_text: 0 for an override.
   pure integer function entry_line(e)
      type(nml_entry_t), intent(in) :: e
      entry_line = merge(0, e%line, e%override)
   end function entry_line

   !> The entry for `key` in group g, or a stand-in holding the default value (line 0).
   function entry_or_default(g, key, value) result(e)
      type(nml_group_t), intent(in) :: g
      character(len=*), intent(in) :: key
      real(dp), intent(in) :: value
      type(nml_entry_t) :: e
      integer :: k
      do k = 1, g%n_entries
         if (g%entries(k)%key == key) then
            e = g%entries(k)
            return
         end if
      end do
      e%key = key
      e%written = trim(real_text_padded(value))//' (default)'
      e%line = 0
   end function entry_or_default

   pure function kind_phrase(value) result(text)
      type(nml_value_t), intent(in) :: value
      character(len=len(value_kind_name(value%kind)) + &
                merge(len(' (strings must be quoted)'), 0, value%kind == value_word)) :: text
      if (value%kind == value_word) then
         text = value_kind_name(value%kind)//' (strings must be quoted)'
      else
         text = value_kind_name(value%kind)
      end if
   end function kind_phrase

   !> Position of `name` in `names` (blank-padded comparison), 0 if absent.
   pure integer function index_of(names, name)
      character(len=*), intent(in) :: names(:)
      character(len=*), intent(in) :: name
      do index_of = 1, size(names)
         if (names(index_of) == name) return
      end do
      index_of = 0
   end function index_of

   pure function names_text(names) result(text)
      character(len=*), intent(in) :: names(:)
      character(len=names_length(names)) :: text
      integer :: k, n
      text = names(1)
      n = len_trim(names(1))
      do k = 2, size(names)
         text(n + 1:) = ', '//names(k)
         n = n + 2 + len_trim(names(k))
      end do
   end function names_text

   !> Length of names_text(names).
   pure integer function names_length(names)
      character(len=*), intent(in) :: names(:)
      names_length = sum(len_trim(names)) + 2*(size(names) - 1)
   end function names_length

   ! --- writing ----------------------------------------------------------------------------

   !> Write the resolved configuration as namelist text, each line starting with `prefix`
   !> (the same text as config_text).
   subroutine write_config(unit, config, prefix)
      integer, intent(in) :: unit
      type(config_t), intent(in) :: config
      character(len=*), intent(in) :: prefix
      character(len=:), allocatable :: text
      integer :: first, eol

      call config_text(config, text)
      first = 1
      do while (first <= len(text))
         eol = index(text(first:), new_line('a'))
         write (unit, '(a)') prefix//text(first:first + eol - 2)
         first = first + eol
      end do
   end subroutine write_config

   !> The resolved input as namelist text (every key, defaults included), one line per key in
   !> the order of the key table, each line ended by new_line('a').  Reading it back gives the
   !> same configuration.  When the scene came from &physical, &physical is written, and then
   !> the scene it gives as comments.
   !> (A subroutine, not a function: gfortran 12 keeps the length of a deferred-length function
   !> result in a static variable of the caller, shared by threads; see tmafm_text.)
   subroutine config_text(config, text)
      type(config_t), intent(in) :: config
      character(len=:), allocatable, intent(out) :: text
      character(len=:), allocatable :: c, value, group, default_value
      character, parameter :: nl = new_line('a')
      type(config_t) :: defaults
      integer :: g, row

      text = ''
      c = ''
      do g = 1, size(key_groups)
         group = trim(key_groups(g))
         if (group == 'physical') cycle
         if (group == 'scan' .and. .not. config%has_scan) cycle
         if (group == 'fm' .and. .not. config%has_fm) cycle
         if (group == 'scene' .and. config%from_physical) then
            ! &physical, then the scene it gives as comments, so the text stays a valid input.
            call put_group('physical')
            c = '! derived by Eq. (12): '
         end if
         call put_group(group)
         c = ''
      end do
   contains
      !> The lines of one group: its keys in the order of the key table (of &physical, those
      !> the scene was given by; the values derived from them follow as comments).
      subroutine put_group(name)
         character(len=*), intent(in) :: name
         call line('&'//name)
         do row = 1, size(keys)
            if (keys(row)%group /= name) cycle
            if (name == 'physical') then
               if (.not. physical_key_given(config%physical, group_index(row))) cycle
            end if
            if (quiet_drive_key(config, row)) cycle
            call key_value_text(config, row, value)
            if (keys(row)%omit_default) then
               ! An optional physics switch that is off (at its default) is left out.
               call key_value_text(defaults, row, default_value)
               if (value == default_value) cycle
            end if
            call line('    '//trim(keys(row)%name)//' = '//value)
            ! Keep the request of an automatic N, and record the choice as a comment.
            if (keys(row)%name == 'n_modes' .and. config%auto_modes) call choice_note()
         end do
         call line('/')
         if (name == 'physical') call derived_lines()
      end subroutine put_group
      !> The derived values of a physical scene as comments (tmafm_calibration physical_derived):
      !> '! derived: name = value unit (meaning)'; the model's own values need N (not yet
      !> chosen when n_modes = 0 has not been resolved).
      subroutine derived_lines()
         real(dp) :: values(n_derived)
         integer :: k, ierr
         character(len=256) :: errmsg
         call physical_derived(config%physical, config%n_modes, config_errata(config), values, ierr, errmsg)
         do k = 1, n_derived
            if (ierr /= ok .and. any(k == [10, 11, 13, 14, 15])) cycle
            ! The second tone's: only when there is one (the one-tone header as before).
            if (k >= 21 .and. all(values(21:22) == 0)) cycle
            call line('! derived: '//trim(derived_names(k))//' = '//trim(shortest_text_padded(values(k)))// &
                      ' '//trim(derived_units(k))//' ('//trim(derived_meanings(k))//')')
         end do
      end subroutine derived_lines
      subroutine line(body)
         character(len=*), intent(in) :: body
         text = text//c//body//nl
      end subroutine line
      !> The comment line that records the chosen N and the search's evidence.
      subroutine choice_note()
         character(len=:), allocatable :: note
         if (config%n_mode_differences == 0) return
         note = '    ! chosen n_modes = '//int_text(config%n_modes)
         call search_note(note)
         ! The comparison made (choose_mode_count): the quantity, each N's value, mode_tol.
         note = note//': max over tau in [0, mode_horizon] of |V_T(N) - V_T(N+1)|/range(V_T(N+1)), '// &
                'located on a grid of >= '//int_text(comparison_points)//' points per period of '// &
                'mode N+1 (dopri5, rtol '//real_text(comparison_rtol)//'): '
         call differences_text(note)
         note = note//' (mode_tol = '//real_text(config%mode_tol)//')'
         call line(note)
      end subroutine choice_note
      !> Append to `note` why the chosen N exceeds the N where the search stopped, if it does.
      subroutine search_note(note)
         character(len=:), allocatable, intent(inout) :: note
         integer :: searched
         searched = config%n_mode_differences
         if (config%mode_differences(searched) > config%mode_tol) searched = searched + 1
         if (config%n_modes > searched) note = note//' (the search stopped at N = '// &
                                               int_text(searched)//'; raised to keep every nonzero '// &
                                               '&initial value)'
      end subroutine search_note
      !> Append to `list` the differences of the search for N.
      subroutine differences_text(list)
         character(len=:), allocatable, intent(inout) :: list
         integer :: j
         do j = 1, config%n_mode_differences
            if (j > 1) list = list//', '
            list = list//'N='//int_text(j)//': '//short_real_text(config%mode_differences(j), mode_digits)
         end do
      end subroutine differences_text
   end subroutine config_text

   !> Whether key `row` is one of the drive's tone keys (the second tone and the phases) while
   !> all of them are 0: the resolved text of a one-tone drive at phase 0 leaves them out, and
   !> is then what it was before the drive had tones (reading it back gives the same defaults).
   pure logical function quiet_drive_key(config, row) result(quiet)
      type(config_t), intent(in) :: config
      integer, intent(in) :: row
      quiet = .false.
      select case (trim(keys(row)%name))
      case ('alpha2_2', 'omega_2', 'drive_phase', 'drive_phase_2', 'drive_amplitude_2', &
            'drive_angular_frequency_2', 'drive_frequency_2', 'free_amplitude_2')
         if (keys(row)%group == 'physical') then
            associate (f => config%physical)
               quiet = all([f%drive_amplitude_2, f%drive_angular_frequency_2, f%drive_phase, &
                            f%drive_phase_2] == 0)
            end associate
         else
            associate (s => config%scene)
               quiet = all([s%alpha2_2, s%omega_2, s%drive_phase, s%drive_phase_2] == 0)
            end associate
         end if
      end select
   end function quiet_drive_key

end module tmafm_namelist

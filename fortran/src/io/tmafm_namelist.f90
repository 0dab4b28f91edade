!> Namelist input: read, type-check and validate the groups &model, &scene, &physical,
!> &initial, &solver and &output; write the resolved input back as namelist text.
!>
!> No Fortran `read(nml=)`: the whole input is read into memory (tmafm_input_file), parsed
!> by tmafm_nml_syntax, and every entry is taken here with its type checked against its key
!> (an integer key takes only an integer, a real key an integer or a real, a string key only a
!> quoted string, a scalar key exactly one value).  Unknown, repeated or unused groups and keys
!> are errors.  Each error is one line:
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
   use tmafm_float_format, only: shortest_text_padded
   use tmafm_modes, only: max_modes
   use tmafm_scene, only: scene_t, physical_t, scene_from_physical, scene_names, scene_values, &
      scene_lower, scene_upper, scene_lower_closed, scene_upper_open, physical_names, &
      physical_values, scene_depends_on
   use tmafm_settings, only: run_settings_t, is_known_method, method_choices, check_run_size, &
      max_max_steps, comparison_intervals, comparison_points, mode_digits, comparison_rtol
   use tmafm_errata, only: errata_t, errata_for_convention, parse_errata, errata_label
   use tmafm_config, only: config_t, output_formats, max_mode_horizon
   use tmafm_nml_syntax, only: nml_document_t, nml_group_t, nml_entry_t, nml_value_t, &
      parse_namelist, value_integer, value_real, value_logical, value_string, value_word, &
      value_kind_name, value_other
   use tmafm_input_file, only: read_text_file
   implicit none
   private

   public :: read_config, read_config_text, write_config, config_text, config_errata, real_text

   !> The namelist groups tmafm knows.
   character(len=*), parameter :: known_groups(6) = &
      [character(len=8) :: 'model', 'scene', 'physical', 'initial', 'solver', 'output']
   character(len=*), parameter :: model_keys = &
      'n_modes, mode_tol, mode_horizon, contact_law, convention, errata'
   character(len=*), parameter :: initial_keys = 'a0, adot0'
   character(len=*), parameter :: solver_keys = &
      'method, dtau, contact_refine, rtol, atol, tau_end, blowup_limit, max_steps'
   character(len=*), parameter :: output_keys = 'file, sample_dtau, format'
   real(dp), parameter :: half_pi = acos(-1.0_dp)/2

   !> What an error message needs to name the place: the source and the group.
   type :: place_t
      character(len=:), allocatable :: label
      character(len=:), allocatable :: group
   end type place_t

contains

   !> Read and validate the namelist file `path` into `config` (the whole file is read first;
   !> pipes work).  A file problem gives err_file, an input problem err_input.
   subroutine read_config(path, config, ierr, errmsg)
      character(len=*), intent(in) :: path
      type(config_t), intent(out) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      character(len=:), allocatable :: text

      call read_text_file(path, text, ierr, errmsg)
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
      integer :: where(size(known_groups)), g, k

      call parse_namelist(text, source_label, doc, ierr, errmsg)
      if (ierr /= ok) return
      ierr = err_input
      where = 0
      do g = 1, doc%n_groups
         k = index_of(known_groups, doc%groups(g)%name)
         if (k == 0) then
            errmsg = source_label//': unknown namelist group &'//doc%groups(g)%name//' at line '// &
                     int_text(doc%groups(g)%line)//' (known: &model, &scene, &physical, '// &
                     '&initial, &solver, &output)'
            return
         end if
         if (where(k) /= 0) then
            errmsg = source_label//': namelist group &'//doc%groups(g)%name//' appears twice '// &
                     '(lines '//int_text(doc%groups(where(k))%line)//' and '// &
                     int_text(doc%groups(g)%line)//')'
            return
         end if
         where(k) = g
      end do
      if (doc%n_groups == 0) then
         errmsg = source_label//': no namelist group found (an empty input is refused; '// &
                  'write &model / to run every default)'
         return
      end if
      if (where(2) /= 0 .and. where(3) /= 0) then
         errmsg = source_label//': give either &scene or &physical, not both'
         return
      end if
      ierr = ok
      errmsg = ''

      if (where(1) /= 0) call read_model(place(1), doc%groups(where(1)), config, ierr, errmsg)
      if (ierr /= ok) return
      if (where(3) /= 0) then
         call read_physical(place(3), doc%groups(where(3)), config, ierr, errmsg)
      else if (where(2) /= 0) then
         call read_scene(place(2), doc%groups(where(2)), config, ierr, errmsg)
      end if
      if (ierr /= ok) return
      if (where(4) /= 0) call read_initial(place(4), doc%groups(where(4)), config, ierr, errmsg)
      if (ierr /= ok) return
      if (where(5) /= 0) call read_solver(place(5), doc%groups(where(5)), config, ierr, errmsg)
      if (ierr /= ok) return
      if (where(6) /= 0) call read_output(place(6), doc%groups(where(6)), config, ierr, errmsg)
      if (ierr /= ok) return
      call check_derived(source_label, doc, where, config, ierr, errmsg)
   contains
      function place(k) result(p)
         integer, intent(in) :: k
         type(place_t) :: p
         p%label = source_label
         p%group = trim(known_groups(k))
      end function place
   end subroutine read_config_text

   !> The corrections a config asks for (its resolved &model errata list).
   pure function config_errata(config) result(errata)
      type(config_t), intent(in) :: config
      type(errata_t) :: errata
      integer :: ierr
      character(len=64) :: bad
      call parse_errata(config%errata, errata, ierr, bad)
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
      character(len=:), allocatable :: contact_law, convention, errata
      type(errata_t) :: parsed
      character(len=64) :: bad
      integer :: k

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
            select case (e%key)
            case ('n_modes')
               call get_integer(p, e, n_modes, ierr, errmsg)
               if (ierr == ok .and. (n_modes < 0 .or. n_modes > max_modes)) then
                  call key_error(p, e, 'must be in 1..'//int_text(max_modes)// &
                                 ' (or 0 to choose N by mode_tol)', ierr, errmsg)
               end if
            case ('mode_tol')
               call get_real(p, e, mode_tol, ierr, errmsg)
               call check_range(p, e, mode_tol, 0.0_dp, 1.0_dp, .false., .false., ierr, errmsg)
            case ('mode_horizon')
               call get_real(p, e, mode_horizon, ierr, errmsg)
               call check_range(p, e, mode_horizon, 0.0_dp, max_mode_horizon, .false., .false., ierr, errmsg)
               ! Why the bound: the search's cost grows with the horizon (docs/reliability.md).
               if (ierr /= ok .and. mode_horizon > max_mode_horizon .and. mode_horizon <= huge(1.0_dp)) then
                  call key_error(p, e, 'must be > 0 and <= '//real_text(max_mode_horizon)// &
                                 ': with n_modes = 0 the search for N may run '//int_text(max_modes)// &
                                 ' comparison runs of this length at rtol 1e-10', ierr, errmsg)
               end if
            case ('contact_law')
               call get_string(p, e, len(config%contact_law), contact_law, ierr, errmsg)
               contact_law = lower(trim(adjustl(contact_law)))
               if (ierr == ok .and. contact_law /= 'hertz' .and. contact_law /= 'dmt') then
                  call key_error(p, e, "must be 'hertz' or 'dmt'", ierr, errmsg)
               end if
            case ('convention')
               call get_string(p, e, len(config%convention), convention, ierr, errmsg)
               convention = lower(trim(adjustl(convention)))
               if (ierr == ok .and. convention /= 'paper' .and. convention /= 'consistent') then
                  call key_error(p, e, "must be 'paper' or 'consistent'", ierr, errmsg)
               end if
            case ('errata')
               call get_string(p, e, len(config%errata), errata, ierr, errmsg)
               if (ierr == ok .and. lower(trim(adjustl(errata))) /= 'convention') then
                  call parse_errata(errata, parsed, ierr, bad)
                  if (ierr /= ok) call key_error(p, e, "'"//trim(bad)//"': must be 'convention', "// &
                                                 "'all', 'none' or a list of distinct E1,E2,E3,E4,E6,E7", &
                                                 ierr, errmsg)
               end if
            case default
               call unknown_key(p, e, model_keys, ierr, errmsg)
            end select
         end associate
      end do
      if (ierr == ok) call check_repeats(p, g, ierr, errmsg)
      if (ierr /= ok) return
      if (lower(trim(adjustl(errata))) == 'convention') then
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

   subroutine read_scene(p, g, config, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_group_t), intent(in) :: g
      type(config_t), intent(inout) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      real(dp) :: values(size(scene_names))
      integer :: k, j

      values = scene_values(config%scene)
      ierr = ok
      do k = 1, g%n_entries
         if (ierr /= ok) return
         associate (e => g%entries(k))
            j = index_of(scene_names, e%key)
            if (j == 0) then
               call unknown_key(p, e, names_text(scene_names), ierr, errmsg)
            else
               call get_real(p, e, values(j), ierr, errmsg)
               call check_range(p, e, values(j), scene_lower(j), scene_upper(j), &
                                scene_lower_closed(j), scene_upper_open(j), ierr, errmsg)
            end if
         end associate
      end do
      if (ierr == ok) call check_repeats(p, g, ierr, errmsg)
      if (ierr /= ok) return
      config%scene = scene_t(values(1), values(2), values(3), values(4), values(5), values(6), &
                             values(7), values(8), values(9), values(10), values(11), values(12), &
                             values(13))
   end subroutine read_scene

   subroutine read_physical(p, g, config, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_group_t), intent(in) :: g
      type(config_t), intent(inout) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      real(dp) :: v(size(physical_names)), mismatch
      ! Ranges of the SI inputs (their derived groups are checked in check_derived).
      real(dp), parameter :: low(20) = [0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, -1.0_dp, 0.0_dp, &
         -1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, -1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, &
         0.0_dp, 0.0_dp]
      real(dp), parameter :: high(20) = [1.0_dp, 1.0_dp, 1.0_dp, 1.0e5_dp, 1.0e13_dp, 0.5_dp, &
         1.0e13_dp, 0.5_dp, 1.0e-2_dp, 1.0e3_dp, half_pi, 1.0_dp, 1.0_dp, 1.0_dp, 1.0_dp, 1.0_dp, &
         1.0e6_dp, 1.0e6_dp, 1.0_dp, 1.0e12_dp]
      logical, parameter :: low_closed(20) = [.false., .false., .false., .false., .false., .false., &
         .false., .false., .false., .false., .true., .false., .true., .true., .false., .true., &
         .true., .true., .true., .true.]
      integer :: k, j
      type(nml_entry_t) :: fixed

      v = physical_values(config%physical)
      ierr = ok
      do k = 1, g%n_entries
         if (ierr /= ok) return
         associate (e => g%entries(k))
            j = index_of(physical_names, e%key)
            if (j == 0) then
               call unknown_key(p, e, names_text(physical_names), ierr, errmsg)
            else
               call get_real(p, e, v(j), ierr, errmsg)
               call check_range(p, e, v(j), low(j), high(j), low_closed(j), j == 11, ierr, errmsg)
            end if
         end associate
      end do
      if (ierr == ok) call check_repeats(p, g, ierr, errmsg)
      if (ierr /= ok) return
      ! tip_position lies on the beam: 0 < x0 <= L.
      if (v(15) > v(1)) then
         fixed = entry_or_default(g, 'tip_position', v(15))
         call key_error(p, fixed, 'must be <= length = '//real_text(v(1)), ierr, errmsg)
         return
      end if
      ! The paper's geometry: d = g0 + delta/cos(theta).
      mismatch = abs(v(12) - v(13) - v(14)/cos(v(11)))
      if (mismatch > 1.0e-6_dp*v(12)) then
         fixed = entry_or_default(g, 'gap', v(12))
         call key_error(p, fixed, 'must equal tip_length + static_offset/cos(tilt) = '// &
                        real_text(v(13) + v(14)/cos(v(11))), ierr, errmsg)
         return
      end if
      config%physical = physical_t(v(1), v(2), v(3), v(4), v(5), v(6), v(7), v(8), v(9), v(10), &
                                   v(11), v(12), v(13), v(14), v(15), v(16), v(17), v(18), v(19), &
                                   v(20))
      config%from_physical = .true.
      config%scene = scene_from_physical(config%physical)
   end subroutine read_physical

   subroutine read_initial(p, g, config, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_group_t), intent(in) :: g
      type(config_t), intent(inout) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      integer :: k

      ierr = ok
      do k = 1, g%n_entries
         if (ierr /= ok) return
         associate (e => g%entries(k))
            select case (e%key)
            case ('a0')
               call take_modal_values(p, e, config%n_modes, config%a0, config%n_initial, ierr, &
                                      errmsg)
            case ('adot0')
               call take_modal_values(p, e, config%n_modes, config%adot0, config%n_initial, ierr, &
                                      errmsg)
            case default
               call unknown_key(p, e, initial_keys, ierr, errmsg)
            end select
         end associate
      end do
      if (ierr == ok) call check_repeats(p, g, ierr, errmsg)
   end subroutine read_initial

   !> Exactly n_modes values (or, with n_modes = 0, any number up to max_modes of leading
   !> modes, the rest zero); each finite with |value| <= 1 (gap units).
   subroutine take_modal_values(p, e, n_modes, values, n_initial, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_entry_t), intent(in) :: e
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
         if (.not. ieee_is_finite(given(j)) .or. abs(given(j)) > 1.0_dp) then
            call key_error(p, e, 'value '//int_text(j)//' = '//real_text(given(j))// &
                           ': must be finite with |value| <= 1 (gap units)', ierr, errmsg)
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
      integer(i8) :: refine
      integer :: k

      s = config%solver
      refine = s%contact_refine
      method = trim(s%method)
      ierr = ok
      do k = 1, g%n_entries
         if (ierr /= ok) return
         associate (e => g%entries(k))
            select case (e%key)
            case ('method')
               call get_string(p, e, len(s%method), method, ierr, errmsg)
               method = lower(trim(adjustl(method)))
               if (ierr == ok .and. .not. is_known_method(method)) then
                  call key_error(p, e, 'must be '//method_choices(), ierr, errmsg)
               end if
            case ('dtau')
               call get_real(p, e, s%dtau, ierr, errmsg)
               call check_range(p, e, s%dtau, 0.0_dp, 10.0_dp, .false., .false., ierr, errmsg)
            case ('contact_refine')
               call get_integer(p, e, refine, ierr, errmsg)
               if (ierr == ok .and. (refine < 1 .or. refine > 100000)) then
                  call key_error(p, e, 'must be in 1..100000', ierr, errmsg)
               end if
            case ('rtol')
               call get_real(p, e, s%rtol, ierr, errmsg)
               call check_range(p, e, s%rtol, 1.0e-15_dp, 1.0e-1_dp, .true., .false., ierr, errmsg)
            case ('atol')
               call get_real(p, e, s%atol, ierr, errmsg)
               call check_range(p, e, s%atol, 0.0_dp, 1.0_dp, .true., .false., ierr, errmsg)
            case ('tau_end')
               call get_real(p, e, s%tau_end, ierr, errmsg)
               call check_range(p, e, s%tau_end, 0.0_dp, 1.0e7_dp, .false., .false., ierr, errmsg)
            case ('blowup_limit')
               call get_real(p, e, s%blowup_limit, ierr, errmsg)
               call check_range(p, e, s%blowup_limit, 0.0_dp, 1.0e10_dp, .false., .false., ierr, &
                                errmsg)
            case ('max_steps')
               call get_integer(p, e, s%max_steps, ierr, errmsg)
               if (ierr == ok .and. (s%max_steps < 1 .or. s%max_steps > max_max_steps)) then
                  call key_error(p, e, 'must be in 1..'//int_text(max_max_steps), ierr, errmsg)
               end if
            case default
               call unknown_key(p, e, solver_keys, ierr, errmsg)
            end select
         end associate
      end do
      if (ierr == ok) call check_repeats(p, g, ierr, errmsg)
      if (ierr /= ok) return
      s%method = method
      s%contact_refine = int(refine)
      config%solver = s
   end subroutine read_solver

   subroutine read_output(p, g, config, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_group_t), intent(in) :: g
      type(config_t), intent(inout) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      character(len=:), allocatable :: file, format
      real(dp) :: sample_dtau
      integer :: k

      file = trim(config%output_file)
      format = trim(config%output_format)
      sample_dtau = config%solver%sample_dtau
      ierr = ok
      do k = 1, g%n_entries
         if (ierr /= ok) return
         associate (e => g%entries(k))
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
               end if
            case ('sample_dtau')
               call get_real(p, e, sample_dtau, ierr, errmsg)
               call check_range(p, e, sample_dtau, 0.0_dp, config%solver%tau_end, .false., .false., &
                                ierr, errmsg)
            case ('format')
               call get_string(p, e, len(config%output_format), format, ierr, errmsg)
               format = lower(trim(adjustl(format)))
               if (ierr == ok .and. .not. any(output_formats == format)) then
                  call key_error(p, e, "must be 'text' or 'npy'", ierr, errmsg)
               end if
            case default
               call unknown_key(p, e, output_keys, ierr, errmsg)
            end select
         end associate
      end do
      if (ierr == ok) call check_repeats(p, g, ierr, errmsg)
      if (ierr /= ok) return
      config%output_file = adjustl(file)
      config%output_format = format
      config%solver%sample_dtau = sample_dtau
   end subroutine read_output

   !> Checks across groups, before any run: sample_dtau within tau_end, the scene derived from
   !> &physical inside the &scene ranges, and the size of the run (and of the automatic-N
   !> comparison runs) inside the limits.
   subroutine check_derived(label, doc, where, config, ierr, errmsg)
      character(len=*), intent(in) :: label
      type(nml_document_t), intent(in) :: doc
      integer, intent(in) :: where(:)
      type(config_t), intent(in) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      real(dp) :: derived(size(scene_names)), phys(size(physical_names)), defaults(size(physical_names))
      real(dp) :: distance, best
      integer, allocatable :: keys(:)
      integer :: k, j, culprit
      type(run_settings_t) :: trial
      type(nml_entry_t) :: e
      type(physical_t) :: default_physical
      character(len=:), allocatable :: as_written

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
         do k = 1, size(scene_names)
            if (in_range(derived(k), scene_lower(k), scene_upper(k), scene_lower_closed(k), &
                         scene_upper_open(k))) cycle
            ! Name the input furthest from its default among those the group depends on.
            keys = scene_depends_on(k)
            culprit = keys(1)
            best = -1
            do j = 1, size(keys)
               distance = abs(phys(keys(j)) - defaults(keys(j)))/max(abs(defaults(keys(j))), tiny(1.0_dp))
               if (phys(keys(j)) > 0 .and. defaults(keys(j)) > 0) then
                  distance = abs(log(phys(keys(j))/defaults(keys(j))))
               end if
               if (distance > best) then
                  best = distance
                  culprit = keys(j)
               end if
            end do
            e = entry_or_default(doc%groups(where(3)), trim(physical_names(culprit)), phys(culprit))
            as_written = e%written
            ierr = err_input
            errmsg = label//': &physical '//trim(physical_names(culprit))//' = '//as_written// &
                     ' gives '//trim(scene_names(k))//' = '//real_text(derived(k))//' by Eq. (12): '// &
                     trim(scene_names(k))//' must be '//range_text(scene_lower(k), scene_upper(k), &
                     scene_lower_closed(k), scene_upper_open(k))//' (it depends on '// &
                     depends_text(keys)//')'
            return
         end do
      end if
      call check_run_size(config%solver, max(config%n_modes, 1), ierr, errmsg)
      if (ierr /= ok) then
         errmsg = label//': '//trim(errmsg)
         return
      end if
      if (config%auto_modes) then
         ! The comparison runs of the automatic N, at the most modes the search may reach, on
         ! their finest grid (tmafm_settings comparison_intervals; not the output's samples).
         trial = config%solver
         trial%method = 'dopri5'
         trial%tau_end = config%mode_horizon
         trial%sample_dtau = config%mode_horizon/comparison_intervals(config%mode_horizon, max_modes, &
                                                                      config%scene%omega)
         call check_run_size(trial, max_modes, ierr, errmsg)
         if (ierr /= ok) then
            errmsg = label//': the automatic-N comparison runs (&model mode_horizon = '// &
                     real_text(config%mode_horizon)//'): '//trim(errmsg)
            return
         end if
      end if
   contains
      pure function depends_text(keys) result(text)
         integer, intent(in) :: keys(:)
         character(len=names_length(physical_names(keys))) :: text
         text = names_text(physical_names(keys))
      end function depends_text
   end subroutine check_derived

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
         if (iostat /= 0) call key_error(p, e, 'cannot be read as a real number', ierr, errmsg)
      end if
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

   !> Error unless value lies in the range (lower_closed: >= lower, else >; upper_open: <
   !> upper, else <=).  Does nothing when ierr is already set.
   subroutine check_range(p, e, value, lower_bound, upper_bound, lower_closed, upper_open, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_entry_t), intent(in) :: e
      real(dp), intent(in) :: value
      real(dp), intent(in) :: lower_bound
      real(dp), intent(in) :: upper_bound
      logical, intent(in) :: lower_closed
      logical, intent(in) :: upper_open
      integer, intent(inout) :: ierr
      character(len=*), intent(inout) :: errmsg
      if (ierr /= ok) return
      if (in_range(value, lower_bound, upper_bound, lower_closed, upper_open)) return
      call key_error(p, e, 'must be '//range_text(lower_bound, upper_bound, lower_closed, upper_open), &
                     ierr, errmsg)
   end subroutine check_range

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

   pure function range_text(lower_bound, upper_bound, lower_closed, upper_open) result(text)
      real(dp), intent(in) :: lower_bound, upper_bound
      logical, intent(in) :: lower_closed, upper_open
      character(len=len('finite, ') + merge(2, 1, lower_closed) + 1 + len(real_text(lower_bound)) + &
                len(' and ') + merge(1, 2, upper_open) + 1 + len(real_text(upper_bound))) :: text
      text = 'finite, '//trim(merge('>=', '> ', lower_closed))//' '//real_text(lower_bound)// &
             ' and '//trim(merge('< ', '<=', upper_open))//' '//real_text(upper_bound)
   end function range_text

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
                        ': the key is given twice (lines '//int_text(g%entries(j)%line)//' and '// &
                        int_text(g%entries(k)%line)//')'
               return
            end if
         end do
      end do
   end subroutine check_repeats

   subroutine unknown_key(p, e, known, ierr, errmsg)
      type(place_t), intent(in) :: p
      type(nml_entry_t), intent(in) :: e
      character(len=*), intent(in) :: known
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
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
      if (e%line > 0) errmsg = trim(errmsg)//' (line '//int_text(e%line)//')'
   end subroutine key_error

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

   !> The resolved input as namelist text (every key, defaults included), one line per key,
   !> each line ended by new_line('a').  Reading it back gives the same configuration.
   !> (A subroutine, not a function: gfortran 12 keeps the length of a deferred-length function
   !> result in a static variable of the caller, shared by threads; see tmafm_text.)
   subroutine config_text(config, text)
      type(config_t), intent(in) :: config
      character(len=:), allocatable, intent(out) :: text
      character(len=:), allocatable :: c
      character, parameter :: nl = new_line('a')
      integer :: n, k

      text = ''
      c = ''
      n = config%n_modes
      call line('&model')
      if (config%auto_modes) then
         ! Keep the request, so the file reruns the choice; record the choice as a comment.
         call line('    n_modes = 0')
         if (config%n_mode_differences > 0) then
            c = '    ! chosen n_modes = '//int_text(n)
            call search_note(c)
            ! The comparison made (choose_mode_count): the quantity, each N's value, mode_tol.
            c = c//': max over tau in [0, mode_horizon] of |V_T(N) - V_T(N+1)|/range(V_T(N+1)), '// &
                'located on a grid of >= '//int_text(comparison_points)//' points per period of '// &
                'mode N+1 (dopri5, rtol '//real_text(comparison_rtol)//'): '
            call differences_text(c)
            c = c//' (mode_tol = '//real_text(config%mode_tol)//')'
            call line('')
            c = ''
         end if
      else
         call line('    n_modes = '//int_text(n))
      end if
      call put('mode_tol', config%mode_tol)
      call put('mode_horizon', config%mode_horizon)
      call line('    contact_law = '//quoted(config%contact_law))
      call line('    convention = '//quoted(config%convention))
      call line('    errata = '//quoted(config%errata))
      call line('/')
      if (config%from_physical) then
         call line('&physical')
         associate (v => physical_values(config%physical))
            do k = 1, size(physical_names)
               call put(trim(physical_names(k)), v(k))
            end do
         end associate
         call line('/')
         ! The derived groups, as comments, so the text stays a valid input.
         c = '! derived by Eq. (12): '
      end if
      call line('&scene')
      associate (v => scene_values(config%scene))
         do k = 1, size(scene_names)
            call put(trim(scene_names(k)), v(k))
         end do
      end associate
      call line('/')
      c = ''
      call line('&initial')
      if (config%auto_modes) n = max(1, config%n_initial)
      call line('    a0 = '//list_text(config%a0(1:n)))
      call line('    adot0 = '//list_text(config%adot0(1:n)))
      call line('/')
      call line('&solver')
      call line('    method = '//quoted(config%solver%method))
      call put('dtau', config%solver%dtau)
      call line('    contact_refine = '//int_text(config%solver%contact_refine))
      call put('rtol', config%solver%rtol)
      call put('atol', config%solver%atol)
      call put('tau_end', config%solver%tau_end)
      call put('blowup_limit', config%solver%blowup_limit)
      call line('    max_steps = '//int_text(config%solver%max_steps))
      call line('/')
      call line('&output')
      call line('    file = '//quoted(config%output_file))
      call put('sample_dtau', config%solver%sample_dtau)
      call line('    format = '//quoted(config%output_format))
      call line('/')
   contains
      subroutine line(body)
         character(len=*), intent(in) :: body
         text = text//c//body//nl
      end subroutine line
      subroutine put(key, value)
         character(len=*), intent(in) :: key
         real(dp), intent(in) :: value
         call line('    '//key//' = '//trim(shortest_text_padded(value)))
      end subroutine put
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

end module tmafm_namelist

!> Entry points of the Python package's object layer (f90wrap wraps this module together with
!> the core's public types config_t, model_t, scene_t and trajectory_t).
!>
!> Everything works in memory: a configuration comes from namelist text, its resolved input
!> goes back as text, and a run fills a trajectory_t that Python reads in place.  No physics
!> here; every routine calls the library, returns ierr (tmafm_errors codes) and a one-line
!> errmsg, and keeps no state between calls, so two threads may run two configurations at once.
!>
!> The routines Python calls without the GIL (config_from_text(s), run_config) poll for Ctrl-C
!> (tmafm_api_poll) when Python says so (on its main thread only), and fill a config_t or run_t
!> that Python made before the call: when a run is interrupted, the f2py wrapper raises instead
!> of returning, and a handle allocated inside the call would be lost with everything it holds.
module tmafm_api
   use tmafm, only: dp, i8, ok, err_input, errmsg_len, sample_count, n_powers, build_model, &
      simulate, choose_mode_count, read_config_text, config_text, &
      entry_text, read_config_document, patch_document, n_keys, describe_key, max_modes, max_samples, &
      max_trajectory_bytes, max_max_steps, max_mode_horizon, max_harmonics, max_p_max, max_observed_periods, &
      nml_document_t, parse_namelist, int_text, observe_options_t, observe_batch, observe_states, config_scales, &
      steady_harmonics, steady_evidence, steady_window, &
      observer_t, n_observables, observable_factors, obs_amplitude, obs_phase, &
      scales_t, steady_test, repeat_steps, steady_harmonic, observable_rows, n_observable_rows, &
      observable_group_name, observable_si_factor, observable_kind_names, observable_scale_names, &
      physical_derived, derived_names, derived_units, derived_meanings, n_derived, config_errata, &
      physical_series, n_series, series_names, series_units, &
      stroboscopic_map, n_orbit_stats, map_state_size, model_jacobian, map_to_model_state, obs_tone_amplitude, &
      obs_tone_phase
   ! The types Python sees are named from the modules that define them, not the facade: f90wrap
   ! reads only the wrapped modules' sources and resolves a type through its defining module.
   use tmafm_config, only: config_t
   use tmafm_contact, only: contact_brackets_t
   use tmafm_model, only: model_t
   use tmafm_trajectory, only: trajectory_t
   use tmafm_api_poll, only: python_interrupted
   use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan, ieee_is_nan
   implicit none
   private

   public :: api_errmsg_len, run_t, config_from_text, config_from_texts, config_sample_count, config_text_length, &
      config_text_codes, model_of_config, run_config, run_sizes, run_samples, run_switches, &
      run_counters, trajectory_energy_flow, key_count, key_entry, limit_count, limit_entry, &
      batch_t, batch_add, batch_size, batch_run, observe_states_of, steady_test_of, &
      steady_harmonic_of, namelist_syntax, observable_count, observable_entry, observable_table_factors, &
      derived_count, derived_entry, config_derived, series_count, series_entry, run_physical_series, &
      orbit_stat_count, orbit_state_size, orbit_period, periodic_map_of, jacobian_of

   !> Length of the error messages returned to Python.
   integer, parameter :: api_errmsg_len = errmsg_len

   !> The core's limits that Python checks against before calling it (limit_entry).
   character(len=*), parameter :: limit_names(*) = [character(len=24) :: 'max_modes', 'max_samples', &
      'max_trajectory_bytes', 'max_max_steps', 'max_mode_horizon', 'max_harmonics', 'max_p_max', &
      'max_observed_periods']
   real(dp), parameter :: limit_values(*) = [real(max_modes, dp), real(max_samples, dp), max_trajectory_bytes, &
      real(max_max_steps, dp), max_mode_horizon, real(max_harmonics, dp), real(max_p_max, dp), &
      real(max_observed_periods, dp)]

   !> The trajectory of one run, held for Python to copy out (run_sizes, run_samples, ...).
   type :: run_t
      private
      type(trajectory_t) :: traj
   end type run_t

   !> Configurations queued for one observed batch (batch_add copies them in; no text), held
   !> for Python: batch_run runs them all and copies the results out.
   type :: batch_t
      private
      integer :: n = 0
      type(config_t), allocatable :: configs(:)
   end type batch_t

contains

   !> Read and validate namelist text into the caller's `config`, and choose N when &model
   !> n_modes = 0 (with `poll`, the comparison runs poll for Ctrl-C).
   subroutine config_from_text(text, source_label, config, poll, ierr, errmsg)
      character(len=*), intent(in) :: text
      character(len=*), intent(in) :: source_label
      type(config_t), intent(inout) :: config
      !> Poll for Ctrl-C (tmafm_api_poll): only on Python's main thread, the only one it helps.
      logical, intent(in) :: poll
      integer, intent(out) :: ierr
      character(len=api_errmsg_len), intent(out) :: errmsg
      call read_config_text(text, source_label, config, ierr, errmsg)
      if (ierr == ok) call choose_modes(config, poll, ierr, errmsg)
   end subroutine config_from_text

   ! choose_mode_count, given python_interrupted as its poll only when `poll`.
   subroutine choose_modes(config, poll, ierr, errmsg)
      type(config_t), intent(inout) :: config
      logical, intent(in) :: poll
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      if (poll) then
         call choose_mode_count(config, ierr, errmsg, poll=python_interrupted)
      else
         call choose_mode_count(config, ierr, errmsg)
      end if
   end subroutine choose_modes

   !> A configuration from a base text patched key by key by an override text: both are parsed
   !> for syntax (messages name base_label or '<overrides>'), entries of the base that an override
   !> sets are dropped, and the patched document is read as one input named `source_label` into
   !> the caller's `config` (N chosen as config_from_text does).  A message names an entry of the
   !> base by its line in the base text, and an override as '(override)'.  An empty base (no
   !> group) is refused as it is without overrides.
   subroutine config_from_texts(base_text, base_label, override_text, source_label, config, poll, &
                                ierr, errmsg)
      character(len=*), intent(in) :: base_text
      character(len=*), intent(in) :: base_label
      character(len=*), intent(in) :: override_text
      character(len=*), intent(in) :: source_label
      type(config_t), intent(inout) :: config
      !> Poll for Ctrl-C, as config_from_text's `poll`.
      logical, intent(in) :: poll
      integer, intent(out) :: ierr
      character(len=api_errmsg_len), intent(out) :: errmsg
      type(nml_document_t) :: base, over, merged
      integer :: g, k

      call parse_namelist(base_text, base_label, base, ierr, errmsg)
      if (ierr /= ok) return
      if (base%n_groups == 0) then
         ! The overrides alone would run every other default from an empty file.
         ierr = err_input
         errmsg = base_label//': no namelist group found (an empty input is refused, also with '// &
                  'overrides; write &model / to run every default)'
         return
      end if
      call parse_namelist(override_text, '<overrides>', over, ierr, errmsg)
      if (ierr /= ok) return
      ! A resolved input (a Config, an output file) pins &model errata to the list its
      ! convention gave; overriding only the convention would keep that list and silently run
      ! the old physics, so the combination is refused with a message saying what to add.
      block
         logical :: sets_convention, sets_errata
         sets_convention = .false.
         sets_errata = .false.
         do g = 1, over%n_groups
            if (over%groups(g)%name /= 'model') cycle
            do k = 1, over%groups(g)%n_entries
               if (over%groups(g)%entries(k)%key == 'convention') sets_convention = .true.
               if (over%groups(g)%entries(k)%key == 'errata') sets_errata = .true.
            end do
         end do
         if (sets_convention .and. .not. sets_errata) then
            do g = 1, base%n_groups
               if (base%groups(g)%name /= 'model') cycle
               do k = 1, base%groups(g)%n_entries
                  if (base%groups(g)%entries(k)%key /= 'errata') cycle
                  ierr = err_input
                  errmsg = source_label//': &model convention is overridden but the base input sets '// &
                           entry_text(base%groups(g)%entries(k))//': override &model errata too '// &
                           '(''convention'' follows the new convention)'
                  return
               end do
            end do
         end if
      end block
      call patch_document(base, over, merged)
      call read_config_document(merged, source_label, config, ierr, errmsg)
      if (ierr == ok) call choose_modes(config, poll, ierr, errmsg)
   end subroutine config_from_texts

   !> Number of output samples of a configuration's run.
   function config_sample_count(config) result(n)
      type(config_t), intent(in) :: config
      integer :: n
      n = sample_count(config%solver)
   end function config_sample_count

   !> Number of characters of the resolved input text.
   function config_text_length(config) result(n)
      type(config_t), intent(in) :: config
      integer :: n
      character(len=:), allocatable :: text
      call config_text(config, text)
      n = len(text)
   end function config_text_length

   !> The resolved input text as character codes, into `codes` (sized by config_text_length).
   subroutine config_text_codes(config, codes)
      type(config_t), intent(in) :: config
      integer, intent(inout) :: codes(:)
      character(len=:), allocatable :: text
      integer :: k
      call config_text(config, text)
      codes = 0
      do k = 1, min(len(text), size(codes))
         codes(k) = iachar(text(k:k))
      end do
   end subroutine config_text_codes

   !> The model of a configuration (its N already chosen).
   subroutine model_of_config(config, model, ierr, errmsg)
      type(config_t), intent(in) :: config
      type(model_t), intent(out) :: model
      integer, intent(out) :: ierr
      character(len=api_errmsg_len), intent(out) :: errmsg
      call build_model(config, model, ierr, errmsg)
   end subroutine model_of_config

   !> Run a configuration into the caller's `run`, polling for Ctrl-C when `poll`.  Python
   !> calls this without holding the GIL.  After a failure `run` holds no samples (a traceback
   !> may keep the Python handle alive for long).
   subroutine run_config(config, run, poll, ierr, errmsg)
      type(config_t), intent(in) :: config
      type(run_t), intent(inout) :: run
      !> Poll for Ctrl-C (tmafm_api_poll): only on Python's main thread, the only one it helps.
      logical, intent(in) :: poll
      integer, intent(out) :: ierr
      character(len=api_errmsg_len), intent(out) :: errmsg
      if (poll) then
         call simulate(config, run%traj, ierr, errmsg, poll=python_interrupted)
      else
         call simulate(config, run%traj, ierr, errmsg)
      end if
      if (ierr /= ok) run%traj = trajectory_t()
   end subroutine run_config

   !> Sizes of a run's arrays: samples, modes and phase switches.
   subroutine run_sizes(run, n_samples, n_modes, n_switches)
      type(run_t), intent(in) :: run
      integer, intent(out) :: n_samples
      integer, intent(out) :: n_modes
      integer, intent(out) :: n_switches
      n_samples = 0
      n_modes = 0
      n_switches = run%traj%n_switches
      if (allocated(run%traj%a)) then
         n_samples = size(run%traj%a, 1)
         n_modes = size(run%traj%a, 2)
      end if
   end subroutine run_sizes

   !> Copy the samples into arrays sized by run_sizes (a and adot: samples x N).
   subroutine run_samples(run, tau, vt, vtdot, contact, a, adot)
      type(run_t), intent(in) :: run
      real(dp), intent(inout) :: tau(:)
      real(dp), intent(inout) :: vt(:)
      real(dp), intent(inout) :: vtdot(:)
      integer, intent(inout) :: contact(:)
      real(dp), intent(inout) :: a(:, :)
      real(dp), intent(inout) :: adot(:, :)
      if (.not. allocated(run%traj%a)) return
      if (size(tau) /= size(run%traj%tau) .or. any(shape(a) /= shape(run%traj%a))) return
      tau = run%traj%tau
      vt = run%traj%vt
      vtdot = run%traj%vtdot
      contact = run%traj%contact
      a = run%traj%a
      adot = run%traj%adot
   end subroutine run_samples

   !> Copy the times of the phase changes into an array sized by run_sizes.
   subroutine run_switches(run, switch_tau)
      type(run_t), intent(in) :: run
      real(dp), intent(inout) :: switch_tau(:)
      integer :: n
      n = min(size(switch_tau), run%traj%n_switches)
      switch_tau(1:n) = run%traj%switch_tau(1:n)
   end subroutine run_switches

   !> The work counters: steps, contact_steps, rejected_steps, rhs_evaluations, phase_switches.
   subroutine run_counters(run, counters)
      type(run_t), intent(in) :: run
      integer(i8), intent(inout) :: counters(:)
      counters = 0
      counters(1:min(5, size(counters))) = [run%traj%steps, run%traj%contact_steps, &
         run%traj%rejected_steps, run%traj%rhs_evaluations, int(run%traj%n_switches, i8)]
   end subroutine run_counters

   !> Along sampled states: the powers of model_t%energy_flow, the modal energy, and the contact
   !> state [theta1, A, f_c, h, P1, P2] where contact(k) = 1 (zeros elsewhere).
   subroutine trajectory_energy_flow(model, tau, a, adot, contact, power, energy, state)
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: tau(:)
      real(dp), intent(in) :: a(:, :)
      real(dp), intent(in) :: adot(:, :)
      integer, intent(in) :: contact(:)
      real(dp), intent(inout) :: power(:, :)
      real(dp), intent(inout) :: energy(:)
      real(dp), intent(inout) :: state(:, :)
      type(contact_brackets_t) :: s
      integer :: k

      power = 0
      energy = 0
      state = 0
      do k = 1, size(tau)
         call model%energy_flow(tau(k), a(k, :), adot(k, :), contact(k) == 1, power(k, 1:n_powers), &
                                energy(k))
         if (contact(k) == 1 .or. model%long_range) then
            s = model%forces_in_phase(tau(k), a(k, :), contact(k) == 1)
            state(k, :) = [s%theta1, s%radius, s%normal, s%friction, s%transverse, s%axial]
         end if
      end do
   end subroutine trajectory_energy_flow

   !> Number of namelist keys (the core's key table, tmafm_keys).
   function key_count() result(n)
      integer :: n
      n = n_keys
   end function key_count

   !> Key k (1 to key_count()) of the key table: its group, name, value type ('integer', 'real',
   !> 'string' or 'list of reals'), range, default (as the resolved text writes it), unit and
   !> meaning, blank-padded (Python checks that none fills its field); all blank for another k.
   subroutine key_entry(k, group, name, kind, range, default, unit, meaning)
      integer, intent(in) :: k
      character(len=16), intent(out) :: group
      character(len=32), intent(out) :: name
      character(len=16), intent(out) :: kind
      character(len=256), intent(out) :: range
      character(len=256), intent(out) :: default
      character(len=16), intent(out) :: unit
      character(len=256), intent(out) :: meaning
      character(len=:), allocatable :: g, n, t, r, d, u, m
      group = ''
      name = ''
      kind = ''
      range = ''
      default = ''
      unit = ''
      meaning = ''
      if (k < 1 .or. k > n_keys) return
      call describe_key(k, g, n, t, r, d, u, m)
      group = g
      name = n
      kind = t
      range = r
      default = d
      unit = u
      meaning = m
   end subroutine key_entry

   !> Number of the derived values of a physical scene (derived_entry, config_derived).
   function derived_count() result(n)
      integer :: n
      n = n_derived
   end function derived_count

   !> Derived value k (1 to derived_count()): its name, unit and meaning, blank-padded; all
   !> blank for another k.
   subroutine derived_entry(k, name, unit, meaning)
      integer, intent(in) :: k
      character(len=32), intent(out) :: name
      character(len=16), intent(out) :: unit
      character(len=128), intent(out) :: meaning
      name = ''
      unit = ''
      meaning = ''
      if (k < 1 .or. k > n_derived) return
      name = derived_names(k)
      unit = derived_units(k)
      meaning = derived_meanings(k)
   end subroutine derived_entry

   !> The derived values of a configuration given in &physical (tmafm_calibration
   !> physical_derived, as the output header prints them) into `values` (derived_count() of
   !> them); has_values = 0 for a dimensionless configuration (values all 0).
   subroutine config_derived(config, values, has_values, ierr, errmsg)
      type(config_t), intent(in) :: config
      real(dp), intent(inout) :: values(:)
      integer, intent(out) :: has_values
      integer, intent(out) :: ierr
      character(len=api_errmsg_len), intent(out) :: errmsg
      values = 0
      has_values = 0
      ierr = ok
      errmsg = ''
      call check_shape('values', shape(values), [n_derived], ierr, errmsg)
      if (ierr /= ok .or. .not. config%from_physical) return
      call physical_derived(config%physical, config%n_modes, config_errata(config), values, ierr, errmsg)
      has_values = 1
   end subroutine config_derived

   !> Number of the SI series of a run of a physical scene (series_entry, run_physical_series).
   function series_count() result(n)
      integer :: n
      n = n_series
   end function series_count

   !> SI series k (1 to series_count()): its name and unit, blank-padded; blank for another k.
   subroutine series_entry(k, name, unit)
      integer, intent(in) :: k
      character(len=32), intent(out) :: name
      character(len=8), intent(out) :: unit
      name = ''
      unit = ''
      if (k < 1 .or. k > n_series) return
      name = series_names(k)
      unit = series_units(k)
   end subroutine series_entry

   !> The SI series of a run of physical configuration `config` (tmafm_physical_series, as the
   !> executable writes them) into `series` (run_sizes' samples x series_count()).
   subroutine run_physical_series(config, run, series, ierr, errmsg)
      type(config_t), intent(in) :: config
      type(run_t), intent(in) :: run
      real(dp), intent(inout) :: series(:, :)
      integer, intent(out) :: ierr
      character(len=api_errmsg_len), intent(out) :: errmsg
      ierr = ok
      errmsg = ''
      series = 0
      call check_shape('series', shape(series), [size(run%traj%tau), n_series], ierr, errmsg)
      if (ierr /= ok) return
      call physical_series(config, run%traj, series, ierr, errmsg)
   end subroutine run_physical_series

   !> Number of the core's limits (limit_entry).
   function limit_count() result(n)
      integer :: n
      n = size(limit_names)
   end function limit_count

   !> Limit k (1 to limit_count()): its name (blank-padded) and value; blank and 0 for another k.
   subroutine limit_entry(k, name, value)
      integer, intent(in) :: k
      character(len=24), intent(out) :: name
      real(dp), intent(out) :: value
      name = ''
      value = 0
      if (k < 1 .or. k > size(limit_names)) return
      name = limit_names(k)
      value = limit_values(k)
   end subroutine limit_entry

   !> Number of rows of the core's observable table (observable_entry).
   function observable_count() result(n)
      integer :: n
      n = n_observable_rows
   end function observable_count

   !> Row k (1 to observable_count()) of the observable table (tmafm_observable_table): its name,
   !> group ('lockin', 'extrema', 'peak_force', 'energy' or 'always') and the group's bit (0 for
   !> always), model unit, SI-derived unit ('' for none), scale (a scales_t component, 'one' or
   !> ''), kind ('column', 'harmonic', 'extremum', 'modal', 'points') and index (its obs_* column
   !> or ext_* index; 0 else), blank-padded; all blank and 0 for another k.
   subroutine observable_entry(k, name, group, bit, unit, si_unit, scale, kind, index)
      integer, intent(in) :: k
      character(len=32), intent(out) :: name
      character(len=16), intent(out) :: group
      integer, intent(out) :: bit
      character(len=16), intent(out) :: unit
      character(len=8), intent(out) :: si_unit
      character(len=16), intent(out) :: scale
      character(len=16), intent(out) :: kind
      integer, intent(out) :: index
      name = ''
      group = ''
      bit = 0
      unit = ''
      si_unit = ''
      scale = ''
      kind = ''
      index = 0
      if (k < 1 .or. k > n_observable_rows) return
      associate (row => observable_rows(k))
         name = row%name
         group = observable_group_name(row%bit)
         bit = row%bit
         unit = row%unit
         si_unit = row%si_unit
         scale = observable_scale_names(row%scale)
         kind = observable_kind_names(row%kind)
         index = row%index
      end associate
   end subroutine observable_entry

   !> The factor from each row's model unit to its SI-derived unit for `config` (its &physical
   !> scales; scales_t's unit defaults when it has none), 0 for a row with no SI-derived unit.
   !> err_input when factors has not observable_count() entries.
   subroutine observable_table_factors(config, factors, ierr, errmsg)
      type(config_t), intent(in) :: config
      real(dp), intent(inout) :: factors(:)
      integer, intent(out) :: ierr
      character(len=api_errmsg_len), intent(out) :: errmsg
      type(scales_t) :: scales
      integer :: k
      ierr = ok
      errmsg = ''
      factors = 0
      if (size(factors) /= n_observable_rows) then
         ierr = err_input
         errmsg = 'observable_table_factors: factors must have observable_count() = ' &
                  //trim(int_text(n_observable_rows))//' entries, not '//trim(int_text(size(factors)))
         return
      end if
      scales = config_scales(config)
      do k = 1, n_observable_rows
         factors(k) = observable_si_factor(scales, observable_rows(k)%scale)
      end do
   end subroutine observable_table_factors

   !> Append a copy of `config` (its N already chosen) to `batch`: no text is written or read.
   subroutine batch_add(batch, config)
      type(batch_t), intent(inout) :: batch
      type(config_t), intent(in) :: config
      type(config_t), allocatable :: grown(:)
      integer :: k
      if (.not. allocated(batch%configs)) allocate (batch%configs(8))
      if (batch%n == size(batch%configs)) then
         allocate (grown(2*batch%n))
         do k = 1, batch%n
            call move_config(batch%configs(k), grown(k))
         end do
         call move_alloc(grown, batch%configs)
      end if
      batch%n = batch%n + 1
      batch%configs(batch%n) = config
      ! N is chosen: the runs reuse it (no second choice of N).
      batch%configs(batch%n)%auto_modes = .false.
   end subroutine batch_add

   ! The configuration `from` into `to` (a copy; the old array is dropped right after).
   subroutine move_config(from, to)
      type(config_t), intent(in) :: from
      type(config_t), intent(out) :: to
      to = from
   end subroutine move_config

   !> Number of configurations in a batch.
   function batch_size(batch) result(n)
      type(batch_t), intent(in) :: batch
      integer :: n
      n = batch%n
   end function batch_size

   ! err_input naming `name` unless an array's shape `actual` is `expected` (ierr set: no change).
   subroutine check_shape(name, actual, expected, ierr, errmsg)
      character(len=*), intent(in) :: name
      integer, intent(in) :: actual(:)
      integer, intent(in) :: expected(:)
      integer, intent(inout) :: ierr
      character(len=*), intent(inout) :: errmsg
      if (ierr /= ok) return
      if (size(actual) == size(expected)) then
         if (all(actual == expected)) return
      end if
      ierr = err_input
      write (errmsg, '(3a,*(i0,:,1x))') 'observe: ', name, ' has the wrong shape: ', actual
      errmsg = trim(errmsg)//', the call needs'
      write (errmsg(len_trim(errmsg) + 2:), '(*(i0,:,1x))') expected
   end subroutine check_shape

   ! The options of an observed run, from the entry points' arguments.
   subroutine set_options(options, max_periods, harmonics, p_max, tol, repeats, stop_at_steady, groups)
      type(observe_options_t), intent(inout) :: options
      integer, intent(in) :: max_periods
      integer, intent(in) :: harmonics
      integer, intent(in) :: p_max
      real(dp), intent(in) :: tol
      integer, intent(in) :: repeats
      logical, intent(in) :: stop_at_steady
      integer, intent(in) :: groups
      options%max_periods = max_periods
      options%p_max = p_max
      options%tol = tol
      options%repeats = repeats
      options%harmonics = harmonics
      options%stop_at_steady = stop_at_steady
      options%groups = groups
   end subroutine set_options

   !> Observed runs of a batch's configurations by the core's OpenMP batch (tmafm_batch
   !> observe_batch) on `threads` threads (0: the OpenMP default); Python calls this without the
   !> GIL.  The options as tmafm_batch observe_options_t (groups: tmafm_observers group_* bits).
   !> The results go into arrays Python made, checked against the batch first (ierr = err_input
   !> and nothing written or run when one has the wrong shape): per configuration k (n of them;
   !> n_state = 2 max N): values(k, period, column) (tmafm_observers columns), the harmonics (k,
   !> period, harmonic), Poincare points (k, 0:period, 1:2N), the located max V_T (k, period),
   !> the modal extrema (k, period, mode, 1:4 = ext_* columns), periods integrated, the steady
   !> period, the factors to SI-derived units and has_scales (1 for &physical), the steady
   !> harmonics, the steady test's evidence, and run_ierr(k); errmsg is then the message of the
   !> first configuration that failed.  `poll`: the calling thread's runs poll for Ctrl-C
   !> (Python's main thread only); an interrupted batch fails with err_interrupted.
   subroutine batch_run(batch, max_periods, harmonics, p_max, tol, repeats, stop_at_steady, groups, threads, &
                        poll, values, harmonic_amplitude, harmonic_phase, poincare, max_gap, modal_extrema, &
                        n_periods, period, factors, has_scales, steady_harmonic_amplitude, &
                        steady_harmonic_phase, evidence, run_ierr, ierr, errmsg)
      type(batch_t), intent(in) :: batch
      integer, intent(in) :: max_periods
      integer, intent(in) :: harmonics
      integer, intent(in) :: p_max
      real(dp), intent(in) :: tol
      integer, intent(in) :: repeats
      logical, intent(in) :: stop_at_steady
      integer, intent(in) :: groups
      integer, intent(in) :: threads
      !> Poll for Ctrl-C (tmafm_api_poll): only on Python's main thread, the only one it helps.
      logical, intent(in) :: poll
      real(dp), intent(inout) :: values(:, :, :)
      real(dp), intent(inout) :: harmonic_amplitude(:, :, :)
      real(dp), intent(inout) :: harmonic_phase(:, :, :)
      real(dp), intent(inout) :: poincare(:, :, :)
      real(dp), intent(inout) :: max_gap(:, :)
      real(dp), intent(inout) :: modal_extrema(:, :, :, :)
      integer, intent(inout) :: n_periods(:)
      integer, intent(inout) :: period(:)
      real(dp), intent(inout) :: factors(:, :)
      integer, intent(inout) :: has_scales(:)
      real(dp), intent(inout) :: steady_harmonic_amplitude(:, :)
      real(dp), intent(inout) :: steady_harmonic_phase(:, :)
      real(dp), intent(inout) :: evidence(:, :)
      integer, intent(inout) :: run_ierr(:)
      integer, intent(out) :: ierr
      character(len=api_errmsg_len), intent(out) :: errmsg
      type(observer_t), allocatable :: observers(:)
      type(observe_options_t) :: options
      type(scales_t) :: scales
      character(len=api_errmsg_len), allocatable :: messages(:)
      integer :: n, s, k, m, h, p

      ierr = ok
      errmsg = ''
      n = batch%n
      s = 0
      do k = 1, n
         s = max(s, 2*batch%configs(k)%n_modes)
      end do
      h = harmonics
      p = max_periods
      call check_shape('values', shape(values), [n, p, n_observables], ierr, errmsg)
      call check_shape('harmonic_amplitude', shape(harmonic_amplitude), [n, p, h], ierr, errmsg)
      call check_shape('harmonic_phase', shape(harmonic_phase), [n, p, h], ierr, errmsg)
      call check_shape('poincare', shape(poincare), [n, p + 1, s], ierr, errmsg)
      call check_shape('max_gap', shape(max_gap), [n, p], ierr, errmsg)
      call check_shape('modal_extrema', shape(modal_extrema), [n, p, s/2, 4], ierr, errmsg)
      call check_shape('n_periods', shape(n_periods), [n], ierr, errmsg)
      call check_shape('period', shape(period), [n], ierr, errmsg)
      call check_shape('factors', shape(factors), [n, n_observables], ierr, errmsg)
      call check_shape('has_scales', shape(has_scales), [n], ierr, errmsg)
      call check_shape('steady_harmonic_amplitude', shape(steady_harmonic_amplitude), [n, h], ierr, errmsg)
      call check_shape('steady_harmonic_phase', shape(steady_harmonic_phase), [n, h], ierr, errmsg)
      call check_shape('evidence', shape(evidence), [n, 5], ierr, errmsg)
      call check_shape('run_ierr', shape(run_ierr), [n], ierr, errmsg)
      if (ierr /= ok .or. n == 0) return
      values = 0; harmonic_amplitude = 0; harmonic_phase = 0; poincare = 0; n_periods = 0
      max_gap = 0; modal_extrema = 0; period = 0; factors = 0; has_scales = 0; run_ierr = ok
      steady_harmonic_amplitude = 0; steady_harmonic_phase = 0; evidence = 0
      call set_options(options, max_periods, harmonics, p_max, tol, repeats, stop_at_steady, groups)
      allocate (observers(n), messages(n))
      messages = ''
      if (poll) then
         call observe_batch(batch%configs(1:n), options, observers, run_ierr, messages, threads, &
                            poll=python_interrupted)
      else
         call observe_batch(batch%configs(1:n), options, observers, run_ierr, messages, threads)
      end if
      do k = 1, n
         if (run_ierr(k) /= ok) then
            if (len_trim(errmsg) == 0) errmsg = messages(k)
            cycle
         end if
         associate (o => observers(k))
            m = o%n_periods
            ! The modal state (a, a'); a viscoelastic sample's w is not copied out.
            s = 2*o%n_modes
            n_periods(k) = m
            period(k) = o%found_period
            values(k, 1:m, :) = o%values(1:m, :)
            harmonic_amplitude(k, 1:m, :) = o%harmonic_amplitude(1:m, :)
            harmonic_phase(k, 1:m, :) = o%harmonic_phase(1:m, :)
            poincare(k, 1:m + 1, 1:s) = transpose(o%poincare(:, 0:m))
            max_gap(k, 1:m) = o%max_gap_values(1:m)
            modal_extrema(k, 1:m, 1:s/2, :) = o%modal_extrema(1:m, :, :)
            call steady_harmonics(o, steady_harmonic_amplitude(k, :), steady_harmonic_phase(k, :))
            evidence(k, :) = steady_evidence(o)
         end associate
         scales = config_scales(batch%configs(k))
         factors(k, :) = observable_factors(scales)
         has_scales(k) = merge(1, 0, scales%known)
      end do
   end subroutine batch_run

   !> Observed runs of one configuration (its N chosen) from many initial states (states(k, :) =
   !> [a0, adot0] of run k), by the core's OpenMP batch (tmafm_batch observe_states) without
   !> the GIL: the model is built once.  Known attractors: orbit j is attractor_points(:,
   !> attractor_first(j):attractor_first(j+1)-1) (none when size(attractor_first) < 2);
   !> `confirm` Poincare points in a row within capture of one label the run and stop it.  The
   !> results go into arrays Python made, checked first (err_input, nothing run, for a wrong
   !> shape): per run k, the steady values (k, column: the mean over the last max(period, 1)
   !> periods, NaN for a group not computed; the same for the harmonics), the last p_max
   !> Poincare points (orbit(k, p_max, :) the final state, NaN before the first), periods run,
   !> the steady period, the attractor (0: none), why no period was found (tmafm_steady_state
   !> unsteady_*), the jitter level of the last point, and run_ierr(k).  ierr: err_input for a
   !> bad input, options or state (nothing runs); errmsg, else, is the first run's failure.
   subroutine observe_states_of(config, states, max_periods, harmonics, p_max, tol, repeats, stop_at_steady, &
                                groups, attractor_points, attractor_first, confirm, capture, threads, poll, &
                                steady, steady_harmonic_amplitude, steady_harmonic_phase, orbit, n_periods, &
                                period, attractor, factors, run_ierr, reason, jitter, has_scales, ierr, errmsg)
      type(config_t), intent(in) :: config
      real(dp), intent(in) :: states(:, :)
      integer, intent(in) :: max_periods
      integer, intent(in) :: harmonics
      integer, intent(in) :: p_max
      real(dp), intent(in) :: tol
      integer, intent(in) :: repeats
      logical, intent(in) :: stop_at_steady
      integer, intent(in) :: groups
      real(dp), intent(in) :: attractor_points(:, :)
      integer, intent(in) :: attractor_first(:)
      integer, intent(in) :: confirm
      real(dp), intent(in) :: capture
      integer, intent(in) :: threads
      !> Poll for Ctrl-C, as batch_run's `poll`.
      logical, intent(in) :: poll
      real(dp), intent(inout) :: steady(:, :)
      real(dp), intent(inout) :: steady_harmonic_amplitude(:, :)
      real(dp), intent(inout) :: steady_harmonic_phase(:, :)
      real(dp), intent(inout) :: orbit(:, :, :)
      integer, intent(inout) :: n_periods(:)
      integer, intent(inout) :: period(:)
      integer, intent(inout) :: attractor(:)
      real(dp), intent(inout) :: factors(:)
      integer, intent(inout) :: run_ierr(:)
      integer, intent(inout) :: reason(:)
      real(dp), intent(inout) :: jitter(:)
      integer, intent(out) :: has_scales
      integer, intent(out) :: ierr
      character(len=api_errmsg_len), intent(out) :: errmsg
      type(config_t) :: chosen
      type(observer_t), allocatable :: observers(:)
      type(observe_options_t) :: options
      type(scales_t) :: scales
      character(len=api_errmsg_len), allocatable :: messages(:)
      integer :: n, s, k, m, last, kept, j

      ierr = ok
      errmsg = ''
      has_scales = 0
      n = size(states, 1)
      s = size(states, 2)
      call check_shape('steady', shape(steady), [n, n_observables], ierr, errmsg)
      call check_shape('steady_harmonic_amplitude', shape(steady_harmonic_amplitude), [n, harmonics], ierr, errmsg)
      call check_shape('steady_harmonic_phase', shape(steady_harmonic_phase), [n, harmonics], ierr, errmsg)
      call check_shape('orbit', shape(orbit), [n, p_max, s], ierr, errmsg)
      call check_shape('n_periods', shape(n_periods), [n], ierr, errmsg)
      call check_shape('period', shape(period), [n], ierr, errmsg)
      call check_shape('attractor', shape(attractor), [n], ierr, errmsg)
      call check_shape('factors', shape(factors), [n_observables], ierr, errmsg)
      call check_shape('run_ierr', shape(run_ierr), [n], ierr, errmsg)
      call check_shape('reason', shape(reason), [n], ierr, errmsg)
      call check_shape('jitter', shape(jitter), [n], ierr, errmsg)
      if (size(attractor_first) >= 2) call check_shape('attractor_points', [size(attractor_points, 1)], [s], &
                                                       ierr, errmsg)
      if (ierr /= ok) return
      steady = 0; steady_harmonic_amplitude = 0; steady_harmonic_phase = 0
      orbit = ieee_value(1.0_dp, ieee_quiet_nan)
      n_periods = 0; period = 0; attractor = 0; factors = 0; run_ierr = 0; reason = 0; jitter = 0
      chosen = config
      ! N is chosen: the runs reuse it (no second choice of N).
      chosen%auto_modes = .false.
      call set_options(options, max_periods, harmonics, p_max, tol, repeats, stop_at_steady, groups)
      options%confirm = confirm
      options%capture = capture
      if (size(attractor_first) >= 2) then
         options%attractor_points = attractor_points
         options%attractor_first = attractor_first
      end if
      allocate (observers(n), messages(n))
      if (poll) then
         call observe_states(chosen, transpose(states), options, observers, ierr, errmsg, run_ierr, messages, &
                             threads, poll=python_interrupted)
      else
         call observe_states(chosen, transpose(states), options, observers, ierr, errmsg, run_ierr, messages, &
                             threads)
      end if
      if (ierr /= ok) return
      do k = 1, n
         if (run_ierr(k) /= ok) then
            if (len_trim(errmsg) == 0) errmsg = messages(k)
            steady(k, :) = ieee_value(1.0_dp, ieee_quiet_nan)
            steady_harmonic_amplitude(k, :) = ieee_value(1.0_dp, ieee_quiet_nan)
            steady_harmonic_phase(k, :) = ieee_value(1.0_dp, ieee_quiet_nan)
            cycle
         end if
         associate (o => observers(k))
            m = o%n_periods
            n_periods(k) = m
            period(k) = o%found_period
            attractor(k) = o%attractor
            last = steady_window(o)
            if (last > 0) then
               steady(k, :) = sum(o%values(m - last + 1:m, :), 1)/last
               ! Amplitude and phase: the harmonic over the orbit's periods (tmafm_steady_state).
               call steady_harmonics(o, steady_harmonic_amplitude(k, :), steady_harmonic_phase(k, :))
               if (.not. ieee_is_nan(steady(k, obs_phase))) then
                  steady(k, obs_amplitude) = steady_harmonic_amplitude(k, 1)
                  steady(k, obs_phase) = steady_harmonic_phase(k, 1)
                  ! Each drive tone's lock-in: its steady harmonic too (free of the +-180 wrap).
                  do j = 1, size(obs_tone_phase)
                     call steady_harmonic(o%values(m - last + 1:m, obs_tone_amplitude(j)), &
                                          o%values(m - last + 1:m, obs_tone_phase(j)), &
                                          steady(k, obs_tone_amplitude(j)), steady(k, obs_tone_phase(j)))
                  end do
                  ! A general drive: amplitude and phase are tone 1's (tmafm_observers).
                  if (o%general_drive) then
                     steady(k, obs_amplitude) = steady(k, obs_tone_amplitude(1))
                     steady(k, obs_phase) = steady(k, obs_tone_phase(1))
                  end if
               end if
            end if
            reason(k) = o%reason
            jitter(k) = o%jitter_floor(m)
            kept = min(p_max, m + 1)
            orbit(k, p_max - kept + 1:p_max, :) = transpose(o%poincare(1:2*o%n_modes, m - kept + 1:m))
         end associate
      end do
      scales = config_scales(chosen)
      factors = observable_factors(scales)
      has_scales = merge(1, 0, scales%known)
   end subroutine observe_states_of

   !> The classifier of tmafm_steady_state on a sequence of points (n_points x n_dim), the one
   !> steady-state rule: the period (0: none), the reason when none (unsteady_*), the closest
   !> repeat (relative to the orbit's size, or to `scale` when scale > 0) and its lag, and into
   !> steps (p_max of them) every lag's largest step (repeat_steps).  floor(j): the absolute
   !> jitter level of point j.  err_input (nothing computed) when floor or steps has the wrong size.
   subroutine steady_test_of(points, p_max, tol, repeats, floor, scale, steps, period, reason, closest, &
                             closest_lag, ierr, errmsg)
      real(dp), intent(in) :: points(:, :)
      integer, intent(in) :: p_max
      real(dp), intent(in) :: tol
      integer, intent(in) :: repeats
      real(dp), intent(in) :: floor(:)
      real(dp), intent(in) :: scale
      real(dp), intent(inout) :: steps(:)
      integer, intent(out) :: period
      integer, intent(out) :: reason
      real(dp), intent(out) :: closest
      integer, intent(out) :: closest_lag
      integer, intent(out) :: ierr
      character(len=api_errmsg_len), intent(out) :: errmsg
      period = 0
      reason = 0
      closest = 0
      closest_lag = 0
      ierr = ok
      errmsg = ''
      call check_shape('floor', shape(floor), [size(points, 1)], ierr, errmsg)
      call check_shape('steps', shape(steps), [p_max], ierr, errmsg)
      if (ierr /= ok) return
      if (scale > 0) then
         call steady_test(transpose(points), p_max, tol, repeats, period, reason, closest, closest_lag, floor, &
                          scale)
         steps = repeat_steps(transpose(points), p_max, repeats, scale)
      else
         call steady_test(transpose(points), p_max, tol, repeats, period, reason, closest, closest_lag, floor)
         steps = repeat_steps(transpose(points), p_max, repeats)
      end if
   end subroutine steady_test_of

   !> The steady first harmonic of an orbit from its per-period amplitudes and phases (degrees):
   !> tmafm_steady_state steady_harmonic, the phase free of the wrap at +-180.  err_input when
   !> the two differ in size.
   subroutine steady_harmonic_of(amplitude, phase, mean_amplitude, mean_phase, ierr, errmsg)
      real(dp), intent(in) :: amplitude(:)
      real(dp), intent(in) :: phase(:)
      real(dp), intent(out) :: mean_amplitude
      real(dp), intent(out) :: mean_phase
      integer, intent(out) :: ierr
      character(len=api_errmsg_len), intent(out) :: errmsg
      mean_amplitude = 0
      mean_phase = 0
      ierr = ok
      errmsg = ''
      call check_shape('phase', shape(phase), shape(amplitude), ierr, errmsg)
      if (ierr /= ok) return
      call steady_harmonic(amplitude, phase, mean_amplitude, mean_phase)
   end subroutine steady_harmonic_of

   !> The syntax tree of namelist text, as tmafm's strict reader parses it (tmafm_nml_syntax), for
   !> files that Python reads itself (sweep files): one record per value, the fields group ordinal,
   !> group name, entry ordinal, key, value kind (value_* constant), repeat count and value text
   !> (a string's contents), as character codes into `codes`; -1 ends a field, -2 a record.
   !> codes(1:length) are in use; length = -1 if codes is too small.
   subroutine namelist_syntax(text, label, codes, length, ierr, errmsg)
      character(len=*), intent(in) :: text
      character(len=*), intent(in) :: label
      integer, intent(inout) :: codes(:)
      integer, intent(out) :: length
      integer, intent(out) :: ierr
      character(len=api_errmsg_len), intent(out) :: errmsg
      type(nml_document_t) :: doc
      integer :: g, e, v

      codes = 0
      length = 0
      call parse_namelist(text, label, doc, ierr, errmsg)
      if (ierr /= ok) return
      do g = 1, doc%n_groups
         associate (group => doc%groups(g))
            do e = 1, group%n_entries
               associate (entry => group%entries(e))
                  do v = 1, size(entry%values)
                     call put(int_text(g))
                     call put(group%name)
                     call put(int_text(e))
                     call put(entry%key)
                     call put(int_text(entry%values(v)%kind))
                     call put(int_text(entry%values(v)%repeat))
                     call put(entry%values(v)%text)
                     call mark(-2)
                  end do
               end associate
            end do
         end associate
      end do
   contains
      subroutine put(field)
         character(len=*), intent(in) :: field
         integer :: k
         if (length < 0) return
         if (length + len(field) + 1 > size(codes)) then
            length = -1
            return
         end if
         codes(length + 1:length + len(field)) = [(iachar(field(k:k)), k = 1, len(field))]
         length = length + len(field)
         call mark(-1)
      end subroutine put
      subroutine mark(code)
         integer, intent(in) :: code
         if (length < 0) return
         if (length + 1 > size(codes)) then
            length = -1
            return
         end if
         length = length + 1
         codes(length) = code
      end subroutine mark
   end subroutine namelist_syntax

   !> Number of the statistics periodic_map_of returns per call (tmafm_monodromy stat_*).
   function orbit_stat_count() result(n)
      integer :: n
      n = n_orbit_stats
   end function orbit_stat_count

   !> The length of the stroboscopic map's state: 2N, or 2N + 1 with a viscoelastic sample
   !> (a, a', w).
   function orbit_state_size(model) result(m)
      type(model_t), intent(in) :: model
      integer :: m
      m = map_state_size(model)
   end function orbit_state_size

   !> The Jacobian of the time derivative in a phase at (tau, y), y of orbit_state_size (a, a'[, w]),
   !> into jac (its square) that Python made (tmafm_model_jacobian).
   subroutine jacobian_of(model, tau, y, in_contact, jac, ierr, errmsg)
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: y(:)
      logical, intent(in) :: in_contact
      real(dp), intent(inout) :: jac(:, :)
      integer, intent(out) :: ierr
      character(len=api_errmsg_len), intent(out) :: errmsg
      real(dp) :: full(model%n_state)
      integer :: m
      ierr = ok
      errmsg = ''
      m = map_state_size(model)
      call check_shape('y', shape(y), [m], ierr, errmsg)
      call check_shape('jac', shape(jac), [m, m], ierr, errmsg)
      if (ierr /= ok) return
      ! model_t's pad after w (a viscoelastic sample) is 0; a meniscus's flag is y's last.
      call map_to_model_state(model, y, full)
      call model_jacobian(model, tau, full, in_contact, jac)
   end subroutine jacobian_of

   !> The period of the stroboscopic map, 2 pi/Omega_0 (Omega_0 the drive's common frequency,
   !> tmafm_drive; one tone: Omega); 0 without a drive frequency.
   function orbit_period(model) result(period)
      type(model_t), intent(in) :: model
      real(dp) :: period
      period = 0
      if (model%drive%fundamental > 0) period = 2*acos(-1.0_dp)/model%drive%fundamental
   end function orbit_period

   !> The stroboscopic map over n_periods drive periods from y0 at tau = 0 and its monodromy
   !> matrix, into arrays Python made (y_end: orbit_state_size, monodromy: its square, stats:
   !> orbit_stat_count()),
   !> with relative tolerance rtol in contact (tmafm_monodromy).
   subroutine periodic_map_of(model, y0, n_periods, rtol, y_end, monodromy, stats, ierr, errmsg)
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: y0(:)
      integer, intent(in) :: n_periods
      real(dp), intent(in) :: rtol
      real(dp), intent(inout) :: y_end(:)
      real(dp), intent(inout) :: monodromy(:, :)
      real(dp), intent(inout) :: stats(:)
      integer, intent(out) :: ierr
      character(len=api_errmsg_len), intent(out) :: errmsg
      integer :: m
      ierr = ok
      errmsg = ''
      m = map_state_size(model)
      call check_shape('y0', shape(y0), [m], ierr, errmsg)
      call check_shape('y_end', shape(y_end), [m], ierr, errmsg)
      call check_shape('monodromy', shape(monodromy), [m, m], ierr, errmsg)
      call check_shape('stats', shape(stats), [n_orbit_stats], ierr, errmsg)
      if (ierr /= ok) return
      call stroboscopic_map(model, y0, n_periods, rtol, y_end, monodromy, stats, ierr, errmsg)
   end subroutine periodic_map_of

end module tmafm_api

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
      simulate, choose_mode_count, read_config_text, config_text, nml_document_t, parse_namelist, &
      entry_text, read_config_document, patch_document, n_keys, describe_key, max_modes, max_samples, &
      max_trajectory_bytes, max_max_steps, max_mode_horizon, max_harmonics, max_p_max, max_observed_periods
   ! The types Python sees are named from the modules that define them, not the facade: f90wrap
   ! reads only the wrapped modules' sources and resolves a type through its defining module.
   use tmafm_config, only: config_t
   use tmafm_contact, only: contact_brackets_t
   use tmafm_model, only: model_t
   use tmafm_trajectory, only: trajectory_t
   use tmafm_api_poll, only: python_interrupted
   implicit none
   private

   public :: api_errmsg_len, run_t, config_from_text, config_from_texts, config_sample_count, config_text_length, &
      config_text_codes, model_of_config, run_config, run_sizes, run_samples, run_switches, &
      run_counters, trajectory_energy_flow, key_count, key_entry, limit_count, limit_entry

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
         if (contact(k) == 1) then
            s = model%contact(tau(k), a(k, :))
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

end module tmafm_api

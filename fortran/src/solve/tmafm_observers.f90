!> Per-drive-period observables computed during a run from the integrator's accepted steps
!> (their dense output) or the exact free flight, split at the period boundaries tau = k T,
!> T = 2 pi/Omega (docs/observables.md defines each one, with units and signs); with two drive
!> tones T is their common period (tmafm_drive), and each tone has its own lock-in columns.
!>
!> A free flight of flight_exact is exact: it is cut only at the period boundaries, and over
!> each part the Fourier sums of V_T, the mean deflection and the drive and beam-damping powers
!> are integrated in closed form (the contact powers and the virial are zero out of contact),
!> and max and min V_T and each mode's max and min are located by a scan whose intervals are
!> cleared by a rigorous bound, with Brent on the exact derivative where one holds an
!> extremum (tmafm_flight_observables; docs/model-notes.md, item 16).
!> Steps are integrated by 8-point Gauss-Legendre on each piece (a step cut into pieces of at
!> most T/16; 3 points on a fixed rk4_paper step's cubic; on a pair's warped step after a
!> contact entry the nodes are placed in sigma, where the integrands are smooth); contact
!> times come from the located switches; min V_T and the peak normal force are located on the
!> dense output by a golden-section search around the best node, and so are max V_T and each
!> mode's max and min over the period's in-contact part and its free part (on a pair's step
!> also around a best piece end, when the function falls into the piece there).
!> Every array is allocated in init; feeding steps allocates nothing.
!>
!> A run computes only the observable groups it asks for (observer_t%groups, bits group_*):
!> the Poincare points, the contact time and the contact count always; the columns of a group
!> not asked for are NaN.  A run with no group asked for evaluates the state only at the period
!> boundaries.  Known attractors (set_attractors) let a run stop as soon as its Poincare points
!> repeat a known orbit (docs/sweeps.md, "Stopping at a known attractor").
module tmafm_observers
   use tmafm_kinds, only: dp
   use tmafm_drive, only: max_tones
   use tmafm_model, only: model_t, n_powers, power_drive, power_beam_damping, &
      power_contact_damping, power_contact_normal, power_contact_friction, power_contact_viscoelastic, &
      power_contact_adhesion
   use tmafm_contact, only: contact_brackets_t
   use tmafm_embedded_pair, only: embedded_pair_t
   use tmafm_flight, only: free_flight_t
   use tmafm_flight_observables, only: flight_observables_t, channel_gap
   use tmafm_steady_state, only: steady_test, jitter_t, jitter_level, unsteady_short, steady_found
   use tmafm_quadrature, only: gauss_legendre
   use tmafm_units, only: scales_t
   use tmafm_interpolation, only: hermite_cubic
   use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
   implicit none
   private

   public :: observer_t, stop_requested, n_observables, observable_factors
   public :: group_lockin, group_extrema, group_peak_force, group_energy, group_all, group_columns
   public :: obs_amplitude, obs_phase, obs_mean_deflection, obs_min_gap, obs_peak_force, &
      obs_contact_time, obs_contacts, obs_dissipated, obs_dissipated_beam, &
      obs_dissipated_contact_damping, obs_dissipated_friction, obs_drive_work, obs_virial, &
      obs_contact_normal_work, obs_dissipated_viscoelastic, ext_max_contact, ext_min_contact, ext_max_free, &
      ext_min_free, obs_tone_amplitude, obs_tone_phase, obs_min_force, obs_dissipated_adhesion

   !> Columns of observer_t%values.
   integer, parameter :: obs_amplitude = 1, obs_phase = 2, obs_mean_deflection = 3, obs_min_gap = 4, &
      obs_peak_force = 5, obs_contact_time = 6, obs_contacts = 7, obs_dissipated = 8, &
      obs_dissipated_beam = 9, obs_dissipated_contact_damping = 10, obs_dissipated_friction = 11, &
      obs_drive_work = 12, obs_virial = 13, obs_contact_normal_work = 14, &
      obs_dissipated_viscoelastic = 15, obs_min_force = 20, obs_dissipated_adhesion = 21, n_observables = 21
   !> Columns of each drive tone's lock-in amplitude and phase (tone k: obs_tone_amplitude(k)).
   integer, parameter :: obs_tone_amplitude(max_tones) = [16, 18], obs_tone_phase(max_tones) = [17, 19]
   !> Observable groups, bits of observer_t%groups: V_T's harmonics, phase and mean deflection;
   !> the located extrema (min_gap, max V_T, modal extrema); the peak force; the energies and
   !> the virial.  contact_time, contacts_per_period and the Poincare points are always computed.
   integer, parameter :: group_lockin = 1, group_extrema = 2, group_peak_force = 4, group_energy = 8, &
      group_all = 15
   !> Last index of observer_t%modal_extrema: mode j's max and min in contact, and free.
   integer, parameter :: ext_max_contact = 1, ext_min_contact = 2, ext_max_free = 3, ext_min_free = 4

   !> Gauss-Legendre points per piece, and pieces per period at least (for long steps).
   integer, parameter :: gl_points = 8, pieces_per_period = 16
   !> Gauss-Legendre points per fixed step (its dense output is a cubic: 3 points integrate
   !> the quadratic powers of it exactly to degree 5, beyond RK4's own O(h^4)).
   integer, parameter :: hermite_points = 3
   !> Golden-section iterations of an extremum search (bracket shrinks by 0.618^k).
   integer, parameter :: golden_iterations = 64
   real(dp), parameter :: pi = acos(-1.0_dp)

   !> A fixed step's end points and derivatives: its cubic Hermite dense output.
   type :: hermite_t
      !> State and derivative at the step start (0) and end (1).
      real(dp), allocatable :: y0(:), f0(:), y1(:), f1(:)
   end type hermite_t

   !> The observer of one run: settings, the current period's accumulators, and the results.
   type :: observer_t
      !> Number of state components: 2N, or 2N + 2 with a viscoelastic sample (tmafm_model).
      integer :: n_state = 0
      !> Number of modes N.
      integer :: n_modes = 0
      !> Harmonics 1..harmonics of V_T reported.
      integer :: harmonics = 3
      !> Periods to integrate at most.
      integer :: max_periods = 100
      !> Largest steady period looked for, and how many repeats in a row confirm it.
      integer :: p_max = 8, repeats = 3
      !> Tolerance of the repeats, relative to the orbit's size.
      real(dp) :: tol = 1.0e-6_dp
      !> A fixed-step method's jitter (tmafm_steady_state): the repeats are within the largest
      !> of tol * size and the jitter level of the points compared (jitter_floor(0:periods)).
      type(jitter_t) :: jitter
      real(dp), allocatable :: jitter_floor(:)
      !> The last steady test: why no period was found (tmafm_steady_state unsteady_*; 0 once
      !> one is), the closest repeat (relative to the orbit's size) and its lag.
      integer :: reason = unsteady_short, closest_lag = 0
      real(dp) :: closest = huge(1.0_dp)
      !> Stop the run at the first steady state found.
      logical :: stop_at_steady = .true.
      !> The observable groups computed (bits group_*), and the same as flags.
      integer :: groups = group_all
      logical :: do_lockin = .true., do_extrema = .true., do_force = .true., do_energy = .true.
      !> Known attractors: orbit k's points are attractor_points(:, first(k):first(k+1)-1), its
      !> size (largest |component|) attractor_size(k); `confirm` points in a row within
      !> capture*size of orbit k's points, in the orbit's order, each closer than the one before,
      !> label the run with k and may stop it.
      real(dp), allocatable :: attractor_points(:, :), attractor_size(:)
      integer, allocatable :: attractor_first(:)
      integer :: n_attractors = 0, confirm = 3
      real(dp) :: capture = 1.0e-6_dp
      !> The matching in progress: attractor, orbit point, how many points in a row, and the
      !> last point's distance (relative to the orbit's size).
      integer :: match_attractor = 0, match_point = 0, match_streak = 0
      real(dp) :: match_distance = huge(1.0_dp)
      !> The known attractor the run was matched to (0: none).
      integer :: attractor = 0
      !> Drive frequency Omega and period T = 2 pi/Omega.
      real(dp) :: omega = 0, period_length = 0
      !> The longest Gauss-Legendre piece: T/pieces_per_period, or for a general drive that
      !> fraction of its fastest tone's period.
      real(dp) :: piece_max = 0
      !> .true. once the run may stop (steady state found, or max_periods done).
      logical :: done = .false.
      !> Periods completed, and the steady period found (0 = none).
      integer :: n_periods = 0, found_period = 0
      !> Accumulators of the current period.
      real(dp), allocatable :: acc_sin(:), acc_cos(:)
      real(dp) :: acc_deflection = 0, acc_contact_time = 0, acc_virial = 0
      !> A general drive (tmafm_drive): V_T's lock-in sums at each tone, against sin and cos of
      !> Omega_k tau + phi_k.  (One tone at phase 0: tone 1 is harmonic 1.)
      logical :: general_drive = .false.
      integer :: n_tones = 1
      real(dp) :: acc_tone_sin(max_tones) = 0, acc_tone_cos(max_tones) = 0
      real(dp) :: acc_powers(n_powers) = 0
      real(dp) :: min_gap = huge(1.0_dp), peak_force = -huge(1.0_dp), max_gap = -huge(1.0_dp)
      !> The period's most attractive (smallest) tip-sample force so far (huge(): none acted).
      real(dp) :: min_force = huge(1.0_dp)
      !> The current period's located extrema of each mode (mode, ext_* column).
      real(dp), allocatable :: acc_modal(:, :)
      !> Work arrays: each mode's a_j at a piece's nodes (node, mode), and a_j' at its ends.
      real(dp), allocatable :: modal_nodes(:, :), modal_rates(:, :)
      !> Contacts begun in the current period.
      integer :: contacts = 0
      !> Gauss-Legendre nodes and weights on [-1, 1]; state registers.
      real(dp) :: gl_x(gl_points) = 0, gl_w(gl_points) = 0
      real(dp) :: gl3_x(hermite_points) = 0, gl3_w(hermite_points) = 0
      real(dp), allocatable :: y(:)
      !> The fixed step being fed (rk4_paper).
      type(hermite_t) :: cubic
      !> The closed forms of the free flights (flight_exact; set by prepare_flight).
      type(flight_observables_t) :: exact
      !> Results: values(period, column), the harmonics (period, k), Poincare points (2N, 0:periods).
      real(dp), allocatable :: values(:, :), harmonic_amplitude(:, :), harmonic_phase(:, :)
      real(dp), allocatable :: poincare(:, :)
      !> Results: located max V_T (period), and modal extrema (period, mode, ext_*; NaN where
      !> the period has no such part).
      real(dp), allocatable :: max_gap_values(:), modal_extrema(:, :, :)
   contains
      !> Allocate everything for a run starting from y0 at tau = 0.
      procedure :: init => observer_init
      !> Give the run known attractors to stop at (after init).
      procedure :: set_attractors => observer_set_attractors
      !> .true. when feeding the step [tau, tau + taken] evaluates the pair's dense output.
      procedure :: needs_dense => observer_needs_dense
      !> Feed an accepted step [tau, tau + taken] of an embedded pair (dense output built when
      !> needs_dense says so, read through the pair's time map).
      procedure :: pair_step => observer_pair_step
      !> Form the closed forms of a model's free flights (flight_exact, once per run, after init).
      procedure :: prepare_flight => observer_prepare_flight
      !> Feed a free flight [tau, tau + length] of the exact flight solution started at tau.
      procedure :: flight_segment => observer_flight_segment
      !> Feed a fixed step [tau, tau + h] through its cubic Hermite interpolant (rk4_paper).
      procedure :: hermite_step => observer_hermite_step
      !> Count a contact that starts at tau.
      procedure :: contact_start => observer_contact_start
   end type observer_t

contains

   !> .true. when an observer is present and asks the run to stop.
   pure logical function stop_requested(observer)
      type(observer_t), intent(in), optional :: observer
      stop_requested = .false.
      if (present(observer)) stop_requested = observer%done
   end function stop_requested

   !> Which columns of observer_t%values the groups compute.
   pure function group_columns(groups) result(computed)
      integer, intent(in) :: groups
      logical :: computed(n_observables)
      computed = .false.
      computed([obs_contact_time, obs_contacts]) = .true.
      if (iand(groups, group_lockin) /= 0) computed([obs_amplitude, obs_phase, obs_mean_deflection, &
                                                     obs_tone_amplitude, obs_tone_phase]) = .true.
      if (iand(groups, group_extrema) /= 0) computed(obs_min_gap) = .true.
      if (iand(groups, group_peak_force) /= 0) computed([obs_peak_force, obs_min_force]) = .true.
      if (iand(groups, group_energy) /= 0) computed([obs_dissipated, obs_dissipated_beam, &
                                                      obs_dissipated_contact_damping, obs_dissipated_friction, &
                                                      obs_drive_work, obs_virial, obs_contact_normal_work, &
                                                      obs_dissipated_viscoelastic, obs_dissipated_adhesion]) = .true.
   end function group_columns

   subroutine observer_init(self, model, max_periods, harmonics, p_max, tol, repeats, &
                            stop_at_steady, y0, groups, jitter)
      class(observer_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      integer, intent(in) :: max_periods
      integer, intent(in) :: harmonics
      integer, intent(in) :: p_max
      real(dp), intent(in) :: tol
      integer, intent(in) :: repeats
      logical, intent(in) :: stop_at_steady
      real(dp), intent(in) :: y0(:)
      !> The observable groups to compute (bits group_*); all when absent.
      integer, intent(in), optional :: groups
      !> A fixed-step method's jitter data (tmafm_steady_state jitter_init); none when absent.
      type(jitter_t), intent(in), optional :: jitter
      self%groups = group_all
      if (present(groups)) self%groups = iand(groups, group_all)
      self%do_lockin = iand(self%groups, group_lockin) /= 0
      self%do_extrema = iand(self%groups, group_extrema) /= 0
      self%do_force = iand(self%groups, group_peak_force) /= 0
      self%do_energy = iand(self%groups, group_energy) /= 0
      self%n_attractors = 0
      self%match_attractor = 0
      self%match_point = 0
      self%match_streak = 0
      self%match_distance = huge(1.0_dp)
      self%attractor = 0
      self%n_state = size(y0)
      self%n_modes = model%n_modes
      self%max_periods = max_periods
      self%harmonics = harmonics
      self%p_max = p_max
      self%tol = tol
      self%repeats = repeats
      self%stop_at_steady = stop_at_steady
      self%jitter = jitter_t()
      if (present(jitter)) self%jitter = jitter
      self%reason = unsteady_short
      self%closest = huge(1.0_dp)
      self%closest_lag = 0
      self%omega = model%drive%fundamental
      self%period_length = 2*pi/model%drive%fundamental
      self%general_drive = model%drive%general
      self%piece_max = self%period_length/pieces_per_period
      if (self%general_drive) self%piece_max = 2*pi/model%drive%top_frequency/pieces_per_period
      self%n_tones = model%drive%n_tones
      self%done = .false.
      self%n_periods = 0
      self%found_period = 0
      call gauss_legendre(gl_points, self%gl_x, self%gl_w)
      call gauss_legendre(hermite_points, self%gl3_x, self%gl3_w)
      if (allocated(self%y)) deallocate (self%y, self%cubic%y0, self%cubic%f0, self%cubic%y1, &
                                         self%cubic%f1)
      allocate (self%cubic%y0(size(y0)), self%cubic%f0(size(y0)), self%cubic%y1(size(y0)), &
                self%cubic%f1(size(y0)))
      if (allocated(self%acc_sin)) deallocate (self%acc_sin, self%acc_cos)
      if (allocated(self%acc_modal)) deallocate (self%acc_modal, self%modal_nodes, self%modal_rates)
      if (allocated(self%max_gap_values)) deallocate (self%max_gap_values, self%modal_extrema)
      allocate (self%acc_modal(self%n_modes, 4), self%modal_nodes(0:gl_points + 1, self%n_modes), &
                self%modal_rates(0:1, self%n_modes))
      allocate (self%max_gap_values(max_periods), &
                self%modal_extrema(max_periods, self%n_modes, 4))
      self%max_gap_values = 0
      self%modal_extrema = 0
      if (allocated(self%values)) deallocate (self%values, self%harmonic_amplitude, &
                                               self%harmonic_phase, self%poincare)
      allocate (self%y(self%n_state), self%acc_sin(harmonics), self%acc_cos(harmonics))
      allocate (self%values(max_periods, n_observables), self%harmonic_amplitude(max_periods, harmonics), &
                self%harmonic_phase(max_periods, harmonics), self%poincare(self%n_state, 0:max_periods))
      self%values = 0
      self%harmonic_amplitude = 0
      self%harmonic_phase = 0
      self%poincare = 0
      self%poincare(:, 0) = y0
      if (allocated(self%jitter_floor)) deallocate (self%jitter_floor)
      allocate (self%jitter_floor(0:max_periods))
      ! The initial state closes no period: no switch of it is misplaced.
      self%jitter_floor = 0
      call reset(self)
   end subroutine observer_init

   !> Known attractors for this run: orbit k is points(:, first(k):first(k+1)-1) (its points in
   !> order, size(first) = number of orbits + 1); `confirm` Poincare points in a row within
   !> capture*size of orbit k (in its order), each closer than the one before, label the run
   !> with k, and stop it if stop_at_steady.
   subroutine observer_set_attractors(self, points, first, confirm, capture)
      class(observer_t), intent(inout) :: self
      real(dp), intent(in) :: points(:, :)
      integer, intent(in) :: first(:)
      integer, intent(in) :: confirm
      real(dp), intent(in) :: capture
      integer :: k
      self%n_attractors = size(first) - 1
      self%confirm = max(confirm, 1)
      self%capture = capture
      if (allocated(self%attractor_points)) deallocate (self%attractor_points, self%attractor_size, &
                                                         self%attractor_first)
      allocate (self%attractor_points, source=points)
      allocate (self%attractor_first, source=first)
      allocate (self%attractor_size(max(self%n_attractors, 0)))
      do k = 1, self%n_attractors
         self%attractor_size(k) = maxval(abs(points(:, first(k):first(k + 1) - 1)))
         if (.not. (self%attractor_size(k) > 0)) self%attractor_size(k) = tiny(1.0_dp)
      end do
   end subroutine observer_set_attractors

   subroutine reset(self)
      class(observer_t), intent(inout) :: self
      self%acc_sin = 0
      self%acc_cos = 0
      self%acc_deflection = 0
      self%acc_tone_sin = 0
      self%acc_tone_cos = 0
      self%acc_contact_time = 0
      self%acc_virial = 0
      self%acc_powers = 0
      self%min_gap = huge(1.0_dp)
      self%peak_force = -huge(1.0_dp)
      self%min_force = huge(1.0_dp)
      self%max_gap = -huge(1.0_dp)
      self%acc_modal(:, [ext_max_contact, ext_max_free]) = -huge(1.0_dp)
      self%acc_modal(:, [ext_min_contact, ext_min_free]) = huge(1.0_dp)
      self%contacts = 0
   end subroutine reset

   pure logical function observer_needs_dense(self, tau, taken)
      class(observer_t), intent(in) :: self
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: taken
      observer_needs_dense = .false.
      if (self%done) return
      ! As process: the groups evaluate every piece; otherwise only a period boundary reached.
      observer_needs_dense = self%do_lockin .or. self%do_extrema .or. self%do_force .or. self%do_energy &
                             .or. tau + taken >= (self%n_periods + 1)*self%period_length
   end function observer_needs_dense

   subroutine observer_pair_step(self, model, pair, tau, taken, in_contact)
      class(observer_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      class(embedded_pair_t), intent(in) :: pair
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: taken
      logical, intent(in) :: in_contact
      ! The pair's dense output is read through its time map (pair%map): origin and h unused.
      call process(self, model, tau, tau + taken, in_contact, tau, 1.0_dp, pair=pair)
   end subroutine observer_pair_step

   subroutine observer_prepare_flight(self, model, flight)
      class(observer_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      type(free_flight_t), intent(in) :: flight
      call self%exact%init(model, flight, self%harmonics)
   end subroutine observer_prepare_flight

   subroutine observer_flight_segment(self, model, flight, tau, length)
      class(observer_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      type(free_flight_t), intent(in) :: flight
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: length
      real(dp) :: a, b, boundary
      ! As process, but the flight is cut only at the period boundaries: its integrals are in
      ! closed form and its extrema are located on any interval (tmafm_flight_observables).
      a = tau
      do while (a < tau + length .and. .not. self%done)
         boundary = (self%n_periods + 1)*self%period_length
         b = min(tau + length, boundary)
         if (b > a) call flight_piece(self, flight, a, b)
         if (b >= boundary) then
            call flight%state(model, boundary - tau, self%y)
            call finish_period(self)
         end if
         a = b
      end do
   end subroutine observer_flight_segment

   !> The closed-form integrals of the flight over [a, b] (one period's part of it), and its
   !> located extrema there: max and min V_T and each mode's max and min out of contact.
   subroutine flight_piece(self, flight, a, b)
      class(observer_t), intent(inout) :: self
      type(free_flight_t), intent(in) :: flight
      real(dp), intent(in) :: a
      real(dp), intent(in) :: b
      integer :: j
      if (self%general_drive) then
         call self%exact%integrate(flight, a, b, self%do_lockin, self%do_energy, self%acc_sin, self%acc_cos, &
                                   self%acc_deflection, self%acc_powers(power_drive), &
                                   self%acc_powers(power_beam_damping), self%acc_tone_sin, self%acc_tone_cos)
      else
         call self%exact%integrate(flight, a, b, self%do_lockin, self%do_energy, self%acc_sin, self%acc_cos, &
                                   self%acc_deflection, self%acc_powers(power_drive), &
                                   self%acc_powers(power_beam_damping))
      end if
      if (.not. self%do_extrema) return
      call self%exact%extremum(flight, channel_gap, -1.0_dp, a, b, self%min_gap)
      call self%exact%extremum(flight, channel_gap, 1.0_dp, a, b, self%max_gap)
      do j = 1, self%n_modes
         call self%exact%extremum(flight, j, 1.0_dp, a, b, self%acc_modal(j, ext_max_free))
         call self%exact%extremum(flight, j, -1.0_dp, a, b, self%acc_modal(j, ext_min_free))
      end do
   end subroutine flight_piece

   subroutine observer_hermite_step(self, model, tau, h, y0, f0, y1, f1, in_contact)
      class(observer_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: h
      real(dp), intent(in) :: y0(:)
      real(dp), intent(in) :: f0(:)
      real(dp), intent(in) :: y1(:)
      real(dp), intent(in) :: f1(:)
      logical, intent(in) :: in_contact
      type(hermite_t) :: cubic
      self%cubic%y0 = y0
      self%cubic%f0 = f0
      self%cubic%y1 = y1
      self%cubic%f1 = f1
      ! A copy keeps the argument apart from self (which process updates).
      call move_alloc(self%cubic%y0, cubic%y0)
      call move_alloc(self%cubic%f0, cubic%f0)
      call move_alloc(self%cubic%y1, cubic%y1)
      call move_alloc(self%cubic%f1, cubic%f1)
      call process(self, model, tau, tau + h, in_contact, tau, h, cubic=cubic)
      call move_alloc(cubic%y0, self%cubic%y0)
      call move_alloc(cubic%f0, self%cubic%f0)
      call move_alloc(cubic%y1, self%cubic%y1)
      call move_alloc(cubic%f1, self%cubic%f1)
   end subroutine observer_hermite_step

   subroutine observer_contact_start(self, tau)
      class(observer_t), intent(inout) :: self
      real(dp), intent(in) :: tau
      if (self%done .or. tau >= self%max_periods*self%period_length) return
      self%contacts = self%contacts + 1
   end subroutine observer_contact_start

   !> The state at time t of the current source: the pair's dense output (at its time map's
   !> fraction of t), or the cubic over [origin, origin + h].
   subroutine state_at(origin, h, t, y, pair, cubic)
      real(dp), intent(in) :: origin
      real(dp), intent(in) :: h
      real(dp), intent(in) :: t
      real(dp), intent(out) :: y(:)
      class(embedded_pair_t), intent(in), optional :: pair
      type(hermite_t), intent(in), optional :: cubic
      if (present(pair)) then
         call pair%dense(pair%map%theta_at(t), y)
      else
         call hermite_cubic(cubic%y0, cubic%f0, cubic%y1, cubic%f1, h, (t - origin)/h, y)
      end if
   end subroutine state_at

   !> The function an extremum search minimises: V_T (kind 1), minus the normal force (2), or
   !> mode -kind's a_j (kind < 0); times sign (+1 or -1, for a maximum).
   subroutine target(model, kind, sign, origin, h, t, y, value, pair, cubic)
      type(model_t), intent(in) :: model
      integer, intent(in) :: kind
      real(dp), intent(in) :: sign
      real(dp), intent(in) :: origin
      real(dp), intent(in) :: h
      real(dp), intent(in) :: t
      real(dp), intent(inout) :: y(:)
      real(dp), intent(out) :: value
      class(embedded_pair_t), intent(in), optional :: pair
      type(hermite_t), intent(in), optional :: cubic
      type(contact_brackets_t) :: state
      call state_at(origin, h, t, y, pair, cubic)
      if (kind < 0) then
         value = sign*y(-kind)
      else if (kind == 1) then
         value = sign*model%tip_gap(t, y)
      else
         value = -sign*model%normal_force(t, y)
      end if
   end subroutine target

   !> Golden-section minimum of target(kind, sign) on [lo, hi]; value at the best point found.
   subroutine golden_minimum(model, kind, sign, origin, h, lo_in, hi_in, best, y, pair, cubic)
      type(model_t), intent(in) :: model
      integer, intent(in) :: kind
      real(dp), intent(in) :: sign
      real(dp), intent(in) :: origin
      real(dp), intent(in) :: h
      real(dp), intent(in) :: lo_in
      real(dp), intent(in) :: hi_in
      real(dp), intent(inout) :: best
      real(dp), intent(inout) :: y(:)
      class(embedded_pair_t), intent(in), optional :: pair
      type(hermite_t), intent(in), optional :: cubic
      real(dp), parameter :: g = (sqrt(5.0_dp) - 1)/2
      real(dp) :: lo, hi, x1, x2, f1, f2
      integer :: k
      lo = lo_in
      hi = hi_in
      x1 = hi - g*(hi - lo)
      x2 = lo + g*(hi - lo)
      call target(model, kind, sign, origin, h, x1, y, f1, pair, cubic)
      call target(model, kind, sign, origin, h, x2, y, f2, pair, cubic)
      do k = 1, golden_iterations
         if (f1 <= f2) then
            hi = x2
            x2 = x1
            f2 = f1
            x1 = hi - g*(hi - lo)
            call target(model, kind, sign, origin, h, x1, y, f1, pair, cubic)
         else
            lo = x1
            x1 = x2
            f1 = f2
            x2 = lo + g*(hi - lo)
            call target(model, kind, sign, origin, h, x2, y, f2, pair, cubic)
         end if
         if (hi - lo <= 4*epsilon(1.0_dp)*max(abs(lo), abs(hi))) exit
      end do
      best = min(best, f1, f2)
   end subroutine golden_minimum

   !> Accumulate [t_start, t_end] (one phase), finishing every period whose end it reaches.
   subroutine process(self, model, t_start, t_end, in_contact, origin, h, pair, cubic)
      class(observer_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: t_start
      real(dp), intent(in) :: t_end
      logical, intent(in) :: in_contact
      real(dp), intent(in) :: origin
      real(dp), intent(in) :: h
      class(embedded_pair_t), intent(in), optional :: pair
      type(hermite_t), intent(in), optional :: cubic
      real(dp) :: a, b, boundary
      logical :: pieces
      ! Without a group that integrates or locates, only the period boundaries are evaluated.
      pieces = self%do_lockin .or. self%do_extrema .or. self%do_force .or. self%do_energy
      a = t_start
      do while (a < t_end .and. .not. self%done)
         boundary = (self%n_periods + 1)*self%period_length
         if (pieces) then
            b = min(t_end, boundary, a + self%piece_max)
            if (b > a) call piece(self, model, a, b, in_contact, origin, h, pair, cubic)
         else
            b = min(t_end, boundary)
         end if
         if (in_contact .and. b > a) self%acc_contact_time = self%acc_contact_time + (b - a)
         if (b >= boundary) then
            call state_at(origin, h, boundary, self%y, pair, cubic)
            call finish_period(self)
         end if
         a = b
      end do
   end subroutine process

   !> Gauss-Legendre sums over [a, b] in one phase, and the extrema located in it.
   subroutine piece(self, model, a, b, in_contact, origin, h, pair, cubic)
      class(observer_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: a
      real(dp), intent(in) :: b
      logical, intent(in) :: in_contact
      real(dp), intent(in) :: origin
      real(dp), intent(in) :: h
      class(embedded_pair_t), intent(in), optional :: pair
      type(hermite_t), intent(in), optional :: cubic
      real(dp) :: t(0:gl_points + 1), gap(0:gl_points + 1), force(0:gl_points + 1), gap_rate(0:1)
      real(dp) :: power(n_powers), energy, weight, half, mid, tip_u, best, s1, c1, sk, ck, next
      real(dp) :: nodes(gl_points), weights(gl_points), gl_weight(gl_points), theta_nodes(gl_points)
      real(dp) :: theta_a, theta_b
      type(contact_brackets_t) :: state
      integer :: i, k, n, i_best, m
      logical :: wet, forced

      n = self%n_modes
      wet = .false.
      half = (b - a)/2
      mid = (a + b)/2
      ! A fixed step's cubic needs fewer points than the pairs' higher-degree dense output.
      if (present(cubic)) then
         m = hermite_points
         nodes(1:m) = self%gl3_x
         weights(1:m) = self%gl3_w
      else
         m = gl_points
         nodes(1:m) = self%gl_x
         weights(1:m) = self%gl_w
      end if
      t(0) = a
      t(m + 1) = b
      t(1:m) = mid + half*nodes(1:m)
      gl_weight(1:m) = half*weights(1:m)
      if (present(pair)) then
         if (pair%map%warped) then
            ! A warped step (after a contact entry): the nodes are Gauss-Legendre in sigma, where
            ! the integrands are smooth, weighted by dtau/dsigma.
            theta_a = pair%map%theta_at(a)
            theta_b = pair%map%theta_at(b)
            theta_nodes(1:m) = (theta_a + theta_b)/2 + (theta_b - theta_a)/2*nodes(1:m)
            t(1:m) = pair%map%time_at(theta_nodes(1:m))
            gl_weight(1:m) = (theta_b - theta_a)/2*weights(1:m)*pair%map%rate_at(theta_nodes(1:m))
         end if
      end if
      force = 0
      do i = 0, m + 1
         ! The ends serve only the located extrema.
         if ((i == 0 .or. i == m + 1) .and. .not. (self%do_extrema .or. self%do_force)) cycle
         call state_at(origin, h, t(i), self%y, pair, cubic)
         if ((i == 0 .or. i == m + 1) .and. present(pair)) then
            ! A pair's piece ends also give the rates: whether an extremum may lie just inside.
            call model%gap_at_phase(self%y, sin(self%omega*t(i)), cos(self%omega*t(i)), gap(i), &
                                    gap_rate(min(i, 1)))
            self%modal_rates(min(i, 1), :) = self%y(n + 1:2*n)
         else
            gap(i) = model%tip_gap(t(i), self%y)
         end if
         if (self%do_extrema) self%modal_nodes(i, :) = self%y(1:n)
         ! A meniscus holds the tip in this flight (its flag, constant over a step).
         wet = model%wet(self%y) .and. .not. in_contact
         if ((in_contact .or. model%long_range .or. wet) .and. (self%do_force .or. self%do_energy)) then
            ! The normal force: in contact, and under 'dmt_vdw' the attraction in flight too (the
            ! viscoelastic part with a viscoelastic sample; a meniscus's pull while it holds).
            force(i) = model%normal_force(t(i), self%y, in_contact)
         end if
         if (i == 0 .or. i == m + 1) cycle
         weight = gl_weight(i)
         tip_u = gap(i) - model%scene%delta_hat
         if (self%do_lockin) then
            ! sin(k Omega t), cos(k Omega t) by the angle-addition recurrence.
            s1 = sin(self%omega*t(i))
            c1 = cos(self%omega*t(i))
            sk = s1
            ck = c1
            do k = 1, self%harmonics
               self%acc_sin(k) = self%acc_sin(k) + weight*gap(i)*sk
               self%acc_cos(k) = self%acc_cos(k) + weight*gap(i)*ck
               next = sk*c1 + ck*s1
               ck = ck*c1 - sk*s1
               sk = next
            end do
            if (self%general_drive) then
               call tone_sums(model, s1, c1, weight*gap(i), tip_u, weight)
            else
               self%acc_deflection = self%acc_deflection + weight*(tip_u - model%scene%alpha2*s1)
            end if
         end if
         if (self%do_energy) then
            if (self%n_state > 2*n) then
               ! A viscoelastic sample: its dashpot w sets the viscoelastic power.
               call model%energy_flow(t(i), self%y(1:n), self%y(n + 1:2*n), in_contact, power, energy, &
                                      self%y(2*n + 1), wet)
            else
               call model%energy_flow(t(i), self%y(1:n), self%y(n + 1:2*n), in_contact, power, energy, wet=wet)
            end if
            self%acc_powers = self%acc_powers + weight*power
            self%acc_virial = self%acc_virial + weight*force(i)*tip_u
         end if
      end do
      ! The force's extrema: in contact, and under 'dmt_vdw' in flight too (the attraction; a
      ! meniscus's pull while it holds).
      forced = in_contact .or. model%long_range .or. wet
      if (self%do_force .and. forced) then
         call locate_peak_force()
         call locate_min_force()
      end if
      if (.not. self%do_extrema) return

      i_best = minloc(gap(0:m + 1), 1) - 1
      best = gap(i_best)
      if (beats(-best, -self%min_gap)) then
         if (searched(i_best, end_rate(i_best, 1))) &
            call golden_minimum(model, 1, 1.0_dp, origin, h, t(max(i_best - 1, 0)), t(min(i_best + 1, m + 1)), &
                                best, self%y, pair, cubic)
         self%min_gap = min(self%min_gap, best)
      end if
      call locate_extremum(self%max_gap, gap(0:m + 1), 1, 1.0_dp)
      do k = 1, n
         if (in_contact) then
            call locate_extremum(self%acc_modal(k, ext_max_contact), self%modal_nodes(0:m + 1, k), -k, 1.0_dp)
            call locate_extremum(self%acc_modal(k, ext_min_contact), self%modal_nodes(0:m + 1, k), -k, -1.0_dp)
         else
            call locate_extremum(self%acc_modal(k, ext_max_free), self%modal_nodes(0:m + 1, k), -k, 1.0_dp)
            call locate_extremum(self%acc_modal(k, ext_min_free), self%modal_nodes(0:m + 1, k), -k, -1.0_dp)
         end if
      end do

   contains

      !> A general drive's lock-in sums at each tone, and the mean deflection less Y.
      subroutine tone_sums(model, s1, c1, weighted_gap, tip_u, weight)
         type(model_t), intent(in) :: model
         real(dp), intent(in) :: s1, c1, weighted_gap, tip_u, weight
         real(dp) :: sin_tone(max_tones), cos_tone(max_tones), base, base_rate, base_accel
         call model%drive%tones(s1, c1, sin_tone, cos_tone)
         self%acc_tone_sin = self%acc_tone_sin + weighted_gap*sin_tone
         self%acc_tone_cos = self%acc_tone_cos + weighted_gap*cos_tone
         call model%drive%base(s1, c1, base, base_rate, base_accel)
         self%acc_deflection = self%acc_deflection + weight*(tip_u - base)
      end subroutine tone_sums

      !> Raise the running peak force by the nodes' best, located by a golden-section search.
      subroutine locate_peak_force()
         i_best = maxloc(force(0:m + 1), 1) - 1
         best = -force(i_best)
         if (beats(-best, self%peak_force)) then
            if (searched(i_best, end_rate(i_best, 1))) &
               call golden_minimum(model, 2, 1.0_dp, origin, h, t(max(i_best - 1, 0)), t(min(i_best + 1, m + 1)), &
                                   best, self%y, pair, cubic)
            self%peak_force = max(self%peak_force, -best)
         end if
      end subroutine locate_peak_force

      !> The most attractive force: the minimum of the force at the nodes, located.
      subroutine locate_min_force()
         i_best = minloc(force(0:m + 1), 1) - 1
         best = force(i_best)
         if (beats(-best, -self%min_force)) then
            ! In flight the attraction grows as the gap closes (min V_T's rule); in contact the
            ! force falls as the gap opens.
            if (searched(i_best, merge(-end_rate(i_best, 1), end_rate(i_best, 1), in_contact))) &
               call golden_minimum(model, 2, -1.0_dp, origin, h, t(max(i_best - 1, 0)), t(min(i_best + 1, m + 1)), &
                                   best, self%y, pair, cubic)
            self%min_force = min(self%min_force, best)
         end if
      end subroutine locate_min_force

      !> Raise the running maximum (direction 1; running minimum for -1) `extreme` of the
      !> values at the nodes, located by a golden-section search around an interior best node.
      subroutine locate_extremum(extreme, values, kind, direction)
         real(dp), intent(inout) :: extreme
         real(dp), intent(in) :: values(0:)
         integer, intent(in) :: kind
         real(dp), intent(in) :: direction
         integer :: j
         real(dp) :: found
         j = maxloc(direction*values, 1) - 1
         if (.not. beats(direction*values(j), direction*extreme)) return
         found = -direction*values(j)
         if (searched(j, -direction*end_rate(j, kind))) &
            call golden_minimum(model, kind, -direction, origin, h, t(max(j - 1, 0)), t(min(j + 1, m + 1)), found, &
                                self%y, pair, cubic)
         extreme = -direction*found
      end subroutine locate_extremum

      !> Whether the best node i is searched around: an interior node always; on a pair's step a
      !> piece end too, when the function searched (whose minimum is sought) falls into the piece
      !> there (slope: its rate at the end), so that its minimum lies between the end and the
      !> next node: the two pieces that share an end would otherwise both miss it.
      logical function searched(i, slope)
         integer, intent(in) :: i
         real(dp), intent(in) :: slope
         searched = i > 0 .and. i < m + 1
         if (searched .or. .not. present(pair)) return
         if (i == 0) then
            searched = slope < 0
         else
            searched = slope > 0
         end if
      end function searched

      !> The rate at node i, if it is an end of a pair's piece, of mode -kind's a_j (kind < 0) or
      !> of V_T (kind 1; also for the force's maximum, which comes with V_T's minimum); else 0
      !> (not used).
      real(dp) function end_rate(i, kind)
         integer, intent(in) :: i
         integer, intent(in) :: kind
         end_rate = 0
         if (.not. (present(pair) .and. (i == 0 .or. i == m + 1))) return
         if (kind < 0) then
            end_rate = self%modal_rates(min(i, 1), -kind)
         else
            end_rate = gap_rate(min(i, 1))
         end if
      end function end_rate

      !> Whether a node's value may raise the running maximum `extreme`: if it is larger, and
      !> on a pair's step also if it is equal (the node is then the end this piece shares with
      !> the last one, and the extremum may lie just inside this piece).
      logical function beats(value, extreme)
         real(dp), intent(in) :: value, extreme
         beats = value > extreme .or. (value == extreme .and. present(pair))
      end function beats
   end subroutine piece

   !> Close the current period: its observables, its end's Poincare point (in self%y), and the
   !> steady-state test.
   subroutine finish_period(self)
      class(observer_t), intent(inout) :: self
      real(dp) :: s, c, period, nan
      integer :: k, m

      period = self%period_length
      m = self%n_periods + 1
      do k = 1, self%harmonics
         s = 2*self%acc_sin(k)/period
         c = 2*self%acc_cos(k)/period
         self%harmonic_amplitude(m, k) = hypot(s, c)
         self%harmonic_phase(m, k) = atan2(c, s)*180/pi
      end do
      associate (v => self%values(m, :))
         v(obs_amplitude) = self%harmonic_amplitude(m, 1)
         v(obs_phase) = self%harmonic_phase(m, 1)
         v(obs_mean_deflection) = self%acc_deflection/period
         v(obs_min_gap) = self%min_gap
         v(obs_peak_force) = merge(self%peak_force, 0.0_dp, self%peak_force > -huge(1.0_dp))
         v(obs_min_force) = merge(self%min_force, 0.0_dp, self%min_force < huge(1.0_dp))
         v(obs_contact_time) = self%acc_contact_time
         v(obs_contacts) = self%contacts
         v(obs_dissipated_beam) = -self%acc_powers(power_beam_damping)
         v(obs_dissipated_contact_damping) = -self%acc_powers(power_contact_damping)
         v(obs_dissipated_friction) = -self%acc_powers(power_contact_friction)
         v(obs_dissipated_viscoelastic) = -self%acc_powers(power_contact_viscoelastic)
         v(obs_dissipated_adhesion) = -self%acc_powers(power_contact_adhesion)
         v(obs_dissipated) = v(obs_dissipated_beam) + v(obs_dissipated_contact_damping) &
                             + v(obs_dissipated_friction) + v(obs_dissipated_viscoelastic) &
                             + v(obs_dissipated_adhesion)
         v(obs_drive_work) = self%acc_powers(power_drive)
         v(obs_virial) = self%acc_virial/period
         v(obs_contact_normal_work) = self%acc_powers(power_contact_normal)
         ! Each tone's lock-in (one tone at phase 0: harmonic 1; no second tone: 0 and 0, the
         ! drive has nothing there).
         v(obs_tone_amplitude) = 0
         v(obs_tone_phase) = 0
         if (self%general_drive) then
            do k = 1, self%n_tones
               s = 2*self%acc_tone_sin(k)/period
               c = 2*self%acc_tone_cos(k)/period
               v(obs_tone_amplitude(k)) = hypot(s, c)
               v(obs_tone_phase(k)) = atan2(c, s)*180/pi
            end do
            ! With a general drive `amplitude` and `phase` are tone 1's lock-in (what an AM-AFM
            ! controller holds); the harmonics stay those of the common period.
            v(obs_amplitude) = v(obs_tone_amplitude(1))
            v(obs_phase) = v(obs_tone_phase(1))
         else
            v(obs_tone_amplitude(1)) = v(obs_amplitude)
            v(obs_tone_phase(1)) = v(obs_phase)
         end if
      end associate
      self%max_gap_values(m) = self%max_gap
      self%modal_extrema(m, :, :) = self%acc_modal
      nan = ieee_value(1.0_dp, ieee_quiet_nan)
      where (abs(self%acc_modal) >= huge(1.0_dp)) self%modal_extrema(m, :, :) = nan
      ! The groups not asked for are NaN, never a stale or default number.
      where (.not. group_columns(self%groups)) self%values(m, :) = nan
      if (.not. self%do_lockin) then
         self%harmonic_amplitude(m, :) = nan
         self%harmonic_phase(m, :) = nan
      end if
      if (.not. self%do_extrema) then
         self%max_gap_values(m) = nan
         self%modal_extrema(m, :, :) = nan
      end if
      self%poincare(:, m) = self%y
      self%n_periods = m
      call reset(self)
      ! Only a period with a switch has the jitter of a misplaced one.
      self%jitter_floor(m) = 0
      if (self%values(m, obs_contacts) > 0 .or. (self%values(m, obs_contact_time) > 0 .and. &
                                                  self%values(m, obs_contact_time) < (1 - 1.0e-9_dp)*period)) &
         self%jitter_floor(m) = jitter_level(self%jitter, self%y)
      if (self%stop_at_steady .or. m == self%max_periods) then
         call steady_test(self%poincare(:, 0:m), self%p_max, self%tol, self%repeats, self%found_period, &
                          self%reason, self%closest, self%closest_lag, self%jitter_floor(0:m))
         if (self%stop_at_steady .and. self%found_period > 0) self%done = .true.
      end if
      if (self%n_attractors > 0 .and. self%found_period == 0) then
         call match_attractors(self)
         if (self%attractor > 0) then
            k = self%attractor
            self%found_period = self%attractor_first(k + 1) - self%attractor_first(k)
            self%reason = steady_found
            if (self%stop_at_steady) self%done = .true.
         end if
      end if
      if (m == self%max_periods) self%done = .true.
   end subroutine finish_period

   !> Follow the newest Poincare point on the known attractors: a point within capture*size of
   !> orbit k's point q continues a match in progress when it is the same orbit, q is the point
   !> after the previous one (cyclically) and it is closer than the previous point (the run
   !> approaches the orbit); `confirm` points in a row set self%attractor.
   subroutine match_attractors(self)
      class(observer_t), intent(inout) :: self
      integer :: k, q, p, expected, found_k, found_q
      real(dp) :: distance, best
      associate (point => self%poincare(:, self%n_periods))
         found_k = 0
         found_q = 0
         best = huge(1.0_dp)
         do k = 1, self%n_attractors
            do q = self%attractor_first(k), self%attractor_first(k + 1) - 1
               distance = maxval(abs(point - self%attractor_points(:, q)))/self%attractor_size(k)
               if (distance <= self%capture .and. distance < best) then
                  best = distance
                  found_k = k
                  found_q = q
               end if
            end do
         end do
      end associate
      if (found_k == 0) then
         self%match_streak = 0
      else
         if (self%match_streak > 0 .and. found_k == self%match_attractor) then
            p = self%attractor_first(found_k + 1) - self%attractor_first(found_k)
            expected = self%attractor_first(found_k) + &
                       mod(self%match_point - self%attractor_first(found_k) + 1, p)
            if (found_q == expected .and. best < self%match_distance) then
               self%match_streak = self%match_streak + 1
            else
               self%match_streak = 1
            end if
         else
            self%match_streak = 1
         end if
         self%match_attractor = found_k
         self%match_point = found_q
         self%match_distance = best
      end if
      if (self%match_streak >= self%confirm) self%attractor = self%match_attractor
   end subroutine match_attractors

   !> Factors from each column's model units to its SI-derived unit (nm, deg, nN, us, 1, aJ).
   pure function observable_factors(scales) result(factors)
      type(scales_t), intent(in) :: scales
      real(dp) :: factors(n_observables)
      real(dp) :: nm, energy
      nm = scales%length*1.0e9_dp
      energy = scales%energy*1.0e18_dp
      factors = energy
      factors(obs_amplitude) = nm
      factors(obs_phase) = 1
      factors(obs_mean_deflection) = nm
      factors(obs_min_gap) = nm
      factors(obs_peak_force) = scales%force*1.0e9_dp
      factors(obs_min_force) = scales%force*1.0e9_dp
      factors(obs_contact_time) = scales%time*1.0e6_dp
      factors(obs_contacts) = 1
      factors(obs_virial) = scales%force_length*1.0e18_dp
      factors(obs_tone_amplitude) = nm
      factors(obs_tone_phase) = 1
   end function observable_factors

end module tmafm_observers

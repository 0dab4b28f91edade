!> The sampled trajectory of a run, its work counters, and the checks made on each new state.
!>
!> Memory is O(samples + switches): the trajectory never holds the steps.
module tmafm_trajectory
   use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
   use tmafm_kinds, only: dp, i8
   use tmafm_errors, only: ok, err_blowup, err_runtime, err_interrupted
   use tmafm_model, only: model_t
   use tmafm_settings, only: run_settings_t, sample_count, method_rk4_paper, method_rk4_event
   use tmafm_posix, only: prefault
   implicit none
   private

   public :: trajectory_t, init_trajectory, check_blowup, progress_t, chatter_switches, stop_poll, &
      poll_every, poll_interval_ms, poll_spacing

   !> Chatter: this many switches within one step length (or with no progress in tau) end
   !> the run.  A real contact needs two switches, a grazing one inside a single step too, so
   !> a run with more than this many switches within one step length is not resolving them.
   integer, parameter :: chatter_switches = 16

   !> The drive phase at the samples is carried by angle addition from one sample to the next
   !> and taken afresh from sin and cos every this many samples: the drift of the rotation
   !> (a few ulp per sample) stays below 32 x 4 eps, under the rounding of Omega tau itself
   !> past tau ~ 100 (tests/test_sampling.py).
   integer, parameter, public :: phase_anchor_every = 32

   !> The sampled trajectory and the work counters of one run.
   type :: trajectory_t
      !> Sample times tau_k = (first_sample + k - 1) sample_dtau.
      real(dp), allocatable :: tau(:)
      !> Tip gap V_T at the samples.
      real(dp), allocatable :: vt(:)
      !> Tip gap rate dV_T/dtau at the samples.
      real(dp), allocatable :: vtdot(:)
      !> 1 where V_T <= 0 (in contact) at the sample, else 0.
      integer, allocatable :: contact(:)
      !> Modal amplitudes, samples x N.
      real(dp), allocatable :: a(:, :)
      !> Modal velocities, samples x N.
      real(dp), allocatable :: adot(:, :)
      !> With a viscoelastic sample: its dashpot coordinate w at the samples (tmafm_viscoelastic);
      !> not allocated without one.
      real(dp), allocatable :: dashpot(:)
      !> With a capillary meniscus: 1 where it holds the tip in flight at the sample, else 0 (its
      !> flag in the state, tmafm_model); not allocated without one.
      integer, allocatable :: meniscus(:)
      !> Times of the phase changes (located switches, or step starts for rk4_paper).
      real(dp), allocatable :: switch_tau(:)
      !> Number of entries of switch_tau in use.
      integer :: n_switches = 0
      !> Index of the next sample to fill.
      integer :: next_sample = 1
      !> Sample spacing (settings%sample_dtau).
      real(dp) :: sample_dtau = 0
      !> The output window (settings%first_sample): sample 1 is the run's sample of this index,
      !> at tau = first_sample sample_dtau.  With a window (first_sample > 0) the start state,
      !> which every run loop stores first, is not kept (store).
      integer(i8) :: first_sample = 0
      !> .false. until the first store (the start state at tau = 0).
      logical :: started = .false.
      !> sin and cos of Omega tau at the last sample filled.
      real(dp) :: last_sin = 0, last_cos = 1
      !> cos and sin of Omega sample_dtau: the rotation from one sample to the next (set at the
      !> first sample, from the model the run uses).
      real(dp) :: step_cos = 1, step_sin = 0
      !> Steps accepted, in all and in contact.
      integer(i8) :: steps = 0, contact_steps = 0
      !> Steps rejected by an error controller.
      integer(i8) :: rejected_steps = 0
      !> Right-hand-side evaluations.
      integer(i8) :: rhs_evaluations = 0
      !> Work charged against &solver max_steps: steps tried (accepted or rejected), event
      !> iterations (root-search trials, flight-scan points) and exact flights.
      integer(i8) :: work = 0
   contains
      !> Store the state y at sample time tau in the next free sample.
      procedure :: store => trajectory_store
      !> sin(Omega tau) and cos(Omega tau) at the next sample (what store_at_phase takes).
      procedure :: next_phase => trajectory_next_phase
      !> Store y in the next free sample, whose drive phase next_phase gave.
      procedure :: store_at_phase => trajectory_store_at_phase
      !> How many of the samples still to fill lie at or before tau.
      procedure :: samples_by => trajectory_samples_by
      !> sin(Omega tau) and cos(Omega tau) at the next count samples (what commit_rows takes).
      procedure :: next_phases => trajectory_next_phases
      !> Complete the next count samples, whose rows of a and adot the caller filled and whose
      !> phases next_phases gave: V_T, its rate and the flags.
      procedure :: commit_rows => trajectory_commit_rows
      !> The time of the next sample still to fill (huge when all are filled).
      procedure :: next_time => trajectory_next_time
      !> .true. once every sample is filled.
      procedure :: complete => trajectory_complete
      !> Record a phase change at tau; fails on chatter (see chatter_switches).
      procedure :: add_switch => trajectory_add_switch
      !> Charge units of work against &solver max_steps; fails once the budget is spent.
      procedure :: charge => trajectory_charge
   end type trajectory_t

   !> A run with a poll asks it at its first update (step, flight or flight sample chunk), then
   !> looks at the clock every poll_every updates and asks it again once the wall time since
   !> the last poll returned is both poll_interval_ms and poll_spacing times what that poll took.
   !> A poll from Python takes the GIL: about 550 instructions when the GIL is free, up to the
   !> 5 ms switch interval while another thread runs Python code, so the polls' rate is bounded
   !> by time, not steps, and they take at most about 1/(1 + poll_spacing) of the run's wall
   !> time.  The cheapest steps (rk4_paper, N = 1) take about 0.4 us, the dearest (dop853 at
   !> rtol 1e-10 with N = 30) 8 to 13 us; a Ctrl-C stops a run within about poll_interval_ms
   !> plus poll_every updates: about 10 ms of CPU (benchmarks/poll_cost.py measures it).
   integer, parameter :: poll_every = 256
   !> Least wall time between the end of a poll and the next one (milliseconds).
   integer, parameter :: poll_interval_ms = 10
   !> Least wall time between polls, in units of the last poll's own wall time.
   integer, parameter :: poll_spacing = 10

   abstract interface
      !> A caller's poll: .true. asks the run to stop (tmafm_errors err_interrupted).  It must
      !> be safe to call from the thread that runs it (the library calls it only from there).
      logical function stop_poll()
      end function stop_poll
   end interface

   !> A progress reporter that writes a line per tenth of the run, and the caller's poll.
   type :: progress_t
      !> Output unit; no output when negative.
      integer :: unit = -1
      !> Next tenth to report.
      integer :: mark = 1
      !> The caller's poll (none when null): asked at the first update, then as poll_every says.
      procedure(stop_poll), pointer, nopass :: poll => null()
      !> Updates left until the next look at the clock.
      integer :: countdown = 1
      !> system_clock count when the last poll returned (-1: not polled yet).
      integer(i8) :: polled_at = -1
      !> system_clock counts the last poll took.
      integer(i8) :: poll_took = 0
   contains
      !> Report if tau passed the next tenth of tau_end; poll the caller (ierr = err_interrupted
      !> when it asks to stop).
      procedure :: update => progress_update
      !> Only poll the caller, as update does (for work between updates: flight sample chunks).
      procedure :: tick => progress_tick
   end type progress_t

contains

   !> Allocate a trajectory for a run of `settings` with n_modes modes.
   subroutine init_trajectory(traj, settings, n_modes, with_dashpot, with_meniscus)
      type(trajectory_t), intent(out) :: traj
      type(run_settings_t), intent(in) :: settings
      integer, intent(in) :: n_modes
      !> Keep the viscoelastic sample's dashpot coordinate at the samples too.
      logical, intent(in), optional :: with_dashpot
      !> Keep the meniscus's flag at the samples too.
      logical, intent(in), optional :: with_meniscus
      integer :: n, k
      n = sample_count(settings)
      allocate (traj%tau(n), traj%vt(n), traj%vtdot(n), traj%contact(n), traj%a(n, n_modes), &
                traj%adot(n, n_modes), traj%switch_tau(64))
      ! Every sample is written once: map the pages in one call each, not a fault per page.
      call prefault(traj%tau, 8*int(n, i8))
      call prefault(traj%vt, 8*int(n, i8))
      call prefault(traj%vtdot, 8*int(n, i8))
      call prefault(traj%contact, storage_size(traj%contact, i8)/8*n)
      call prefault(traj%a, 8*int(n, i8)*n_modes)
      call prefault(traj%adot, 8*int(n, i8)*n_modes)
      ! The same expression as without a window: a window's samples are the run's, bit for bit.
      do k = 1, n
         traj%tau(k) = real(settings%first_sample + (k - 1), dp)*settings%sample_dtau
      end do
      traj%sample_dtau = settings%sample_dtau
      traj%first_sample = settings%first_sample
      if (present(with_dashpot)) then
         if (with_dashpot) allocate (traj%dashpot(n), source=0.0_dp)
      end if
      if (present(with_meniscus)) then
         if (with_meniscus) allocate (traj%meniscus(n), source=0)
      end if
   end subroutine init_trajectory

   pure function trajectory_next_time(self) result(tau)
      class(trajectory_t), intent(in) :: self
      real(dp) :: tau
      if (self%next_sample > size(self%tau)) then
         tau = huge(1.0_dp)
      else
         tau = self%tau(self%next_sample)
      end if
   end function trajectory_next_time

   pure function trajectory_complete(self) result(done)
      class(trajectory_t), intent(in) :: self
      logical :: done
      done = self%next_sample > size(self%tau)
   end function trajectory_complete

   pure subroutine trajectory_store(self, model, y)
      class(trajectory_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      real(dp), contiguous, intent(in) :: y(:)
      real(dp) :: sin_phase, cos_phase
      if (.not. self%started) then
         ! The run loops store the start state first; a window that starts later drops it.
         self%started = .true.
         if (self%first_sample > 0) return
      end if
      call self%next_phase(model, sin_phase, cos_phase)
      call self%store_at_phase(model, y, sin_phase, cos_phase)
   end subroutine trajectory_store

   !> Samples are filled in order, so the phase of sample k is that of sample k - 1 turned
   !> by Omega sample_dtau; every phase_anchor_every samples of the run (the first included)
   !> it is sin and cos of Omega tau_k.  A window's first sample between anchors takes the
   !> phase the run would have carried there (window_phase), so its samples are the run's.
   pure subroutine trajectory_next_phase(self, model, sin_phase, cos_phase)
      class(trajectory_t), intent(in) :: self
      type(model_t), intent(in) :: model
      real(dp), intent(out) :: sin_phase
      real(dp), intent(out) :: cos_phase
      integer :: k
      real(dp) :: last_sin, last_cos, step_sin, step_cos
      k = self%next_sample
      if (mod(self%first_sample + (k - 1), int(phase_anchor_every, i8)) == 0) then
         call model%phase(self%tau(k), sin_phase, cos_phase)
      else if (k == 1) then
         call window_phase(self, model, last_sin, last_cos, step_sin, step_cos)
         sin_phase = last_sin*step_cos + last_cos*step_sin
         cos_phase = last_cos*step_cos - last_sin*step_sin
      else
         sin_phase = self%last_sin*self%step_cos + self%last_cos*self%step_sin
         cos_phase = self%last_cos*self%step_cos - self%last_sin*self%step_sin
      end if
   end subroutine trajectory_next_phase

   !> The phase the run carries at the sample before a window's first one (first_sample - 1),
   !> between two anchors: from the anchor before it, turned sample by sample as the run
   !> turns it; and the turn (step_sin, step_cos).
   pure subroutine window_phase(self, model, last_sin, last_cos, step_sin, step_cos)
      class(trajectory_t), intent(in) :: self
      type(model_t), intent(in) :: model
      real(dp), intent(out) :: last_sin, last_cos, step_sin, step_cos
      integer(i8) :: anchor, i
      real(dp) :: turned
      call model%phase(self%sample_dtau, step_sin, step_cos)
      anchor = self%first_sample - mod(self%first_sample, int(phase_anchor_every, i8))
      call model%phase(real(anchor, dp)*self%sample_dtau, last_sin, last_cos)
      do i = anchor + 1, self%first_sample - 1
         turned = last_sin*step_cos + last_cos*step_sin
         last_cos = last_cos*step_cos - last_sin*step_sin
         last_sin = turned
      end do
   end subroutine window_phase

   !> One row: the state copied, V_T and its rate from model%gap_at_phase (their definition).
   pure subroutine trajectory_store_at_phase(self, model, y, sin_phase, cos_phase)
      class(trajectory_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      real(dp), contiguous, intent(in) :: y(:)
      real(dp), intent(in) :: sin_phase
      real(dp), intent(in) :: cos_phase
      real(dp) :: vt, vtdot
      integer :: k
      k = self%next_sample
      if (k == 1) call model%phase(self%sample_dtau, self%step_sin, self%step_cos)
      call put_row(model%n_modes, size(self%tau), k, y, self%a, self%adot)
      if (allocated(self%dashpot) .and. size(y) > 2*model%n_modes) self%dashpot(k) = y(2*model%n_modes + 1)
      if (allocated(self%meniscus)) self%meniscus(k) = merge(1, 0, model%wet(y))
      call model%gap_at_phase(y, sin_phase, cos_phase, vt, vtdot)
      self%vt(k) = vt
      self%vtdot(k) = vtdot
      self%contact(k) = merge(1, 0, vt <= 0)
      self%last_sin = sin_phase
      self%last_cos = cos_phase
      self%next_sample = k + 1
   end subroutine trajectory_store_at_phase

   pure integer function trajectory_samples_by(self, tau) result(count)
      class(trajectory_t), intent(in) :: self
      real(dp), intent(in) :: tau
      integer :: k
      k = self%next_sample
      do while (k <= size(self%tau))
         if (.not. (self%tau(k) <= tau)) exit
         k = k + 1
      end do
      count = k - self%next_sample
   end function trajectory_samples_by

   !> The phases next_phase would give, sample after sample, for the next count samples
   !> (count <= the samples left to fill).
   pure subroutine trajectory_next_phases(self, model, count, sin_phase, cos_phase)
      class(trajectory_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      integer, intent(in) :: count
      real(dp), intent(out) :: sin_phase(count)
      real(dp), intent(out) :: cos_phase(count)
      real(dp) :: last_sin, last_cos, step_sin, step_cos
      integer :: i, k, since
      if (count < 1) return
      k = self%next_sample
      if (k == 1) call model%phase(self%sample_dtau, self%step_sin, self%step_cos)
      last_sin = self%last_sin
      last_cos = self%last_cos
      if (k == 1 .and. self%first_sample > 0) call window_phase(self, model, last_sin, last_cos, step_sin, step_cos)
      step_sin = self%step_sin
      step_cos = self%step_cos
      since = int(mod(self%first_sample + (k - 1), int(phase_anchor_every, i8)))
      do i = 1, count
         if (since == 0) then
            call model%phase(self%tau(k + i - 1), sin_phase(i), cos_phase(i))
         else
            sin_phase(i) = last_sin*step_cos + last_cos*step_sin
            cos_phase(i) = last_cos*step_cos - last_sin*step_sin
         end if
         last_sin = sin_phase(i)
         last_cos = cos_phase(i)
         since = since + 1
         if (since == phase_anchor_every) since = 0
      end do
   end subroutine trajectory_next_phases

   !> store_at_phase for count samples at once, for a caller that wrote their states straight
   !> into rows next_sample .. next_sample + count - 1 of a and adot (tmafm_flight's samples);
   !> their drive phases are sin_phase(i), cos_phase(i).  V_T and its rate are model%gap_rows's
   !> (gap_at_phase's sums, the same bits), from the stored rows, a mode at a time.
   pure subroutine trajectory_commit_rows(self, model, count, sin_phase, cos_phase)
      class(trajectory_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      integer, intent(in) :: count
      real(dp), intent(in) :: sin_phase(count)
      real(dp), intent(in) :: cos_phase(count)
      integer :: k, rows
      if (count < 1) return
      k = self%next_sample
      if (k == 1) call model%phase(self%sample_dtau, self%step_sin, self%step_cos)
      rows = size(self%tau)
      call model%gap_rows(rows, k, count, self%a, self%adot, sin_phase, cos_phase, self%vt, self%vtdot)
      call put_flags(rows, k, count, self%vt, self%contact)
      self%last_sin = sin_phase(count)
      self%last_cos = cos_phase(count)
      self%next_sample = k + count
   end subroutine trajectory_commit_rows

   !> Row k of a and adot (rows x n) from the state y = (a, a').
   pure subroutine put_row(n, rows, k, y, a, adot)
      integer, intent(in) :: n, rows, k
      real(dp), intent(in) :: y(2*n)
      real(dp), intent(inout) :: a(rows, n), adot(rows, n)
      integer :: j
      do j = 1, n
         a(k, j) = y(j)
         adot(k, j) = y(n + j)
      end do
   end subroutine put_row

   !> contact(i) = 1 where vt(i) <= 0, else 0, for rows k .. k + count - 1.
   pure subroutine put_flags(rows, k, count, vt, contact)
      integer, intent(in) :: rows, k, count
      real(dp), intent(in) :: vt(rows)
      integer, intent(inout) :: contact(rows)
      integer :: i
      do i = k, k + count - 1
         contact(i) = merge(1, 0, vt(i) <= 0)
      end do
   end subroutine put_flags

   !> step is the length of the step that found the switch (or the method's nominal step).
   pure subroutine trajectory_add_switch(self, tau, step, ierr, errmsg)
      class(trajectory_t), intent(inout) :: self
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: step
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      real(dp), allocatable :: grown(:)
      real(dp) :: span
      ierr = ok
      if (self%n_switches >= chatter_switches) then
         span = tau - self%switch_tau(self%n_switches - chatter_switches + 1)
         if (span <= step) then
            ierr = err_runtime
            write (errmsg, '(a,es13.6e3,a,i0,a,es10.3e3,a,es10.3e3,a)') 'switch chatter at tau = ', &
               tau, ': ', chatter_switches + 1, ' phase changes within ', span, &
               ', not more than one step (', step, '): the contact flips faster than any step '// &
               'resolves; check the contact damping and stiffness of the scene, or reduce &solver dtau'
            return
         end if
      end if
      if (self%n_switches == size(self%switch_tau)) then
         allocate (grown(2*size(self%switch_tau)))
         grown(1:self%n_switches) = self%switch_tau
         call move_alloc(grown, self%switch_tau)
      end if
      self%n_switches = self%n_switches + 1
      self%switch_tau(self%n_switches) = tau
   end subroutine trajectory_add_switch

   !> The budget is checked where the work is done, so no loop can outrun it.
   pure subroutine trajectory_charge(self, settings, tau, units, ierr, errmsg)
      class(trajectory_t), intent(inout) :: self
      type(run_settings_t), intent(in) :: settings
      real(dp), intent(in) :: tau
      integer, intent(in) :: units
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      ierr = ok
      self%work = self%work + units
      if (self%work <= settings%max_steps) return
      ierr = err_runtime
      write (errmsg, '(a,i0,a,es13.6e3,a,es10.3e3,a,i0,a,i0,a)') '&solver max_steps = ', &
         settings%max_steps, ' spent at tau = ', tau, ' of tau_end = ', settings%tau_end, ' (', &
         self%steps + self%rejected_steps, ' steps tried, ', &
         self%work - self%steps - self%rejected_steps, ' event iterations): raise &solver '// &
         'max_steps, or ask for less work (larger dtau or rtol, shorter tau_end)'
   end subroutine trajectory_charge

   !> Fail with err_blowup if the new state is not finite or an amplitude ran away.
   subroutine check_blowup(model, settings, tau, h, in_contact, y, ierr, errmsg)
      type(model_t), intent(in) :: model
      type(run_settings_t), intent(in) :: settings
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: h
      logical, intent(in) :: in_contact
      real(dp), intent(in) :: y(:)
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      character(len=64) :: what
      character(len=*), parameter :: phase_name(2) = ['free   ', 'contact']

      ierr = ok
      if (all(ieee_is_finite(y))) then
         if (maxval(abs(y(1:model%n_modes))) <= settings%blowup_limit) return
         write (what, '(a,es10.3e3,a,es10.3e3)') 'max|a_j| = ', maxval(abs(y(1:model%n_modes))), &
            ' > &solver blowup_limit = ', settings%blowup_limit
      else
         what = 'the state is NaN or Inf'
      end if
      ierr = err_blowup
      write (errmsg, '(a,es13.6e3,4a,es10.3e3,4a)') 'blow-up at tau = ', tau, ': ', trim(what), &
         ', after a ', 'step of ', h, ' (', trim(phase_name(merge(2, 1, in_contact))), ' phase); ', &
         trim(likely_cause(settings%method))
   end subroutine check_blowup

   !> What a blow-up most likely means for a method, and what to change.
   !> (Blank-padded: a deferred-length result is not thread-safe with gfortran 12, see tmafm_text.)
   pure function likely_cause(method) result(text)
      character(len=*), intent(in) :: method
      character(len=256) :: text
      select case (trim(method))
      case (method_rk4_paper, method_rk4_event)
         text = 'the step is past the stability limit: reduce &solver dtau'
      case default
         text = 'the error control keeps an adaptive step stable, so the motion itself diverged: '// &
                'check the scene (damping, drive, initial state), or raise &solver blowup_limit '// &
                'if larger amplitudes are expected'
      end select
   end function likely_cause

   subroutine progress_update(self, tau, tau_end, ierr, errmsg)
      class(progress_t), intent(inout) :: self
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: tau_end
      integer, intent(out) :: ierr
      !> Set only when the run must stop (a step loop's message buffer, not cleared here).
      character(len=*), intent(inout) :: errmsg
      ierr = ok
      ! The test here, not only in tick: a run without a poll (the executable's) calls no
      ! procedure per step for it (tick costs 0.8 % of a fixed-step run as a call).
      if (associated(self%poll)) then
         call self%tick(tau, tau_end, ierr, errmsg)
         if (ierr /= ok) return
      end if
      if (self%unit < 0) return
      if (tau >= self%mark*tau_end/10) then
         write (self%unit, '(a,i0,a,g0.6,a,g0.6)') 'tmafm: ', 10*self%mark, '% tau = ', tau, &
            ' of ', tau_end
         flush (self%unit)
         self%mark = self%mark + 1
      end if
   end subroutine progress_update

   subroutine progress_tick(self, tau, tau_end, ierr, errmsg)
      class(progress_t), intent(inout) :: self
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: tau_end
      integer, intent(out) :: ierr
      !> Set only when the run must stop (a step loop's message buffer, not cleared here).
      character(len=*), intent(inout) :: errmsg
      integer(i8) :: now, rate, since
      logical :: asked
      ierr = ok
      if (.not. associated(self%poll)) return
      self%countdown = self%countdown - 1
      if (self%countdown > 0) return
      self%countdown = poll_every
      call system_clock(now, rate)
      if (self%polled_at >= 0) then
         since = now - self%polled_at
         if (since*1000 < poll_interval_ms*rate .or. since < poll_spacing*self%poll_took) return
      end if
      asked = self%poll()
      call system_clock(self%polled_at)
      self%poll_took = self%polled_at - now
      if (asked) then
         ierr = err_interrupted
         write (errmsg, '(a,g0.6,a,g0.6,a)') 'run interrupted at tau = ', tau, ' of tau_end = ', &
            tau_end, ': its caller asked it to stop (Ctrl-C); no result is kept'
      end if
   end subroutine progress_tick

end module tmafm_trajectory

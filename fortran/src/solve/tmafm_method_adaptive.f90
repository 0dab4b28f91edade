!> `dopri5` and `dop853`: an adaptive embedded pair under rtol/atol (tmafm_error_scale says
!> what they control), with every switch V_T = 0, grazing ones included, located to
!> round-off on the pair's dense output by a Brent search.  The run restarts at the switch
!> in the new phase.  `advance` is also the in-contact integrator of `flight_exact`.
!>
!> Per step the loop does the pair's stages and O(N) bookkeeping: V_T, dV_T/dtau and the
!> switch margin at the step end are computed once and carried to the next step start; the
!> dense output is built only when a sample or a switch falls in the step; every register
!> lives in adaptive_state_t, allocated once.
!>
!> Contact entry.  At a contact entered through a switch at tau_e the force ~ (tau - tau_e)^(3/2)
!> is not smooth, but in sigma = sqrt(tau - tau_e) it is ~ sigma^3 and the state is smooth: the
!> first stretch of the contact is integrated in sigma (warped steps, tmafm_embedded_pair
!> time_map_t), by the same pair, error norm and controller, until sigma >= warp_leave x the
!> next step in sigma; then the run goes on in tau with the step 2 sigma dsigma.  Samples,
!> switches and observers read the step's dense output through its time map.
!>
!> Thermal noise (docs/model.md §21).  The Langevin force is constant on each interval of the
!> noise grid: run_adaptive holds its own copy of the model, whose noise_accel it sets at each
!> grid point, and `advance` ends its steps on the grid (tau_stop) and returns there, so that no
!> step straddles a jump of the force; it then resumes in the same phase with a fresh derivative.
module tmafm_method_adaptive
   use tmafm_kinds, only: dp, i8
   use tmafm_errors, only: ok, err_runtime
   use tmafm_model, only: model_t
   use tmafm_settings, only: run_settings_t
   use tmafm_trajectory, only: trajectory_t, check_blowup, progress_t
   use tmafm_embedded_pair, only: embedded_pair_t, step_controller_t, time_map_t
   use tmafm_error_scale, only: error_scale_t
   use tmafm_dopri5, only: dopri5_pair_t
   use tmafm_dop853, only: dop853_pair_t
   use tmafm_lawson, only: lawson_pair_t
   use tmafm_events, only: no_event, event_candidate, step_event_test, initial_phase, phase_sign, &
                           switch_margin, hermite_minimum
   use tmafm_roots, only: bracketed_root_t
   use tmafm_observers, only: observer_t, stop_requested
   use tmafm_thermal, only: automatic_noise_step
   implicit none
   private

   public :: run_adaptive, adaptive_state_t, pair_dopri5, pair_dop853, pair_lawson

   !> Contact exit.  The contact force ~ (-V_T)^(3/2) has a kink where V_T reaches 0: a
   !> step across it, or a long one that ends near it, fails the error test.  After each
   !> contact step a quadratic in V_T, V_T' and V_T'' (from f_new) predicts the time t_e
   !> left to the exit.  Once t_e <= exit_cross_slack x the crossing length (learned from the
   !> last exit), the step t_e * exit_reach crosses it, just past the kink; before that, a
   !> step ends at least exit_approach x its length short of it (a graded approach).
   real(dp), parameter :: exit_reach = 1.05_dp
   !> A predicted exit this multiple of the crossing length away is crossed in one step.
   real(dp), parameter :: exit_cross_slack = 1.5_dp
   !> Before the crossing step, a step must end at least this multiple of its own length
   !> before the predicted exit (the derivatives of the force grow as the kink nears: the
   !> approach is graded, as the ramp after an entry).
   real(dp), parameter :: exit_approach = 0.5_dp
   !> The error norm a crossing step aims at (the crossing length is learned from it).
   real(dp), parameter :: exit_target = 0.25_dp

   !> A warped stretch after a contact entry ends once sigma is this multiple of the next step
   !> in sigma (dtau/dsigma then changes by at most 1/warp_leave over a step); 2, 3 and 4
   !> measured alike (docs/performance.md), 1 left too early.
   real(dp), parameter :: warp_leave = 2.0_dp
   !> The first step in sigma of a warped entry: this fraction of the step the controller
   !> proposed after the previous entry's first step (whose error is far below the tolerance).
   real(dp), parameter :: warp_first = 0.8_dp

   !> Steps after the warp for which the controller is PI (then classical again until a
   !> rejection: when PI still took two real powers a step, keeping it for the whole contact
   !> cost 2 % of the instructions on the tilted scene at rtol 1e-10).
   integer, parameter :: warp_pi_steps = 4

   !> A Lawson flight step toward the surface (V_T' < 0) covers at most this fraction of the
   !> distance V_T + eps to the surface (eps = &scene vdw_range, the law's own length): the force
   !> at a distance grows as the gap closes (as 1/(V_T + eps)^2 under 'dmt_vdw'), and the
   !> controller, which learns a step from the last one, overshot it by norms of 1e2-1e4, about
   !> seven rejections a flight (docs/performance.md, "Long-range forces in flight").
   real(dp), parameter :: gap_reach = 0.5_dp

   !> Pieces a step (and then a piece) is split into by the dip search out of contact.
   integer, parameter :: dip_pieces = 8

   !> A learned step length is replaced only by a value outside [1/learn_band, learn_band] x it.
   real(dp), parameter :: learn_band = 1.25_dp

   !> Which embedded pair an adaptive state uses: pair_lawson is dop853 in contact and its
   !> Lawson form on the exact free flow in flight (tmafm_lawson; flight_exact with a force at a
   !> distance).
   integer, parameter :: pair_dopri5 = 1, pair_dop853 = 2, pair_lawson = 3

   !> The method dop853 never steps further than h omega_N = dop853_mode_reach, omega_N =
   !> beta_N^2 the highest mode's free frequency (the error norm's, tmafm_error_scale).  Past
   !> about 4.4 its steps are set by that mode's error alone (it is 0.74 of DOP853's stability
   !> limit 5.96 on the imaginary axis, where |R(i y)| = 0.945 per step), the step pattern
   !> never repeats, and the mode's error builds up over its high Q: on tapping_polystyrene
   !> (Q3 ~ 7000, rtol 1e-9, atol 1e-13) the third mode's velocity at the drive period's
   !> boundary jittered by 1.2e-9 from period to period (a fifth of its size) and no period
   !> repeated within 1e-8 in 6000 periods, where dopri5 and flight_exact find period 1 after
   !> 1731 (issue 27; docs/observables.md, "Steady state").  With the cap, 4 (4.3 did as well,
   !> 4.6 not: `python benchmarks/steady_dop853.py`), it finds it after 1731.  flight_exact's
   !> contact phases (this pair too) are not capped.
   real(dp), parameter :: dop853_mode_reach = 4.0_dp
   !> The method dopri5 never steps further than h omega_N = dopri5_mode_reach.  Its stability
   !> polynomial (1, 1, 1/2, 1/6, 1/24, 1/120, 1/600) holds the imaginary axis only up to
   !> h omega = 0.9972: past it a mode of damping ratio zeta is amplified each step unless zeta
   !> exceeds zeta_min(h omega), 1.4e-6 at 1.0 and 1.2e-4 at 1.13.  With N = 4 at the default
   !> tolerances on tapping_polystyrene (free, Q4 ~ 13700, zeta4 = 3.7e-5) the error control
   !> chose h omega_4 ~ 1.13: mode 4 was excited by the method and no period repeated in 6000
   !> periods (issue 27).  0.9 keeps every step inside the interval (|R(i 0.9)| = 1 - 2.5e-5),
   !> with a tenth of it for omega_N = beta_N^2 being an upper bound and the stepping's spread
   !> (`python benchmarks/steady_dop853.py`; docs/observables.md, "Steady state").
   real(dp), parameter :: dopri5_mode_reach = 0.9_dp

   !> Where an adaptive integration stands: time, state, phase, next step, and registers.
   type :: adaptive_state_t
      !> Current time.
      real(dp) :: tau = 0
      !> Current state (a, a').
      real(dp), allocatable :: y(:)
      !> Current phase.
      logical :: in_contact = .false.
      !> .true. when the next contact phase starts at a crossing (a located switch, or a
      !> flight's contact): its first stretch is warped.
      logical :: entry_pending = .false.
      !> .true. while steps are taken in sigma = sqrt(tau - warp_origin).
      logical :: warped = .false.
      !> The warp's origin (the contact's entry) and the current sigma.
      real(dp) :: warp_origin = 0, sigma = 0
      !> The first accepted step in sigma of the latest warped entry (0: none yet).
      real(dp) :: h_warp_start = 0
      !> The longest contact step (in tau) of the latest contact, and of the current one: the
      !> scale sigma_c^2 of the warped steps' error model (warp_step).
      real(dp) :: h_plateau = 0, h_contact_max = 0
      !> Step to try next (in sigma while warped).
      real(dp) :: h = 0
      !> The first accepted step of the latest free (1) and contact (2) phase: the trial step
      !> at the next start of that phase (a contact begins with V_T^(3/2) forces, whose
      !> steps the controller would otherwise relearn by rejections at every contact).
      real(dp) :: h_phase_start(2) = 0
      !> The length of the step that crosses a contact exit (learned from each exit; 0: not
      !> yet known, then a quarter of the controller's step).
      real(dp) :: h_exit_cross = 0
      !> Largest step in tau (not in sigma): dop853_mode_reach/omega_N for the method dop853,
      !> dopri5_mode_reach/omega_N for dopri5, huge otherwise (flight_exact's contacts).
      real(dp) :: h_max = huge(1.0_dp)
      !> .true. for pair_lawson: a flight step toward the surface is limited by gap_reach.
      logical :: gap_limited = .false.
      !> Steps end at this time at the latest, and `advance` returns there (the next point of the
      !> thermal noise grid; huge: no such stop).
      real(dp) :: tau_stop = huge(1.0_dp)
      !> .true. when tau_stop is set (a run with thermal noise): the loop's only test otherwise.
      logical :: stops = .false.
      !> .true. when `advance` returned at tau_stop within a phase: the next call goes on in that
      !> phase with a fresh derivative (the force changed), not as a phase start.
      logical :: resume = .false.
      !> The embedded pair and its registers.
      class(embedded_pair_t), allocatable :: pair
      !> The step-size controller.
      type(step_controller_t) :: controller
      !> The weights of the error norm (running amplitudes).
      type(error_scale_t) :: scale
      !> Registers: derivative (d/dtau, or d/dsigma while warped) at the step start and end,
      !> the trial state, a dense sample.
      real(dp), allocatable :: f0(:), f_new(:), y_new(:), y_sample(:)
   contains
      !> Allocate for a state y0 at tau0 with the pair `kind` and set the first trial step.
      procedure :: init => adaptive_init
      !> Integrate, sampling into traj, until traj is complete or (if asked) the phase changes.
      procedure :: advance => adaptive_advance
   end type adaptive_state_t

contains

   !> Integrate from y0 at tau = 0 with the pair `kind` until every sample of traj is filled.
   subroutine run_adaptive(kind, model, settings, y0, traj, ierr, errmsg, progress, observer)
      integer, intent(in) :: kind
      type(model_t), intent(in) :: model
      type(run_settings_t), intent(in) :: settings
      real(dp), intent(in) :: y0(:)
      type(trajectory_t), intent(inout) :: traj
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(progress_t), intent(inout) :: progress
      !> If present, fed every accepted step and contact (tmafm_observers); may stop the run.
      type(observer_t), intent(inout), optional :: observer
      type(adaptive_state_t) :: state
      type(model_t) :: noisy
      real(dp) :: noise_step
      integer(i8) :: interval

      ierr = ok
      errmsg = ''
      if (settings%thermal_noise /= 1) then
         call start_adaptive(kind, model, settings, y0, traj, state, ierr, errmsg)
         if (ierr /= ok) return
         call state%advance(model, settings, traj, .false., ierr, errmsg, progress, observer)
         return
      end if
      ! Thermal noise: this run's copy of the model carries the force of the current interval.
      noise_step = settings%noise_step
      if (.not. (noise_step > 0)) noise_step = automatic_noise_step(maxval(model%beta(1:model%n_modes)**2))
      noisy = model
      call noisy%set_thermal(noise_step, settings%noise_seed)
      call start_adaptive(kind, noisy, settings, y0, traj, state, ierr, errmsg)
      if (ierr /= ok) return
      interval = 0
      do
         state%stops = .true.
         state%tau_stop = real(interval + 1, dp)*noise_step
         call state%advance(noisy, settings, traj, .false., ierr, errmsg, progress, observer)
         if (ierr /= ok .or. traj%complete() .or. stop_requested(observer)) return
         interval = interval + 1
         call noisy%set_noise_interval(interval)
      end do
   end subroutine run_adaptive

   !> Store the first sample and set up the state and its pair for a run from y0 at tau = 0.
   subroutine start_adaptive(kind, model, settings, y0, traj, state, ierr, errmsg)
      integer, intent(in) :: kind
      type(model_t), intent(in) :: model
      type(run_settings_t), intent(in) :: settings
      real(dp), intent(in) :: y0(:)
      type(trajectory_t), intent(inout) :: traj
      type(adaptive_state_t), intent(inout) :: state
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      ierr = ok
      errmsg = ''
      call traj%store(model, y0)
      call state%init(kind, model, settings, 0.0_dp, y0)
      select type (pair => state%pair)
      type is (lawson_pair_t)
         call pair%setup(model, ierr, errmsg)
      end select
      if (ierr /= ok) return
      ! The first sample's phase is the run's (a JKR neck may start stretched: &initial in_contact).
      if (model%hysteretic) traj%contact(1) = merge(1, 0, state%in_contact)
      if (kind == pair_dop853) state%h_max = dop853_mode_reach/maxval(model%beta(1:model%n_modes)**2)
      if (kind == pair_dopri5) state%h_max = dopri5_mode_reach/maxval(model%beta(1:model%n_modes)**2)
   end subroutine start_adaptive

   subroutine adaptive_init(self, kind, model, settings, tau0, y0)
      class(adaptive_state_t), intent(inout) :: self
      integer, intent(in) :: kind
      type(model_t), intent(in) :: model
      type(run_settings_t), intent(in) :: settings
      real(dp), intent(in) :: tau0
      real(dp), intent(in) :: y0(:)
      integer :: n
      n = size(y0)
      if (allocated(self%pair)) deallocate (self%pair)
      select case (kind)
      case (pair_dop853)
         allocate (dop853_pair_t :: self%pair)
      case (pair_lawson)
         allocate (lawson_pair_t :: self%pair)
         self%gap_limited = .true.
      case default
         allocate (dopri5_pair_t :: self%pair)
      end select
      call self%pair%init(n)
      if (allocated(self%y)) deallocate (self%y, self%f0, self%f_new, self%y_new, self%y_sample)
      allocate (self%y(n), self%f0(n), self%f_new(n), self%y_new(n), self%y_sample(n))
      call self%scale%init(model, settings%rtol, settings%atol, y0)
      self%tau = tau0
      self%y = y0
      self%in_contact = initial_phase(model, tau0, y0)
      ! &initial in_contact, checked against V_T by the driver (check_initial_phase).
      if (settings%initial_contact >= 0) self%in_contact = settings%initial_contact == 1
      ! The first trial step; the controller corrects it within a few steps.
      self%h = settings%dtau
   end subroutine adaptive_init

   !> V_T and its rate less the gap where the phase ends and its rate (model_t%switch_offset: a
   !> JKR neck breaks above the surface, a meniscus at its rupture gap), so that the phase's
   !> switch is where they cross zero.
   pure subroutine past_offset(model, y, in_contact, vt, rate)
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: y(:)
      logical, intent(in) :: in_contact
      real(dp), intent(inout) :: vt
      real(dp), intent(inout) :: rate
      real(dp) :: offset, offset_rate
      call model%switch_offset(y, in_contact, vt, rate, offset, offset_rate)
      vt = vt - offset
      rate = rate - offset_rate
   end subroutine past_offset

   !> V_T, dV_T/dtau and the switch margin (tmafm_events) at a state, given sin and cos of the
   !> drive phase there.
   pure subroutine gap_state(model, sin_phase, cos_phase, y, vt, rate, margin, drive)
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: sin_phase
      real(dp), intent(in) :: cos_phase
      real(dp), intent(in) :: y(:)
      real(dp), intent(out) :: vt
      real(dp), intent(out) :: rate
      real(dp), intent(out) :: margin
      !> The drive's part d2Y/dtau2 of V_T'' (one tone: -Omega^2 alpha2 sin(Omega tau)).
      real(dp), intent(out) :: drive
      real(dp) :: base, base_rate
      call model%gap_at_phase(y, sin_phase, cos_phase, vt, rate)
      call model%drive_signals(sin_phase, cos_phase, base, base_rate, drive)
      margin = switch_margin(model, y)
   end subroutine gap_state

   subroutine adaptive_advance(self, model, settings, traj, stop_at_switch, ierr, errmsg, progress, &
                               observer)
      class(adaptive_state_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      type(run_settings_t), intent(in) :: settings
      type(trajectory_t), intent(inout) :: traj
      logical, intent(in) :: stop_at_switch
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(progress_t), intent(inout) :: progress
      type(observer_t), intent(inout), optional :: observer

      type(bracketed_root_t) :: root
      type(time_map_t) :: map
      real(dp) :: h, h_time, norm, side, s_test, theta, step_taken, drive, drive1, sin_test, cos_test
      real(dp) :: base1, base_rate1
      real(dp) :: ds0, ds1, tau_end, sigma_end, h_next, theta_low, g_low, g_test
      ! V_T, its rate and the margin at the step start (0) and end (1); G = side V_T + margin0.
      real(dp) :: vt0, rate0, margin0, vt1, rate1, margin1, vt_test, rate_test, margin_test
      logical :: have_f0, dense_ready, phase_start, capped
      integer :: status

      ierr = ok
      errmsg = ''
      have_f0 = .false.
      phase_start = .false.
      side = 1
      associate (tau => self%tau, y => self%y, pair => self%pair, controller => self%controller, &
                 f0 => self%f0, f_new => self%f_new, y_new => self%y_new, y_sample => self%y_sample)
         do while (.not. traj%complete())
            ! The noise grid's next point (reached, or a located switch a few ulps before it).
            if (self%stops) then
               if (self%tau_stop - tau <= 64*epsilon(1.0_dp)*max(1.0_dp, abs(tau))) then
                  self%resume = have_f0
                  return
               end if
            end if
            if (.not. have_f0 .and. self%resume) then
               ! On in the same phase after a grid point: only the force changed.
               self%resume = .false.
               call model%derivative(tau, y, self%in_contact, f0)
               traj%rhs_evaluations = traj%rhs_evaluations + 1
               if (self%warped) f0 = 2*self%sigma*f0
               have_f0 = .true.
               side = phase_sign(self%in_contact)
               call model%phase(tau, sin_test, cos_test)
               call gap_state(model, sin_test, cos_test, y, vt0, rate0, margin0, drive)
               if (model%hysteretic) call past_offset(model, y, self%in_contact, vt0, rate0)
            end if
            if (.not. have_f0) then
               ! A phase starts here: a fresh derivative in this phase, and G from the state.
               self%warped = self%in_contact .and. self%entry_pending
               self%entry_pending = .false.
               if (self%warped) then
                  ! dy/dsigma = 2 sigma f vanishes at sigma = 0.
                  self%warp_origin = tau
                  self%sigma = 0
                  f0 = 0
               else
                  call model%derivative(tau, y, self%in_contact, f0)
                  traj%rhs_evaluations = traj%rhs_evaluations + 1
               end if
               have_f0 = .true.
               side = phase_sign(self%in_contact)
               call model%phase(tau, sin_test, cos_test)
               call gap_state(model, sin_test, cos_test, y, vt0, rate0, margin0, drive)
               if (model%hysteretic) call past_offset(model, y, self%in_contact, vt0, rate0)
               phase_start = .true.
               call controller%restart()
               if (self%warped) then
                  if (self%h_warp_start > 0) then
                     self%h = self%h_warp_start
                  else
                     self%h = sqrt(abs(self%h))
                  end if
               else if (self%h_phase_start(phase_index(self%in_contact)) > 0) then
                  self%h = self%h_phase_start(phase_index(self%in_contact))
               end if
            end if
            if (.not. self%warped) self%h = min(self%h, self%h_max)
            ! A step ends on the noise grid at the latest.
            capped = .false.
            if (self%stops) then
               if (self%warped) then
                  if ((self%sigma + self%h)**2 >= self%tau_stop - self%warp_origin) then
                     self%h = sqrt(self%tau_stop - self%warp_origin) - self%sigma
                     capped = .true.
                  end if
               else if (self%h >= self%tau_stop - tau) then
                  self%h = self%tau_stop - tau
                  capped = .true.
               end if
            end if
            h = self%h
            if (self%warped) then
               map = time_map_t(s0=self%sigma, h=h, origin=self%warp_origin, warped=.true.)
               h_time = h*(2*self%sigma + h)
            else
               map = time_map_t(s0=tau, h=h)
               h_time = h
            end if
            if (h_time < controller%h_min_relative*max(1.0_dp, abs(tau))) then
               ierr = err_runtime
               write (errmsg, '(a,es13.6e3,a,es10.3e3,a)') 'step size underflow at tau = ', tau, &
                  ' (h = ', h_time, '): the tolerances cannot be met; loosen &solver rtol or atol'
               return
            end if
            call traj%charge(settings, tau, 1, ierr, errmsg)
            if (ierr /= ok) return
            call pair%step(model, map, y, self%in_contact, f0, y_new, f_new)
            traj%rhs_evaluations = traj%rhs_evaluations + pair%stage_evaluations
            call pair%error_norm(h, f0, f_new, self%scale, norm)
            self%h = controller%next_step(pair, h, norm)
            if (self%warped) self%h = warp_step(self, h, norm <= 1)
            if (.not. (norm <= 1)) then
               traj%rejected_steps = traj%rejected_steps + 1
               cycle
            end if
            dense_ready = .false.
            if (phase_start) then
               if (self%warped) then
                  call learn(self%h_warp_start, warp_first*self%h)
               else
                  self%h_phase_start(phase_index(self%in_contact)) = h
               end if
            end if
            phase_start = .false.

            ! V_T, its rate and the drive phase at the step end: the pair's, as f_new formed them
            ! (no sin/cos and no dot products here).
            vt1 = pair%vt_end
            rate1 = pair%rate_end
            if (model%hysteretic) call past_offset(model, y_new, self%in_contact, vt1, rate1)
            call model%drive_signals(pair%sin_end, pair%cos_end, base1, base_rate1, drive1)
            margin1 = switch_margin(model, y_new)
            ! A Lawson flight toward the surface: the force in flight grows as the gap closes.
            if (self%gap_limited .and. .not. self%in_contact .and. rate1 < 0) &
               self%h = min(self%h, gap_reach*(vt1 + model%scene%vdw_range)/(-rate1))
            ! G's rates per unit of the step variable: dtau/ds = 1, or 2 sigma when warped.
            ds0 = 1
            ds1 = 1
            if (self%warped) then
               ds0 = 2*self%sigma
               ds1 = 2*(self%sigma + h)
            end if
            call step_event_test(side*vt0 + margin0, side*rate0*ds0, side*vt1 + margin0, side*rate1*ds1, &
                                 h, self%in_contact, status, s_test)
            if (status == event_candidate) then
               ! Is the dip of the interpolant real?  Check the dense output there.
               call build_dense(self, model, traj, dense_ready)
               call pair%dense(s_test/h, y_sample)
               call model%phase(map%time_at(s_test/h), sin_test, cos_test)
               call gap_state(model, sin_test, cos_test, y_sample, vt_test, rate_test, margin_test, drive)
               if (model%hysteretic) call past_offset(model, y_sample, self%in_contact, vt_test, rate_test)
               if (side*vt_test + margin0 > 0) status = no_event
            end if
            theta_low = 0
            g_low = side*vt0 + margin0
            ! Out of contact the first crossing is wanted: a dip the cubic missed, or one
            ! before a crossing at the step end or at the cubic's minimum.  (A meniscus's flight
            ! ends at either end of its band, V_T (1 - V_T/o) = 0: the cubic test alone.)
            if (.not. (self%in_contact .or. model%wet(y))) &
               call free_dip_search(self, model, traj, map, h, vt0 + margin0, rate0, vt1 + margin0, rate1, &
                                    margin0, dense_ready, status, theta_low, g_low, s_test)
            if (status == no_event) then
               tau_end = tau + h
               if (self%warped) tau_end = map%time_at(1.0_dp)
               if (capped) tau_end = self%tau_stop
               sigma_end = self%sigma + h
            else
               ! G(theta) = side V_T + margin0 on the dense output: positive at theta_low (0, or
               ! the last point the dip search cleared), not at s_test/h.
               call build_dense(self, model, traj, dense_ready)
               call pair%dense(s_test/h, y_sample)
               g_test = side*model%switch_gap(map%time_at(s_test/h), y_sample, self%in_contact) + margin0
               call root%start(theta_low, g_low, s_test/h, g_test, 4*epsilon(1.0_dp)*abs(tau)/h_time)
               do while (.not. root%converged())
                  call traj%charge(settings, tau, 1, ierr, errmsg)
                  if (ierr /= ok) return
                  call root%next_point(theta)
                  call pair%dense(theta, y_sample)
                  call root%update(side*model%switch_gap(map%time_at(theta), y_sample, self%in_contact) + margin0)
               end do
               call root%end_with_sign(-1.0_dp, theta)
               tau_end = map%time_at(theta)
               sigma_end = self%sigma + theta*h
               call pair%dense(theta, y_new)
            end if
            step_taken = tau_end - tau

            traj%steps = traj%steps + 1
            if (self%in_contact) then
               traj%contact_steps = traj%contact_steps + 1
               self%h_contact_max = max(self%h_contact_max, h_time)
            end if
            if (.not. state_bounded(size(y)/2, y_new, settings%blowup_limit)) then
               call check_blowup(model, settings, tau_end, step_taken, self%in_contact, y_new, ierr, errmsg)
               if (ierr /= ok) return
            end if
            do while (traj%next_time() <= tau_end)
               call build_dense(self, model, traj, dense_ready)
               call pair%dense(map%theta_at(traj%next_time()), y_sample)
               call traj%store(model, y_sample)
               ! A JKR neck holds above the surface: the sample's phase is the run's, not V_T's sign.
               if (model%hysteretic) traj%contact(traj%next_sample - 1) = merge(1, 0, self%in_contact)
            end do
            if (present(observer)) then
               if (observer%needs_dense(tau, step_taken)) call build_dense(self, model, traj, dense_ready)
               call observer%pair_step(model, pair, tau, step_taken, self%in_contact)
            end if
            tau = tau_end
            call copy_state(size(y)/2, y_new, y)
            call self%scale%update(y)
            call progress%update(tau, settings%tau_end, ierr, errmsg)
            if (ierr /= ok) return
            if (status == no_event) then
               ! The step end is the next start: carry f, V_T, its rate and the margin.
               call copy_state(size(y)/2, f_new, f0)
               vt0 = vt1
               rate0 = rate1
               margin0 = margin1
               if (self%warped) then
                  self%sigma = sigma_end
                  ! aim_at_exit works in tau: its step and V_T'' from f = (dy/dsigma)/(2 sigma).
                  h_next = self%h*(2*sigma_end + self%h)
                  call aim_at_exit(self, h_next, side*vt1 + margin0, side*rate1, &
                                   side*gap_acceleration(model, f_new, 1/(2*sigma_end), drive1))
                  ! The next step in sigma, sqrt(sigma^2 + h_next) - sigma without cancellation.
                  self%h = h_next/(sqrt(sigma_end**2 + h_next) + sigma_end)
                  if (sigma_end >= warp_leave*self%h) then
                     ! Leave the warp: dtau = 2 sigma dsigma, f = (dy/dsigma)/(2 sigma).
                     self%warped = .false.
                     f0 = f_new/(2*sigma_end)
                     self%h = 2*sigma_end*self%h
                     ! The controller is PI for the next warp_pi_steps steps: near the entry
                     ! the error still grows faster than h^8, and the classical law's growth
                     ! from the small norms there overshot (a rejection per period at rtol
                     ! 1e-7 on tilted_hertz_3).
                     call controller%restart()
                     controller%pi_steps = warp_pi_steps
                  end if
               else if (self%in_contact) then
                  h_next = self%h
                  call aim_at_exit(self, h_next, side*vt1 + margin0, side*rate1, &
                                   side*gap_acceleration(model, f_new, 1.0_dp, drive1))
                  self%h = h_next
               end if
            else
               ! A contact exit: learn the crossing length from this crossing's error.
               if (self%in_contact) self%h_exit_cross = &
                  h_time/exit_reach*min(2.0_dp, max(0.5_dp, &
                  (exit_target/max(norm, 1.0e-12_dp))**(1.0_dp/3)))
               if (self%in_contact) call learn(self%h_plateau, self%h_contact_max)
               self%h_contact_max = 0
               call model%next_phase(tau, y, self%in_contact)
               self%entry_pending = self%in_contact
               self%warped = .false.
               call traj%add_switch(tau, h_time, ierr, errmsg)
               if (ierr /= ok) return
               have_f0 = .false.
               if (present(observer) .and. self%in_contact) call observer%contact_start(tau)
               if (stop_at_switch) return
            end if
            if (stop_requested(observer)) return
         end do
      end associate

   end subroutine adaptive_advance

   !> The next step in sigma after a warped step of length h from self%sigma (accepted: the next
   !> starts at its end) for which the controller proposed self%h.  The controller assumes an
   !> error constant x h^8; a warped step's grows with sigma (the eighth sigma-derivative of
   !> y(tau_e + sigma^2) holds tau-derivatives of order 4..8 times sigma^0..sigma^8), so it
   !> overshot: the second step of an entry failed at norms 2-100.  The error is modelled as
   !> C(sigma) h^8, C ~ (sigma_c^2 + sigma^2)^8 at the step's midpoint, sigma_c^2 the latest
   !> contact's longest step in tau (the exponent 8 fitted to those failures at rtol 1e-7 and
   !> 1e-10; 4 still failed), and the proposal is scaled by (C(old)/C(new))^(1/8), the new
   !> midpoint from the scaled proposal (two passes).
   pure function warp_step(self, h, accepted) result(h_next)
      type(adaptive_state_t), intent(in) :: self
      real(dp), intent(in) :: h
      logical, intent(in) :: accepted
      real(dp) :: h_next, c2, start, old_mid, proposal
      integer :: pass
      c2 = self%h_plateau
      if (c2 <= 0) c2 = h*(2*self%sigma + h)
      start = self%sigma
      if (accepted) start = self%sigma + h
      old_mid = self%sigma + h/2
      proposal = self%h
      h_next = proposal
      do pass = 1, 2
         h_next = proposal*(c2 + old_mid**2)/(c2 + (start + h_next/2)**2)
      end do
   end function warp_step

   !> Out of contact, where G = V_T + margin first drops to zero inside an accepted step: a
   !> dip the cubic test (tmafm_events) missed, or one before the crossing it found (Brent on
   !> a bracket with three roots may converge to the last).  The cubic Hermite of G over a piece of length l is
   !> within K l^4/384 of G, K a bound on |d^4 G/dtau^4| (free_fourth_derivative_bound); a
   !> piece whose cubic stays above that is cleared.  The step is tried whole; if it is not
   !> cleared, its dense output is read at dip_pieces points (G and G' from the state there),
   !> and every piece not cleared is split once more the same way; a piece still not cleared
   !> then is checked at its cubic's minimum (a dip left is below dip_pieces^-8 of the step's
   !> allowance).  The first point with G <= 0 ends the search: status event_candidate, s_test
   !> there, and [theta_low, s_test/h] brackets the switch with g_low = G(theta_low) > 0.  A
   !> step cleared whole keeps the caller's status and bracket.
   subroutine free_dip_search(self, model, traj, map, h, g0, rate0, g1, rate1, margin, dense_ready, &
                              status, theta_low, g_low, s_test)
      type(adaptive_state_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      type(trajectory_t), intent(inout) :: traj
      type(time_map_t), intent(in) :: map
      real(dp), intent(in) :: h
      !> G and dG/dtau at the step's start and end.
      real(dp), intent(in) :: g0, rate0, g1, rate1
      !> The margin in G (G = V_T + margin).
      real(dp), intent(in) :: margin
      logical, intent(inout) :: dense_ready
      integer, intent(inout) :: status
      real(dp), intent(inout) :: theta_low, g_low
      !> In: the caller's test point (h for a crossing at the end); out: the search's, if found.
      real(dp), intent(inout) :: s_test
      real(dp) :: bound, piece, sub, t_left, g_left, r_left, t_right, g_right, r_right
      real(dp) :: t_sub, g_sub, r_sub, t_inner, g_inner, r_inner, theta_min, cubic_min, g_min, r_min
      integer :: k, j

      bound = free_fourth_derivative_bound(self, model)
      if (cleared(g0, h*rate0, g1, h*rate1, bound*h**4)) return
      call build_dense(self, model, traj, dense_ready)
      piece = 1.0_dp/dip_pieces
      sub = piece/dip_pieces
      t_left = 0
      g_left = g0
      r_left = rate0
      do k = 1, dip_pieces
         t_right = k*piece
         call dense_gap(t_right, g_right, r_right)
         if (g_right <= 0) then
            call found(t_left, g_left, t_right)
            return
         end if
         if (.not. cleared(g_left, piece*h*r_left, g_right, piece*h*r_right, bound*(piece*h)**4)) then
            ! Split the piece once more.
            t_sub = t_left
            g_sub = g_left
            r_sub = r_left
            do j = 1, dip_pieces
               t_inner = t_left + j*sub
               call dense_gap(t_inner, g_inner, r_inner)
               if (g_inner <= 0) then
                  call found(t_sub, g_sub, t_inner)
                  return
               end if
               if (.not. cleared(g_sub, sub*h*r_sub, g_inner, sub*h*r_inner, bound*(sub*h)**4)) then
                  call hermite_minimum(g_sub, sub*h*r_sub, g_inner, sub*h*r_inner, theta_min, cubic_min)
                  if (theta_min > 0) then
                     call dense_gap(t_sub + theta_min*sub, g_min, r_min)
                     if (g_min <= 0) then
                        call found(t_sub, g_sub, t_sub + theta_min*sub)
                        return
                     end if
                  end if
               end if
               t_sub = t_inner
               g_sub = g_inner
               r_sub = r_inner
            end do
         end if
         t_left = t_right
         g_left = g_right
         r_left = r_right
      end do

   contains

      !> G and dG/dtau at fraction t of the step, from the dense output.
      subroutine dense_gap(t, g, rate)
         real(dp), intent(in) :: t
         real(dp), intent(out) :: g, rate
         real(dp) :: sin_phase, cos_phase, vt, margin_here, drive
         call self%pair%dense(t, self%y_sample)
         call model%phase(map%time_at(t), sin_phase, cos_phase)
         call gap_state(model, sin_phase, cos_phase, self%y_sample, vt, rate, margin_here, drive)
         g = vt + margin
      end subroutine dense_gap

      !> A switch bracketed by [t_pos, t_neg], with G(t_pos) = g_pos > 0.
      subroutine found(t_pos, g_pos, t_neg)
         real(dp), intent(in) :: t_pos, g_pos, t_neg
         status = event_candidate
         theta_low = t_pos
         g_low = g_pos
         s_test = t_neg*h
      end subroutine found

   end subroutine free_dip_search

   !> Whether the cubic Hermite through (0, g0, d0), (1, g1, d1) (d per unit fraction), less
   !> its interpolation error allowance/384 (allowance = K l^4), stays positive on [0, 1].
   pure logical function cleared(g0, d0, g1, d1, allowance)
      real(dp), intent(in) :: g0, d0, g1, d1, allowance
      real(dp) :: theta, cubic_min
      call hermite_minimum(g0, d0, g1, d1, theta, cubic_min)
      cleared = min(g0, g1, cubic_min) - allowance/384 > 0
   end function cleared

   !> A bound on |d^4 V_T/dtau^4| out of contact from the running amplitudes S_j of the modes
   !> (tmafm_error_scale): sum_j |p_j| omega_j^4 S_j, doubled for the mass coupling and the
   !> damping that the free frequencies omega_j leave out, plus the drive's alpha2 Omega^4
   !> (sum_k alpha_k Omega_k^4 over the tones).
   pure function free_fourth_derivative_bound(self, model) result(bound)
      type(adaptive_state_t), intent(in) :: self
      type(model_t), intent(in) :: model
      real(dp) :: bound
      bound = 2*sum(abs(model%tip)*self%scale%omega**4*self%scale%amplitude) &
              + model%drive%bound4
   end function free_fourth_derivative_bound

   !> V_T'' from the derivative f = (a', a'') times scale (1, or 1/(2 sigma) for dy/dsigma) and
   !> the drive's part d2Y/dtau2 of V_T''.
   pure function gap_acceleration(model, f, scale, drive) result(accel)
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: f(:)
      real(dp), intent(in) :: scale
      real(dp), intent(in) :: drive
      real(dp) :: accel
      accel = tip_dot(model%n_modes, model%tip, f)*scale + drive
   end function gap_acceleration

   !> p . (second half of f), f = (a', a''): dot_product's sum, in order from the first term, on
   !> explicit shapes (no array descriptors to build).
   pure function tip_dot(n, tip, f) result(total)
      integer, intent(in) :: n
      real(dp), intent(in) :: tip(n)
      real(dp), intent(in) :: f(2*n)
      real(dp) :: total
      integer :: j
      total = 0
      do j = 1, n
         total = total + tip(j)*f(n + j)
      end do
   end function tip_dot

   !> In contact, after an accepted step that ends with G = g, G' = rate, G'' = accel (G =
   !> -V_T + margin > 0, derivatives in tau): limit the next step h (its length in tau) so that
   !> it crosses the exit only as a short step just past it, and before that ends well short.
   pure subroutine aim_at_exit(self, h, g, rate, accel)
      type(adaptive_state_t), intent(in) :: self
      real(dp), intent(inout) :: h
      real(dp), intent(in) :: g
      real(dp), intent(in) :: rate
      real(dp), intent(in) :: accel
      real(dp) :: t_exit, cross
      t_exit = first_root(g, rate, accel)
      if (t_exit >= huge(1.0_dp)) return
      cross = self%h_exit_cross
      if (cross <= 0) cross = h/4
      if (t_exit <= exit_cross_slack*cross) then
         h = min(h, exit_reach*t_exit)
      else
         h = min(h, t_exit/(1 + exit_approach))
      end if
   end subroutine aim_at_exit

   !> The first positive root of g + rate s + accel s^2/2 (g > 0), or huge if there is none.
   pure function first_root(g, rate, accel) result(s)
      real(dp), intent(in) :: g
      real(dp), intent(in) :: rate
      real(dp), intent(in) :: accel
      real(dp) :: s, disc, q
      s = huge(1.0_dp)
      disc = rate*rate - 2*accel*g
      if (disc < 0) return
      ! The roots are 2g/(-rate -+ sqrt(disc)) (no cancellation); with g > 0 the first
      ! positive one is 2g/(-rate + sqrt(disc)) when its denominator is positive.
      q = -rate + sqrt(disc)
      if (q > 0) s = 2*g/q
   end function first_root

   !> Replace a learned step length by a new value only when it moved by more than the factor
   !> learn_band: the warp's first step and its error scale each shape the next contact's
   !> steps, and learned at every contact they settled into a two-period cycle (inputs'
   !> fig4a from a1 = -1e-3: Poincare points 1e-6 apart in alternate periods, no steady state).
   pure subroutine learn(stored, new)
      real(dp), intent(inout) :: stored
      real(dp), intent(in) :: new
      if (stored <= 0 .or. new > learn_band*stored .or. new*learn_band < stored) stored = new
   end subroutine learn

   !> to = from for a state (a, a') of n_modes modes (or (a, a', w, 0) of n_modes - 1 modes
   !> with a viscoelastic sample): an explicit-shape copy of even length,
   !> a few vector moves, where the assignment of the registers' allocatable components went
   !> through a generic strided loop (about 50 instructions a copy for N = 3).
   pure subroutine copy_state(n_modes, from, to)
      integer, intent(in) :: n_modes
      real(dp), intent(in) :: from(2*n_modes)
      real(dp), intent(out) :: to(2*n_modes)
      to = from
   end subroutine copy_state

   !> .true. when check_blowup (tmafm_trajectory) would pass the state (a, a') of n_modes modes:
   !> every component finite (|x| <= huge is false for NaN and Inf) and every |a_j| <= limit.
   !> A short loop of compares on explicit shapes for the common case; the caller calls
   !> check_blowup, which words the error, only when it is .false.
   pure logical function state_bounded(n_modes, y, limit)
      integer, intent(in) :: n_modes
      real(dp), intent(in) :: y(2*n_modes)
      real(dp), intent(in) :: limit
      integer :: i
      state_bounded = .true.
      do i = 1, n_modes
         state_bounded = state_bounded .and. abs(y(i)) <= limit .and. abs(y(i)) <= huge(1.0_dp) &
                         .and. abs(y(n_modes + i)) <= huge(1.0_dp)
      end do
   end function state_bounded

   !> 1 for the free phase, 2 for contact.
   elemental function phase_index(in_contact) result(k)
      logical, intent(in) :: in_contact
      integer :: k
      k = merge(2, 1, in_contact)
   end function phase_index

   !> The dense output of the step just accepted from self%tau (over the pair's time map), once
   !> per step.
   subroutine build_dense(self, model, traj, dense_ready)
      type(adaptive_state_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      type(trajectory_t), intent(inout) :: traj
      logical, intent(inout) :: dense_ready
      if (dense_ready) return
      call self%pair%prepare_dense(model, self%y, self%y_new, self%in_contact, self%f0, self%f_new)
      traj%rhs_evaluations = traj%rhs_evaluations + self%pair%dense_evaluations
      dense_ready = .true.
   end subroutine build_dense

end module tmafm_method_adaptive

!> `flight_exact`: out of contact the state is propagated by the exact modal solution
!> (tmafm_flight), and the next contact is the first root of V_T on that closed form; only
!> the contact phases are integrated numerically, by the adaptive pair `contact_pair`.  With a
!> force at a distance (model_t%long_range) the flight is the exact free flow plus the force's
!> response, integrated by the Lawson form of dop853 (tmafm_lawson) in the adaptive run loop,
!> whose switches are located on the pair's dense output as dop853's.
!> Thermal noise (docs/model.md §21): the Langevin force is constant on each interval of the
!> noise grid, so a flight is cut at the grid points and each piece is the exact flight under
!> that interval's held force (free_flight_t%hold: the particular solution shifted by K^-1 xi);
!> the contacts step on the grid as in run_adaptive.  The flight is then exact for the held
!> process, the same realisation dopri5 and dop853 integrate to their tolerance.
!> Each flight and its scan points are charged to &solver max_steps (one scan is itself
!> bounded by tmafm_flight).  The caller's poll (progress_t) is asked after each flight and
!> each chunk of a flight's samples, so a run that stays out of contact can be stopped too.
module tmafm_method_flight
   use tmafm_kinds, only: dp, i8
   use tmafm_errors, only: ok
   use tmafm_model, only: model_t
   use tmafm_viscoelastic, only: sls_free_relaxation
   use tmafm_settings, only: run_settings_t
   use tmafm_trajectory, only: trajectory_t, check_blowup, progress_t
   use tmafm_flight, only: free_flight_t
   use tmafm_flight_observables, only: flight_observables_t
   use tmafm_method_adaptive, only: adaptive_state_t, pair_dop853, pair_lawson, run_adaptive
   use tmafm_observers, only: observer_t, stop_requested
   use tmafm_thermal, only: automatic_noise_step
   implicit none
   private

   public :: run_flight_exact, contact_pair

   !> The embedded pair used in contact (measured fastest: docs/performance.md).
   integer, parameter :: contact_pair = pair_dop853

   !> Flight samples taken together (phases, states, rows), a block at a time.
   integer, parameter :: sample_chunk = 64

contains

   !> Integrate from y0 at tau = 0 until every sample of traj is filled.
   subroutine run_flight_exact(model, settings, y0, traj, ierr, errmsg, progress, observer)
      type(model_t), intent(in), target :: model
      type(run_settings_t), intent(in) :: settings
      real(dp), intent(in) :: y0(:)
      type(trajectory_t), intent(inout) :: traj
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(progress_t), intent(inout) :: progress
      !> If present, fed every flight, contact step and contact (tmafm_observers).
      type(observer_t), intent(inout), optional :: observer

      type(free_flight_t) :: flight
      type(flight_observables_t) :: closed
      type(adaptive_state_t) :: contact
      !> With thermal noise: this run's copy of the model, which carries the current interval's
      !> force (the model the run uses is `active`: this copy, or `model` itself).
      type(model_t), target :: noisy
      type(model_t), pointer :: active
      real(dp) :: s_contact, horizon, sin_block(sample_chunk), cos_block(sample_chunk), s_over, a_over
      real(dp) :: y_over(size(y0)), s_end, noise_step
      logical :: found, over, noise, to_grid
      integer :: evaluations, left, count, k, mode
      integer(i8) :: interval

      if (model%long_range) then
         ! A force at a distance acts in flight: the exact free flow with the force as its
         ! perturbation (tmafm_lawson), the contacts by the same dop853 pair (with noise, the
         ! held force is part of the free flow: run_adaptive's grid).
         call run_adaptive(pair_lawson, model, settings, y0, traj, ierr, errmsg, progress, observer)
         return
      end if
      noise = settings%thermal_noise == 1
      noise_step = 0
      interval = 0
      if (noise) then
         noise_step = settings%noise_step
         if (.not. (noise_step > 0)) noise_step = automatic_noise_step(maxval(model%beta(1:model%n_modes)**2))
         noisy = model
         call noisy%set_thermal(noise_step, settings%noise_seed)
         active => noisy
      else
         active => model
      end if
      call flight%init(active, ierr, errmsg)
      if (ierr /= ok) return
      call flight%sample_step(settings%sample_dtau)
      call closed%init(active, flight, 1)
      if (present(observer)) call observer%prepare_flight(active, flight)
      call traj%store(active, y0)
      call contact%init(contact_pair, active, settings, 0.0_dp, y0)
      ! The first sample's phase is the run's (a JKR neck may start stretched: &initial in_contact).
      if (active%hysteretic) traj%contact(1) = merge(1, 0, contact%in_contact)
      horizon = traj%tau(size(traj%tau))
      ! With noise the contacts end their steps on the grid (tau_stop), as in run_adaptive.
      contact%stops = noise
      if (noise) contact%tau_stop = noise_step

      do while (.not. traj%complete())
         if (noise) then
            ! At the grid's next point (reached, or a located switch a few ulps before it): the
            ! next interval's force.
            if (contact%tau_stop - contact%tau <= 64*epsilon(1.0_dp)*max(1.0_dp, abs(contact%tau))) then
               interval = interval + 1
               call noisy%set_noise_interval(interval)
               contact%tau_stop = real(interval + 1, dp)*noise_step
            end if
         end if
         ! A contact, or a flight a meniscus holds (a force acts): the adaptive pair.
         if (contact%in_contact .or. active%wet(contact%y)) then
            call contact%advance(active, settings, traj, .true., ierr, errmsg, progress, observer)
            if (ierr /= ok .or. stop_requested(observer)) return
            cycle
         end if
         associate (tau => contact%tau, y => contact%y)
            ! With noise a flight ends at the grid's next point at the latest, under its held force.
            s_end = horizon - tau
            to_grid = .false.
            if (noise) then
               to_grid = contact%tau_stop < horizon
               if (to_grid) s_end = contact%tau_stop - tau
               call flight%hold(active, noisy%noise_accel)
            end if
            call flight%start(active, tau, y)
            evaluations = 0
            call flight%first_contact(active, s_end, found, s_contact, evaluations, ierr, errmsg)
            if (ierr /= ok) return
            ! Closed-form evaluations of V_T cost O(N); count them as right-hand sides, and
            ! charge them (and the flight itself) to the step budget.
            traj%rhs_evaluations = traj%rhs_evaluations + evaluations
            traj%steps = traj%steps + 1
            call traj%charge(settings, tau, 1 + evaluations, ierr, errmsg)
            if (ierr /= ok) return
            ! The flight's largest |a_j| against &solver blowup_limit, located (not only at its
            ! ends and samples): an envelope clears most flights at once.
            call closed%exceeds(flight, s_contact, settings%blowup_limit, over, s_over, mode, a_over)
            if (over) then
               call flight%state(active, s_over, y_over)
               y_over(mode) = a_over
               call check_blowup(active, settings, tau + s_over, s_over, .false., y_over, ierr, errmsg)
               if (ierr /= ok) return
            end if
            ! The flight's samples, sample_chunk at a time: their drive phases, their states
            ! (straight into the trajectory's rows), then V_T and the flags.
            left = traj%samples_by(tau + s_contact)
            do while (left > 0)
               count = min(left, sample_chunk)
               k = traj%next_sample
               call traj%next_phases(active, count, sin_block, cos_block)
               call flight%samples(count, traj%tau(k:k + count - 1), sin_block, cos_block, size(traj%tau), k, &
                                   traj%a, traj%adot)
               call traj%commit_rows(active, count, sin_block, cos_block)
               ! The sample's surface recovers in closed form while the tip is away.
               if (allocated(traj%dashpot)) traj%dashpot(k:k + count - 1) = &
                  sls_free_relaxation(active%sls, flight%dashpot0, traj%tau(k:k + count - 1) - tau)
               left = left - count
               ! A long flight (no contact for many periods) must still heed a Ctrl-C.
               call progress%tick(traj%tau(k + count - 1), settings%tau_end, ierr, errmsg)
               if (ierr /= ok) return
            end do
            if (present(observer)) call observer%flight_segment(active, flight, tau, s_contact)
            call flight%state(active, s_contact, y)
            tau = tau + s_contact
            ! A flight to the grid ends on its point exactly (the next interval starts there).
            if (to_grid .and. .not. found) tau = contact%tau_stop
            call check_blowup(active, settings, tau, s_contact, .false., y, ierr, errmsg)
            if (ierr /= ok) return
            call contact%scale%update(y)
            if (found) then
               contact%in_contact = .true.
               contact%entry_pending = .true.
               call traj%add_switch(tau, s_contact, ierr, errmsg)
               if (ierr /= ok) return
               if (present(observer)) call observer%contact_start(tau)
            end if
            call progress%update(tau, settings%tau_end, ierr, errmsg)
            if (ierr /= ok) return
            if (stop_requested(observer)) return
         end associate
      end do
   end subroutine run_flight_exact

end module tmafm_method_flight

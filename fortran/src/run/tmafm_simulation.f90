!> From a resolved configuration to a sampled trajectory: chooses N when asked, builds the
!> model, then runs it.
module tmafm_simulation
   use tmafm_kinds, only: dp
   use tmafm_errors, only: ok, err_input, err_runtime
   use tmafm_kinds, only: i8
   use tmafm_modes, only: max_modes
   use tmafm_contact, only: law_hertz, law_dmt
   use tmafm_vdw, only: law_dmt_vdw
   use tmafm_jkr, only: law_jkr
   use tmafm_model, only: model_t, init_model
   use tmafm_drive, only: drive_t, init_drive
   use tmafm_driver, only: run_trajectory
   use tmafm_trajectory, only: trajectory_t, stop_poll
   use tmafm_config, only: config_t
   use tmafm_settings, only: method_dopri5, check_run_size, comparison_intervals, mode_digits, &
      comparison_rtol, comparison_atol, search_work_budget
   use tmafm_namelist, only: config_errata, read_config
   use tmafm_text, only: int_text, real_text, short_real_text
   implicit none
   private

   public :: build_model, prepare_model, simulate, choose_mode_count, load_model, refuse_instrument

contains

   !> The model a configuration describes.
   subroutine build_model(config, model, ierr, errmsg)
      type(config_t), intent(in) :: config
      type(model_t), intent(out) :: model
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      integer :: law
      law = law_hertz
      if (trim(config%contact_law) == 'dmt') law = law_dmt
      if (trim(config%contact_law) == 'dmt_vdw') law = law_dmt_vdw
      if (trim(config%contact_law) == 'jkr') law = law_jkr
      call init_model(model, config%n_modes, config%scene, law, config_errata(config), ierr, errmsg)
   end subroutine build_model

   !> The model of a namelist file, for callers that already know N (n_modes > 0): an input
   !> asking for another fixed N is an error; an automatic one takes n_modes.
   subroutine load_model(path, n_modes, model, ierr, errmsg)
      character(len=*), intent(in) :: path
      integer, intent(in) :: n_modes
      type(model_t), intent(out) :: model
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(config_t) :: config

      call read_config(path, config, ierr, errmsg)
      if (ierr /= ok) return
      if (config%auto_modes) then
         config%auto_modes = .false.
         config%n_modes = n_modes
      else if (config%n_modes /= n_modes) then
         ierr = err_input
         write (errmsg, '(a,i0,a,i0)') 'n_modes = ', n_modes, ' of the call does not match '// &
            '&model n_modes = ', config%n_modes
         return
      end if
      call build_model(config, model, ierr, errmsg)
   end subroutine load_model

   !> For &model n_modes = 0: the smallest N, counting from N = 1, whose V_T over mode_horizon
   !> agrees with N+1's within mode_tol: max over tau in [0, mode_horizon] of
   !> |V_T(N) - V_T(N+1)|, over the range max - min of V_T(N+1), both located between the points
   !> of a comparison grid of the core's own (comparison_intervals, never the output's
   !> sample_dtau; docs/model-notes.md, item 14).  Never fewer than the last mode with a
   !> nonzero &initial value, so no given initial value is dropped (the comparison runs at
   !> smaller N start from the first N values: the initial state projected on those modes).
   !> Sets config%n_modes and the evidence (one difference per N compared).
   !> The comparison runs use dopri5 at tight tolerances, whatever the run's own method, so
   !> that integration error (or a fixed step past RK4's stability limit) cannot decide N.
   recursive subroutine choose_mode_count(config, ierr, errmsg, progress_unit, poll, budget)
      type(config_t), intent(inout) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      !> If present, one line per comparison goes to this unit.
      integer, intent(in), optional :: progress_unit
      !> If present, every comparison run polls it (run_trajectory) and stops when asked.
      procedure(stop_poll), optional :: poll
      !> The search's work budget (default search_work_budget; tests give a small one).
      real(dp), intent(in), optional :: budget
      type(config_t) :: trial
      type(trajectory_t) :: upper
      real(dp), allocatable :: lower_vt(:), lower_rate(:)
      real(dp) :: difference, fastest
      type(drive_t) :: drive
      integer :: n, intervals
      ! What is left of search_work_budget (work times the modes of each run).
      real(dp) :: budget_left, budget_total

      ierr = ok
      errmsg = ''
      if (.not. config%auto_modes .or. config%n_mode_differences > 0) return
      ! The grids resolve the fastest drive tone (one tone: omega).
      call init_drive(config%scene, drive, ierr, errmsg)
      if (ierr /= ok) return
      fastest = drive%top_frequency
      trial = config
      trial%auto_modes = .false.
      ! The comparison runs are trajectories of the cantilever, whatever the input measures.
      trial%has_scan = .false.
      trial%has_fm = .false.
      trial%solver%tau_end = config%mode_horizon
      ! The comparisons need every sample of their grid, not the output's window.
      trial%solver%first_sample = 0
      trial%solver%method = method_dopri5
      ! The search compares the deterministic model (the noise would differ between N and N+1).
      trial%solver%thermal_noise = 0
      trial%solver%noise_seed = 0
      trial%solver%noise_step = 0
      trial%solver%rtol = comparison_rtol
      trial%solver%atol = comparison_atol
      config%n_mode_differences = 0
      budget_left = search_work_budget
      if (present(budget)) budget_left = budget
      budget_total = budget_left
      ! Each run is sampled on the grid of the next comparison it takes part in: run N on
      ! N+1's grid (where it is the lower run); the grids nest (powers of two), so the upper
      ! run's finer grid holds every point of the lower's.
      n = 1
      call sampled_run(n, comparison_intervals(config%mode_horizon, n + 1, fastest))
      if (ierr /= ok) return
      do while (n < max_modes)
         call move_alloc(upper%vt, lower_vt)
         call move_alloc(upper%vtdot, lower_rate)
         intervals = size(lower_vt) - 1
         call sampled_run(n + 1, comparison_intervals(config%mode_horizon, min(n + 2, max_modes), &
                                                      fastest))
         if (ierr /= ok) return
         difference = located_difference(lower_vt, lower_rate, upper%vt, upper%vtdot, &
                                         config%mode_horizon/intervals)
         config%n_mode_differences = config%n_mode_differences + 1
         config%mode_differences(config%n_mode_differences) = difference
         if (present(progress_unit)) then
            write (progress_unit, '(a)') 'tmafm: choosing N: N = '//int_text(n)//' against '// &
               int_text(n + 1)//' over mode_horizon = '//real_text(config%mode_horizon)// &
               ': max|dV_T|/range = '//short_real_text(difference, mode_digits)//' (mode_tol = '// &
               real_text(config%mode_tol)//')'
            flush (progress_unit)
         end if
         if (difference <= config%mode_tol) exit
         n = n + 1
      end do
      config%n_modes = max(n, last_nonzero(config%a0), last_nonzero(config%adot0))

   contains

      !> Run the trial at `modes` modes sampled on `count` intervals of mode_horizon (upper).
      subroutine sampled_run(modes, count)
         integer, intent(in) :: modes
         integer, intent(in) :: count
         trial%n_modes = modes
         ! A power of two divides mode_horizon exactly: the grids of two runs share points.
         trial%solver%sample_dtau = config%mode_horizon/count
         ! The run may spend what is left of the search's budget, and no more than a run may.
         trial%solver%max_steps = int(min(budget_left/modes, real(config%solver%max_steps, dp)), i8)
         if (trial%solver%max_steps >= 1) call simulate(trial, upper, ierr, errmsg, poll=poll)
         if (trial%solver%max_steps < 1 .or. (ierr /= ok .and. upper%work > trial%solver%max_steps &
                                               .and. budget_left/modes <= config%solver%max_steps)) then
            ierr = err_runtime
            errmsg = '&model n_modes = 0: the search for N stopped at N = '//int_text(max(modes - 1, 1))// &
                     ' against '//int_text(max(modes, 2))//': its comparison runs (dopri5, rtol '// &
                     real_text(comparison_rtol)//', over mode_horizon = '//real_text(config%mode_horizon)// &
                     ') spent their budget of '//real_text(budget_total)//' steps times modes; '// &
                     'give n_modes, a larger mode_tol (now '// &
                     real_text(config%mode_tol)//') or a shorter mode_horizon'
            return
         end if
         budget_left = budget_left - real(upper%work, dp)*modes
      end subroutine sampled_run
   end subroutine choose_mode_count

   !> max|V_T(upper) - V_T(lower)| over the range of V_T(upper), from samples of V_T and its
   !> rate: lower on a grid of spacing h, upper on the same grid or one 2^k times finer.  On
   !> each interval of the lower grid the difference (and V_T(upper)) is the cubic Hermite
   !> interpolant of its ends' values and rates, whose extrema are located exactly (the roots
   !> of its derivative): the value is the signal's, to the interpolant's error, not the grid's.
   pure function located_difference(lower_vt, lower_rate, upper_vt, upper_rate, h) result(ratio)
      real(dp), intent(in) :: lower_vt(:)
      real(dp), intent(in) :: lower_rate(:)
      real(dp), intent(in) :: upper_vt(:)
      real(dp), intent(in) :: upper_rate(:)
      real(dp), intent(in) :: h
      real(dp) :: ratio
      real(dp) :: largest, top, bottom, low, high
      integer :: k, i, j, stride
      stride = (size(upper_vt) - 1)/(size(lower_vt) - 1)
      largest = 0
      top = -huge(1.0_dp)
      bottom = huge(1.0_dp)
      do k = 1, size(lower_vt) - 1
         i = (k - 1)*stride + 1
         j = k*stride + 1
         call cubic_extrema(upper_vt(i) - lower_vt(k), upper_vt(j) - lower_vt(k + 1), &
                            upper_rate(i) - lower_rate(k), upper_rate(j) - lower_rate(k + 1), h, low, high)
         largest = max(largest, high, -low)
         call cubic_extrema(upper_vt(i), upper_vt(j), upper_rate(i), upper_rate(j), h, low, high)
         top = max(top, high)
         bottom = min(bottom, low)
      end do
      ratio = largest/max(tiny(1.0_dp), top - bottom)
   end function located_difference

   !> Least and greatest value over [0, h] of the cubic with values p0, p1 and derivatives
   !> d0, d1 at its ends: at the ends or where its derivative (a quadratic) vanishes inside.
   pure subroutine cubic_extrema(p0, p1, d0, d1, h, low, high)
      real(dp), intent(in) :: p0
      real(dp), intent(in) :: p1
      real(dp), intent(in) :: d0
      real(dp), intent(in) :: d1
      real(dp), intent(in) :: h
      real(dp), intent(out) :: low
      real(dp), intent(out) :: high
      real(dp) :: m0, m1, c2, c3, a, b, c, disc, q, roots(2), value
      integer :: k, n_roots
      ! p(s) = p0 + m0 s + c2 s^2 + c3 s^3 on s in [0, 1], s = (tau - tau_0)/h.
      m0 = h*d0
      m1 = h*d1
      c2 = 3*(p1 - p0) - 2*m0 - m1
      c3 = 2*(p0 - p1) + m0 + m1
      low = min(p0, p1)
      high = max(p0, p1)
      ! p'(s) = a s^2 + b s + c; its roots by the cancellation-free form.
      a = 3*c3
      b = 2*c2
      c = m0
      n_roots = 0
      if (a == 0) then
         if (b /= 0) then
            n_roots = 1
            roots(1) = -c/b
         end if
      else
         disc = b*b - 4*a*c
         if (disc >= 0) then
            q = -(b + sign(sqrt(disc), b))/2
            n_roots = 1
            roots(1) = q/a
            if (q /= 0) then
               n_roots = 2
               roots(2) = c/q
            end if
         end if
      end if
      do k = 1, n_roots
         if (.not. (roots(k) > 0 .and. roots(k) < 1)) cycle
         value = p0 + roots(k)*(m0 + roots(k)*(c2 + roots(k)*c3))
         low = min(low, value)
         high = max(high, value)
      end do
   end subroutine cubic_extrema

   !> Index of the last nonzero entry (0 if none).
   pure integer function last_nonzero(values)
      real(dp), intent(in) :: values(:)
      integer :: j
      last_nonzero = 0
      do j = size(values), 1, -1
         if (values(j) /= 0) then
            last_nonzero = j
            return
         end if
      end do
   end function last_nonzero

   !> The configuration with N chosen (when &model n_modes = 0), and the model it describes:
   !> the common first step of every run.
   recursive subroutine prepare_model(config, chosen, model, ierr, errmsg, poll)
      type(config_t), intent(in) :: config
      type(config_t), intent(out) :: chosen
      type(model_t), intent(out) :: model
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      !> If present, the comparison runs of an automatic N poll it (choose_mode_count).
      procedure(stop_poll), optional :: poll
      chosen = config
      call choose_mode_count(chosen, ierr, errmsg, poll=poll)
      if (ierr /= ok) return
      call build_model(chosen, model, ierr, errmsg)
   end subroutine prepare_model

   !> An input with an instrument group (&scan, &fm) asks for that measurement, which the
   !> executable and tmafm.instrument run: a trajectory or observed run of it would silently
   !> leave the group out, so it is refused in one line naming the group.
   subroutine refuse_instrument(config, what, ierr, errmsg)
      type(config_t), intent(in) :: config
      !> What the caller would run instead (for the message): 'a trajectory', ...
      character(len=*), intent(in) :: what
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      ierr = ok
      errmsg = ''
      if (config%has_scan) then
         ierr = err_input
         errmsg = '&scan: the input asks for a scan line (the executable or tmafm.instrument.scan_line runs it), '// &
                  'not '//what//': remove &scan to run '//what
      else if (config%has_fm) then
         ierr = err_input
         errmsg = '&fm: the input asks for an FM approach (the executable or tmafm.fm_approach runs it), '// &
                  'not '//what//': remove &fm to run '//what
      end if
   end subroutine refuse_instrument

   !> Run a configuration; `traj` holds the samples when ierr == ok.
   recursive subroutine simulate(config, traj, ierr, errmsg, progress_unit, poll)
      type(config_t), intent(in) :: config
      type(trajectory_t), intent(out) :: traj
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      !> If present, progress lines go to this unit.
      integer, intent(in), optional :: progress_unit
      !> If present, the run (and the comparison runs of an automatic N) ask it at the first
      !> step and every poll_every steps whether to stop: ierr = err_interrupted then.
      procedure(stop_poll), optional :: poll
      type(model_t) :: model
      type(config_t) :: chosen
      integer :: n

      call refuse_instrument(config, 'a trajectory', ierr, errmsg)
      if (ierr /= ok) return
      call prepare_model(config, chosen, model, ierr, errmsg, poll)
      if (ierr /= ok) return
      n = chosen%n_modes
      ! Every run (the comparison runs of an automatic N included) obeys the size limits.
      call check_run_size(chosen%solver, n, ierr, errmsg)
      if (ierr /= ok) return
      call run_trajectory(model, chosen%solver, chosen%a0(1:n), chosen%adot0(1:n), traj, ierr, &
                          errmsg, progress_unit, poll=poll)
   end subroutine simulate

end module tmafm_simulation

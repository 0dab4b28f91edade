! Flat entry points for the Python package, compiled by numpy.f2py into tmafm._core.
!
! Only scalars, strings and explicit-shape arrays cross this boundary, so the wrapper
! stays plain: every routine returns ierr (0 on success, the tmafm_errors codes
! otherwise) and a one-line errmsg, and never stops.  No physics lives here: each
! routine reads the input through the library and calls it.

!> Read and validate a namelist; write the resolved input to resolved_path (if not blank).
subroutine resolve(path, resolved_path, n_modes, n_samples, scene, ierr, errmsg)
   use tmafm, only: config_t, read_config, write_config, choose_mode_count, ok, err_file
   use tmafm_settings, only: sample_count
   use tmafm_kinds, only: dp
   implicit none
   character(len=*), intent(in) :: path
   character(len=*), intent(in) :: resolved_path
   integer, intent(out) :: n_modes
   integer, intent(out) :: n_samples
   real(dp), intent(out) :: scene(13)
   integer, intent(out) :: ierr
   character(len=512), intent(out) :: errmsg
   type(config_t) :: config
   integer :: unit, iostat

   n_modes = 0
   n_samples = 0
   scene = 0
   call read_config(path, config, ierr, errmsg)
   if (ierr /= ok) return
   call choose_mode_count(config, ierr, errmsg)
   if (ierr /= ok) return
   n_modes = config%n_modes
   n_samples = sample_count(config%solver)
   associate (s => config%scene)
      scene = [s%alpha1, s%alpha2, s%alpha3, s%alpha4, s%alpha5, s%alpha6, s%beta, s%omega, &
               s%theta, s%l_over_d, s%g0_over_d, s%delta_hat, s%xi0]
   end associate
   if (len_trim(resolved_path) == 0) return
   open (newunit=unit, file=resolved_path, status='replace', action='write', iostat=iostat)
   if (iostat /= 0) then
      ierr = err_file
      errmsg = 'cannot write '''//trim(resolved_path)//''''
      return
   end if
   call write_config(unit, config, '')
   close (unit)
end subroutine resolve

!> Run a namelist; the arrays are sized by resolve's n_samples and n_modes.  The first
!> counters(5) entries of switch_tau are the times of the phase changes (at most max_switches).
subroutine run(path, n_samples, n_modes, max_switches, tau, vt, vtdot, contact, a, adot, &
               switch_tau, counters, ierr, errmsg)
   use tmafm, only: config_t, trajectory_t, read_config, simulate, ok, err_runtime
   use tmafm_kinds, only: dp, i8
   implicit none
   character(len=*), intent(in) :: path
   integer, intent(in) :: n_samples
   integer, intent(in) :: n_modes
   integer, intent(in) :: max_switches
   real(dp), intent(out) :: tau(n_samples)
   real(dp), intent(out) :: vt(n_samples)
   real(dp), intent(out) :: vtdot(n_samples)
   integer, intent(out) :: contact(n_samples)
   real(dp), intent(out) :: a(n_samples, n_modes)
   real(dp), intent(out) :: adot(n_samples, n_modes)
   real(dp), intent(out) :: switch_tau(max_switches)
   integer(i8), intent(out) :: counters(5)
   integer, intent(out) :: ierr
   character(len=512), intent(out) :: errmsg
   type(config_t) :: config
   type(trajectory_t) :: traj

   tau = 0; vt = 0; vtdot = 0; contact = 0; a = 0; adot = 0; counters = 0; switch_tau = 0
   call read_config(path, config, ierr, errmsg)
   if (ierr /= ok) return
   ! resolve() already chose N for an automatic n_modes: reuse its choice.
   if (config%auto_modes) then
      config%auto_modes = .false.
      config%n_modes = n_modes
   end if
   call simulate(config, traj, ierr, errmsg)
   if (ierr /= ok) return
   if (size(traj%tau) /= n_samples .or. config%n_modes /= n_modes) then
      ierr = err_runtime
      errmsg = 'internal: array sizes do not match the input (call resolve first)'
      return
   end if
   tau = traj%tau
   vt = traj%vt
   vtdot = traj%vtdot
   contact = traj%contact
   a = traj%a
   adot = traj%adot
   if (traj%n_switches > max_switches) then
      ierr = err_runtime
      write (errmsg, '(a,i0,a,i0,a)') 'the run changed phase ', traj%n_switches, &
         ' times, more than max_switches = ', max_switches, ' can return'
      return
   end if
   switch_tau(1:traj%n_switches) = traj%switch_tau(1:traj%n_switches)
   counters = [traj%steps, traj%contact_steps, traj%rejected_steps, traj%rhs_evaluations, &
               int(traj%n_switches, i8)]
end subroutine run

!> The explicit M, C, K, F of Eq. (15) and the state derivative for one state of a namelist's model.
subroutine model_terms(path, n_modes, tau, a, adot, in_contact, mass, damping, stiffness, force, &
                       rate, ierr, errmsg)
   use tmafm, only: model_t, load_model, ok
   use tmafm_kinds, only: dp
   implicit none
   character(len=*), intent(in) :: path
   integer, intent(in) :: n_modes
   real(dp), intent(in) :: tau
   real(dp), intent(in) :: a(n_modes)
   real(dp), intent(in) :: adot(n_modes)
   logical, intent(in) :: in_contact
   real(dp), intent(out) :: mass(n_modes, n_modes)
   real(dp), intent(out) :: damping(n_modes, n_modes)
   real(dp), intent(out) :: stiffness(n_modes, n_modes)
   real(dp), intent(out) :: force(n_modes)
   real(dp), intent(out) :: rate(2*n_modes)
   integer, intent(out) :: ierr
   character(len=512), intent(out) :: errmsg
   type(model_t) :: model

   mass = 0; damping = 0; stiffness = 0; force = 0; rate = 0
   call load_model(path, n_modes, model, ierr, errmsg)
   if (ierr /= ok) return
   call model%matrices(tau, a, in_contact, mass, damping, stiffness, force)
   call model%derivative(tau, [a, adot], in_contact, rate)
end subroutine model_terms

!> The state derivative of derivative_at_phase, and that of derivative_and_gap with its V_T and
!> dV_T/dtau, for one state of a namelist's model (the phase from model%phase(tau)).
subroutine model_rates_at_phase(path, n_modes, tau, a, adot, in_contact, rate, rate_with_gap, vt, vtdot, &
                                ierr, errmsg)
   use tmafm, only: model_t, load_model, ok
   use tmafm_kinds, only: dp
   implicit none
   character(len=*), intent(in) :: path
   integer, intent(in) :: n_modes
   real(dp), intent(in) :: tau
   real(dp), intent(in) :: a(n_modes)
   real(dp), intent(in) :: adot(n_modes)
   logical, intent(in) :: in_contact
   real(dp), intent(out) :: rate(2*n_modes)
   real(dp), intent(out) :: rate_with_gap(2*n_modes)
   real(dp), intent(out) :: vt
   real(dp), intent(out) :: vtdot
   integer, intent(out) :: ierr
   character(len=512), intent(out) :: errmsg
   type(model_t) :: model
   real(dp) :: sin_phase, cos_phase

   rate = 0; rate_with_gap = 0; vt = 0; vtdot = 0
   call load_model(path, n_modes, model, ierr, errmsg)
   if (ierr /= ok) return
   call model%phase(tau, sin_phase, cos_phase)
   call model%derivative_at_phase([a, adot], in_contact, sin_phase, cos_phase, rate)
   call model%derivative_and_gap([a, adot], in_contact, sin_phase, cos_phase, rate_with_gap, vt, vtdot)
end subroutine model_rates_at_phase

!> sin and cos of the drive phase at tau + nodes*h as the embedded pairs' stages take them.
subroutine stage_phases(path, n_modes, tau, h, n_nodes, nodes, sin_phase, cos_phase, ierr, errmsg)
   use tmafm, only: model_t, load_model, ok
   use tmafm_embedded_pair, only: pair_stage_phases => stage_phases
   use tmafm_kinds, only: dp
   implicit none
   character(len=*), intent(in) :: path
   integer, intent(in) :: n_modes
   real(dp), intent(in) :: tau
   real(dp), intent(in) :: h
   integer, intent(in) :: n_nodes
   real(dp), intent(in) :: nodes(n_nodes)
   real(dp), intent(out) :: sin_phase(n_nodes)
   real(dp), intent(out) :: cos_phase(n_nodes)
   integer, intent(out) :: ierr
   character(len=512), intent(out) :: errmsg
   type(model_t) :: model

   sin_phase = 0; cos_phase = 0
   call load_model(path, n_modes, model, ierr, errmsg)
   if (ierr /= ok) return
   call pair_stage_phases(model, tau, h, nodes, sin_phase, cos_phase)
end subroutine stage_phases

!> Contact state [theta1, A, f_c, h, P1, P2] for one gap and slope; law 1 Hertz, 2 DMT.
subroutine contact_state(vt, scaled_slope, theta, beta, law, kappa5, kappa6, signed_slope, state)
   use tmafm, only: contact_brackets_t, contact_brackets
   use tmafm_kinds, only: dp
   implicit none
   real(dp), intent(in) :: vt
   real(dp), intent(in) :: scaled_slope
   real(dp), intent(in) :: theta
   real(dp), intent(in) :: beta
   integer, intent(in) :: law
   real(dp), intent(in) :: kappa5
   real(dp), intent(in) :: kappa6
   logical, intent(in) :: signed_slope
   real(dp), intent(out) :: state(6)
   type(contact_brackets_t) :: s
   s = contact_brackets(vt, scaled_slope, theta, beta, law, kappa5, kappa6, signed_slope)
   state = [s%theta1, s%radius, s%normal, s%friction, s%transverse, s%axial]
end subroutine contact_state

!> Mode roots beta(n) and the derivative of order `order` of each mode at the points xi(nx).
subroutine modes(n, nx, xi, order, beta, values)
   use tmafm, only: beam_roots, mode_shape
   use tmafm_kinds, only: dp
   implicit none
   integer, intent(in) :: n
   integer, intent(in) :: nx
   real(dp), intent(in) :: xi(nx)
   integer, intent(in) :: order
   real(dp), intent(out) :: beta(n)
   real(dp), intent(out) :: values(nx, n)
   integer :: j
   beta = beam_roots(n)
   do j = 1, n
      values(:, j) = mode_shape(beta(j), xi, order)
   end do
end subroutine modes

!> Galerkin integrals of n modes, closed form and quadrature (G over [0, xi_end]), plus the Gram matrix.
subroutine galerkin(n, xi_end, q_closed, g_closed, q_quadrature, g_quadrature, gram)
   use tmafm, only: beam_roots
   use tmafm_galerkin, only: mode_integrals_closed_form, axial_matrix_closed_form, &
      mode_integrals_quadrature, axial_matrix_quadrature, mass_matrix_quadrature, quadrature_panels
   use tmafm_kinds, only: dp
   implicit none
   integer, intent(in) :: n
   real(dp), intent(in) :: xi_end
   real(dp), intent(out) :: q_closed(n)
   real(dp), intent(out) :: g_closed(n, n)
   real(dp), intent(out) :: q_quadrature(n)
   real(dp), intent(out) :: g_quadrature(n, n)
   real(dp), intent(out) :: gram(n, n)
   real(dp) :: beta(n)
   integer :: panels
   beta = beam_roots(n)
   panels = quadrature_panels(beta(n), 1.0_dp)
   q_closed = mode_integrals_closed_form(beta)
   g_closed = axial_matrix_closed_form(beta)
   q_quadrature = mode_integrals_quadrature(beta, panels)
   g_quadrature = axial_matrix_quadrature(beta, xi_end, quadrature_panels(beta(n), xi_end))
   gram = mass_matrix_quadrature(beta, panels)
end subroutine galerkin

!> Observed runs of n_configs namelist texts (text(offsets(k)+1:offsets(k+1)) is input k, with
!> n_modes(k) modes), run by the OpenMP batch on `threads` threads (0: OpenMP default) with the
!> GIL released.  Per input k: values(k, period, column) (tmafm_observers columns), the
!> harmonics (k, period, harmonic), Poincare points (k, 0:period, 1:2N), the located max V_T
!> (k, period) and modal extrema (k, period, mode, 1:4 = ext_* columns), periods integrated,
!> the steady period found, the factors to SI-derived units and has_scales (1 for &physical).
!> `groups` selects the observable groups (tmafm_observers group_* bits; the others are NaN).
!> `poll`: the calling thread's runs poll for Ctrl-C (Python's main thread only).
!> ierr(k) per input; errmsg is the message of the first input that failed.
subroutine observe_texts(text, offsets, n_configs, n_modes, max_periods, harmonics, p_max, tol, &
                         repeats, stop_at_steady, groups, threads, poll, n_state_max, n_columns, values, &
                         harmonic_amplitude, harmonic_phase, poincare, max_gap, modal_extrema, &
                         n_periods, period, factors, &
                         has_scales, steady_harmonic_amplitude, steady_harmonic_phase, evidence, ierr, errmsg)
   use tmafm_kinds, only: dp
   use tmafm_errors, only: ok, err_runtime
   use tmafm_config, only: config_t
   use tmafm_namelist, only: read_config_text
   use tmafm_observers, only: observer_t, n_observables, observable_factors
   use tmafm_batch, only: observe_options_t, observe_batch, config_scales, steady_harmonics, steady_evidence
   use tmafm_units, only: scales_t
   use tmafm_api_poll, only: python_interrupted
   implicit none
   !f2py threadsafe
   character(len=*), intent(in) :: text
   integer, intent(in) :: n_configs
   integer, intent(in) :: offsets(n_configs + 1)
   integer, intent(in) :: n_modes(n_configs)
   integer, intent(in) :: max_periods
   integer, intent(in) :: harmonics
   integer, intent(in) :: p_max
   real(dp), intent(in) :: tol
   integer, intent(in) :: repeats
   logical, intent(in) :: stop_at_steady
   integer, intent(in) :: groups
   integer, intent(in) :: threads
   logical, intent(in) :: poll
   integer, intent(in) :: n_state_max
   integer, intent(in) :: n_columns
   real(dp), intent(out) :: values(n_configs, max_periods, n_columns)
   real(dp), intent(out) :: harmonic_amplitude(n_configs, max_periods, harmonics)
   real(dp), intent(out) :: harmonic_phase(n_configs, max_periods, harmonics)
   real(dp), intent(out) :: poincare(n_configs, max_periods + 1, n_state_max)
   real(dp), intent(out) :: max_gap(n_configs, max_periods)
   real(dp), intent(out) :: modal_extrema(n_configs, max_periods, n_state_max/2, 4)
   integer, intent(out) :: n_periods(n_configs)
   integer, intent(out) :: period(n_configs)
   real(dp), intent(out) :: factors(n_configs, n_columns)
   integer, intent(out) :: has_scales(n_configs)
   real(dp), intent(out) :: steady_harmonic_amplitude(n_configs, harmonics)
   real(dp), intent(out) :: steady_harmonic_phase(n_configs, harmonics)
   real(dp), intent(out) :: evidence(n_configs, 5)
   integer, intent(out) :: ierr(n_configs)
   character(len=512), intent(out) :: errmsg
   type(config_t), allocatable :: configs(:)
   type(observer_t), allocatable :: observers(:)
   type(observe_options_t) :: options
   type(scales_t) :: scales
   character(len=512), allocatable :: messages(:)
   integer :: k, m, s

   values = 0; harmonic_amplitude = 0; harmonic_phase = 0; poincare = 0; n_periods = 0
   max_gap = 0; modal_extrema = 0
   period = 0; factors = 0; has_scales = 0; ierr = 0; errmsg = ''
   steady_harmonic_amplitude = 0; steady_harmonic_phase = 0; evidence = 0
   if (n_columns /= n_observables) then
      ierr = err_runtime
      write (errmsg, '(a,i0)') 'internal: observe_texts n_columns must be ', n_observables
      return
   end if
   allocate (configs(n_configs), observers(n_configs), messages(n_configs))
   messages = ''
   do k = 1, n_configs
      call read_config_text(text(offsets(k) + 1:offsets(k + 1)), 'observe input', configs(k), &
                            ierr(k), messages(k))
      if (ierr(k) /= ok) cycle
      ! The caller already chose N for an automatic n_modes: reuse its choice.
      configs(k)%auto_modes = .false.
      configs(k)%n_modes = n_modes(k)
      if (2*n_modes(k) > n_state_max) then
         ierr(k) = err_runtime
         messages(k) = 'internal: n_state_max is smaller than 2 n_modes'
      end if
   end do
   options%max_periods = max_periods
   options%p_max = p_max
   options%tol = tol
   options%repeats = repeats
   options%harmonics = harmonics
   options%stop_at_steady = stop_at_steady
   options%groups = groups
   ! Ctrl-C (when `poll`: Python's main thread): the calling thread's runs poll Python
   ! (tmafm_api_poll); inputs not yet started are skipped, and the f2py wrapper raises the
   ! exception Python's handler set.
   if (all(ierr == ok)) then
      if (poll) then
         call observe_batch(configs, options, observers, ierr, messages, threads, poll=python_interrupted)
      else
         call observe_batch(configs, options, observers, ierr, messages, threads)
      end if
   end if
   do k = 1, n_configs
      if (ierr(k) /= ok) then
         if (len_trim(errmsg) == 0) errmsg = messages(k)
         cycle
      end if
      m = observers(k)%n_periods
      s = observers(k)%n_state
      n_periods(k) = m
      period(k) = observers(k)%found_period
      values(k, 1:m, :) = observers(k)%values(1:m, :)
      harmonic_amplitude(k, 1:m, :) = observers(k)%harmonic_amplitude(1:m, :)
      harmonic_phase(k, 1:m, :) = observers(k)%harmonic_phase(1:m, :)
      poincare(k, 1:m + 1, 1:s) = transpose(observers(k)%poincare(:, 0:m))
      max_gap(k, 1:m) = observers(k)%max_gap_values(1:m)
      modal_extrema(k, 1:m, 1:s/2, :) = observers(k)%modal_extrema(1:m, :, :)
      call steady_harmonics(observers(k), steady_harmonic_amplitude(k, :), steady_harmonic_phase(k, :))
      evidence(k, :) = steady_evidence(observers(k))
      scales = config_scales(configs(k))
      factors(k, :) = observable_factors(scales)
      has_scales(k) = merge(1, 0, scales%known)
   end do
end subroutine observe_texts

!> Observed runs of one namelist text (with n_modes modes, N already chosen) from n_points
!> initial states (states(k, :) = [a0, adot0] of run k), by the OpenMP batch on `threads`
!> threads with the GIL released; the input is read and its model built once (a basin map).
!> Known attractors: orbit j is attractor_points(:, attractor_first(j):attractor_first(j+1)-1)
!> (n_first - 1 orbits; none when n_first < 2); `confirm` Poincare points in a row within
!> capture (relative to the orbit's size) of one, each closer than the one before, label the
!> run with it (attractor(k) = j, 0: none) and stop it.  Per run k: the steady
!> values (steady(k, column): the mean over the last max(period, 1) periods, NaN for a group
!> not computed; the same for the harmonics), the last p_max Poincare points (orbit(k, p_max, :)
!> is the final state; NaN before the first), periods run, the steady period, the attractor,
!> why no period was found (reason, tmafm_steady_state unsteady_*) and the jitter level of the
!> last point (absolute; 0 for a located method).
!> ierr: err_input for a bad input, options or state (nothing runs), with errmsg; run k's own
!> failure is run_ierr(k), and errmsg is then the first such message.  `poll` as observe_texts'.
subroutine observe_states_text(text, n_modes, states, n_points, n_state, max_periods, harmonics, &
                               p_max, tol, repeats, stop_at_steady, groups, attractor_points, &
                               n_attractor_points, attractor_first, n_first, confirm, capture, threads, &
                               poll, n_columns, steady, steady_harmonic_amplitude, steady_harmonic_phase, &
                               orbit, n_periods, period, attractor, factors, has_scales, run_ierr, &
                               reason, jitter, ierr, errmsg)
   use tmafm_kinds, only: dp
   use tmafm_errors, only: ok, err_runtime
   use tmafm_config, only: config_t
   use tmafm_namelist, only: read_config_text
   use tmafm_observers, only: observer_t, n_observables, observable_factors
   use tmafm_batch, only: observe_options_t, observe_states, config_scales, steady_harmonics
   use tmafm_observers, only: obs_amplitude, obs_phase
   use tmafm_units, only: scales_t
   use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan, ieee_is_nan
   use tmafm_api_poll, only: python_interrupted
   implicit none
   !f2py threadsafe
   character(len=*), intent(in) :: text
   integer, intent(in) :: n_modes
   integer, intent(in) :: n_points
   integer, intent(in) :: n_state
   real(dp), intent(in) :: states(n_points, n_state)
   integer, intent(in) :: max_periods
   integer, intent(in) :: harmonics
   integer, intent(in) :: p_max
   real(dp), intent(in) :: tol
   integer, intent(in) :: repeats
   logical, intent(in) :: stop_at_steady
   integer, intent(in) :: groups
   integer, intent(in) :: n_attractor_points
   real(dp), intent(in) :: attractor_points(n_state, n_attractor_points)
   integer, intent(in) :: n_first
   integer, intent(in) :: attractor_first(n_first)
   integer, intent(in) :: confirm
   real(dp), intent(in) :: capture
   integer, intent(in) :: threads
   logical, intent(in) :: poll
   integer, intent(in) :: n_columns
   real(dp), intent(out) :: steady(n_points, n_columns)
   real(dp), intent(out) :: steady_harmonic_amplitude(n_points, harmonics)
   real(dp), intent(out) :: steady_harmonic_phase(n_points, harmonics)
   real(dp), intent(out) :: orbit(n_points, p_max, n_state)
   integer, intent(out) :: n_periods(n_points)
   integer, intent(out) :: period(n_points)
   integer, intent(out) :: attractor(n_points)
   real(dp), intent(out) :: factors(n_columns)
   integer, intent(out) :: has_scales
   integer, intent(out) :: run_ierr(n_points)
   integer, intent(out) :: reason(n_points)
   real(dp), intent(out) :: jitter(n_points)
   integer, intent(out) :: ierr
   character(len=512), intent(out) :: errmsg
   type(config_t) :: config
   type(observer_t), allocatable :: observers(:)
   type(observe_options_t) :: options
   type(scales_t) :: scales
   character(len=512), allocatable :: messages(:)
   integer :: k, m, last, kept

   steady = 0; steady_harmonic_amplitude = 0; steady_harmonic_phase = 0
   orbit = ieee_value(1.0_dp, ieee_quiet_nan)
   n_periods = 0; period = 0; attractor = 0; factors = 0; has_scales = 0; run_ierr = 0; reason = 0; jitter = 0
   ierr = 0; errmsg = ''
   if (n_columns /= n_observables) then
      ierr = err_runtime
      write (errmsg, '(a,i0)') 'internal: observe_states_text n_columns must be ', n_observables
      return
   end if
   call read_config_text(text, 'observe input', config, ierr, errmsg)
   if (ierr /= ok) return
   ! The caller already chose N for an automatic n_modes: reuse its choice.
   config%auto_modes = .false.
   config%n_modes = n_modes
   options%max_periods = max_periods
   options%p_max = p_max
   options%tol = tol
   options%repeats = repeats
   options%harmonics = harmonics
   options%stop_at_steady = stop_at_steady
   options%groups = groups
   options%confirm = confirm
   options%capture = capture
   if (n_first >= 2) then
      options%attractor_points = attractor_points
      options%attractor_first = attractor_first
   end if
   allocate (observers(n_points), messages(n_points))
   if (poll) then
      call observe_states(config, transpose(states), options, observers, ierr, errmsg, run_ierr, messages, &
                          threads, poll=python_interrupted)
   else
      call observe_states(config, transpose(states), options, observers, ierr, errmsg, run_ierr, messages, &
                          threads)
   end if
   if (ierr /= ok) return
   do k = 1, n_points
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
         last = min(max(o%found_period, 1), m)
         if (last > 0) then
            steady(k, :) = sum(o%values(m - last + 1:m, :), 1)/last
            ! Amplitude and phase: the harmonic over the orbit's periods (tmafm_steady_state).
            call steady_harmonics(o, steady_harmonic_amplitude(k, :), steady_harmonic_phase(k, :))
            if (.not. ieee_is_nan(steady(k, obs_phase))) then
               steady(k, obs_amplitude) = steady_harmonic_amplitude(k, 1)
               steady(k, obs_phase) = steady_harmonic_phase(k, 1)
            end if
         end if
         reason(k) = o%reason
         jitter(k) = o%jitter_floor(m)
         kept = min(p_max, m + 1)
         orbit(k, p_max - kept + 1:p_max, :) = transpose(o%poincare(:, m - kept + 1:m))
      end associate
   end do
   scales = config_scales(config)
   factors = observable_factors(scales)
   has_scales = merge(1, 0, scales%known)
end subroutine observe_states_text

!> The classifier of tmafm_steady_state on a sequence of points (n_points x n_dim), the one
!> steady-state rule (tmafm.observe.steady_test, tmafm.analysis, the sweeps' attractor labels):
!> the period (0: none), the reason when none (unsteady_*), the closest repeat (relative to the
!> orbit's size, or to `scale` when scale > 0) and its lag, and every lag's largest step
!> (tmafm_steady_state repeat_steps).  floor(j): the absolute jitter level of point j (all 0:
!> none).
subroutine steady_test_of(points, n_points, n_dim, p_max, tol, repeats, floor, scale, period, reason, &
                          closest, closest_lag, steps)
   use tmafm_kinds, only: dp
   use tmafm_steady_state, only: steady_test, repeat_steps
   implicit none
   integer, intent(in) :: n_points
   integer, intent(in) :: n_dim
   real(dp), intent(in) :: points(n_points, n_dim)
   integer, intent(in) :: p_max
   real(dp), intent(in) :: tol
   integer, intent(in) :: repeats
   real(dp), intent(in) :: floor(n_points)
   real(dp), intent(in) :: scale
   integer, intent(out) :: period
   integer, intent(out) :: reason
   real(dp), intent(out) :: closest
   integer, intent(out) :: closest_lag
   real(dp), intent(out) :: steps(p_max)
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
!> tmafm_steady_state steady_harmonic, the phase free of the wrap at +-180.
subroutine steady_harmonic_of(amplitude, phase, n, mean_amplitude, mean_phase)
   use tmafm_kinds, only: dp
   use tmafm_steady_state, only: steady_harmonic
   implicit none
   integer, intent(in) :: n
   real(dp), intent(in) :: amplitude(n)
   real(dp), intent(in) :: phase(n)
   real(dp), intent(out) :: mean_amplitude
   real(dp), intent(out) :: mean_phase
   call steady_harmonic(amplitude, phase, mean_amplitude, mean_phase)
end subroutine steady_harmonic_of

!> One free flight of a namelist's model from y0 at tau0, sampled at tau0 + j dt (j = 0 ..
!> n_samples - 1) twice: as the run loop samples it (flight%sample: each term turned by
!> exp(lambda dt) from sample to sample) and by direct evaluation (flight%state: exp(lambda s)
!> at every sample).  Columns are the states (a, a').  For tests of the sampling.
subroutine flight_samples(path, n_modes, tau0, y0, dt, n_samples, recurrence, direct, ierr, errmsg)
   use tmafm, only: model_t, load_model, ok
   use tmafm_kinds, only: dp
   use tmafm_flight, only: free_flight_t
   implicit none
   character(len=*), intent(in) :: path
   integer, intent(in) :: n_modes
   real(dp), intent(in) :: tau0
   real(dp), intent(in) :: y0(2*n_modes)
   real(dp), intent(in) :: dt
   integer, intent(in) :: n_samples
   real(dp), intent(out) :: recurrence(2*n_modes, n_samples)
   real(dp), intent(out) :: direct(2*n_modes, n_samples)
   integer, intent(out) :: ierr
   character(len=512), intent(out) :: errmsg
   type(model_t) :: model
   type(free_flight_t) :: flight
   real(dp) :: s, sin_phase, cos_phase
   integer :: j

   recurrence = 0
   direct = 0
   call load_model(path, n_modes, model, ierr, errmsg)
   if (ierr /= ok) return
   call flight%init(model, ierr, errmsg)
   if (ierr /= ok) return
   call flight%sample_step(dt)
   call flight%start(model, tau0, y0)
   do j = 1, n_samples
      s = real(j - 1, dp)*dt
      call model%phase(tau0 + s, sin_phase, cos_phase)
      call flight%sample(s, sin_phase, cos_phase, recurrence(:, j))
      call flight%state(model, s, direct(:, j))
   end do
end subroutine flight_samples

!> V_T and dV_T/dtau of rows first .. first + count - 1 of a table of states (a and adot: rows x
!> n_modes, one sample per row, drive phases sin_phase(i), cos_phase(i) of row first + i - 1), as
!> the trajectory's rows take them (model%gap_rows), for a namelist's model; no other row of vt
!> and vtdot is touched.  ierr = err_input (nothing computed) when the rows are not inside the
!> table or n_modes is not the input's.  For tests of the rows.
subroutine gap_rows(path, rows, n_modes, first, count, a, adot, sin_phase, cos_phase, vt, vtdot, ierr, errmsg)
   use tmafm, only: model_t, load_model, ok
   use tmafm_kinds, only: dp
   use tmafm_errors, only: err_input
   implicit none
   character(len=*), intent(in) :: path
   integer, intent(in) :: rows
   integer, intent(in) :: n_modes
   integer, intent(in) :: first
   integer, intent(in) :: count
   real(dp), intent(in) :: a(rows, n_modes)
   real(dp), intent(in) :: adot(rows, n_modes)
   real(dp), intent(in) :: sin_phase(count)
   real(dp), intent(in) :: cos_phase(count)
   real(dp), intent(inout) :: vt(rows)
   real(dp), intent(inout) :: vtdot(rows)
   integer, intent(out) :: ierr
   character(len=512), intent(out) :: errmsg
   type(model_t) :: model

   ierr = ok
   errmsg = ''
   if (count < 1 .or. first < 1 .or. first > rows - count + 1) then
      ierr = err_input
      write (errmsg, '(a,i0,a,i0,a,i0,a)') 'gap_rows: rows ', first, ' to ', first + count - 1, &
         ' are not inside the table of ', rows, ' rows'
      return
   end if
   call load_model(path, n_modes, model, ierr, errmsg)  ! err_input unless N is the input's
   if (ierr /= ok) return
   call model%gap_rows(rows, first, count, a, adot, sin_phase, cos_phase, vt, vtdot)
end subroutine gap_rows

!> The first contact of one free flight of a namelist's model from y0 at tau0 within s_max, as
!> flight%first_contact scans it: anchor = 0 as the run loop does (V_T turned along the scan
!> ladder, evaluated directly every scan_anchor_every points), anchor = 1 with every scan point
!> evaluated directly.  found = 1 if V_T reaches zero; evaluations counts the scan's points
!> (direct or turned) and Brent's.  For tests of the scan.
subroutine flight_scan(path, n_modes, tau0, y0, s_max, anchor, found, s_contact, evaluations, ierr, errmsg)
   use tmafm, only: model_t, load_model, ok
   use tmafm_kinds, only: dp
   use tmafm_flight, only: free_flight_t
   implicit none
   character(len=*), intent(in) :: path
   integer, intent(in) :: n_modes
   real(dp), intent(in) :: tau0
   real(dp), intent(in) :: y0(2*n_modes)
   real(dp), intent(in) :: s_max
   integer, intent(in) :: anchor
   integer, intent(out) :: found
   real(dp), intent(out) :: s_contact
   integer, intent(out) :: evaluations
   integer, intent(out) :: ierr
   character(len=512), intent(out) :: errmsg
   type(model_t) :: model
   type(free_flight_t) :: flight
   logical :: hit

   found = 0
   s_contact = 0
   evaluations = 0
   call load_model(path, n_modes, model, ierr, errmsg)
   if (ierr /= ok) return
   call flight%init(model, ierr, errmsg)
   if (ierr /= ok) return
   call flight%start(model, tau0, y0)
   if (anchor > 0) then
      call flight%first_contact(model, s_max, hit, s_contact, evaluations, ierr, errmsg, anchor)
   else
      call flight%first_contact(model, s_max, hit, s_contact, evaluations, ierr, errmsg)
   end if
   found = merge(1, 0, hit)
end subroutine flight_scan

!> The resolved input's text of each of values(1:n), twice: as config_text writes it
!> (shortest_text_padded) and by trial formatted writes and reads (real_text_padded), as the
!> character codes of 40 blank-padded characters each.  For tests of the fast path.
subroutine real_texts(values, n, fast, slow)
   use tmafm_kinds, only: dp
   use tmafm_text, only: real_text_padded
   use tmafm_float_format, only: shortest_text_padded
   implicit none
   real(dp), intent(in) :: values(n)
   integer, intent(in) :: n
   integer, intent(out) :: fast(40, n)
   integer, intent(out) :: slow(40, n)
   character(len=40) :: text
   integer :: j, k

   do j = 1, n
      text = shortest_text_padded(values(j))
      fast(:, j) = [(iachar(text(k:k)), k = 1, 40)]
      text = real_text_padded(values(j))
      slow(:, j) = [(iachar(text(k:k)), k = 1, 40)]
   end do
end subroutine real_texts

!> The syntax tree of namelist text, as tmafm's strict reader parses it (tmafm_nml_syntax), for
!> files that Python reads itself (sweep files): one record per value, the fields group ordinal,
!> group name, entry ordinal, key, value kind (value_* constant), repeat count and value text
!> (a string's contents), as character codes; -1 ends a field, -2 a record.  codes(1:length)
!> are in use; length = -1 if max_codes is too small.
subroutine namelist_syntax(text, label, max_codes, codes, length, ierr, errmsg)
   use tmafm_nml_syntax, only: nml_document_t, parse_namelist
   use tmafm_text, only: int_text
   implicit none
   character(len=*), intent(in) :: text
   character(len=*), intent(in) :: label
   integer, intent(in) :: max_codes
   integer, intent(out) :: codes(max_codes)
   integer, intent(out) :: length
   integer, intent(out) :: ierr
   character(len=1024), intent(out) :: errmsg
   type(nml_document_t) :: doc
   integer :: g, e, v

   codes = 0
   length = 0
   call parse_namelist(text, label, doc, ierr, errmsg)
   if (ierr /= 0) return
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
      if (length + len(field) + 1 > max_codes) then
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
      if (length + 1 > max_codes) then
         length = -1
         return
      end if
      length = length + 1
      codes(length) = code
   end subroutine mark
end subroutine namelist_syntax

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

!> The constant data of a namelist's model, for peers and analysis written in numpy:
!> M, Lambda, G, and the vectors p, s, m (tip-mass point), r (moment shape), q; plus kappa5, kappa6.
subroutine model_data(path, n_modes, mass, eigen, axial, tip, slope, mass_point, moment_shape, &
                      integral, kappas, ierr, errmsg)
   use tmafm, only: model_t, load_model, ok
   use tmafm_kinds, only: dp
   implicit none
   character(len=*), intent(in) :: path
   integer, intent(in) :: n_modes
   real(dp), intent(out) :: mass(n_modes, n_modes)
   real(dp), intent(out) :: eigen(n_modes)
   real(dp), intent(out) :: axial(n_modes, n_modes)
   real(dp), intent(out) :: tip(n_modes)
   real(dp), intent(out) :: slope(n_modes)
   real(dp), intent(out) :: mass_point(n_modes)
   real(dp), intent(out) :: moment_shape(n_modes)
   real(dp), intent(out) :: integral(n_modes)
   real(dp), intent(out) :: kappas(2)
   integer, intent(out) :: ierr
   character(len=512), intent(out) :: errmsg
   type(model_t) :: model

   mass = 0; eigen = 0; axial = 0; tip = 0; slope = 0; mass_point = 0; moment_shape = 0
   integral = 0; kappas = 0
   call load_model(path, n_modes, model, ierr, errmsg)
   if (ierr /= ok) return
   mass = model%mass
   eigen = model%eigen
   axial = model%axial
   tip = model%tip
   slope = model%slope
   mass_point = model%mass_point
   moment_shape = model%moment_shape
   integral = model%integral
   kappas = [model%kappa5, model%kappa6]
end subroutine model_data

!> Along a sampled trajectory: the five powers of model_t%energy_flow, the modal energy, and
!> the contact state [theta1, A, f_c, h, P1, P2] (zeros out of contact; contact(k) = 1 marks it).
subroutine energy_flow(path, n_samples, n_modes, tau, a, adot, contact, power, energy, state, &
                       ierr, errmsg)
   use tmafm, only: model_t, load_model, ok, contact_brackets_t
   use tmafm_kinds, only: dp
   implicit none
   character(len=*), intent(in) :: path
   integer, intent(in) :: n_samples
   integer, intent(in) :: n_modes
   real(dp), intent(in) :: tau(n_samples)
   real(dp), intent(in) :: a(n_samples, n_modes)
   real(dp), intent(in) :: adot(n_samples, n_modes)
   integer, intent(in) :: contact(n_samples)
   real(dp), intent(out) :: power(n_samples, 5)
   real(dp), intent(out) :: energy(n_samples)
   real(dp), intent(out) :: state(n_samples, 6)
   integer, intent(out) :: ierr
   character(len=512), intent(out) :: errmsg
   type(model_t) :: model
   type(contact_brackets_t) :: s
   integer :: k

   power = 0; energy = 0; state = 0
   call load_model(path, n_modes, model, ierr, errmsg)
   if (ierr /= ok) return
   do k = 1, n_samples
      call model%energy_flow(tau(k), a(k, :), adot(k, :), contact(k) == 1, power(k, :), energy(k))
      if (contact(k) == 1) then
         s = model%contact(tau(k), a(k, :))
         state(k, :) = [s%theta1, s%radius, s%normal, s%friction, s%transverse, s%axial]
      end if
   end do
end subroutine energy_flow

!> Observed runs of n_configs namelist texts (text(offsets(k)+1:offsets(k+1)) is input k, with
!> n_modes(k) modes), run by the OpenMP batch on `threads` threads (0: OpenMP default) with the
!> GIL released.  Per input k: values(k, period, column) (tmafm_observers columns), the
!> harmonics (k, period, harmonic), Poincare points (k, 0:period, 1:2N), the located max V_T
!> (k, period) and modal extrema (k, period, mode, 1:4 = ext_* columns), periods integrated,
!> the steady period found, the factors to SI-derived units and has_scales (1 for &physical).
!> ierr(k) per input; errmsg is the message of the first input that failed.
subroutine observe_texts(text, offsets, n_configs, n_modes, max_periods, harmonics, p_max, tol, &
                         repeats, stop_at_steady, threads, n_state_max, n_columns, values, &
                         harmonic_amplitude, harmonic_phase, poincare, max_gap, modal_extrema, &
                         n_periods, period, factors, &
                         has_scales, ierr, errmsg)
   use tmafm_kinds, only: dp
   use tmafm_errors, only: ok, err_runtime
   use tmafm_config, only: config_t
   use tmafm_namelist, only: read_config_text
   use tmafm_observers, only: observer_t, n_observables, observable_factors
   use tmafm_batch, only: observe_options_t, observe_batch, config_scales
   use tmafm_units, only: scales_t
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
   integer, intent(in) :: threads
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
   options = observe_options_t(max_periods=max_periods, p_max=p_max, tol=tol, repeats=repeats, &
                               harmonics=harmonics, stop_at_steady=stop_at_steady)
   if (all(ierr == ok)) call observe_batch(configs, options, observers, ierr, messages, threads)
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
      scales = config_scales(configs(k))
      factors(k, :) = observable_factors(scales)
      has_scales(k) = merge(1, 0, scales%known)
   end do
end subroutine observe_texts

!> The classifier of tmafm_steady_state on a sequence of points (n_points x n_dim), for tests.
subroutine steady_period_of(points, n_points, n_dim, p_max, tol, repeats, period)
   use tmafm_kinds, only: dp
   use tmafm_steady_state, only: steady_period
   implicit none
   integer, intent(in) :: n_points
   integer, intent(in) :: n_dim
   real(dp), intent(in) :: points(n_points, n_dim)
   integer, intent(in) :: p_max
   real(dp), intent(in) :: tol
   integer, intent(in) :: repeats
   integer, intent(out) :: period
   period = steady_period(transpose(points), p_max, tol, repeats)
end subroutine steady_period_of

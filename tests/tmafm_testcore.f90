! Test-only entry points into the core, compiled by numpy.f2py into tmafm_testcore: an
! extension built into a build folder only (pywrap/meson.build: build_by_default false,
! install false) and loaded by tests/testcore.py.  The package reaches the core only through
! tmafm_api (f90wrap); nothing here is installed.
!
! Only scalars, strings and explicit-shape arrays cross this boundary: every routine that can
! fail returns ierr (0 on success, the tmafm_errors codes otherwise) and a one-line errmsg.

!> Read and validate a namelist file with the core's file reader (tmafm_input_file), choose N,
!> and write the resolved input to resolved_path.  For tests of the file reader.
subroutine resolve(path, resolved_path, ierr, errmsg)
   use tmafm, only: config_t, read_config, write_config, choose_mode_count, ok, err_file
   implicit none
   character(len=*), intent(in) :: path
   character(len=*), intent(in) :: resolved_path
   integer, intent(out) :: ierr
   character(len=512), intent(out) :: errmsg
   type(config_t) :: config
   integer :: unit, iostat

   call read_config(path, config, ierr, errmsg)
   if (ierr /= ok) return
   call choose_mode_count(config, ierr, errmsg)
   if (ierr /= ok) return
   open (newunit=unit, file=resolved_path, status='replace', action='write', iostat=iostat)
   if (iostat /= 0) then
      ierr = err_file
      errmsg = 'cannot write '''//trim(resolved_path)//''''
      return
   end if
   call write_config(unit, config, '')
   close (unit)
end subroutine resolve

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

!> K0(z), K1(z) at n complex points z = z_re + i z_im, and the hydrodynamic functions of a
!> circular and a rectangular beam at n Reynolds numbers re (tmafm_hydrodynamics).
subroutine hydrodynamic_functions(n, z_re, z_im, k0_re, k0_im, k1_re, k1_im, converged, re, &
                                  circ_re, circ_im, rect_re, rect_im)
   use tmafm_kinds, only: dp
   use tmafm_hydrodynamics, only: bessel_k01, gamma_circular, gamma_rectangular
   implicit none
   integer, intent(in) :: n
   real(dp), intent(in) :: z_re(n)
   real(dp), intent(in) :: z_im(n)
   real(dp), intent(out) :: k0_re(n)
   real(dp), intent(out) :: k0_im(n)
   real(dp), intent(out) :: k1_re(n)
   real(dp), intent(out) :: k1_im(n)
   logical, intent(out) :: converged(n)
   real(dp), intent(in) :: re(n)
   real(dp), intent(out) :: circ_re(n)
   real(dp), intent(out) :: circ_im(n)
   real(dp), intent(out) :: rect_re(n)
   real(dp), intent(out) :: rect_im(n)
   complex(dp) :: k0, k1, g
   integer :: j
   do j = 1, n
      call bessel_k01(cmplx(z_re(j), z_im(j), dp), k0, k1, converged(j))
      k0_re(j) = real(k0, dp)
      k0_im(j) = aimag(k0)
      k1_re(j) = real(k1, dp)
      k1_im(j) = aimag(k1)
      g = gamma_circular(re(j))
      circ_re(j) = real(g, dp)
      circ_im(j) = aimag(g)
      g = gamma_rectangular(re(j))
      rect_re(j) = real(g, dp)
      rect_im(j) = aimag(g)
   end do
end subroutine hydrodynamic_functions

!> A namelist's model in a liquid: each mode's added mass, damping C_jj, frequency in the liquid
!> and Reynolds number there (model_t; zero added mass and alpha3 damping without a liquid).
subroutine fluid_loads(path, n_modes, added_mass, damping, frequency, reynolds, ierr, errmsg)
   use tmafm, only: model_t, load_model, ok
   use tmafm_kinds, only: dp
   implicit none
   character(len=*), intent(in) :: path
   integer, intent(in) :: n_modes
   real(dp), intent(out) :: added_mass(n_modes)
   real(dp), intent(out) :: damping(n_modes)
   real(dp), intent(out) :: frequency(n_modes)
   real(dp), intent(out) :: reynolds(n_modes)
   integer, intent(out) :: ierr
   character(len=512), intent(out) :: errmsg
   type(model_t) :: model
   added_mass = 0; damping = 0; frequency = 0; reynolds = 0
   call load_model(path, n_modes, model, ierr, errmsg)
   if (ierr /= ok) return
   added_mass = model%added_mass
   damping = model%modal_damping
   frequency = model%medium_frequency
   reynolds = model%medium_reynolds
end subroutine fluid_loads
!> A viscoelastic sample's dashpot coordinate w at the first max_switches switches V_T = 0 of
!> an adaptive run (pair 1 dopri5, 2 dop853) of a namelist's model from rest: switch k at
!> tau(k) with w(k), entering contact when entering(k) = 1.  The pair integrates w in flight
!> as in contact (the model's ODE), so that a test can check the flight against the closed form.
subroutine sls_switches(path, n_modes, pair, max_switches, tau, w, entering, n_switches, ierr, errmsg)
   use tmafm, only: model_t, config_t, read_config, build_model, ok, err_input
   use tmafm_kinds, only: dp
   use tmafm_trajectory, only: trajectory_t, init_trajectory, progress_t
   use tmafm_method_adaptive, only: adaptive_state_t
   implicit none
   character(len=*), intent(in) :: path
   integer, intent(in) :: n_modes
   integer, intent(in) :: pair
   integer, intent(in) :: max_switches
   real(dp), intent(out) :: tau(max_switches)
   real(dp), intent(out) :: w(max_switches)
   integer, intent(out) :: entering(max_switches)
   integer, intent(out) :: n_switches
   integer, intent(out) :: ierr
   character(len=512), intent(out) :: errmsg
   type(config_t) :: config
   type(model_t) :: model
   type(trajectory_t) :: traj
   type(progress_t) :: progress
   type(adaptive_state_t) :: state
   real(dp), allocatable :: y0(:)

   tau = 0; w = 0; entering = 0; n_switches = 0
   call read_config(path, config, ierr, errmsg)
   if (ierr /= ok) return
   if (config%n_modes /= n_modes) then
      ierr = err_input
      errmsg = 'n_modes of the call does not match the namelist'
      return
   end if
   call build_model(config, model, ierr, errmsg)
   if (ierr /= ok) return
   if (.not. model%sls%on) then
      ierr = err_input
      errmsg = 'the namelist has no viscoelastic sample'
      return
   end if
   allocate (y0(model%n_state), source=0.0_dp)
   call init_trajectory(traj, config%solver, n_modes)
   call state%init(pair, model, config%solver, 0.0_dp, y0)
   do while (n_switches < max_switches .and. .not. traj%complete())
      call state%advance(model, config%solver, traj, .true., ierr, errmsg, progress)
      if (ierr /= ok) return
      if (traj%complete()) exit
      n_switches = n_switches + 1
      tau(n_switches) = state%tau
      w(n_switches) = state%y(2*n_modes + 1)
      entering(n_switches) = merge(1, 0, state%in_contact)
   end do
end subroutine sls_switches

!> Read a namelist and choose N with the search's work budget `budget` (steps times modes),
!> instead of tmafm_settings search_work_budget; n_modes is the N chosen.  For the test of the
!> budget's refusal, which the default budget reaches only after about a minute.
subroutine choose_with_budget(path, budget, n_modes, ierr, errmsg)
   use tmafm, only: config_t, read_config, choose_mode_count, ok
   use tmafm_kinds, only: dp
   implicit none
   character(len=*), intent(in) :: path
   real(dp), intent(in) :: budget
   integer, intent(out) :: n_modes
   integer, intent(out) :: ierr
   character(len=512), intent(out) :: errmsg
   type(config_t) :: config

   n_modes = 0
   call read_config(path, config, ierr, errmsg)
   if (ierr /= ok) return
   call choose_mode_count(config, ierr, errmsg, budget=budget)
   if (ierr /= ok) return
   n_modes = config%n_modes
end subroutine choose_with_budget

!> The closed-form integrals (tmafm_flight_observables' integrate) of one free flight of a
!> namelist's model from y0 at tau0, under the held modal force accel (zeros: none), over
!> [tau0 + s_a, tau0 + s_b]: `whole` in one piece by a new observer, `split` as the sum over
!> `pieces` equal pieces taken in turn by another (the integrals' cache of the first piece's
!> length then serves the others, whose lengths differ from it by the rounding of their ends).
!> Each is V_T's lock-in sums against sin and cos of harmonics 1..harmonics, int p.a, and the
!> drive and beam-damping works.  For tests of the cache.
subroutine flight_piece_sums(path, n_modes, harmonics, tau0, y0, accel, s_a, s_b, pieces, whole, split, ierr, &
                             errmsg)
   use tmafm, only: model_t, load_model, ok
   use tmafm_kinds, only: dp, i8
   use tmafm_flight, only: free_flight_t
   use tmafm_flight_observables, only: flight_observables_t
   implicit none
   character(len=*), intent(in) :: path
   integer, intent(in) :: n_modes
   integer, intent(in) :: harmonics
   real(dp), intent(in) :: tau0
   real(dp), intent(in) :: y0(2*n_modes)
   real(dp), intent(in) :: accel(n_modes)
   real(dp), intent(in) :: s_a
   real(dp), intent(in) :: s_b
   integer, intent(in) :: pieces
   real(dp), intent(out) :: whole(2*harmonics + 3)
   real(dp), intent(out) :: split(2*harmonics + 3)
   integer, intent(out) :: ierr
   character(len=512), intent(out) :: errmsg
   type(model_t) :: model
   type(free_flight_t) :: flight
   type(flight_observables_t) :: one, many
   real(dp) :: acc_sin(harmonics), acc_cos(harmonics), deflection, drive, beam
   integer :: j

   whole = 0
   split = 0
   call load_model(path, n_modes, model, ierr, errmsg)
   if (ierr /= ok) return
   ! The noise on (any grid; the force is accel): the flight forms its static response for hold.
   call model%set_thermal(1.0_dp, 1_i8)
   call flight%init(model, ierr, errmsg)
   if (ierr /= ok) return
   call flight%hold(model, accel)
   call flight%start(model, tau0, y0)
   call one%init(model, flight, harmonics)
   call many%init(model, flight, harmonics)
   call clear()
   call one%integrate(flight, tau0 + s_a, tau0 + s_b, .true., .true., acc_sin, acc_cos, deflection, drive, beam)
   whole = [acc_sin, acc_cos, deflection, drive, beam]
   call clear()
   do j = 1, pieces
      call many%integrate(flight, tau0 + (s_a + (s_b - s_a)*real(j - 1, dp)/pieces), &
                          tau0 + (s_a + (s_b - s_a)*real(j, dp)/pieces), .true., .true., acc_sin, acc_cos, &
                          deflection, drive, beam)
   end do
   split = [acc_sin, acc_cos, deflection, drive, beam]

contains

   subroutine clear()
      acc_sin = 0
      acc_cos = 0
      deflection = 0
      drive = 0
      beam = 0
   end subroutine clear
end subroutine flight_piece_sums

!> The stroboscopic map P^n over n drive periods and its Jacobian, the monodromy matrix, for
!> the shooting and continuation of periodic orbits (docs/continuation.md).
!>
!> P^n takes the state y at tau = 0 to the state at tau = n T, T = 2 pi/Omega_0 the drive's
!> period (one tone: Omega_0 = Omega; two tones or a phase: the common period of tmafm_drive; the
!> equations depend on tau only through the drive, so every period starts at phase 0).  The state
!> is y = (a, a'), or (a, a', w) with a viscoelastic sample (w the dashpot coordinate; model_t's
!> pad y(2N + 2) = 0 never changes and is left out: map_state_size).  Along the orbit the matrix
!> Phi = dy(tau)/dy(0) is carried with the state:
!>  - in a free flight of the laws with no force out of contact (hertz, dmt) exactly, as the
!>    flight's own propagator exp(A s) = sum_k Re(V_k e^(lambda_k s) W_k) from the modal
!>    decomposition of tmafm_flight, the same one that moves the state, whose first contact it
!>    also locates (and w relaxes as exp(-r s/T), tmafm_viscoelastic);
!>  - in contact, and under 'dmt_vdw' in flight too (the attraction acts there, so the flight is
!>    not the free flow), by the variational equations Phi' = J(tau, y) Phi (J from
!>    tmafm_model_jacobian) integrated together with the state by the Dormand-Prince 5(4) pair,
!>    every component under the step control; the switch (V_T = 0 upwards ending a contact,
!>    downwards ending such a flight, also where V_T dips below 0 and back inside one step) is
!>    located by Brent on the length of the last step (each trial a full step from the same
!>    start);
!>  - at every switch by the saltation matrix S = I + (f+ - f-) n^T / (dV_T/dtau), n = (p, 0[, 0]),
!>    f- and f+ the vector fields before and after the switch at the switch state (identity
!>    when the force is continuous there: Hertz, or 'dmt_vdw', whose attraction meets the DMT
!>    force at V_T = 0, without contact damping);
!>  - with a capillary meniscus (docs/model.md §19), a flight it holds is integrated like a contact
!>    (its force acts), and ends at V_T (1 - V_T/o) = 0 (model_t%switch_gap): where the tip touches again
!>    (the saltation above) or where the meniscus breaks (its force is zero there: no saltation).
!>    Its flag is the map state's last component, discrete: no row and no column of Phi.
!> Along the way it records what grazing and the observables need (stats, stat_* indices).
!> Everything is allocated once per call; the steps allocate nothing.
module tmafm_monodromy
   use tmafm_kinds, only: dp
   use tmafm_errors, only: ok, err_input, err_runtime
   use tmafm_model, only: model_t
   use tmafm_contact, only: law_hertz, law_dmt
   use tmafm_vdw, only: law_dmt_vdw
   use tmafm_jkr, only: law_jkr
   use tmafm_contact, only: contact_angle_sin_cos
   use tmafm_model_jacobian, only: model_jacobian, map_state_size, map_to_model_state, model_to_map_state
   use tmafm_flight, only: free_flight_t
   use tmafm_events, only: initial_phase
   use tmafm_roots, only: bracketed_root_t
   use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
   implicit none
   private

   public :: stroboscopic_map, n_orbit_stats, map_state_size
   public :: stat_contacts, stat_gap_min, stat_gap_max, stat_flight_gap_min, stat_contact_time, &
      stat_switch_rate_min, stat_contact_steps, stat_evaluations

   !> Indices of stats: contacts begun; min and max of V_T over the orbit; the smallest local
   !> minimum of V_T inside a flight (huge() if none: the distance from grazing); time in
   !> contact; the smallest |dV_T/dtau| at a switch (huge() if none); steps of the integrated
   !> phases taken (the contacts; under 'dmt_vdw' the flights too); right-hand sides evaluated.
   integer, parameter :: stat_contacts = 1, stat_gap_min = 2, stat_gap_max = 3, stat_flight_gap_min = 4, &
      stat_contact_time = 5, stat_switch_rate_min = 6, stat_contact_steps = 7, stat_evaluations = 8
   !> Number of stats.
   integer, parameter :: n_orbit_stats = 8
   !> Most steps (accepted or not) one integrated phase may take.
   integer, parameter :: max_contact_steps = 2000000
   !> The largest relative tolerance accepted.
   real(dp), parameter :: max_rtol = 1.0e-3_dp
   !> Scan points per drive period of a flight's extrema (at least; more for fast modes).
   integer, parameter :: scan_per_period = 64

   ! Dormand-Prince 5(4) (Hairer, Norsett, Wanner, Table II.5.2).
   real(dp), parameter :: c2 = 0.2_dp, c3 = 0.3_dp, c4 = 0.8_dp, c5 = 8.0_dp/9.0_dp
   real(dp), parameter :: a21 = 0.2_dp
   real(dp), parameter :: a31 = 3.0_dp/40.0_dp, a32 = 9.0_dp/40.0_dp
   real(dp), parameter :: a41 = 44.0_dp/45.0_dp, a42 = -56.0_dp/15.0_dp, a43 = 32.0_dp/9.0_dp
   real(dp), parameter :: a51 = 19372.0_dp/6561.0_dp, a52 = -25360.0_dp/2187.0_dp, &
      a53 = 64448.0_dp/6561.0_dp, a54 = -212.0_dp/729.0_dp
   real(dp), parameter :: a61 = 9017.0_dp/3168.0_dp, a62 = -355.0_dp/33.0_dp, a63 = 46732.0_dp/5247.0_dp, &
      a64 = 49.0_dp/176.0_dp, a65 = -5103.0_dp/18656.0_dp
   real(dp), parameter :: b1 = 35.0_dp/384.0_dp, b3 = 500.0_dp/1113.0_dp, b4 = 125.0_dp/192.0_dp, &
      b5 = -2187.0_dp/6784.0_dp, b6 = 11.0_dp/84.0_dp
   real(dp), parameter :: e1 = 71.0_dp/57600.0_dp, e3 = -71.0_dp/16695.0_dp, e4 = 71.0_dp/1920.0_dp, &
      e5 = -17253.0_dp/339200.0_dp, e6 = 22.0_dp/525.0_dp, e7 = -1.0_dp/40.0_dp

   !> Registers of the augmented integrator, z = (y, Phi(:)): y the model's state (n_state,
   !> with its pad), Phi the map's m x m matrix.
   type :: work_t
      integer :: m = 0, n_state = 0, size = 0
      real(dp), allocatable :: k(:, :), z(:), z_new(:), z_try(:), stage(:), weight(:), jac(:, :)
      real(dp) :: rtol = 0, atol_state = 0
      integer :: evaluations = 0
   end type work_t

contains

   !> y_end = P^n(y0) and monodromy = dP^n/dy0 over n_periods drive periods from tau = 0, with
   !> relative tolerance rtol where the orbit is integrated; stats as the stat_* indices say.
   !> y0, y_end: map_state_size(model); monodromy: its square.
   subroutine stroboscopic_map(model, y0, n_periods, rtol, y_end, monodromy, stats, ierr, errmsg)
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: y0(:)
      integer, intent(in) :: n_periods
      real(dp), intent(in) :: rtol
      real(dp), intent(out) :: y_end(:)
      real(dp), intent(out) :: monodromy(:, :)
      real(dp), intent(out) :: stats(n_orbit_stats)
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(free_flight_t) :: flight
      type(work_t) :: w
      real(dp) :: tau, t_end, s_contact, h, period, scale_period, y(model%n_state), phi(size(y0), size(y0))
      real(dp) :: vt, offset, offset_rate
      logical :: in_contact, found
      integer :: m, n, j, evaluations

      ierr = ok
      errmsg = ''
      stats = 0
      y_end = 0
      monodromy = 0
      m = map_state_size(model)
      n = model%n_modes
      if (size(y0) /= m .or. size(y_end) /= m .or. any(shape(monodromy) /= [m, m])) then
         ierr = err_input
         if (model%sls%on .or. model%hysteretic) then
            write (errmsg, '(a,i0,a)') 'stroboscopic map: the state (a, adot[, w][, phase flag]) must have ', m, &
               ' components'
         else
            write (errmsg, '(a,i0)') 'stroboscopic map: the state must have 2N = ', m
         end if
         return
      end if
      if (model%law == law_jkr .and. model%surface%on) then
         ierr = err_input
         errmsg = "stroboscopic map: &model contact_law = 'jkr' with a force at a distance (a tip bias or a "// &
                  "double layer): the neck's Jacobian does not take it; continue the JKR scene without it"
         return
      end if
      if (model%law /= law_hertz .and. model%law /= law_dmt .and. model%law /= law_dmt_vdw &
          .and. model%law /= law_jkr) then
         ierr = err_input
         write (errmsg, '(a,i0,a)') 'stroboscopic map: &model contact_law = ', model%law, &
            ' has no Jacobian (hertz, dmt, dmt_vdw or jkr)'
         return
      end if
      if (n_periods < 1) then
         ierr = err_input
         write (errmsg, '(a,i0,a)') 'stroboscopic map: n_periods = ', n_periods, ': must be >= 1'
         return
      end if
      if (.not. (rtol >= 100*epsilon(1.0_dp) .and. rtol <= max_rtol)) then
         ierr = err_input
         write (errmsg, '(a,es10.3,a,es8.1,a,es8.1)') 'stroboscopic map: rtol = ', rtol, &
            ': must be in ', 100*epsilon(1.0_dp), ' to ', max_rtol
         return
      end if
      if (.not. all(ieee_is_finite(y0))) then
         ierr = err_input
         errmsg = 'stroboscopic map: the state must be finite'
         return
      end if
      if (.not. (model%drive%fundamental > 0)) then
         ierr = err_input
         errmsg = 'stroboscopic map: &scene omega must be > 0 (a drive period is needed)'
         return
      end if
      if (model%sls%on) then
         if (.not. (y0(2*n + 1) >= 0)) then
            ierr = err_input
            write (errmsg, '(a,es12.5,a)') 'stroboscopic map: the dashpot coordinate w = ', y0(2*n + 1), &
               ' must be >= 0'
            return
         end if
      end if

      if (.not. model%long_range) then
         call flight%init(model, ierr, errmsg)
         if (ierr /= ok) return
      end if
      w%m = m
      w%n_state = model%n_state
      w%size = w%n_state + m*m
      w%rtol = rtol
      ! The state's absolute floor: rtol times its own scale (the tip's stroke, the drive's size,
      ! or the state, whichever is largest), so that a component passing through zero stays
      ! controlled.
      w%atol_state = rtol*max(maxval(abs(y0)), model%drive%size, abs(model%scene%delta_hat))
      allocate (w%k(w%size, 7), w%z(w%size), w%z_new(w%size), w%z_try(w%size), w%stage(w%size), &
                w%weight(w%size), w%jac(m, m))

      period = 2*acos(-1.0_dp)/model%drive%fundamental
      ! The time scale of the steps and scans: the fastest tone's period (one tone: T itself).
      scale_period = 2*acos(-1.0_dp)/max(model%drive%top_frequency, model%drive%fundamental)
      t_end = n_periods*period
      tau = 0
      call map_to_model_state(model, y0, y)
      phi = 0
      do j = 1, m
         phi(j, j) = 1
      end do
      ! The phase's flag (the map state's last component) is discrete: no row, no column.
      if (model%hysteretic) phi(m, m) = 0
      if (model%meniscus%on) then
         y(model%meniscus_slot) = merge(1.0_dp, 0.0_dp, y0(m) > 0.5_dp)
         ! A meniscus stretched past its rupture gap has broken.
         vt = model%tip_gap(0.0_dp, y)
         call model%switch_offset(y, .false., vt, 0.0_dp, offset, offset_rate)
         if (vt > 0 .and. vt - offset <= 0) y(model%meniscus_slot) = 0
      end if
      stats(stat_gap_min) = huge(1.0_dp)
      stats(stat_gap_max) = -huge(1.0_dp)
      stats(stat_flight_gap_min) = huge(1.0_dp)
      stats(stat_switch_rate_min) = huge(1.0_dp)
      in_contact = initial_phase(model, 0.0_dp, y)
      if (model%law == law_jkr .and. y0(m) > 0.5_dp) then
         ! A neck that holds at the boundary, stretched above the surface up to its pull-off gap.
         vt = model%tip_gap(0.0_dp, y)
         call model%switch_offset(y, .true., vt, 0.0_dp, offset, offset_rate)
         in_contact = vt <= offset
      end if
      h = 0
      do while (tau < t_end)
         if (in_contact .or. model%long_range .or. model%wet(y)) then
            ! In contact, a forced flight, or a flight a meniscus holds (whose rupture leaves the
            ! phase with a continuous force: no saltation).
            found = in_contact
            call forced_phase(model, w, tau, t_end, scale_period, y, phi, h, in_contact, stats, ierr, errmsg)
            if (ierr /= ok) return
            if (in_contact .neqv. found) then
               call saltation(model, tau, y, phi, in_contact, stats)
               if (in_contact) then
                  stats(stat_contacts) = stats(stat_contacts) + 1
                  h = 0
               end if
            end if
         else
            call flight%start(model, tau, y)
            evaluations = 0
            call flight%first_contact(model, t_end - tau, found, s_contact, evaluations, ierr, errmsg)
            if (ierr /= ok) return
            w%evaluations = w%evaluations + evaluations
            call flight_extrema(model, flight, s_contact, scale_period, stats, w%evaluations)
            call flight%state(model, s_contact, y)
            call flight_propagate(flight, s_contact, phi(1:2*n, :))
            ! The dashpot relaxes on its own in flight: w(s) = w(0) exp(-r s/T).
            if (model%sls%on) phi(m, :) = phi(m, :)*exp(-model%sls%modulus_ratio*model%sls%rate*s_contact)
            if (found) then
               tau = tau + s_contact
               call saltation(model, tau, y, phi, .true., stats)
               in_contact = .true.
               stats(stat_contacts) = stats(stat_contacts) + 1
               h = 0
            else
               tau = t_end
            end if
         end if
         if (.not. (all(ieee_is_finite(y)) .and. all(ieee_is_finite(phi)))) then
            ierr = err_runtime
            errmsg = 'stroboscopic map: the orbit or its monodromy matrix is not finite'
            return
         end if
      end do
      call model_to_map_state(model, y, y_end)
      if (model%law == law_jkr) y_end(m) = merge(1.0_dp, 0.0_dp, in_contact)
      monodromy = phi
      stats(stat_evaluations) = w%evaluations
   end subroutine stroboscopic_map

   !> Phi <- exp(A s) Phi, exp(A s) = sum over the kept terms of multiplicity Re(V_k e^(lambda_k s) W_k).
   subroutine flight_propagate(flight, s, phi)
      type(free_flight_t), intent(in) :: flight
      real(dp), intent(in) :: s
      real(dp), intent(inout) :: phi(:, :)
      real(dp) :: e(size(phi, 1), size(phi, 1))
      complex(dp) :: col(size(phi, 1))
      integer :: k, j
      e = 0
      do k = 1, flight%n_terms
         col = flight%vectors(:, k)*exp(flight%eigenvalue(k)*s)
         do j = 1, size(phi, 1)
            e(:, j) = e(:, j) + flight%multiplicity(k)*real(col*flight%inverse(k, j), dp)
         end do
      end do
      phi = matmul(e, phi)
   end subroutine flight_propagate

   !> Phi <- S Phi at a switch at (tau, y): S = I + (f+ - f-) (p, 0)^T / (dV_T/dtau), f- the
   !> field of the phase left and f+ that of the phase entered (entering: free -> contact).
   subroutine saltation(model, tau, y, phi, entering, stats)
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: y(:)
      real(dp), intent(inout) :: phi(:, :)
      logical, intent(in) :: entering
      real(dp), intent(inout) :: stats(n_orbit_stats)
      real(dp) :: f_free(size(y)), f_contact(size(y)), jump(size(phi, 1)), row(size(phi, 2)), rate
      real(dp) :: normal(model%n_modes)
      integer :: n, j
      n = model%n_modes
      call model%derivative(tau, y, .false., f_free)
      call model%derivative(tau, y, .true., f_contact)
      rate = model%tip_gap_rate(tau, y)
      normal = model%tip
      if (.not. entering .and. model%law == law_jkr) then
         ! A JKR neck breaks at h = V_T - offset(theta1) = 0: its normal and rate.
         call switch_gradient(model, y, rate, normal)
      end if
      stats(stat_switch_rate_min) = min(stats(stat_switch_rate_min), abs(rate))
      ! The jump in the map's coordinates (a phase's flag has none; model_t's pad is left out).
      if (entering) then
         call model_to_map_state(model, f_contact - f_free, jump)
      else
         call model_to_map_state(model, f_free - f_contact, jump)
      end if
      if (all(jump == 0)) return
      ! n^T Phi: the rows of the displacements weighted by the switch's normal.
      do j = 1, size(phi, 2)
         row(j) = dot_product(normal, phi(1:n, j))
      end do
      do j = 1, size(phi, 2)
         phi(:, j) = phi(:, j) + jump*(row(j)/rate)
      end do
   end subroutine saltation

   !> The switch function h = V_T - offset of a JKR neck at a state y (model_t%switch_offset, offset
   !> = -D_c beta/sin(theta1)): its gradient in a, p + offset cos(theta1)/sin(theta1) dtheta1/da, and
   !> its rate along the neck's field, dV_T/dtau - offset' (rate: in dV_T/dtau, out dh/dtau).
   subroutine switch_gradient(model, y, rate, normal)
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: y(:)
      real(dp), intent(inout) :: rate
      real(dp), intent(out) :: normal(:)
      real(dp) :: offset, offset_rate, slope, sin1, cos1, dtheta
      integer :: n
      n = model%n_modes
      call model%switch_offset(y, .true., 0.0_dp, rate, offset, offset_rate)
      slope = dot_product(model%scaled_slope, y(1:n))
      call contact_angle_sin_cos(model%sin_theta, model%cos_theta, slope, model%errata%e7_signed_slope, sin1, cos1)
      sin1 = max(sin1, epsilon(1.0_dp))
      ! dtheta1/dslope (Eq. 3, or E7's signed form).
      dtheta = 1/(1 + slope*slope)
      if (.not. model%errata%e7_signed_slope) dtheta = -sign(1.0_dp, slope)*dtheta
      normal = model%tip + offset*cos1/sin1*dtheta*model%scaled_slope
      rate = rate - offset_rate
   end subroutine switch_gradient

   !> The extrema of V_T along a flight of length s_end: a scan of dV_T/dtau (spacing at most
   !> T/scan_per_period and 1/|fastest rate|), each sign change refined by Brent.
   subroutine flight_extrema(model, flight, s_end, period, stats, evaluations)
      type(model_t), intent(in) :: model
      type(free_flight_t), intent(in) :: flight
      real(dp), intent(in) :: s_end
      real(dp), intent(in) :: period
      real(dp), intent(inout) :: stats(n_orbit_stats)
      integer, intent(inout) :: evaluations
      type(bracketed_root_t) :: root
      real(dp) :: ds, s0, s1, v0, r0, v1, r1, x, vx, rx
      integer :: count, i
      if (s_end <= 0) return
      ds = min(period/scan_per_period, 1/max(flight%rate_max, tiny(1.0_dp)))
      ds = max(ds, period/4096)
      count = max(2, ceiling(s_end/ds))
      s0 = 0
      call flight%gap(model, s0, v0, r0)
      stats(stat_gap_min) = min(stats(stat_gap_min), v0)
      stats(stat_gap_max) = max(stats(stat_gap_max), v0)
      do i = 1, count
         s1 = s_end*real(i, dp)/count
         call flight%gap(model, s1, v1, r1)
         evaluations = evaluations + 1
         stats(stat_gap_min) = min(stats(stat_gap_min), v1)
         stats(stat_gap_max) = max(stats(stat_gap_max), v1)
         if ((r0 < 0 .and. r1 >= 0) .or. (r0 > 0 .and. r1 <= 0)) then
            call root%start(s0, r0, s1, r1, 4*epsilon(1.0_dp)*max(s1, 1.0_dp))
            do while (.not. root%converged())
               call root%next_point(x)
               call flight%gap(model, x, vx, rx)
               evaluations = evaluations + 1
               call root%update(rx)
            end do
            call flight%gap(model, root%b, vx, rx)
            stats(stat_gap_min) = min(stats(stat_gap_min), vx)
            stats(stat_gap_max) = max(stats(stat_gap_max), vx)
            ! A minimum strictly inside the flight: how far the flight is from grazing.
            if (r0 < 0 .and. root%b > 0 .and. root%b < s_end) &
               stats(stat_flight_gap_min) = min(stats(stat_flight_gap_min), vx)
         end if
         s0 = s1
         v0 = v1
         r0 = r1
      end do
   end subroutine flight_extrema

   !> Integrate the state and Phi in a phase whose field the Dormand-Prince pair integrates (in
   !> contact; under 'dmt_vdw' in flight too) from tau until the phase ends (in_contact flipped,
   !> tau and y at the switch) or tau reaches t_end.  h: the step to try (0: choose).
   subroutine forced_phase(model, w, tau, t_end, period, y, phi, h, in_contact, stats, ierr, errmsg)
      type(model_t), intent(in) :: model
      type(work_t), intent(inout) :: w
      real(dp), intent(inout) :: tau
      real(dp), intent(in) :: t_end
      real(dp), intent(in) :: period
      real(dp), intent(inout) :: y(:)
      real(dp), intent(inout) :: phi(:, :)
      real(dp), intent(inout) :: h
      logical, intent(inout) :: in_contact
      real(dp), intent(inout) :: stats(n_orbit_stats)
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(bracketed_root_t) :: root
      real(dp) :: err, step, vt0, vt1, rate0, rate1, x, gx, tau0, side, reach, vt_reach, x_ext, vt_ext
      real(dp) :: left, vt_left
      logical :: last, crossed
      integer :: m, ns, steps

      ierr = ok
      errmsg = ''
      m = w%m
      ns = w%n_state
      w%z(1:ns) = y
      w%z(ns + 1:) = reshape(phi, [m*m])
      if (h <= 0) h = period*w%rtol**0.2_dp
      ! In a flight the step stays below a sixteenth of a period, so that V_T turns at most once
      ! inside a step (a dip below the surface and back is then seen as a minimum).
      if (.not. in_contact) h = min(h, period/16)
      ! G = side V_T is positive inside the phase.
      side = merge(-1.0_dp, 1.0_dp, in_contact)
      steps = 0
      do
         steps = steps + 1
         stats(stat_contact_steps) = stats(stat_contact_steps) + 1
         if (steps > max_contact_steps) then
            ierr = err_runtime
            write (errmsg, '(a,i0,a,es12.5)') 'stroboscopic map: more than ', max_contact_steps, &
               ' steps in one phase at tau = ', tau
            return
         end if
         last = h >= t_end - tau
         step = merge(t_end - tau, h, last)
         if (.not. (step > 0)) then
            ierr = err_runtime
            write (errmsg, '(a,es12.5)') 'stroboscopic map: the step vanished at tau = ', tau
            return
         end if
         call dp5_step(model, w, tau, w%z, step, w%z_new, err, in_contact)
         if (.not. (err <= 1)) then
            if (.not. (err == err)) err = 1.0e10_dp
            h = step*max(0.2_dp, 0.9_dp*err**(-0.2_dp))
            cycle
         end if
         ! Accepted.
         tau0 = tau
         vt0 = model%tip_gap(tau0, w%z(1:ns))
         rate0 = model%tip_gap_rate(tau0, w%z(1:ns))
         vt1 = model%tip_gap(tau0 + step, w%z_new(1:ns))
         rate1 = model%tip_gap_rate(tau0 + step, w%z_new(1:ns))
         ! The phase's switch function: V_T, but in a flight a meniscus holds V_T (1 - V_T/o), which
         ! also ends where it breaks (model_t%switch_offset).
         crossed = side*model%switch_gap(tau0 + step, w%z_new(1:ns), in_contact) < 0
         reach = step
         vt_reach = vt1
         if (.not. crossed .and. .not. in_contact .and. rate0 < 0 .and. rate1 >= 0) then
            ! A minimum of V_T inside a flight step: below the surface it is a contact the step
            ! ends missed (V_T dipped below 0 and back); the switch then lies before it.
            call phase_extremum(model, w, tau0, step, rate0, rate1, in_contact, x_ext, vt_ext)
            if (vt_ext < 0) then
               crossed = .true.
               reach = x_ext
               vt_reach = vt_ext
            else
               stats(stat_gap_min) = min(stats(stat_gap_min), vt_ext)
               stats(stat_flight_gap_min) = min(stats(stat_flight_gap_min), vt_ext)
            end if
         end if
         if (crossed) then
            ! The phase ended inside the step: the step length x with V_T = 0, on the side of the
            ! phase entered.  A phase that began at a switch starts at V_T = 0 moving into the
            ! phase, and there V_T is 0 to round-off for a while: Brent could take that for the
            ! root (a phase of zero length, then the same switch again, without end).  So when
            ! the step starts moving into the phase the bracket starts at V_T's turn inside it.
            left = 0
            vt_left = vt0
            if (side*rate0 > 0 .and. side*rate1 < 0 .and. reach == step) &
               call phase_extremum(model, w, tau0, step, rate0, rate1, in_contact, left, vt_left)
            if (model%hysteretic) then
               ! The bracket's values are the switch function's (V_T (1 - V_T/o) in a flight the
               ! meniscus holds: V_T alone has no sign change where it breaks).
               vt_left = bracket_value(model, w, tau0, left, in_contact)
               vt_reach = bracket_value(model, w, tau0, reach, in_contact)
            end if
            call root%start(left, side*max(side*vt_left, tiny(1.0_dp)), reach, vt_reach, &
                            4*epsilon(1.0_dp)*max(tau0, 1.0_dp))
            do while (.not. root%converged())
               call root%next_point(x)
               call dp5_step(model, w, tau0, w%z, x, w%z_try, gx, in_contact)
               call root%update(model%switch_gap(tau0 + x, w%z_try(1:ns), in_contact))
            end do
            call root%end_with_sign(-side, x)
            call dp5_step(model, w, tau0, w%z, x, w%z_new, gx, in_contact)
            call record_extremum(model, w, tau0, x, rate0, model%tip_gap_rate(tau0 + x, w%z_new(1:ns)), &
                                 in_contact, stats)
            vt1 = model%tip_gap(tau0 + x, w%z_new(1:ns))
            stats(stat_gap_max) = max(stats(stat_gap_max), vt1)
            stats(stat_gap_min) = min(stats(stat_gap_min), vt1)
            w%z = w%z_new
            tau = tau0 + x
            if (in_contact) stats(stat_contact_time) = stats(stat_contact_time) + x
            call model%next_phase(tau, w%z(1:ns), in_contact)
            exit
         end if
         call record_extremum(model, w, tau0, step, rate0, rate1, in_contact, stats)
         stats(stat_gap_min) = min(stats(stat_gap_min), vt1)
         stats(stat_gap_max) = max(stats(stat_gap_max), vt1)
         if (in_contact) stats(stat_contact_time) = stats(stat_contact_time) + step
         w%z = w%z_new
         if (last) then
            tau = t_end
            exit
         end if
         tau = tau0 + step
         h = step*min(5.0_dp, max(0.2_dp, 0.9_dp*max(err, 1.0e-10_dp)**(-0.2_dp)))
         if (.not. in_contact) h = min(h, period/16)
      end do
      y = w%z(1:ns)
      phi = reshape(w%z(ns + 1:), [m, m])
   end subroutine forced_phase

   !> The switch function model_t%switch_gap a step of length x from w%z at tau0 reaches (x = 0: w%z's).
   function bracket_value(model, w, tau0, x, in_contact) result(gap)
      type(model_t), intent(in) :: model
      type(work_t), intent(inout) :: w
      real(dp), intent(in) :: tau0
      real(dp), intent(in) :: x
      logical, intent(in) :: in_contact
      real(dp) :: gap, err
      integer :: ns
      ns = w%n_state
      if (x > 0) then
         call dp5_step(model, w, tau0, w%z, x, w%z_try, err, in_contact)
         gap = model%switch_gap(tau0 + x, w%z_try(1:ns), in_contact)
      else
         gap = model%switch_gap(tau0, w%z(1:ns), in_contact)
      end if
   end function bracket_value

   !> The stats of an extremum of V_T inside a step of length step from w%z at tau0 in a phase:
   !> a minimum (dV_T/dtau from negative to non-negative) lowers gap_min (in a flight also
   !> flight_gap_min), a maximum (from positive to non-positive) raises gap_max.
   subroutine record_extremum(model, w, tau0, step, rate0, rate1, in_contact, stats)
      type(model_t), intent(in) :: model
      type(work_t), intent(inout) :: w
      real(dp), intent(in) :: tau0
      real(dp), intent(in) :: step
      real(dp), intent(in) :: rate0
      real(dp), intent(in) :: rate1
      logical, intent(in) :: in_contact
      real(dp), intent(inout) :: stats(n_orbit_stats)
      real(dp) :: x, vt
      if (rate0 < 0 .and. rate1 >= 0) then
         call phase_extremum(model, w, tau0, step, rate0, rate1, in_contact, x, vt)
         stats(stat_gap_min) = min(stats(stat_gap_min), vt)
         if (.not. in_contact .and. x > 0 .and. x < step) &
            stats(stat_flight_gap_min) = min(stats(stat_flight_gap_min), vt)
      else if (rate0 > 0 .and. rate1 <= 0) then
         call phase_extremum(model, w, tau0, step, rate0, rate1, in_contact, x, vt)
         stats(stat_gap_max) = max(stats(stat_gap_max), vt)
      end if
   end subroutine record_extremum

   !> Where dV_T/dtau changes sign inside a step of length step from w%z at tau0 (rate0, rate1 of
   !> opposite signs at its ends): the step length x (Brent on it, as for the switch) and V_T there.
   subroutine phase_extremum(model, w, tau0, step, rate0, rate1, in_contact, x, vt)
      type(model_t), intent(in) :: model
      type(work_t), intent(inout) :: w
      real(dp), intent(in) :: tau0
      real(dp), intent(in) :: step
      real(dp), intent(in) :: rate0
      real(dp), intent(in) :: rate1
      logical, intent(in) :: in_contact
      real(dp), intent(out) :: x
      real(dp), intent(out) :: vt
      type(bracketed_root_t) :: root
      real(dp) :: gx
      integer :: ns
      ns = w%n_state
      call root%start(0.0_dp, rate0, step, rate1, 4*epsilon(1.0_dp)*max(tau0, 1.0_dp))
      do while (.not. root%converged())
         call root%next_point(x)
         call dp5_step(model, w, tau0, w%z, x, w%z_try, gx, in_contact)
         call root%update(model%tip_gap_rate(tau0 + x, w%z_try(1:ns)))
      end do
      x = root%b
      call dp5_step(model, w, tau0, w%z, x, w%z_try, gx, in_contact)
      vt = model%tip_gap(tau0 + x, w%z_try(1:ns))
   end subroutine phase_extremum

   !> One Dormand-Prince 5(4) step of length h of the augmented system of a phase from z at tau:
   !> z_out, and the error norm err (RMS of the embedded difference over atol + rtol |z|).
   subroutine dp5_step(model, w, tau, z, h, z_out, err, in_contact)
      type(model_t), intent(in) :: model
      type(work_t), intent(inout) :: w
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: z(:)
      real(dp), intent(in) :: h
      real(dp), intent(out) :: z_out(:)
      real(dp), intent(out) :: err
      logical, intent(in) :: in_contact
      integer :: i, ns
      ns = w%n_state
      call augmented(model, w, tau, z, w%k(:, 1), in_contact)
      w%stage = z + h*a21*w%k(:, 1)
      call augmented(model, w, tau + c2*h, w%stage, w%k(:, 2), in_contact)
      w%stage = z + h*(a31*w%k(:, 1) + a32*w%k(:, 2))
      call augmented(model, w, tau + c3*h, w%stage, w%k(:, 3), in_contact)
      w%stage = z + h*(a41*w%k(:, 1) + a42*w%k(:, 2) + a43*w%k(:, 3))
      call augmented(model, w, tau + c4*h, w%stage, w%k(:, 4), in_contact)
      w%stage = z + h*(a51*w%k(:, 1) + a52*w%k(:, 2) + a53*w%k(:, 3) + a54*w%k(:, 4))
      call augmented(model, w, tau + c5*h, w%stage, w%k(:, 5), in_contact)
      w%stage = z + h*(a61*w%k(:, 1) + a62*w%k(:, 2) + a63*w%k(:, 3) + a64*w%k(:, 4) + a65*w%k(:, 5))
      call augmented(model, w, tau + h, w%stage, w%k(:, 6), in_contact)
      z_out = z + h*(b1*w%k(:, 1) + b3*w%k(:, 3) + b4*w%k(:, 4) + b5*w%k(:, 5) + b6*w%k(:, 6))
      call augmented(model, w, tau + h, z_out, w%k(:, 7), in_contact)
      w%stage = h*(e1*w%k(:, 1) + e3*w%k(:, 3) + e4*w%k(:, 4) + e5*w%k(:, 5) + e6*w%k(:, 6) + e7*w%k(:, 7))
      ! Every component is controlled, Phi too (relative to 1 + |Phi|): near a Hertz contact's
      ! start J grows like the square root of the depth, and Phi's error there is larger than
      ! the state's (controlling the state alone left 2e-6 relative error on Fig. 4).
      do i = 1, w%size
         if (i <= ns) then
            w%weight(i) = w%atol_state + w%rtol*max(abs(z(i)), abs(z_out(i)))
         else
            w%weight(i) = w%rtol*(1 + max(abs(z(i)), abs(z_out(i))))
         end if
      end do
      err = sqrt(sum((w%stage/w%weight)**2)/w%size)
   end subroutine dp5_step

   !> The augmented field in a phase: (f(tau, y), J(tau, y) Phi).
   subroutine augmented(model, w, tau, z, dz, in_contact)
      type(model_t), intent(in) :: model
      type(work_t), intent(inout) :: w
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: z(:)
      real(dp), intent(out) :: dz(:)
      logical, intent(in) :: in_contact
      integer :: m, ns, n, i, j, k, col
      real(dp) :: acc
      m = w%m
      ns = w%n_state
      n = model%n_modes
      call model%derivative(tau, z(1:ns), in_contact, dz(1:ns))
      call model_jacobian(model, tau, z(1:ns), in_contact, w%jac)
      ! dPhi = J Phi, column by column (Phi(:, j) at z(ns + (j - 1) m + 1:)); the first N rows
      ! of J are [0 I 0], so those rows are copies.
      do j = 1, m
         col = ns + (j - 1)*m
         do i = 1, n
            dz(col + i) = z(col + n + i)
         end do
         do i = n + 1, m
            acc = 0
            do k = 1, m
               acc = acc + w%jac(i, k)*z(col + k)
            end do
            dz(col + i) = acc
         end do
      end do
      w%evaluations = w%evaluations + 1
   end subroutine augmented

end module tmafm_monodromy

!> The stroboscopic map P^n over n drive periods and its Jacobian, the monodromy matrix, for
!> the shooting and continuation of periodic orbits (docs/continuation.md).
!>
!> P^n takes the state y = (a, a') at tau = 0 to the state at tau = n T, T = 2 pi/Omega (the
!> equations depend on tau only through the drive, so every period starts at phase 0).  Along
!> the orbit the matrix Phi = dy(tau)/dy(0) is carried with the state:
!>  - in free flight exactly, as the flight's own propagator exp(A s) = sum_k Re(V_k e^(lambda_k s) W_k)
!>    from the modal decomposition of tmafm_flight, the same one that moves the state, whose
!>    first contact it also locates;
!>  - in contact by the variational equations Phi' = J(tau, y) Phi (J from tmafm_model_jacobian)
!>    integrated together with the state by the Dormand-Prince 5(4) pair, every component
!>    under the step control, and the end of contact (V_T = 0 upwards) located by
!>    Brent on the length of the last step (each trial a full step from the same start);
!>  - at every switch by the saltation matrix S = I + (f+ - f-) n^T / (dV_T/dtau), n = (p, 0),
!>    f- and f+ the vector fields before and after the switch at the switch state (identity
!>    when the force is continuous there, as for Hertz without contact damping).
!> Along the way it records what grazing and the observables need (stats, stat_* indices).
!> Everything is allocated once per call; the steps allocate nothing.
module tmafm_monodromy
   use tmafm_kinds, only: dp
   use tmafm_errors, only: ok, err_input, err_runtime
   use tmafm_model, only: model_t
   use tmafm_contact, only: law_hertz, law_dmt
   use tmafm_model_jacobian, only: model_jacobian
   use tmafm_flight, only: free_flight_t
   use tmafm_events, only: initial_phase
   use tmafm_roots, only: bracketed_root_t
   use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
   implicit none
   private

   public :: stroboscopic_map, n_orbit_stats
   public :: stat_contacts, stat_gap_min, stat_gap_max, stat_flight_gap_min, stat_contact_time, &
      stat_switch_rate_min, stat_contact_steps, stat_evaluations

   !> Indices of stats: contacts begun; min and max of V_T over the orbit; the smallest local
   !> minimum of V_T inside a free flight (huge() if none: the distance from grazing); time in
   !> contact; the smallest |dV_T/dtau| at a switch (huge() if none); contact steps taken;
   !> right-hand sides evaluated.
   integer, parameter :: stat_contacts = 1, stat_gap_min = 2, stat_gap_max = 3, stat_flight_gap_min = 4, &
      stat_contact_time = 5, stat_switch_rate_min = 6, stat_contact_steps = 7, stat_evaluations = 8
   !> Number of stats.
   integer, parameter :: n_orbit_stats = 8
   !> Most contact steps (accepted or not) one call may take.
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

   !> Registers of the augmented contact integrator, z = (y, Phi(:)).
   type :: work_t
      integer :: m = 0, size = 0
      real(dp), allocatable :: k(:, :), z(:), z_new(:), z_try(:), stage(:), weight(:), jac(:, :)
      real(dp) :: rtol = 0, atol_state = 0
      integer :: evaluations = 0
   end type work_t

contains

   !> y_end = P^n(y0) and monodromy = dP^n/dy0 over n_periods drive periods from tau = 0, with
   !> relative tolerance rtol in contact; stats as the stat_* indices say.
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
      real(dp) :: tau, t_end, s_contact, h, period, y(size(y0)), phi(size(y0), size(y0))
      logical :: in_contact, found
      integer :: m, j, evaluations

      ierr = ok
      errmsg = ''
      stats = 0
      y_end = 0
      monodromy = 0
      m = 2*model%n_modes
      if (size(y0) /= m .or. size(y_end) /= m .or. any(shape(monodromy) /= [m, m])) then
         ierr = err_input
         write (errmsg, '(a,i0)') 'stroboscopic map: the state must have 2N = ', m
         return
      end if
      if (model%law /= law_hertz .and. model%law /= law_dmt) then
         ierr = err_input
         errmsg = 'stroboscopic map: &model contact_law must be hertz or dmt (the laws whose '// &
                  'Jacobian and saltation matrix are derived)'
         return
      end if
      if (model%drive%general) then
         ierr = err_input
         errmsg = 'stroboscopic map: &scene alpha2_2 or drive_phase is not 0: the map is built for one '// &
                  'drive tone with no phase (the period 2 pi/Omega)'
         return
      end if
      if (model%sls%on) then
         ierr = err_input
         errmsg = 'stroboscopic map: &scene sls_relaxation_time > 0: the viscoelastic sample''s '// &
                  'state is not in the map (its Jacobian and saltation matrix are not derived)'
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
      if (model%scene%omega <= 0) then
         ierr = err_input
         errmsg = 'stroboscopic map: &scene omega must be > 0 (a drive period is needed)'
         return
      end if

      call flight%init(model, ierr, errmsg)
      if (ierr /= ok) return
      w%m = m
      w%size = m + m*m
      w%rtol = rtol
      ! The state's absolute floor: rtol times its own scale (the tip's stroke alpha2 or the
      ! state, whichever is larger), so that a component passing through zero stays controlled.
      w%atol_state = rtol*max(maxval(abs(y0)), abs(model%scene%alpha2), abs(model%scene%delta_hat))
      allocate (w%k(w%size, 7), w%z(w%size), w%z_new(w%size), w%z_try(w%size), w%stage(w%size), &
                w%weight(w%size), w%jac(m, m))

      period = 2*acos(-1.0_dp)/model%scene%omega
      t_end = n_periods*period
      tau = 0
      y = y0
      phi = 0
      do j = 1, m
         phi(j, j) = 1
      end do
      stats(stat_gap_min) = huge(1.0_dp)
      stats(stat_gap_max) = -huge(1.0_dp)
      stats(stat_flight_gap_min) = huge(1.0_dp)
      stats(stat_switch_rate_min) = huge(1.0_dp)
      in_contact = initial_phase(model, 0.0_dp, y)
      h = 0
      do while (tau < t_end)
         if (in_contact) then
            call contact_phase(model, w, tau, t_end, period, y, phi, h, in_contact, stats, ierr, errmsg)
            if (ierr /= ok) return
            if (.not. in_contact) call saltation(model, tau, y, phi, .false., stats)
         else
            call flight%start(model, tau, y)
            evaluations = 0
            call flight%first_contact(model, t_end - tau, found, s_contact, evaluations, ierr, errmsg)
            if (ierr /= ok) return
            w%evaluations = w%evaluations + evaluations
            call flight_extrema(model, flight, s_contact, period, stats, w%evaluations)
            call flight%state(model, s_contact, y)
            call flight_propagate(flight, s_contact, phi)
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
      y_end = y
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
      real(dp) :: f_free(size(y)), f_contact(size(y)), jump(size(y)), row(size(y)), rate
      integer :: n, j
      n = model%n_modes
      call model%derivative(tau, y, .false., f_free)
      call model%derivative(tau, y, .true., f_contact)
      rate = model%tip_gap_rate(tau, y)
      stats(stat_switch_rate_min) = min(stats(stat_switch_rate_min), abs(rate))
      if (entering) then
         jump = f_contact - f_free
      else
         jump = f_free - f_contact
      end if
      if (all(jump == 0)) return
      ! n^T Phi: the rows of the displacements weighted by p.
      do j = 1, size(phi, 2)
         row(j) = dot_product(model%tip, phi(1:n, j))
      end do
      do j = 1, size(phi, 2)
         phi(:, j) = phi(:, j) + jump*(row(j)/rate)
      end do
   end subroutine saltation

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

   !> Integrate the state and Phi in contact from tau until the contact ends (in_contact set
   !> .false., tau and y at the switch) or tau reaches t_end.  h: the step to try (0: choose).
   subroutine contact_phase(model, w, tau, t_end, period, y, phi, h, in_contact, stats, ierr, errmsg)
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
      real(dp) :: err, step, vt0, vt1, rate0, rate1, x, gx, tau0
      logical :: last
      integer :: m, steps

      ierr = ok
      errmsg = ''
      m = w%m
      w%z(1:m) = y
      w%z(m + 1:) = reshape(phi, [m*m])
      if (h <= 0) h = period*w%rtol**0.2_dp
      steps = 0
      do
         steps = steps + 1
         stats(stat_contact_steps) = stats(stat_contact_steps) + 1
         if (steps > max_contact_steps) then
            ierr = err_runtime
            write (errmsg, '(a,i0,a,es12.5)') 'stroboscopic map: more than ', max_contact_steps, &
               ' contact steps at tau = ', tau
            return
         end if
         last = h >= t_end - tau
         step = merge(t_end - tau, h, last)
         if (.not. (step > 0)) then
            ierr = err_runtime
            write (errmsg, '(a,es12.5)') 'stroboscopic map: the contact step vanished at tau = ', tau
            return
         end if
         call dp5_step(model, w, tau, w%z, step, w%z_new, err)
         if (.not. (err <= 1)) then
            if (.not. (err == err)) err = 1.0e10_dp
            h = step*max(0.2_dp, 0.9_dp*err**(-0.2_dp))
            cycle
         end if
         ! Accepted.
         tau0 = tau
         vt0 = model%tip_gap(tau0, w%z(1:m))
         rate0 = model%tip_gap_rate(tau0, w%z(1:m))
         vt1 = model%tip_gap(tau0 + step, w%z_new(1:m))
         rate1 = model%tip_gap_rate(tau0 + step, w%z_new(1:m))
         if (vt1 > 0) then
            ! The contact ended inside the step: the step length x with V_T = 0.
            call root%start(0.0_dp, min(vt0, 0.0_dp), step, vt1, 4*epsilon(1.0_dp)*max(tau0, 1.0_dp))
            do while (.not. root%converged())
               call root%next_point(x)
               call dp5_step(model, w, tau0, w%z, x, w%z_try, gx)
               call root%update(model%tip_gap(tau0 + x, w%z_try(1:m)))
            end do
            call root%end_with_sign(1.0_dp, x)
            call dp5_step(model, w, tau0, w%z, x, w%z_new, gx)
            call contact_minimum(model, w, tau0, x, rate0, model%tip_gap_rate(tau0 + x, w%z_new(1:m)), stats)
            stats(stat_gap_max) = max(stats(stat_gap_max), model%tip_gap(tau0 + x, w%z_new(1:m)))
            w%z = w%z_new
            tau = tau0 + x
            stats(stat_contact_time) = stats(stat_contact_time) + x
            in_contact = .false.
            exit
         end if
         call contact_minimum(model, w, tau0, step, rate0, rate1, stats)
         stats(stat_gap_min) = min(stats(stat_gap_min), vt1)
         stats(stat_gap_max) = max(stats(stat_gap_max), vt1)
         stats(stat_contact_time) = stats(stat_contact_time) + step
         w%z = w%z_new
         if (last) then
            tau = t_end
            exit
         end if
         tau = tau0 + step
         h = step*min(5.0_dp, max(0.2_dp, 0.9_dp*max(err, 1.0e-10_dp)**(-0.2_dp)))
      end do
      y = w%z(1:m)
      phi = reshape(w%z(m + 1:), [m, m])
   end subroutine contact_phase

   !> The deepest V_T of a contact step of length step from w%z at tau0 when dV_T/dtau turns
   !> from negative to non-negative in it (Brent on the step length, as for the switch).
   subroutine contact_minimum(model, w, tau0, step, rate0, rate1, stats)
      type(model_t), intent(in) :: model
      type(work_t), intent(inout) :: w
      real(dp), intent(in) :: tau0
      real(dp), intent(in) :: step
      real(dp), intent(in) :: rate0
      real(dp), intent(in) :: rate1
      real(dp), intent(inout) :: stats(n_orbit_stats)
      type(bracketed_root_t) :: root
      real(dp) :: x, gx
      integer :: m
      if (.not. (rate0 < 0 .and. rate1 >= 0)) return
      m = w%m
      call root%start(0.0_dp, rate0, step, rate1, 4*epsilon(1.0_dp)*max(tau0, 1.0_dp))
      do while (.not. root%converged())
         call root%next_point(x)
         call dp5_step(model, w, tau0, w%z, x, w%z_try, gx)
         call root%update(model%tip_gap_rate(tau0 + x, w%z_try(1:m)))
      end do
      call dp5_step(model, w, tau0, w%z, root%b, w%z_try, gx)
      stats(stat_gap_min) = min(stats(stat_gap_min), model%tip_gap(tau0 + root%b, w%z_try(1:m)))
   end subroutine contact_minimum

   !> One Dormand-Prince 5(4) step of length h of the augmented contact system from z at tau:
   !> z_out, and the error norm err (RMS of the embedded difference over atol + rtol |z|).
   subroutine dp5_step(model, w, tau, z, h, z_out, err)
      type(model_t), intent(in) :: model
      type(work_t), intent(inout) :: w
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: z(:)
      real(dp), intent(in) :: h
      real(dp), intent(out) :: z_out(:)
      real(dp), intent(out) :: err
      integer :: i, m
      m = w%m
      call augmented(model, w, tau, z, w%k(:, 1))
      w%stage = z + h*a21*w%k(:, 1)
      call augmented(model, w, tau + c2*h, w%stage, w%k(:, 2))
      w%stage = z + h*(a31*w%k(:, 1) + a32*w%k(:, 2))
      call augmented(model, w, tau + c3*h, w%stage, w%k(:, 3))
      w%stage = z + h*(a41*w%k(:, 1) + a42*w%k(:, 2) + a43*w%k(:, 3))
      call augmented(model, w, tau + c4*h, w%stage, w%k(:, 4))
      w%stage = z + h*(a51*w%k(:, 1) + a52*w%k(:, 2) + a53*w%k(:, 3) + a54*w%k(:, 4))
      call augmented(model, w, tau + c5*h, w%stage, w%k(:, 5))
      w%stage = z + h*(a61*w%k(:, 1) + a62*w%k(:, 2) + a63*w%k(:, 3) + a64*w%k(:, 4) + a65*w%k(:, 5))
      call augmented(model, w, tau + h, w%stage, w%k(:, 6))
      z_out = z + h*(b1*w%k(:, 1) + b3*w%k(:, 3) + b4*w%k(:, 4) + b5*w%k(:, 5) + b6*w%k(:, 6))
      call augmented(model, w, tau + h, z_out, w%k(:, 7))
      w%stage = h*(e1*w%k(:, 1) + e3*w%k(:, 3) + e4*w%k(:, 4) + e5*w%k(:, 5) + e6*w%k(:, 6) + e7*w%k(:, 7))
      ! Every component is controlled, Phi too (relative to 1 + |Phi|): near a Hertz contact's
      ! start J grows like the square root of the depth, and Phi's error there is larger than
      ! the state's (controlling the state alone left 2e-6 relative error on Fig. 4).
      do i = 1, w%size
         if (i <= m) then
            w%weight(i) = w%atol_state + w%rtol*max(abs(z(i)), abs(z_out(i)))
         else
            w%weight(i) = w%rtol*(1 + max(abs(z(i)), abs(z_out(i))))
         end if
      end do
      err = sqrt(sum((w%stage/w%weight)**2)/w%size)
   end subroutine dp5_step

   !> The augmented field in contact: (f(tau, y), J(tau, y) Phi).
   subroutine augmented(model, w, tau, z, dz)
      type(model_t), intent(in) :: model
      type(work_t), intent(inout) :: w
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: z(:)
      real(dp), intent(out) :: dz(:)
      integer :: m, i, j, k
      real(dp) :: acc
      m = w%m
      call model%derivative(tau, z(1:m), .true., dz(1:m))
      call model_jacobian(model, tau, z(1:m), .true., w%jac)
      ! dPhi = J Phi, column by column (Phi(:, j) at z(m + (j - 1) m + 1:)); the top half of
      ! J is [0 I], so the first m/2 rows are copies.
      do j = 1, m
         do i = 1, m/2
            dz(m + (j - 1)*m + i) = z(m + (j - 1)*m + m/2 + i)
         end do
         do i = m/2 + 1, m
            acc = 0
            do k = 1, m
               acc = acc + w%jac(i, k)*z(m + (j - 1)*m + k)
            end do
            dz(m + (j - 1)*m + i) = acc
         end do
      end do
      w%evaluations = w%evaluations + 1
   end subroutine augmented

end module tmafm_monodromy

!> Exact propagation out of contact.  Free of contact the model is linear with harmonic
!> forcing, y' = A y + b_s sin(Omega tau) + b_c cos(Omega tau), so
!>
!>   y(tau0 + s) = y_p(tau0 + s) + Re( V exp(Lambda s) z ),   z = V^-1 (y(tau0) - y_p(tau0)),
!>
!> with A = V Lambda V^-1 (LAPACK dgeev; the damping alpha3 I is not proportional to M, so
!> the modes are complex) and the periodic particular solution y_p = u sin + v cos (dgesv).
!> V_T along a flight is a short sum of damped exponentials and one harmonic, evaluated in
!> O(N); its first root is found by a scan whose subintervals are cleared with a rigorous
!> bound on the cubic-interpolation error, then refined by Brent.
module tmafm_flight
   use tmafm_kinds, only: dp
   use tmafm_errors, only: ok, err_runtime
   use tmafm_model, only: model_t
   use tmafm_events, only: hermite_minimum, switch_margin
   use tmafm_roots, only: bracketed_root_t
   implicit none
   private

   public :: free_flight_t

   !> The modal solution of the free phase of one model, and the flight now under way.
   type :: free_flight_t
      !> Size of the state, 2N.
      integer :: n_state = 0
      !> Eigenvalues of A.
      complex(dp), allocatable :: eigenvalue(:)
      !> Right eigenvectors of A (columns) and their LU factors.
      complex(dp), allocatable :: vectors(:, :), factors(:, :)
      !> Row pivots of the LU factors.
      integer, allocatable :: pivots(:)
      !> Particular solution y_p = u sin(Omega tau) + v cos(Omega tau).
      real(dp), allocatable :: u(:), v(:)
      !> p^T of the displacement part of each eigenvector.
      complex(dp), allocatable :: tip_of_vector(:)
      !> Particular V_T: tip_sin sin(Omega tau) + tip_cos cos(Omega tau) (drive included).
      real(dp) :: tip_sin = 0, tip_cos = 0
      !> Start of the flight under way.
      real(dp) :: tau0 = 0
      !> Modal coefficients z of the flight, and z times p^T V (each term's share of V_T).
      complex(dp), allocatable :: z(:), tip_weight(:)
      !> Round-off level of V_T at the flight start: contact begins at V_T <= -margin.
      real(dp) :: margin = 0
      !> Bound on |d^4 V_T/ds^4| over the flight (it only decays).
      real(dp) :: fourth_derivative_bound = 0
      !> Scan step: a quarter of the shortest time scale of the free system.
      real(dp) :: scan_step = 0
   contains
      !> Decompose the free system of a model (once per run).
      procedure :: init => flight_init
      !> Start a flight from state y at tau.
      procedure :: start => flight_start
      !> The state at tau0 + s.
      procedure :: state => flight_state
      !> V_T and dV_T/dtau at tau0 + s.
      procedure :: gap => flight_gap
      !> The first s in (0, s_max] with V_T <= 0, located to round-off; found = .false. if none.
      procedure :: first_contact => flight_first_contact
   end type free_flight_t

   !> Deepest halving of a scan interval whose error bound does not clear it.
   integer, parameter :: max_halvings = 30

contains

   subroutine flight_init(self, model, ierr, errmsg)
      class(free_flight_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      real(dp), allocatable :: a(:, :), wr(:), wi(:), vr(:, :), work(:), system(:, :), rhs(:)
      real(dp) :: dummy(1, 1), omega
      integer, allocatable :: ipiv(:)
      integer :: n, m, j, info, lwork

      ierr = ok
      errmsg = ''
      n = model%n_modes
      m = 2*n
      self%n_state = m
      omega = model%scene%omega
      allocate (a(m, m), wr(m), wi(m), vr(m, m))
      a = 0
      do j = 1, n
         a(j, n + j) = 1
      end do
      a(n + 1:m, 1:n) = -model%inv_mass_eigen
      a(n + 1:m, n + 1:m) = -model%scene%alpha3*model%inv_mass

      ! Particular solution: [A, Omega I; -Omega I, A] [u; v] = -[b_s; b_c].
      allocate (system(2*m, 2*m), rhs(2*m), ipiv(2*m))
      system = 0
      system(1:m, 1:m) = a
      system(m + 1:2*m, m + 1:2*m) = a
      do j = 1, m
         system(j, m + j) = omega
         system(m + j, j) = -omega
      end do
      rhs = 0
      rhs(n + 1:m) = -model%scene%alpha2*omega**2*model%inv_mass_inertial
      rhs(m + n + 1:2*m) = model%scene%alpha2*model%scene%alpha3*omega*model%inv_mass_integral
      call dgesv(2*m, 1, system, 2*m, ipiv, rhs, 2*m, info)
      if (info /= 0) then
         ierr = err_runtime
         errmsg = 'flight_exact: the drive is at an undamped resonance of the free beam'
         return
      end if
      self%u = rhs(1:m)
      self%v = rhs(m + 1:2*m)
      self%tip_sin = dot_product(model%tip, self%u(1:n)) + model%scene%alpha2
      self%tip_cos = dot_product(model%tip, self%v(1:n))

      lwork = 8*m
      allocate (work(lwork))
      call dgeev('N', 'V', m, a, m, wr, wi, dummy, 1, vr, m, work, lwork, info)
      if (info /= 0) then
         ierr = err_runtime
         write (errmsg, '(a,i0)') 'flight_exact: eigen-decomposition failed, LAPACK info = ', info
         return
      end if
      allocate (self%eigenvalue(m), self%vectors(m, m))
      j = 1
      do while (j <= m)
         if (wi(j) == 0) then
            self%eigenvalue(j) = cmplx(wr(j), 0, dp)
            self%vectors(:, j) = cmplx(vr(:, j), 0, dp)
            j = j + 1
         else
            self%eigenvalue(j) = cmplx(wr(j), wi(j), dp)
            self%eigenvalue(j + 1) = cmplx(wr(j + 1), wi(j + 1), dp)
            self%vectors(:, j) = cmplx(vr(:, j), vr(:, j + 1), dp)
            self%vectors(:, j + 1) = cmplx(vr(:, j), -vr(:, j + 1), dp)
            j = j + 2
         end if
      end do
      self%factors = self%vectors
      allocate (self%pivots(m))
      call zgetrf(m, m, self%factors, m, self%pivots, info)
      if (info /= 0) then
         ierr = err_runtime
         errmsg = 'flight_exact: the free system is defective (eigenvectors not independent)'
         return
      end if
      self%tip_of_vector = matmul(cmplx(model%tip, 0, dp), self%vectors(1:n, :))
      allocate (self%z(m), self%tip_weight(m))
      self%scan_step = 0.25_dp/max(maxval(abs(self%eigenvalue)), omega)
   end subroutine flight_init

   subroutine flight_start(self, model, tau, y)
      class(free_flight_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: y(:)
      integer :: info
      real(dp) :: phase

      self%tau0 = tau
      phase = model%scene%omega*tau
      self%z = cmplx(y - self%u*sin(phase) - self%v*cos(phase), 0, dp)
      call zgetrs('N', self%n_state, 1, self%factors, self%n_state, self%pivots, self%z, &
                  self%n_state, info)
      self%tip_weight = self%z*self%tip_of_vector
      self%margin = switch_margin(model, tau, y)
      self%fourth_derivative_bound = sum(abs(self%tip_weight)*abs(self%eigenvalue)**4) &
         + model%scene%omega**4*hypot(self%tip_sin, self%tip_cos)
   end subroutine flight_start

   pure subroutine flight_state(self, model, s, y)
      class(free_flight_t), intent(in) :: self
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: s
      real(dp), intent(out) :: y(:)
      real(dp) :: phase
      integer :: k
      phase = model%scene%omega*(self%tau0 + s)
      y = self%u*sin(phase) + self%v*cos(phase)
      do k = 1, self%n_state
         y = y + real(self%vectors(:, k)*(self%z(k)*exp(self%eigenvalue(k)*s)), dp)
      end do
   end subroutine flight_state

   pure subroutine flight_gap(self, model, s, vt, vtdot)
      class(free_flight_t), intent(in) :: self
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: s
      real(dp), intent(out) :: vt
      real(dp), intent(out) :: vtdot
      complex(dp) :: terms(self%n_state)
      real(dp) :: phase, omega
      omega = model%scene%omega
      phase = omega*(self%tau0 + s)
      terms = self%tip_weight*exp(self%eigenvalue*s)
      vt = real(sum(terms), dp) + self%tip_sin*sin(phase) + self%tip_cos*cos(phase) &
           + model%scene%delta_hat
      vtdot = real(sum(terms*self%eigenvalue), dp) &
              + omega*(self%tip_sin*cos(phase) - self%tip_cos*sin(phase))
   end subroutine flight_gap

   subroutine flight_first_contact(self, model, s_max, found, s_contact, evaluations)
      class(free_flight_t), intent(in) :: self
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: s_max
      logical, intent(out) :: found
      real(dp), intent(out) :: s_contact
      integer, intent(inout) :: evaluations
      type(bracketed_root_t) :: root
      real(dp) :: left, right, g_left, r_left, g_right, r_right, s_low, s_high, g_high, x, rx
      integer :: halvings

      found = .false.
      s_contact = s_max
      left = 0
      call switch_function(self, model, left, g_left, r_left, evaluations)
      halvings = 0
      do while (left < s_max)
         right = min(s_max, left + self%scan_step*0.5_dp**halvings)
         call switch_function(self, model, right, g_right, r_right, evaluations)
         call classify_interval(self, model, left, g_left, r_left, right, g_right, r_right, &
                                s_low, s_high, g_high, evaluations)
         if (s_high > 0) then
            ! A bracket [s_low, s_high]: refine it to round-off.
            call switch_function(self, model, s_low, x, rx, evaluations)
            call root%start(s_low, max(x, tiny(1.0_dp)), s_high, g_high, &
                            4*epsilon(1.0_dp)*abs(self%tau0 + s_high))
            do while (.not. root%converged())
               call root%next_point(x)
               call switch_function(self, model, x, g_high, rx, evaluations)
               call root%update(g_high)
            end do
            call root%end_with_sign(-1.0_dp, s_contact)
            found = .true.
            return
         else if (s_high < 0 .and. halvings < max_halvings) then
            halvings = halvings + 1      ! not cleared: look closer
            cycle
         end if
         left = right
         g_left = g_right
         r_left = r_right
         halvings = max(0, halvings - 1)
      end do
   end subroutine flight_first_contact

   !> G = V_T + margin along the flight (contact begins where G <= 0), and its rate.
   subroutine switch_function(self, model, s, g, rate, evaluations)
      type(free_flight_t), intent(in) :: self
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: s
      real(dp), intent(out) :: g
      real(dp), intent(out) :: rate
      integer, intent(inout) :: evaluations
      call self%gap(model, s, g, rate)
      g = g + self%margin
      evaluations = evaluations + 1
   end subroutine switch_function

   !> Classify the scan interval [s0, s1] of G: s_high > 0 gives a bracket [s_low, s_high]
   !> with G(s_high) <= 0; s_high = 0 means the interval is cleared; s_high < 0 means the
   !> error bound does not clear it.  The cubic Hermite error is G''''(xi)/24 (s-s0)^2 (s-s1)^2,
   !> zero at both ends, with |G''''| <= fourth_derivative_bound.
   subroutine classify_interval(self, model, s0, g0, r0, s1, g1, r1, s_low, s_high, g_high, &
                                evaluations)
      type(free_flight_t), intent(in) :: self
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: s0, g0, r0, s1, g1, r1
      real(dp), intent(out) :: s_low, s_high, g_high
      integer, intent(inout) :: evaluations
      real(dp) :: width, theta, cubic_min, lowest, t, a3, b3, g_mid, r_mid
      integer :: k
      integer, parameter :: n_check = 32

      s_low = s0
      s_high = 0
      g_high = 0
      width = s1 - s0
      if (g1 <= 0) then
         s_high = s1
         g_high = g1
         return
      end if
      ! Lower envelope: cubic minus the error bound, checked on a fine grid of theta.
      a3 = 2*g0 + width*r0 - 2*g1 + width*r1
      b3 = -3*g0 - 2*width*r0 + 3*g1 - width*r1
      lowest = huge(1.0_dp)
      do k = 1, n_check - 1
         t = real(k, dp)/n_check
         lowest = min(lowest, ((a3*t + b3)*t + width*r0)*t + g0 &
                      - self%fourth_derivative_bound*width**4*(t*(1 - t))**2/24)
      end do
      if (lowest > 0) return
      call hermite_minimum(g0, width*r0, g1, width*r1, theta, cubic_min)
      if (theta > 0 .and. cubic_min <= 0) then
         call switch_function(self, model, s0 + theta*width, g_mid, r_mid, evaluations)
         if (g_mid <= 0) then
            s_high = s0 + theta*width
            g_high = g_mid
            return
         end if
      end if
      s_high = -1
   end subroutine classify_interval

end module tmafm_flight

!> Exact propagation out of contact.  Free of contact the model is linear with harmonic
!> forcing, y' = A y + b_s sin(Omega tau) + b_c cos(Omega tau), so
!>
!>   y(tau0 + s) = y_p(tau0 + s) + Re( V exp(Lambda s) z ),   z = V^-1 (y(tau0) - y_p(tau0)),
!>
!> with A = V Lambda V^-1 (LAPACK dgeev; the damping alpha3 I is not proportional to M, so
!> the modes are complex) and the periodic particular solution y_p = u sin + v cos (dgesv).
!> Everything LAPACK does happens once, in init: V^-1 is formed there, so a flight start is
!> one complex matrix-vector product.  Eigenvalues come in conjugate pairs with conjugate
!> coefficients, so only one of each pair is kept, counted twice.
!>
!> V_T along a flight is a short sum of damped exponentials and one harmonic, evaluated in
!> O(N).  Its first root is found by a scan whose subintervals are cleared with a rigorous
!> lower bound (cubic Hermite interpolant minus its error bound |G''''| h^4 t^2 (1-t)^2/24),
!> then refined by Brent.  The scan step comes from the same bound: the largest step whose
!> error bound at mid-interval is half of what the gap (or its rise) would allow, so a
!> flight takes a few tens of evaluations instead of a fixed step per fastest time scale.
!>
!> The output samples of a flight are equally spaced (dt = sample_dtau), so `sample` turns each
!> term from one sample to the next by the fixed factor exp(lambda dt) (set once per run by
!> `sample_step`) instead of calling exp: O(N^2) multiplications per sample and no libm.  The
!> terms are taken afresh from exp(lambda s) at the first sample of a flight, every
!> anchor_every samples, and whenever a sample is not dt past the previous one; between
!> anchors the rounding drifts by a few ulp per sample (tests/test_sampling.py bounds it).
module tmafm_flight
   use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
   use tmafm_kinds, only: dp
   use tmafm_errors, only: ok, err_input, err_runtime
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
      !> Number of modal terms kept: one per real eigenvalue and per conjugate pair.
      integer :: n_terms = 0
      !> Eigenvalues of A, one per term.
      complex(dp), allocatable :: eigenvalue(:)
      !> 1 for a real eigenvalue, 2 for a pair (the conjugate term is the complex conjugate).
      real(dp), allocatable :: multiplicity(:)
      !> Right eigenvectors of A (columns), one per term.
      complex(dp), allocatable :: vectors(:, :)
      !> The rows of V^-1 that go with the kept terms (n_terms x 2N).
      complex(dp), allocatable :: inverse(:, :)
      !> Particular solution y_p = u sin(Omega tau) + v cos(Omega tau).
      real(dp), allocatable :: u(:), v(:)
      !> p^T of the displacement part of each kept eigenvector.
      complex(dp), allocatable :: tip_of_vector(:)
      !> Particular V_T: tip_sin sin(Omega tau) + tip_cos cos(Omega tau) (drive included).
      real(dp) :: tip_sin = 0, tip_cos = 0
      !> Omega^4 times the amplitude of the particular V_T: its share of |d^4 V_T/ds^4|.
      real(dp) :: harmonic_bound = 0
      !> Start of the flight under way.
      real(dp) :: tau0 = 0
      !> Modal coefficients z of the flight, and z times p^T V (each term's share of V_T).
      complex(dp), allocatable :: z(:), tip_weight(:)
      !> multiplicity |tip_weight| |lambda|^4: each term's share of |d^4 V_T/ds^4| at s = 0.
      real(dp), allocatable :: weight4(:)
      !> Round-off level of V_T at the flight start: contact begins at V_T <= -margin.
      real(dp) :: margin = 0
      !> Bound on |d^4 V_T/ds^4| at the flight start.
      real(dp) :: fourth_derivative_bound = 0
      !> Smallest scan step: 2^-10 of a quarter of the shortest time scale of the free system.
      real(dp) :: min_step = 0
      !> Real and imaginary parts of the eigenvectors (2N x n_terms), for the sample kernel.
      real(dp), allocatable :: vectors_re(:, :), vectors_im(:, :)
      !> Spacing of the samples (0 until sample_step is called), and exp(lambda dt) per term
      !> (real and imaginary parts).
      real(dp) :: sample_dt = 0
      real(dp), allocatable :: rotor_re(:), rotor_im(:)
      !> multiplicity z exp(lambda s) per term at the last sample s_last (real and imaginary
      !> parts), and the samples taken since those terms were last computed with exp.
      real(dp), allocatable :: running_re(:), running_im(:)
      real(dp) :: s_last = 0
      integer :: since_anchor = huge(1)
   contains
      !> Decompose the free system of a model (once per run).
      procedure :: init => flight_init
      !> Start a flight from state y at tau.
      procedure :: start => flight_start
      !> The state at tau0 + s.
      procedure :: state => flight_state
      !> Set the spacing dt of the output samples (once per run).
      procedure :: sample_step => flight_sample_step
      !> The state at the output sample tau0 + s, given sin and cos of Omega (tau0 + s).
      procedure :: sample => flight_sample
      !> V_T and dV_T/dtau at tau0 + s.
      procedure :: gap => flight_gap
      !> The first s in (0, s_max] with V_T <= 0, located to round-off; found = .false. if none.
      procedure :: first_contact => flight_first_contact
   end type free_flight_t

   !> Deepest halving of a scan interval whose error bound does not clear it.
   integer, parameter :: max_halvings = 30
   !> Most evaluations of V_T one call of first_contact may take before it gives up.
   integer, parameter :: max_scan_evaluations = 10000000
   !> Samples between two evaluations of exp(lambda s) in `sample`.
   integer, parameter, public :: anchor_every = 32

contains

   subroutine flight_init(self, model, ierr, errmsg)
      class(free_flight_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      real(dp), allocatable :: a(:, :), wr(:), wi(:), vr(:, :), work(:), system(:, :), rhs(:)
      complex(dp), allocatable :: vectors(:, :), inverse(:, :)
      real(dp) :: dummy(1, 1), omega
      integer, allocatable :: ipiv(:), keep(:)
      integer :: n, m, j, k, info, lwork

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
      rhs(n + 1:m) = -model%drive_sin
      rhs(m + n + 1:2*m) = -model%drive_cos
      ! LAPACK is given finite numbers only: on infinities or NaN it reports illegal values
      ! through XERBLA, and dgeev then runs on and corrupts the heap.
      if (.not. (all(ieee_is_finite(system)) .and. all(ieee_is_finite(rhs)))) then
         ierr = err_input
         write (errmsg, '(a,3(a,es12.4e3))') 'flight_exact: the free beam equations overflow: ', &
            '&scene omega = ', omega, ', alpha2 = ', model%scene%alpha2, ', alpha3 = ', &
            model%scene%alpha3
         return
      end if
      call dgesv(2*m, 1, system, 2*m, ipiv, rhs, 2*m, info)
      if (info /= 0 .or. .not. all(ieee_is_finite(rhs))) then
         ierr = err_runtime
         write (errmsg, '(a,es12.4e3,a)') 'flight_exact: the drive &scene omega = ', omega, &
            ' is at an undamped resonance of the free beam (alpha3 = 0?)'
         return
      end if
      self%u = rhs(1:m)
      self%v = rhs(m + 1:2*m)
      self%tip_sin = dot_product(model%tip, self%u(1:n)) + model%scene%alpha2
      self%tip_cos = dot_product(model%tip, self%v(1:n))
      self%harmonic_bound = omega**4*hypot(self%tip_sin, self%tip_cos)

      lwork = 8*m
      allocate (work(lwork))
      call dgeev('N', 'V', m, a, m, wr, wi, dummy, 1, vr, m, work, lwork, info)
      if (info /= 0 .or. .not. (all(ieee_is_finite(wr)) .and. all(ieee_is_finite(wi)) &
                                .and. all(ieee_is_finite(vr)))) then
         ierr = err_runtime
         write (errmsg, '(a,i0)') 'flight_exact: eigen-decomposition failed, LAPACK info = ', info
         return
      end if
      ! All 2N eigenvectors, to invert V; then one term per real eigenvalue or conjugate pair.
      allocate (vectors(m, m), keep(m))
      self%n_terms = 0
      j = 1
      do while (j <= m)
         self%n_terms = self%n_terms + 1
         keep(self%n_terms) = j
         if (wi(j) == 0 .or. j == m) then
            vectors(:, j) = cmplx(vr(:, j), 0, dp)
            j = j + 1
         else
            vectors(:, j) = cmplx(vr(:, j), vr(:, j + 1), dp)
            vectors(:, j + 1) = cmplx(vr(:, j), -vr(:, j + 1), dp)
            j = j + 2
         end if
      end do
      ! V^-1 by LU with the identity on the right (zgesv).
      allocate (inverse(m, m))
      inverse = 0
      do j = 1, m
         inverse(j, j) = 1
      end do
      block
         complex(dp) :: factors(m, m)
         factors = vectors
         call zgesv(m, m, factors, m, ipiv, inverse, m, info)
      end block
      if (info /= 0 .or. .not. all(ieee_is_finite(real(inverse)) .and. ieee_is_finite(aimag(inverse)))) then
         ierr = err_runtime
         errmsg = 'flight_exact: the free system is defective (eigenvectors not independent)'
         return
      end if
      k = self%n_terms
      allocate (self%eigenvalue(k), self%multiplicity(k), self%vectors(m, k), self%inverse(k, m), &
                self%tip_of_vector(k), self%z(k), self%tip_weight(k), self%weight4(k), &
                self%vectors_re(m, k), self%vectors_im(m, k), self%rotor_re(k), self%rotor_im(k), &
                self%running_re(k), self%running_im(k))
      self%rotor_re = 1
      self%rotor_im = 0
      self%sample_dt = 0
      do k = 1, self%n_terms
         j = keep(k)
         self%eigenvalue(k) = cmplx(wr(j), wi(j), dp)
         self%multiplicity(k) = merge(1.0_dp, 2.0_dp, wi(j) == 0)
         self%vectors(:, k) = vectors(:, j)
         self%inverse(k, :) = inverse(j, :)
         self%tip_of_vector(k) = sum(model%tip*vectors(1:n, j))
      end do
      self%vectors_re = real(self%vectors, dp)
      self%vectors_im = aimag(self%vectors)
      self%min_step = 0.25_dp/max(maxval(abs(self%eigenvalue)), omega, tiny(1.0_dp))/1024
   end subroutine flight_init

   subroutine flight_start(self, model, tau, y)
      class(free_flight_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: y(:)
      real(dp) :: phase, offset(self%n_state)
      integer :: j

      self%tau0 = tau
      phase = model%scene%omega*tau
      offset = y - self%u*sin(phase) - self%v*cos(phase)
      self%z = 0
      do j = 1, self%n_state
         self%z = self%z + self%inverse(:, j)*offset(j)
      end do
      self%tip_weight = self%z*self%tip_of_vector
      self%weight4 = self%multiplicity*abs(self%tip_weight)*abs(self%eigenvalue)**4
      self%margin = switch_margin(model, y)
      self%fourth_derivative_bound = sum(self%weight4) + self%harmonic_bound
      self%since_anchor = anchor_every
   end subroutine flight_start

   subroutine flight_sample_step(self, dt)
      class(free_flight_t), intent(inout) :: self
      real(dp), intent(in) :: dt
      complex(dp) :: rotor(self%n_terms)
      self%sample_dt = dt
      rotor = exp(self%eigenvalue*dt)
      self%rotor_re = real(rotor, dp)
      self%rotor_im = aimag(rotor)
      self%since_anchor = anchor_every
   end subroutine flight_sample_step

   !> The same state as flight_state to round-off, for the output samples of a flight: if s
   !> is sample_dt past the previous sample of this flight the terms are turned by the rotor,
   !> else taken from exp.  sin_phase and cos_phase are those of Omega (tau0 + s) (the
   !> trajectory carries them from sample to sample).
   pure subroutine flight_sample(self, s, sin_phase, cos_phase, y)
      class(free_flight_t), intent(inout) :: self
      real(dp), intent(in) :: s
      real(dp), intent(in) :: sin_phase
      real(dp), intent(in) :: cos_phase
      real(dp), intent(out) :: y(:)
      complex(dp) :: term
      integer :: k
      if (self%since_anchor < anchor_every .and. &
          abs(s - (self%s_last + self%sample_dt)) <= 16*epsilon(1.0_dp)*(abs(self%tau0) + abs(s))) then
         call turn(self%n_terms, self%rotor_re, self%rotor_im, self%running_re, self%running_im)
         self%since_anchor = self%since_anchor + 1
      else
         do k = 1, self%n_terms
            term = self%multiplicity(k)*self%z(k)*exp(self%eigenvalue(k)*s)
            self%running_re(k) = real(term, dp)
            self%running_im(k) = aimag(term)
         end do
         self%since_anchor = 1
      end if
      self%s_last = s
      call sum_terms(self%n_state, self%n_terms, self%u, self%v, self%vectors_re, self%vectors_im, &
                     self%running_re, self%running_im, sin_phase, cos_phase, y)
   end subroutine flight_sample

   !> running = running rotor, term by term (complex numbers as real and imaginary parts).
   pure subroutine turn(n_terms, rotor_re, rotor_im, running_re, running_im)
      integer, intent(in) :: n_terms
      real(dp), intent(in) :: rotor_re(n_terms), rotor_im(n_terms)
      real(dp), intent(inout) :: running_re(n_terms), running_im(n_terms)
      real(dp) :: re
      integer :: k
      do k = 1, n_terms
         re = running_re(k)*rotor_re(k) - running_im(k)*rotor_im(k)
         running_im(k) = running_re(k)*rotor_im(k) + running_im(k)*rotor_re(k)
         running_re(k) = re
      end do
   end subroutine turn

   !> y = u sin + v cos + sum_k Re(V(:, k) running_k): the state from the particular solution
   !> and the turned terms (the multiplicity is in running).
   pure subroutine sum_terms(m, n_terms, u, v, vectors_re, vectors_im, running_re, running_im, &
                             sin_phase, cos_phase, y)
      integer, intent(in) :: m, n_terms
      real(dp), intent(in) :: u(m), v(m), vectors_re(m, n_terms), vectors_im(m, n_terms)
      real(dp), intent(in) :: running_re(n_terms), running_im(n_terms)
      real(dp), intent(in) :: sin_phase, cos_phase
      real(dp), intent(out) :: y(m)
      integer :: i, k
      do i = 1, m
         y(i) = u(i)*sin_phase + v(i)*cos_phase
      end do
      do k = 1, n_terms
         do i = 1, m
            y(i) = y(i) + (vectors_re(i, k)*running_re(k) - vectors_im(i, k)*running_im(k))
         end do
      end do
   end subroutine sum_terms

   pure subroutine flight_state(self, model, s, y)
      class(free_flight_t), intent(in) :: self
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: s
      real(dp), intent(out) :: y(:)
      real(dp) :: phase
      integer :: k
      phase = model%scene%omega*(self%tau0 + s)
      y = self%u*sin(phase) + self%v*cos(phase)
      do k = 1, self%n_terms
         y = y + self%multiplicity(k)*real(self%vectors(:, k)*(self%z(k)*exp(self%eigenvalue(k)*s)), dp)
      end do
   end subroutine flight_state

   pure subroutine flight_gap(self, model, s, vt, vtdot)
      class(free_flight_t), intent(in) :: self
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: s
      real(dp), intent(out) :: vt
      real(dp), intent(out) :: vtdot
      real(dp) :: bound(2)
      call gap_and_bound(self, model, s, vt, vtdot, bound)
   end subroutine flight_gap

   !> V_T, dV_T/dtau and each modal term's share of |d^4 V_T/ds^4| at s, summed apart for
   !> the terms that decay (bound(1), with the harmonic) and grow (bound(2); none when
   !> alpha3 > 0): over [s0, s1] |d^4 V_T/ds^4| <= bound(1) at s0 + bound(2) at s1.
   pure subroutine gap_and_bound(self, model, s, vt, vtdot, bound)
      type(free_flight_t), intent(in) :: self
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: s
      real(dp), intent(out) :: vt
      real(dp), intent(out) :: vtdot
      real(dp), intent(out) :: bound(2)
      complex(dp) :: term
      real(dp) :: phase, omega, decay, angle
      integer :: k
      omega = model%scene%omega
      phase = omega*(self%tau0 + s)
      vt = self%tip_sin*sin(phase) + self%tip_cos*cos(phase) + model%scene%delta_hat
      vtdot = omega*(self%tip_sin*cos(phase) - self%tip_cos*sin(phase))
      bound(1) = self%harmonic_bound
      bound(2) = 0
      do k = 1, self%n_terms
         decay = exp(real(self%eigenvalue(k), dp)*s)
         angle = aimag(self%eigenvalue(k))*s
         term = self%multiplicity(k)*decay*self%tip_weight(k)*cmplx(cos(angle), sin(angle), dp)
         vt = vt + real(term, dp)
         vtdot = vtdot + real(term*self%eigenvalue(k), dp)
         if (decay <= 1) then
            bound(1) = bound(1) + self%weight4(k)*decay
         else
            bound(2) = bound(2) + self%weight4(k)*decay
         end if
      end do
   end subroutine gap_and_bound

   subroutine flight_first_contact(self, model, s_max, found, s_contact, evaluations, ierr, errmsg)
      class(free_flight_t), intent(in) :: self
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: s_max
      logical, intent(out) :: found
      real(dp), intent(out) :: s_contact
      integer, intent(inout) :: evaluations
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(bracketed_root_t) :: root
      real(dp) :: left, right, g_left, r_left, b_left(2), g_right, r_right, b_right(2), s_low, s_high
      real(dp) :: g_high, x, rx, bx(2), h
      integer :: halvings, first_evaluation

      ierr = ok
      errmsg = ''
      found = .false.
      s_contact = s_max
      first_evaluation = evaluations
      left = 0
      call switch_function(self, model, left, g_left, r_left, b_left, evaluations)
      if (.not. (ieee_is_finite(g_left) .and. ieee_is_finite(r_left) .and. ieee_is_finite(sum(b_left)))) then
         ierr = err_runtime
         write (errmsg, '(a,es13.5e3)') 'flight_exact: the free flight is not finite at tau = ', self%tau0
         return
      end if
      h = max(self%min_step, scan_step(g_left, r_left, sum(b_left)))
      halvings = 0
      do while (left < s_max)
         right = min(s_max, left + h)
         if (.not. (right > left) .or. evaluations - first_evaluation > max_scan_evaluations) then
            ierr = err_runtime
            write (errmsg, '(a,es13.5e3,a,i0,a,es10.2e3,a)') 'flight_exact: the contact scan stalls at tau = ', &
               self%tau0 + left, ' (', evaluations - first_evaluation, ' evaluations, step ', h, &
               '); &scene omega or the tolerances are out of reach, use method = ''dopri5'''
            return
         end if
         call switch_function(self, model, right, g_right, r_right, b_right, evaluations)
         call classify_interval(self, model, left, g_left, r_left, right, g_right, r_right, &
                                b_left(1) + b_right(2), s_low, s_high, g_high, evaluations)
         if (s_high > 0) then
            ! A bracket [s_low, s_high] = [left, .]: refine it to round-off.
            call root%start(s_low, max(g_left, tiny(1.0_dp)), s_high, g_high, &
                            4*epsilon(1.0_dp)*abs(self%tau0 + s_high))
            do while (.not. root%converged())
               call root%next_point(x)
               call switch_function(self, model, x, g_high, rx, bx, evaluations)
               call root%update(g_high)
            end do
            call root%end_with_sign(-1.0_dp, s_contact)
            found = .true.
            return
         else if (s_high < 0 .and. halvings < max_halvings) then
            halvings = halvings + 1      ! not cleared: look closer
            h = h/2
            cycle
         end if
         left = right
         g_left = g_right
         r_left = r_right
         b_left = b_right
         halvings = 0
         h = max(self%min_step, scan_step(g_left, r_left, sum(b_left)))
      end do
   end subroutine flight_first_contact

   !> The scan step from G, G' and the bound B on |G''''| at the left end: the largest h whose
   !> Hermite error bound B h^4 t^2 (1-t)^2/24 stays below half of G (at t = 1/2: h^4 = 192 G/B)
   !> or, for a rising G, below half of the rise G' h t (at t = 1/3: h^3 = 81 G'/B).
   pure function scan_step(g, rate, bound) result(h)
      real(dp), intent(in) :: g
      real(dp), intent(in) :: rate
      real(dp), intent(in) :: bound
      real(dp) :: h
      if (.not. (bound > 0)) then
         h = huge(1.0_dp)
         return
      end if
      h = sqrt(sqrt(192*max(g, 0.0_dp)/bound))
      if (rate > 0) h = max(h, (81*rate/bound)**(1.0_dp/3))
   end function scan_step

   !> G = V_T + margin along the flight (contact begins where G <= 0), its rate, and the
   !> bound on |G''''| there.
   subroutine switch_function(self, model, s, g, rate, bound, evaluations)
      type(free_flight_t), intent(in) :: self
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: s
      real(dp), intent(out) :: g
      real(dp), intent(out) :: rate
      real(dp), intent(out) :: bound(2)
      integer, intent(inout) :: evaluations
      call gap_and_bound(self, model, s, g, rate, bound)
      g = g + self%margin
      evaluations = evaluations + 1
   end subroutine switch_function

   !> Classify the scan interval [s0, s1] of G: s_high > 0 gives a bracket [s_low, s_high]
   !> with G(s_high) <= 0; s_high = 0 means the interval is cleared; s_high < 0 means the
   !> error bound does not clear it.  The cubic Hermite error is G''''(xi)/24 (s-s0)^2 (s-s1)^2,
   !> zero at both ends, with |G''''| <= bound, so G >= E(t) = c(t) - K t^2 (1-t)^2 with
   !> K = bound h^4/24.  E is checked on a grid of spacing 1/n_check, and between grid points
   !> it is at least the smaller neighbour minus max|E''|/(8 n_check^2): rigorous.
   subroutine classify_interval(self, model, s0, g0, r0, s1, g1, r1, bound, s_low, s_high, g_high, &
                                evaluations)
      type(free_flight_t), intent(in) :: self
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: s0, g0, r0, s1, g1, r1, bound
      real(dp), intent(out) :: s_low, s_high, g_high
      integer, intent(inout) :: evaluations
      real(dp) :: width, theta, cubic_min, lowest, t, a3, b3, g_mid, r_mid, b_mid(2), big_k, curvature
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
      ! Lower envelope E(t) = c(t) - K (t (1 - t))^2 on the grid, less the curvature allowance.
      a3 = 2*g0 + width*r0 - 2*g1 + width*r1
      b3 = -3*g0 - 2*width*r0 + 3*g1 - width*r1
      big_k = bound*width**4/24
      curvature = 2*abs(b3) + 6*abs(a3) + 2*big_k
      lowest = min(g0, g1)
      do k = 1, n_check - 1
         t = real(k, dp)/n_check
         lowest = min(lowest, ((a3*t + b3)*t + width*r0)*t + g0 - big_k*(t*(1 - t))**2)
      end do
      if (lowest - curvature/(8*n_check**2) > 0) return
      call hermite_minimum(g0, width*r0, g1, width*r1, theta, cubic_min)
      if (theta > 0 .and. cubic_min <= 0) then
         call switch_function(self, model, s0 + theta*width, g_mid, r_mid, b_mid, evaluations)
         if (g_mid <= 0) then
            s_high = s0 + theta*width
            g_high = g_mid
            return
         end if
      end if
      s_high = -1
   end subroutine classify_interval

end module tmafm_flight

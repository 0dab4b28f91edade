!> Exact propagation out of contact.  Free of contact the model is linear with harmonic
!> forcing, y' = A y + b_s sin(Omega tau) + b_c cos(Omega tau), so
!>
!>   y(tau0 + s) = y_p(tau0 + s) + Re( V exp(Lambda s) z ),   z = V^-1 (y(tau0) - y_p(tau0)),
!>
!> with A = V Lambda V^-1 (LAPACK dgeev; the damping alpha3 I, or a liquid's diagonal C, is not
!> proportional to M, so the modes are complex) and the periodic particular solution y_p = u sin + v cos (dgesv).
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
!> The steps are taken down to a ladder h_k = h0 m_j 2^o (8 levels an octave, h0 a power of
!> two), whose factors exp(lambda h_k) and exp(i Omega h_k) are tabulated once, in init: a
!> scan point one step past the last is the last point's terms times one table entry each,
!> no libm, with a direct evaluation every scan_anchor_every points and a rounding allowance
!> taken off G before an interval is cleared (flight_first_contact says how much).
!>
!> The output samples of a flight are equally spaced (dt = sample_dtau), so `sample` turns each
!> term from one sample to the next by the fixed factor exp(lambda dt) (set once per run by
!> `sample_step`) instead of calling exp, and the state is one product of a matrix built in
!> init, [u | v | Re V | -Im V], with [sin, cos, Re terms, Im terms], a block of rows at a time
!> (O(N^2) multiplications per sample, vectorised along the rows, and no libm).  The
!> terms are taken afresh from exp(lambda s) at the first sample of a flight, every
!> anchor_every samples, and (in `sample`) whenever a sample is not dt past the previous one;
!> between anchors the rounding drifts by a few ulp per sample (tests/test_sampling.py bounds
!> it).  The run loop takes a flight's samples a block at a time (`samples`), on explicit
!> shapes, with the anchors counted, and each state goes straight into its row of the
!> trajectory's a and adot; N = 4 with four conjugate pairs (Fig. 2) has its own kernel of
!> fixed shapes (sample_run_4), the same sums in the same order.
module tmafm_flight
   use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
   use tmafm_kinds, only: dp, i8
   use tmafm_errors, only: ok, err_input, err_runtime
   use tmafm_model, only: model_t
   use tmafm_viscoelastic, only: sls_free_relaxation
   use tmafm_drive, only: drive_t, max_tones
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
      !> A general drive (tmafm_drive; model%drive%general): the particular solution is a sum over
      !> the tones, y_p = sum_k tone_u(:, k) sin(Omega_k tau + phi_k) + tone_v(:, k) cos(..), and
      !> so is the particular V_T (tone_tip_sin, tone_tip_cos); u, v, tip_sin, tip_cos are tone
      !> 1's, and the samples and the modal start take the other tones off first.
      logical :: general = .false.
      integer :: n_tones = 1
      type(drive_t) :: drive
      real(dp), allocatable :: tone_u(:, :), tone_v(:, :)
      real(dp) :: tone_tip_sin(max_tones) = 0, tone_tip_cos(max_tones) = 0, tone_frequency(max_tones) = 0
      !> Omega^4 times the amplitude of the particular V_T: its share of |d^4 V_T/ds^4|.
      real(dp) :: harmonic_bound = 0
      !> A force held constant over the flights to come (thermal noise on its grid, docs/model.md
      !> §21; `hold`): the flight's constant particular part y_c = (K^-1 xi, 0) and its share
      !> p.K^-1 xi of V_T, added to every state, sample and V_T of the flight.
      logical :: held = .false.
      real(dp), allocatable :: held_state(:)
      real(dp) :: held_tip = 0
      !> (M^-1 K)^-1: the static response K^-1 xi = (M^-1 K)^-1 (M^-1 xi).
      real(dp), allocatable :: static_response(:, :)
      !> Start of the flight under way.
      real(dp) :: tau0 = 0
      !> A viscoelastic sample's dashpot coordinate w at tau0 (tmafm_viscoelastic): in flight it
      !> relaxes in closed form, w exp(-r s/T), written after the modes when y has room for it.
      real(dp) :: dashpot0 = 0
      !> Modal coefficients z of the flight, and z times p^T V (each term's share of V_T).
      complex(dp), allocatable :: z(:), tip_weight(:)
      !> multiplicity |tip_weight| |lambda|^4: each term's share of |d^4 V_T/ds^4| at s = 0.
      real(dp), allocatable :: weight4(:)
      !> |lambda|^4 per term.
      real(dp), allocatable :: rate4(:)
      !> Round-off level of V_T at the flight start: contact begins at V_T <= -margin.
      real(dp) :: margin = 0
      !> Bound on |d^4 V_T/ds^4| at the flight start.
      real(dp) :: fourth_derivative_bound = 0
      !> Smallest scan step: 2^-10 of a quarter of the shortest time scale of the free system.
      real(dp) :: min_step = 0
      !> Blocks of sample_block rows that hold the 2N rows of the state (padding rows are 0).
      integer :: sample_blocks = 0
      !> The sample kernel's matrix [u | v | Re V | -Im V], a block of rows at a time:
      !> sample_block x (2 + 2 n_terms) x sample_blocks.  The state at a sample is this matrix
      !> times sample_weights.
      real(dp), allocatable :: sample_matrix(:, :, :)
      !> [sin, cos, Re running, Im running] at the last sample s_last, where running is
      !> multiplicity z exp(lambda s) per term.
      real(dp), allocatable :: sample_weights(:)
      !> Spacing of the samples (0 until sample_step is called), and exp(lambda dt) per term
      !> (real and imaginary parts).
      real(dp) :: sample_dt = 0
      real(dp), allocatable :: rotor_re(:), rotor_im(:)
      !> Time of the last sample, and the samples taken since its terms were last computed
      !> with exp.
      real(dp) :: s_last = 0
      integer :: since_anchor = huge(1)
      !> Real and imaginary parts of the eigenvalues, one per term.
      real(dp), allocatable :: eigen_re(:), eigen_im(:)
      !> The largest |lambda| of the free system, Omega included.
      real(dp) :: rate_max = 0
      !> Amplitude of the particular V_T (of the drive term).
      real(dp) :: drive_size = 0
      !> multiplicity |tip_weight| per term: each term's |share of V_T| at s = 0 (per flight).
      real(dp), allocatable :: term_size(:)
      !> The scan's ladder of steps h_k = h0 m_j 2^o, k = 1 + ladder_per_octave o + j, with h0 a
      !> power of two (so that sums of steps are mostly exact), m_j = floor(16 2^(j/8))/16,
      !> and h_k^3, h_k^4 to look a step up on it.
      real(dp), allocatable :: ladder(:), ladder3(:), ladder4(:)
      !> exp(lambda h_k) per term and level (n_terms x levels: real, imaginary parts and modulus)
      !> and cos, sin of Omega h_k per level: the factors that take the terms one step on.
      real(dp), allocatable :: ladder_re(:, :), ladder_im(:, :), ladder_decay(:, :)
      real(dp), allocatable :: ladder_cos(:), ladder_sin(:)
      !> Levels of the ladder in use.
      integer :: n_levels = 0
      !> The scan's two points (left, right) in flight: each term's share of V_T (real and
      !> imaginary parts) and its decay, n_terms x 2 (workspace of first_contact).
      real(dp), allocatable :: point_re(:, :), point_im(:, :), point_decay(:, :)
   contains
      !> Decompose the free system of a model (once per run).
      procedure :: init => flight_init
      !> Hold a constant force over the flights to come, given as M^-1 xi (model_t%noise_accel).
      procedure :: hold => flight_hold
      !> Start a flight from state y at tau.
      procedure :: start => flight_start
      !> The state at tau0 + s.
      procedure :: state => flight_state
      !> Set the spacing dt of the output samples (once per run).
      procedure :: sample_step => flight_sample_step
      !> The state at the output sample tau0 + s, given sin and cos of Omega (tau0 + s).
      procedure :: sample => flight_sample
      !> The states at consecutive output samples of the flight, given sin and cos at each,
      !> into consecutive rows of a table of samples (a, adot: one sample per row).
      procedure :: samples => flight_samples
      !> V_T and dV_T/dtau at tau0 + s.
      procedure :: gap => flight_gap
      !> The first s in (0, s_max] with V_T <= 0, located to round-off; found = .false. if none.
      procedure :: first_contact => flight_first_contact
   end type free_flight_t

   !> Deepest halving of a scan interval whose error bound does not clear it.
   integer, parameter :: max_halvings = 30
   !> Most evaluations of V_T one call of first_contact may take before it gives up.
   integer, parameter :: max_scan_evaluations = 10000000
   !> Rows the sample kernel computes together (a fixed count, so that its inner loop has a
   !> constant length the compiler vectorises; sample_matrix is padded to a multiple of it).
   integer, parameter, public :: sample_block = 8
   !> Modes and terms of the fixed-shape sample kernel (sample_run_4): N = 4 with four
   !> conjugate pairs, the Fig. 2 scenes (2N = sample_block: one block of rows).
   integer, parameter :: small_modes = 4
   !> Samples between two evaluations of exp(lambda s) in `sample`.
   integer, parameter, public :: anchor_every = 32
   !> Scan points between two direct evaluations of V_T (exp, sin, cos) in `first_contact`;
   !> the points in between are turned by the ladder's factors.
   integer, parameter, public :: scan_anchor_every = 16
   !> Steps of the scan ladder per octave (the step halves every this many levels).
   integer, parameter :: ladder_per_octave = 8
   !> Most octaves of the ladder above h0.
   integer, parameter :: ladder_octaves = 48
   !> Rounding of one turn of a term by a ladder factor, in units of epsilon: the factor's
   !> own rounding (exp, sin, cos: about 1 ulp each) and the complex product (sqrt 5 / 2 ulp).
   real(dp), parameter :: turn_rounding = 8

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
      ! -M^-1 C: alpha3 I, or in a liquid alpha3 + each mode's damping (model_t%pass_v).
      a(n + 1:m, n + 1:m) = model%pass_v(1:n, :)

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
      self%general = model%drive%general
      self%n_tones = model%drive%n_tones
      self%drive = model%drive
      if (self%general) then
         ! Tone 1 here (at its own frequency and phase); the other tones below.
         call tone_particular(1, ierr, errmsg)
         if (ierr /= ok) return
      end if
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
      if (self%general) then
         allocate (self%tone_u(m, max_tones), self%tone_v(m, max_tones), source=0.0_dp)
         self%tone_u(:, 1) = self%u
         self%tone_v(:, 1) = self%v
         do k = 2, self%n_tones
            call tone_particular(k, ierr, errmsg)
            if (ierr /= ok) return
            call dgesv(2*m, 1, system, 2*m, ipiv, rhs, 2*m, info)
            if (info /= 0 .or. .not. all(ieee_is_finite(rhs))) then
               ierr = err_runtime
               write (errmsg, '(a,es12.4e3,a)') 'flight_exact: the drive tone &scene omega_2 = ', &
                  model%drive%frequency(k), ' is at an undamped resonance of the free beam (alpha3 = 0?)'
               return
            end if
            self%tone_u(:, k) = rhs(1:m)
            self%tone_v(:, k) = rhs(m + 1:2*m)
         end do
         self%tip_sin = dot_product(model%tip, self%u(1:n)) + model%drive%amplitude(1)
         self%harmonic_bound = 0
         self%drive_size = 0
         do k = 1, self%n_tones
            self%tone_frequency(k) = model%drive%frequency(k)
            self%tone_tip_sin(k) = dot_product(model%tip, self%tone_u(1:n, k)) + model%drive%amplitude(k)
            self%tone_tip_cos(k) = dot_product(model%tip, self%tone_v(1:n, k))
            self%harmonic_bound = self%harmonic_bound &
                                  + self%tone_frequency(k)**4*hypot(self%tone_tip_sin(k), self%tone_tip_cos(k))
         end do
      end if

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
                self%rotor_re(k), self%rotor_im(k), self%eigen_re(k), self%eigen_im(k), &
                self%term_size(k))
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
      k = self%n_terms
      self%sample_blocks = (m + sample_block - 1)/sample_block
      allocate (self%sample_matrix(sample_block, 2 + 2*k, self%sample_blocks), &
                self%sample_weights(2 + 2*k))
      block
         real(dp) :: columns(sample_block*self%sample_blocks, 2 + 2*k)
         integer :: b
         columns = 0
         columns(1:m, 1) = self%u
         columns(1:m, 2) = self%v
         columns(1:m, 3:2 + k) = real(self%vectors, dp)
         columns(1:m, 3 + k:2 + 2*k) = -aimag(self%vectors)
         do b = 1, self%sample_blocks
            self%sample_matrix(:, :, b) = columns((b - 1)*sample_block + 1:b*sample_block, :)
         end do
      end block
      self%sample_weights = 0
      self%min_step = 0.25_dp/max(maxval(abs(self%eigenvalue)), model%drive%top_frequency, tiny(1.0_dp))/1024
      self%rate4 = abs(self%eigenvalue)**4
      self%eigen_re = real(self%eigenvalue, dp)
      self%eigen_im = aimag(self%eigenvalue)
      self%rate_max = max(maxval(abs(self%eigenvalue)), model%drive%top_frequency)
      if (self%general) then
         self%drive_size = sum(hypot(self%tone_tip_sin(1:self%n_tones), self%tone_tip_cos(1:self%n_tones)))
      else
         self%drive_size = hypot(self%tip_sin, self%tip_cos)
      end if
      self%term_size = 0
      call build_ladder(self, model%drive%fundamental)
      self%held = .false.
      self%held_tip = 0
      allocate (self%held_state(m), source=0.0_dp)
      ! (M^-1 K)^-1 by LU with the identity on the right: once per run, for `hold` (any flight may
      ! hold a force; the clamped beam's K is positive definite).
      allocate (self%static_response(n, n), source=0.0_dp)
      do j = 1, n
         self%static_response(j, j) = 1
      end do
      block
         real(dp) :: factors(n, n)
         factors = model%inv_mass_eigen
         call dgesv(n, n, factors, n, ipiv, self%static_response, n, info)
      end block
      if (info /= 0 .or. .not. all(ieee_is_finite(self%static_response))) then
         ierr = err_runtime
         errmsg = 'flight_exact: the free beam has no static response (its stiffness is singular)'
         return
      end if

   contains

      !> The system and right-hand side of tone k's particular solution (general drive): the
      !> forcing alpha_k Omega_k^2 M^-1 (alpha1 m + (1 + mu) q) sin(..) - alpha_k Omega_k M^-1 C q cos(..)
      !> at Omega_k, the phase phi_k in the sin and cos.
      subroutine tone_particular(k, ierr, errmsg)
         integer, intent(in) :: k
         integer, intent(out) :: ierr
         character(len=*), intent(out) :: errmsg
         real(dp) :: w, amp
         ierr = ok
         errmsg = ''
         w = model%drive%frequency(k)
         amp = model%drive%amplitude(k)
         system = 0
         system(1:m, 1:m) = a
         system(m + 1:2*m, m + 1:2*m) = a
         do j = 1, m
            system(j, m + j) = w
            system(m + j, j) = -w
         end do
         rhs = 0
         rhs(n + 1:m) = -amp*w**2*model%inv_mass_inertial
         ! The base velocity through the damping: alpha3 M^-1 q in air, M^-1 C q in a liquid.
         if (model%has_medium) then
            rhs(m + n + 1:2*m) = amp*w*model%inv_mass_damped_integral
         else
            rhs(m + n + 1:2*m) = amp*model%scene%alpha3*w*model%inv_mass_integral
         end if
         if (.not. (all(ieee_is_finite(system)) .and. all(ieee_is_finite(rhs)))) then
            ierr = err_input
            write (errmsg, '(a,i0,a,es12.4e3)') 'flight_exact: the free beam equations overflow for drive tone ', &
               k, ' at frequency ', w
         end if
      end subroutine tone_particular
   end subroutine flight_init

   !> The scan ladder, from h0 = the power of two just above min_step up past 64 drive periods
   !> (at most ladder_octaves octaves), with each level's factors; it ends below the first
   !> level whose factors are not finite (a growing term; h0 itself is 2^-11 of the fastest
   !> time scale, so its factors are all near 1).
   subroutine build_ladder(self, omega)
      type(free_flight_t), intent(inout) :: self
      real(dp), intent(in) :: omega
      real(dp) :: h0, h, longest, mantissa(0:ladder_per_octave - 1)
      complex(dp) :: factor
      integer :: n, k, j, octaves

      h0 = scale(1.0_dp, exponent(self%min_step))
      longest = 64*(8*atan(1.0_dp))/max(omega, tiny(1.0_dp))
      octaves = ladder_octaves
      if (longest/h0 < 2.0_dp**ladder_octaves) octaves = max(1, exponent(longest/h0))
      do j = 0, ladder_per_octave - 1
         mantissa(j) = floor(16*2.0_dp**(real(j, dp)/ladder_per_octave))/16.0_dp
      end do
      n = ladder_per_octave*octaves + 1
      allocate (self%point_re(self%n_terms, 2), self%point_im(self%n_terms, 2), &
                self%point_decay(self%n_terms, 2))
      self%point_re = 0
      self%point_im = 0
      self%point_decay = 0
      allocate (self%ladder(n), self%ladder3(n), self%ladder4(n), self%ladder_re(self%n_terms, n), &
                self%ladder_im(self%n_terms, n), self%ladder_decay(self%n_terms, n), &
                self%ladder_cos(n), self%ladder_sin(n))
      self%n_levels = n
      do k = 1, n
         h = scale(h0*mantissa(mod(k - 1, ladder_per_octave)), (k - 1)/ladder_per_octave)
         self%ladder(k) = h
         self%ladder3(k) = h*h*h
         self%ladder4(k) = (h*h)*(h*h)
         do j = 1, self%n_terms
            factor = exp(self%eigenvalue(j)*h)
            self%ladder_re(j, k) = real(factor, dp)
            self%ladder_im(j, k) = aimag(factor)
            self%ladder_decay(j, k) = exp(self%eigen_re(j)*h)
         end do
         self%ladder_cos(k) = cos(omega*h)
         self%ladder_sin(k) = sin(omega*h)
         if (.not. (all(ieee_is_finite(self%ladder_re(:, k))) .and. all(ieee_is_finite(self%ladder_im(:, k))) &
                    .and. all(ieee_is_finite(self%ladder_decay(:, k))) .and. ieee_is_finite(self%ladder4(k)))) then
            self%n_levels = max(1, k - 1)
            exit
         end if
      end do
   end subroutine build_ladder

   !> The flights to come feel the constant force xi, given as accel = M^-1 xi: their particular
   !> solution gains y_c = (a_c, 0) with K a_c = xi (A y_c + (0, M^-1 xi) = 0), and V_T p.a_c.
   pure subroutine flight_hold(self, model, accel)
      class(free_flight_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: accel(:)
      integer :: i, j, n
      n = self%n_state/2
      self%held = .true.
      self%held_state = 0
      do j = 1, n
         do i = 1, n
            self%held_state(i) = self%held_state(i) + self%static_response(i, j)*accel(j)
         end do
      end do
      self%held_tip = dot_product(model%tip, self%held_state(1:n))
   end subroutine flight_hold

   subroutine flight_start(self, model, tau, y)
      class(free_flight_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: y(:)
      real(dp) :: phase, sin_phase, cos_phase

      self%tau0 = tau
      if (size(y) > self%n_state) self%dashpot0 = y(self%n_state + 1)
      phase = model%drive%fundamental*tau
      sin_phase = sin(phase)
      cos_phase = cos(phase)
      if (self%general) then
         block
            real(dp) :: sin_tone(max_tones), cos_tone(max_tones), rest(self%n_state)
            integer :: k
            call model%drive%tones(sin_phase, cos_phase, sin_tone, cos_tone)
            rest = y(1:self%n_state)
            do k = 2, self%n_tones
               rest = rest - self%tone_u(:, k)*sin_tone(k) - self%tone_v(:, k)*cos_tone(k)
            end do
            call modal_coefficients(self%n_state, self%n_terms, self%inverse, self%u, self%v, rest, &
                                    sin_tone(1), cos_tone(1), self%z, self%held_state)
         end block
      else
         call modal_coefficients(self%n_state, self%n_terms, self%inverse, self%u, self%v, y, sin_phase, &
                                 cos_phase, self%z, self%held_state)
      end if
      self%tip_weight = self%z*self%tip_of_vector
      self%term_size = self%multiplicity*abs(self%tip_weight)
      self%weight4 = self%term_size*self%rate4
      self%margin = switch_margin(model, y)
      self%fourth_derivative_bound = sum(self%weight4) + self%harmonic_bound
      self%since_anchor = anchor_every
   end subroutine flight_start

   !> z = V^-1 (y - held - u sin - v cos) for the kept terms, column by column of V^-1
   !> (explicit shapes; held is the held force's y_c, zero without one).
   pure subroutine modal_coefficients(m, n_terms, inverse, u, v, y, sin_phase, cos_phase, z, held)
      integer, intent(in) :: m, n_terms
      complex(dp), intent(in) :: inverse(n_terms, m)
      real(dp), intent(in) :: u(m), v(m), y(m), sin_phase, cos_phase
      complex(dp), intent(out) :: z(n_terms)
      real(dp), intent(in) :: held(m)
      real(dp) :: h
      integer :: j, k
      z = 0
      do j = 1, m
         h = (y(j) - held(j)) - u(j)*sin_phase - v(j)*cos_phase
         do k = 1, n_terms
            z(k) = z(k) + inverse(k, j)*h
         end do
      end do
   end subroutine modal_coefficients

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
   !> else taken from exp.  sin_phase and cos_phase are those of Omega (tau0 + s).
   pure subroutine flight_sample(self, s, sin_phase, cos_phase, y)
      class(free_flight_t), intent(inout) :: self
      real(dp), intent(in) :: s
      real(dp), intent(in) :: sin_phase
      real(dp), intent(in) :: cos_phase
      real(dp), contiguous, intent(out) :: y(:)
      integer :: n
      if (.not. (abs(s - (self%s_last + self%sample_dt)) <= 16*epsilon(1.0_dp)*(abs(self%tau0) + abs(s)))) &
         self%since_anchor = anchor_every
      n = self%n_state/2
      ! y = (a, a') is a table of one row.
      if (self%general) then
         call general_samples(self, 1, 0.0_dp, [s], [sin_phase], [cos_phase], 1, 1, y(1:n), y(n + 1:2*n))
      else
         call sample_run(self%n_state, self%n_terms, self%sample_blocks, 1, 0.0_dp, [s], &
                         [sin_phase], [cos_phase], self%multiplicity, self%z, self%eigenvalue, self%rotor_re, &
                         self%rotor_im, self%sample_matrix, self%sample_weights, self%since_anchor, 1, 1, y(1:n), &
                         y(n + 1:2*n))
      end if
      if (self%held) y(1:self%n_state) = y(1:self%n_state) + self%held_state
      self%s_last = s
   end subroutine flight_sample

   !> The states at count consecutive output samples of the flight, at times tau(1:count): each
   !> sample_dt past the one before, the first sample_dt past the flight's last one sampled
   !> unless it is the flight's first (the trajectory's samples, in order).  sin_phase and
   !> cos_phase are those of Omega tau.  The terms are turned by the rotor from one sample to
   !> the next, and taken afresh from exp(lambda s), s = tau - tau0, at the flight's first
   !> sample and every anchor_every samples: the anchors of `sample`, counted, not tested.
   !> Sample i goes to row first + i - 1 of a and adot (the trajectory's table, passed whole).
   pure subroutine flight_samples(self, count, tau, sin_phase, cos_phase, rows, first, a, adot)
      class(free_flight_t), intent(inout) :: self
      integer, intent(in) :: count
      real(dp), intent(in) :: tau(count)
      real(dp), intent(in) :: sin_phase(count)
      real(dp), intent(in) :: cos_phase(count)
      !> Rows of the table, and the row of the first sample.
      integer, intent(in) :: rows
      integer, intent(in) :: first
      !> Modal amplitudes and velocities, one sample per row (rows x N).
      real(dp), intent(inout) :: a(rows, self%n_state/2)
      real(dp), intent(inout) :: adot(rows, self%n_state/2)
      if (count < 1) return
      if (self%general) then
         call general_samples(self, count, self%tau0, tau, sin_phase, cos_phase, rows, first, a, adot)
      else
         call sample_run(self%n_state, self%n_terms, self%sample_blocks, count, self%tau0, &
                         tau, sin_phase, cos_phase, self%multiplicity, self%z, self%eigenvalue, self%rotor_re, &
                         self%rotor_im, self%sample_matrix, self%sample_weights, self%since_anchor, rows, first, &
                         a, adot)
      end if
      if (self%held) call add_held(self%n_state/2, self%held_state, count, rows, first, a, adot)
      self%s_last = tau(count) - self%tau0
   end subroutine flight_samples

   !> The held force's constant part y_c added to rows first .. first + count - 1 of a and adot.
   pure subroutine add_held(n, held, count, rows, first, a, adot)
      integer, intent(in) :: n, count, rows, first
      real(dp), intent(in) :: held(2*n)
      real(dp), intent(inout) :: a(rows, n), adot(rows, n)
      integer :: i, j
      do j = 1, n
         do i = first, first + count - 1
            a(i, j) = a(i, j) + held(j)
            adot(i, j) = adot(i, j) + held(n + j)
         end do
      end do
   end subroutine add_held

   !> flight_samples for a general drive, a sample at a time: sample_run with tone 1's phase
   !> (u, v are tone 1's), then the other tones' particular parts added to the row.
   pure subroutine general_samples(self, count, origin, tau, sin_phase, cos_phase, rows, first, a, adot)
      type(free_flight_t), intent(inout) :: self
      integer, intent(in) :: count
      !> tau - origin is the time in the flight.
      real(dp), intent(in) :: origin
      real(dp), intent(in) :: tau(count)
      real(dp), intent(in) :: sin_phase(count)
      real(dp), intent(in) :: cos_phase(count)
      integer, intent(in) :: rows
      integer, intent(in) :: first
      real(dp), intent(inout) :: a(rows, self%n_state/2)
      real(dp), intent(inout) :: adot(rows, self%n_state/2)
      real(dp) :: sin_tone(max_tones), cos_tone(max_tones)
      integer :: i, k, n, row
      n = self%n_state/2
      do i = 1, count
         call self%drive%tones(sin_phase(i), cos_phase(i), sin_tone, cos_tone)
         row = first + i - 1
         call sample_run(self%n_state, self%n_terms, self%sample_blocks, 1, origin, tau(i:i), &
                         sin_tone(1:1), cos_tone(1:1), self%multiplicity, self%z, self%eigenvalue, self%rotor_re, &
                         self%rotor_im, self%sample_matrix, self%sample_weights, self%since_anchor, rows, row, a, adot)
         do k = 2, self%n_tones
            a(row, :) = a(row, :) + self%tone_u(1:n, k)*sin_tone(k) + self%tone_v(1:n, k)*cos_tone(k)
            adot(row, :) = adot(row, :) + self%tone_u(n + 1:2*n, k)*sin_tone(k) + self%tone_v(n + 1:2*n, k)*cos_tone(k)
         end do
      end do
   end subroutine general_samples

   !> The sample loop on explicit shapes: per sample the weights [sin, cos, Re running, Im
   !> running] (the terms turned, or anchored: running = multiplicity z exp(lambda s), s =
   !> tau - origin), then the state from sum_terms, into row first + i - 1 of a and adot.
   !> N = 4 with four pairs goes to sample_run_4.
   pure subroutine sample_run(m, n_terms, blocks, count, origin, tau, sin_phase, cos_phase, multiplicity, z, &
                              eigenvalue, rotor_re, rotor_im, matrix, weights, since_anchor, rows, first, a, adot)
      integer, intent(in) :: m, n_terms, blocks, count
      real(dp), intent(in) :: origin, tau(count), sin_phase(count), cos_phase(count), multiplicity(n_terms)
      complex(dp), intent(in) :: z(n_terms), eigenvalue(n_terms)
      real(dp), intent(in) :: rotor_re(n_terms), rotor_im(n_terms)
      real(dp), intent(in) :: matrix(sample_block, 2 + 2*n_terms, blocks)
      real(dp), intent(inout) :: weights(2 + 2*n_terms)
      integer, intent(inout) :: since_anchor
      integer, intent(in) :: rows, first
      real(dp), intent(inout) :: a(rows, m/2), adot(rows, m/2)
      integer :: i
      if (m == 2*small_modes .and. n_terms == small_modes) then
         call sample_run_4(count, origin, tau, sin_phase, cos_phase, multiplicity, z, eigenvalue, rotor_re, &
                           rotor_im, matrix, weights, since_anchor, rows, first, a, adot)
         return
      end if
      do i = 1, count
         call next_weights(n_terms, origin, tau(i), multiplicity, z, eigenvalue, rotor_re, rotor_im, &
                           weights(3:2 + n_terms), weights(3 + n_terms:2 + 2*n_terms), since_anchor)
         weights(1) = sin_phase(i)
         weights(2) = cos_phase(i)
         call sum_terms(m, blocks, 2 + 2*n_terms, matrix, weights, rows, first + i - 1, a, adot)
      end do
   end subroutine sample_run

   !> sample_run for N = 4 with four pairs (so 2N = sample_block), every shape fixed: the same
   !> sums in the same order, in loops the compiler unrolls.
   pure subroutine sample_run_4(count, origin, tau, sin_phase, cos_phase, multiplicity, z, eigenvalue, rotor_re, &
                                rotor_im, matrix, weights, since_anchor, rows, first, a, adot)
      integer, parameter :: n = small_modes, columns = 2 + 2*small_modes
      integer, intent(in) :: count
      real(dp), intent(in) :: origin, tau(count), sin_phase(count), cos_phase(count), multiplicity(n)
      complex(dp), intent(in) :: z(n), eigenvalue(n)
      real(dp), intent(in) :: rotor_re(n), rotor_im(n)
      real(dp), intent(in) :: matrix(sample_block, columns)
      real(dp), intent(inout) :: weights(columns)
      integer, intent(inout) :: since_anchor
      integer, intent(in) :: rows, first
      real(dp), intent(inout) :: a(rows, n), adot(rows, n)
      real(dp) :: acc(sample_block), w1, w2
      integer :: i, j, r
      do i = 1, count
         call next_weights(n, origin, tau(i), multiplicity, z, eigenvalue, rotor_re, rotor_im, &
                           weights(3:2 + n), weights(3 + n:columns), since_anchor)
         weights(1) = sin_phase(i)
         weights(2) = cos_phase(i)
         acc = 0
         do j = 1, columns - 1, 2
            w1 = weights(j)
            w2 = weights(j + 1)
            !$omp simd
            do r = 1, sample_block
               acc(r) = acc(r) + (matrix(r, j)*w1 + matrix(r, j + 1)*w2)
            end do
         end do
         do j = 1, n
            a(first + i - 1, j) = acc(j)
            adot(first + i - 1, j) = acc(n + j)
         end do
      end do
   end subroutine sample_run_4

   !> The running terms (real and imaginary parts) one sample on: turned by the rotor, or,
   !> every anchor_every samples, taken afresh as multiplicity z exp(lambda (tau - origin)).
   pure subroutine next_weights(n_terms, origin, tau, multiplicity, z, eigenvalue, rotor_re, rotor_im, &
                                running_re, running_im, since_anchor)
      integer, intent(in) :: n_terms
      real(dp), intent(in) :: origin, tau, multiplicity(n_terms)
      complex(dp), intent(in) :: z(n_terms), eigenvalue(n_terms)
      real(dp), intent(in) :: rotor_re(n_terms), rotor_im(n_terms)
      real(dp), intent(inout) :: running_re(n_terms), running_im(n_terms)
      integer, intent(inout) :: since_anchor
      complex(dp) :: term
      integer :: k
      if (since_anchor < anchor_every) then
         call turn(n_terms, rotor_re, rotor_im, running_re, running_im)
         since_anchor = since_anchor + 1
      else
         do k = 1, n_terms
            term = multiplicity(k)*z(k)*exp(eigenvalue(k)*(tau - origin))
            running_re(k) = real(term, dp)
            running_im(k) = aimag(term)
         end do
         since_anchor = 1
      end if
   end subroutine next_weights

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

   !> The state (the first m rows of matrix weights) into row `row` of a and adot (the first
   !> m/2 rows of the product, then the rest), sample_block rows at a time and two columns per
   !> pass (columns is even): with matrix = [u | v | Re V | -Im V] (its rows padded to whole
   !> blocks, each block's columns stored together) and weights = [sin, cos, Re running,
   !> Im running], the state u sin + v cos + sum_k Re(V(:, k) running_k) (the multiplicity is
   !> in running).  The block (acc) stays in registers; `omp simd` has gcc vectorise along its rows
   !> (left to itself it vectorises across the column pairs and shuffles the rows back).
   pure subroutine sum_terms(m, blocks, columns, matrix, weights, rows, row, a, adot)
      integer, intent(in) :: m, blocks, columns
      real(dp), intent(in) :: matrix(sample_block, columns, blocks)
      real(dp), intent(in) :: weights(columns)
      integer, intent(in) :: rows, row
      real(dp), intent(inout) :: a(rows, m/2), adot(rows, m/2)
      real(dp) :: acc(sample_block), w1, w2
      integer :: b, i, j, r, n, base, last
      n = m/2
      do b = 1, blocks
         acc = 0
         do j = 1, columns - 1, 2
            w1 = weights(j)
            w2 = weights(j + 1)
            !$omp simd
            do i = 1, sample_block
               acc(i) = acc(i) + (matrix(i, j, b)*w1 + matrix(i, j + 1, b)*w2)
            end do
         end do
         ! State rows base + 1 .. last: those up to n are a's, the rest adot's.
         base = (b - 1)*sample_block
         last = min(base + sample_block, m)
         do r = base + 1, min(last, n)
            a(row, r) = acc(r - base)
         end do
         do r = max(base + 1, n + 1), last
            adot(row, r - n) = acc(r - base)
         end do
      end do
   end subroutine sum_terms

   pure subroutine flight_state(self, model, s, y)
      class(free_flight_t), intent(in) :: self
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: s
      real(dp), intent(out) :: y(:)
      real(dp) :: phase, sin_phase, cos_phase
      complex(dp) :: w
      integer :: i, k
      phase = model%drive%fundamental*(self%tau0 + s)
      sin_phase = sin(phase)
      cos_phase = cos(phase)
      if (self%general) then
         block
            real(dp) :: sin_tone(max_tones), cos_tone(max_tones)
            call model%drive%tones(sin_phase, cos_phase, sin_tone, cos_tone)
            y(1:self%n_state) = 0
            do k = 1, self%n_tones
               y(1:self%n_state) = y(1:self%n_state) + self%tone_u(:, k)*sin_tone(k) + self%tone_v(:, k)*cos_tone(k)
            end do
         end block
      else
         do i = 1, self%n_state
            y(i) = self%u(i)*sin_phase + self%v(i)*cos_phase
         end do
      end if
      ! The real part of each product V(i, k) w written out: a complex product also forms the
      ! imaginary part, and tests both for NaN.
      do k = 1, self%n_terms
         w = self%z(k)*exp(self%eigenvalue(k)*s)
         do i = 1, self%n_state
            y(i) = y(i) + self%multiplicity(k)*(real(self%vectors(i, k), dp)*real(w, dp) &
                                                - aimag(self%vectors(i, k))*aimag(w))
         end do
      end do
      if (self%held) y(1:self%n_state) = y(1:self%n_state) + self%held_state
      if (size(y) > self%n_state) then
         y(self%n_state + 1) = sls_free_relaxation(model%sls, self%dashpot0, s)
         y(self%n_state + 2:) = 0
      end if
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

   !> V_T, dV_T/dtau and the bound on |d^4 V_T/ds^4| at s by direct evaluation (exp, sin, cos).
   pure subroutine gap_and_bound(self, model, s, vt, vtdot, bound)
      type(free_flight_t), intent(in) :: self
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: s
      real(dp), intent(out) :: vt
      real(dp), intent(out) :: vtdot
      real(dp), intent(out) :: bound(2)
      real(dp) :: re, im, decay, cos_phase, sin_phase, size
      integer :: k
      call drive_at(self, model, s, cos_phase, sin_phase)
      call gap_of_drive(self, model, cos_phase, sin_phase, vt, vtdot, bound, size)
      do k = 1, self%n_terms
         call term_at(self, k, s, re, im, decay)
         call add_term(self, k, re, im, decay, vt, vtdot, bound, size)
      end do
   end subroutine gap_and_bound

   !> cos and sin of the drive phase Omega (tau0 + s).
   pure subroutine drive_at(self, model, s, cos_phase, sin_phase)
      type(free_flight_t), intent(in) :: self
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: s
      real(dp), intent(out) :: cos_phase, sin_phase
      real(dp) :: phase
      phase = model%drive%fundamental*(self%tau0 + s)
      sin_phase = sin(phase)
      cos_phase = cos(phase)
   end subroutine drive_at

   !> Modal term k of V_T at s by direct evaluation: its share re + i im (multiplicity
   !> included) and its decay |exp(lambda s)|.
   pure subroutine term_at(self, k, s, re, im, decay)
      type(free_flight_t), intent(in) :: self
      integer, intent(in) :: k
      real(dp), intent(in) :: s
      real(dp), intent(out) :: re, im, decay
      complex(dp) :: term
      real(dp) :: angle
      decay = exp(self%eigen_re(k)*s)
      angle = self%eigen_im(k)*s
      term = self%multiplicity(k)*decay*self%tip_weight(k)*cmplx(cos(angle), sin(angle), dp)
      re = real(term, dp)
      im = aimag(term)
   end subroutine term_at

   !> The particular V_T and its rate at a drive phase, with the harmonic's share of the bound
   !> on |d^4 V_T/ds^4| and its amplitude: what add_term then adds each modal term to.
   pure subroutine gap_of_drive(self, model, cos_phase, sin_phase, vt, vtdot, bound, size)
      type(free_flight_t), intent(in) :: self
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: cos_phase, sin_phase
      real(dp), intent(out) :: vt, vtdot, bound(2), size
      real(dp) :: sin_tone(max_tones), cos_tone(max_tones)
      integer :: k
      if (self%general) then
         call model%drive%tones(sin_phase, cos_phase, sin_tone, cos_tone)
         vt = model%scene%delta_hat
         vtdot = 0
         do k = 1, self%n_tones
            vt = vt + (self%tone_tip_sin(k)*sin_tone(k) + self%tone_tip_cos(k)*cos_tone(k))
            vtdot = vtdot + self%tone_frequency(k)*(self%tone_tip_sin(k)*cos_tone(k) - self%tone_tip_cos(k)*sin_tone(k))
         end do
         if (self%held) vt = vt + self%held_tip
         bound(1) = self%harmonic_bound
         bound(2) = 0
         size = self%drive_size
         return
      end if
      vt = self%tip_sin*sin_phase + self%tip_cos*cos_phase + model%scene%delta_hat
      if (self%held) vt = vt + self%held_tip
      vtdot = model%scene%omega*(self%tip_sin*cos_phase - self%tip_cos*sin_phase)
      bound(1) = self%harmonic_bound
      bound(2) = 0
      size = self%drive_size
   end subroutine gap_of_drive

   !> Add modal term k (share re + i im, decay) to V_T, its rate, the bound on |d^4 V_T/ds^4|
   !> (bound(1) for a term that decays, bound(2) for one that grows, none when alpha3 > 0: over
   !> [s0, s1] |d^4 V_T/ds^4| <= bound(1) at s0 + bound(2) at s1) and the size sum |terms|.
   pure subroutine add_term(self, k, re, im, decay, vt, vtdot, bound, size)
      type(free_flight_t), intent(in) :: self
      integer, intent(in) :: k
      real(dp), intent(in) :: re, im, decay
      real(dp), intent(inout) :: vt, vtdot, bound(2), size
      vt = vt + re
      vtdot = vtdot + (re*self%eigen_re(k) - im*self%eigen_im(k))
      if (decay <= 1) then
         bound(1) = bound(1) + self%weight4(k)*decay
      else
         bound(2) = bound(2) + self%weight4(k)*decay
      end if
      size = size + self%term_size(k)*decay
   end subroutine add_term

   !> The scan walks [0, s_max] in steps taken from the ladder: at each point G = V_T + margin,
   !> its rate and the bound on |G''''|.  A point one ladder step past the last is computed by
   !> turning the last point's terms (`turned`) when the step sums exactly (left + h_k is
   !> the point) and fewer than `anchor` points (default scan_anchor_every) were turned since
   !> the last direct evaluation; otherwise, and wherever the turned G is within its rounding
   !> allowance of zero, V_T is evaluated directly.  The allowance of a turned point is
   !>   eps (turn_rounding (points since the direct one + 1) + rate_max (s - s_direct)) sum|terms|:
   !> each turn rounds by a few ulp of each term, and the factor exp(lambda h) of a step h is
   !> that of the rounded lambda h, as exp(lambda s) in a direct evaluation is.  It is taken off
   !> G at both ends of an interval before the interval is cleared (with the rate's share,
   !> rate_max times the same, over the interval), and the bound on |G''''| is raised by the
   !> same relative amount.  Brent's points and the Hermite-minimum checks are always direct,
   !> so the located contact is that of direct evaluation to round-off.
   subroutine flight_first_contact(self, model, s_max, found, s_contact, evaluations, ierr, errmsg, anchor)
      class(free_flight_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: s_max
      logical, intent(out) :: found
      real(dp), intent(out) :: s_contact
      integer, intent(inout) :: evaluations
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      !> Scan points per direct evaluation (1: every point direct); default scan_anchor_every.
      integer, intent(in), optional :: anchor
      type(bracketed_root_t) :: root
      real(dp) :: left, right, g_left, r_left, b_left(2), g_right, r_right, b_right(2), s_low, s_high
      real(dp) :: g_high, x, rx, bx(2), h, shift
      real(dp) :: l_cos, l_sin, r_cos, r_sin, l_size, r_size, l_rel, r_rel, l_origin, r_origin
      integer :: halvings, first_evaluation, level, l_since, r_since, every, il, ir

      ierr = ok
      errmsg = ''
      found = .false.
      s_contact = s_max
      first_evaluation = evaluations
      every = scan_anchor_every
      if (present(anchor)) every = max(1, anchor)
      ! A general drive's tones are not turned by the ladder: every scan point is direct.
      if (self%general) every = 1
      il = 1
      ir = 2
      left = 0
      call direct(il, left, l_cos, l_sin, g_left, r_left, b_left, l_size)
      l_since = 0
      l_origin = left
      l_rel = 0
      if (.not. (ieee_is_finite(g_left) .and. ieee_is_finite(r_left) .and. ieee_is_finite(sum(b_left)))) then
         ierr = err_runtime
         write (errmsg, '(a,es13.5e3)') 'flight_exact: the free flight is not finite at tau = ', self%tau0
         return
      end if
      level = ladder_level(self, g_left, r_left, sum(b_left))
      h = self%ladder(level)
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
         r_rel = 0
         if (level > 0 .and. l_since + 1 < every .and. sum_is_exact(left, h, right)) then
            call turned(il, ir, level, l_cos, l_sin, r_cos, r_sin, g_right, r_right, b_right, r_size)
            r_since = l_since + 1
            r_origin = l_origin
            r_rel = epsilon(1.0_dp)*(turn_rounding*(r_since + 1) + self%rate_max*(right - r_origin))
            ! Within its allowance of zero the sign of G is that of a direct evaluation.
            if (.not. (g_right - r_rel*r_size > 0)) r_rel = 0
         end if
         if (.not. (r_rel > 0)) then
            call direct(ir, right, r_cos, r_sin, g_right, r_right, b_right, r_size)
            r_since = 0
            r_origin = right
         end if
         shift = max(l_rel*l_size, r_rel*r_size)*(1 + (right - left)*self%rate_max/4)
         call classify_interval(self, model, left, g_left, r_left, right, g_right, r_right, &
                                (b_left(1) + b_right(2))*(1 + max(l_rel, r_rel)), shift, s_low, s_high, &
                                g_high, evaluations)
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
            if (level > ladder_per_octave) then
               level = level - ladder_per_octave
               h = self%ladder(level)
            else
               level = 0                  ! below the ladder's foot: direct evaluations
               h = h/2
            end if
            cycle
         end if
         left = right
         g_left = g_right
         r_left = r_right
         b_left = b_right
         il = 3 - il
         ir = 3 - ir
         l_cos = r_cos
         l_sin = r_sin
         l_size = r_size
         l_rel = r_rel
         l_since = r_since
         l_origin = r_origin
         halvings = 0
         level = ladder_level(self, g_left, r_left, sum(b_left))
         h = self%ladder(level)
      end do

   contains

      !> The point s by direct evaluation into column col of the workspace: G = V_T + margin,
      !> its rate, the bound on |G''''| and sum|terms|.
      subroutine direct(col, s, cos_phase, sin_phase, g, rate, bound, size)
         integer, intent(in) :: col
         real(dp), intent(in) :: s
         real(dp), intent(out) :: cos_phase, sin_phase, g, rate, bound(2), size
         integer :: k
         call drive_at(self, model, s, cos_phase, sin_phase)
         call gap_of_drive(self, model, cos_phase, sin_phase, g, rate, bound, size)
         do k = 1, self%n_terms
            call term_at(self, k, s, self%point_re(k, col), self%point_im(k, col), self%point_decay(k, col))
            call add_term(self, k, self%point_re(k, col), self%point_im(k, col), self%point_decay(k, col), &
                          g, rate, bound, size)
         end do
         g = g + self%margin
         evaluations = evaluations + 1
      end subroutine direct

      !> The point one ladder step h_level past column from, into column col: each term turned
      !> by exp(lambda h), its decay times |exp(lambda h)|, the drive phase by Omega h (no libm).
      subroutine turned(from, col, level, cos_from, sin_from, cos_phase, sin_phase, g, rate, bound, size)
         integer, intent(in) :: from, col, level
         real(dp), intent(in) :: cos_from, sin_from
         real(dp), intent(out) :: cos_phase, sin_phase, g, rate, bound(2), size
         integer :: k
         cos_phase = cos_from*self%ladder_cos(level) - sin_from*self%ladder_sin(level)
         sin_phase = sin_from*self%ladder_cos(level) + cos_from*self%ladder_sin(level)
         call gap_of_drive(self, model, cos_phase, sin_phase, g, rate, bound, size)
         call turn_terms(self%n_terms, self%point_re(:, from), self%point_im(:, from), &
                         self%point_decay(:, from), self%ladder_re(:, level), self%ladder_im(:, level), &
                         self%ladder_decay(:, level), self%point_re(:, col), self%point_im(:, col), &
                         self%point_decay(:, col))
         do k = 1, self%n_terms
            call add_term(self, k, self%point_re(k, col), self%point_im(k, col), self%point_decay(k, col), &
                          g, rate, bound, size)
         end do
         g = g + self%margin
         evaluations = evaluations + 1
      end subroutine turned

   end subroutine flight_first_contact

   !> Each term (re + i im, decay) times its factor (f_re + i f_im, f_decay).
   pure subroutine turn_terms(n, re, im, decay, f_re, f_im, f_decay, re_out, im_out, decay_out)
      integer, intent(in) :: n
      real(dp), intent(in) :: re(n), im(n), decay(n), f_re(n), f_im(n), f_decay(n)
      real(dp), intent(out) :: re_out(n), im_out(n), decay_out(n)
      integer :: k
      do k = 1, n
         re_out(k) = re(k)*f_re(k) - im(k)*f_im(k)
         im_out(k) = re(k)*f_im(k) + im(k)*f_re(k)
         decay_out(k) = decay(k)*f_decay(k)
      end do
   end subroutine turn_terms

   !> Whether right = left + h exactly (left, h >= 0, right their rounded sum): with the larger
   !> addend first, right - larger is exact (Fast2Sum), so the sum is exact iff it gives back
   !> the smaller.
   pure logical function sum_is_exact(left, h, right)
      real(dp), intent(in) :: left, h, right
      if (left >= h) then
         sum_is_exact = right - left == h
      else
         sum_is_exact = right - h == left
      end if
   end function sum_is_exact

   !> The scan step from G, G' and the bound B on |G''''| at the left end, as a level of the
   !> ladder: the largest h_k whose Hermite error bound B h^4 t^2 (1-t)^2/24 stays below half of
   !> G (at t = 1/2: h^4 <= 192 G/B) or, for a rising G, below half of the rise G' h t (at
   !> t = 1/3: h^3 <= 81 G'/B); at least the ladder's foot h0, at most its top.
   pure function ladder_level(self, g, rate, bound) result(level)
      type(free_flight_t), intent(in) :: self
      real(dp), intent(in) :: g
      real(dp), intent(in) :: rate
      real(dp), intent(in) :: bound
      integer :: level
      if (.not. (bound > 0)) then
         level = self%n_levels
         return
      end if
      level = highest_below(self%ladder4, self%n_levels, 192*max(g, 0.0_dp)/bound, 4)
      if (rate > 0) level = max(level, highest_below(self%ladder3, self%n_levels, 81*rate/bound, 3))
   end function ladder_level

   !> The largest k <= n with p(k) <= x in the increasing table p(k) = h_k^power (1 if none):
   !> a first guess from the binary exponents (ladder_per_octave levels per octave of h), then
   !> a step or two along the table.
   pure function highest_below(p, n, x, power) result(k)
      real(dp), intent(in) :: p(:)
      integer, intent(in) :: n
      real(dp), intent(in) :: x
      integer, intent(in) :: power
      integer :: k
      if (.not. (x >= p(1))) then
         k = 1
         return
      end if
      if (x >= p(n)) then
         k = n
         return
      end if
      k = min(max(1 + (ladder_per_octave*(binary_exponent(x) - binary_exponent(p(1))))/power, 1), n)
      do while (k < n)
         if (p(k + 1) > x) exit
         k = k + 1
      end do
      do while (k > 1)
         if (p(k) <= x) exit
         k = k - 1
      end do
   end function highest_below

   !> The biased binary exponent of a positive finite x, from its IEEE bits (the intrinsic
   !> exponent() is a library call).
   elemental integer function binary_exponent(x)
      real(dp), intent(in) :: x
      binary_exponent = int(ishft(transfer(x, 0_i8), -52))
   end function binary_exponent

   !> G = V_T + margin along the flight (contact begins where G <= 0), its rate, and the
   !> bound on |G''''| there, by direct evaluation.
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
   !> K = bound h^4/24, c built from G - shift at both ends (shift: the rounding allowance of
   !> the end values, the rate's share included).  First the cheap test: K t^2 (1-t)^2 <=
   !> K t (1-t)/4 (at most K/16, equal at t = 1/2), so E >= c(t) - K t (1-t)/4, a cubic with
   !> the same end values whose least value on [0, 1] is at an end or at its interior minimum
   !> (hermite_minimum, closed form): if that, less the rounding of c, is positive, the
   !> interval is cleared.  Else E is checked on a grid of spacing 1/n_check, and between grid
   !> points it is at least the smaller neighbour minus max|E''|/(8 n_check^2): rigorous.
   subroutine classify_interval(self, model, s0, g0, r0, s1, g1, r1, bound, shift, s_low, s_high, g_high, &
                                evaluations)
      type(free_flight_t), intent(in) :: self
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: s0, g0, r0, s1, g1, r1, bound, shift
      real(dp), intent(out) :: s_low, s_high, g_high
      integer, intent(inout) :: evaluations
      real(dp) :: width, theta, cubic_min, lowest, t, a3, b3, g_mid, r_mid, b_mid(2), big_k, curvature
      real(dp) :: low0, low1
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
      low0 = g0 - shift
      low1 = g1 - shift
      a3 = 2*low0 + width*r0 - 2*low1 + width*r1
      b3 = -3*low0 - 2*width*r0 + 3*low1 - width*r1
      big_k = bound*width**4/24
      call hermite_minimum(low0, width*r0 - big_k/4, low1, width*r1 + big_k/4, theta, cubic_min)
      if (min(low0, low1, cubic_min) - 8*epsilon(1.0_dp)*(abs(a3) + abs(b3) + abs(width*r0) + abs(low0) &
                                                           + big_k) > 0) return
      call hermite_minimum(low0, width*r0, low1, width*r1, theta, cubic_min)
      ! Lower envelope E(t) = c(t) - K (t (1 - t))^2 on the grid, less the curvature allowance.
      curvature = 2*abs(b3) + 6*abs(a3) + 2*big_k
      lowest = min(low0, low1)
      do k = 1, n_check - 1
         t = real(k, dp)/n_check
         lowest = min(lowest, ((a3*t + b3)*t + width*r0)*t + low0 - big_k*(t*(1 - t))**2)
      end do
      if (lowest - curvature/(8*n_check**2) > 0) return
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

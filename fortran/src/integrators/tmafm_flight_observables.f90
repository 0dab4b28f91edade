!> What an observer needs from the exact free flight (tmafm_flight), in closed form: the
!> integrals of the per-period observables over any interval of a flight, and the extrema of a
!> mode's amplitude or of V_T, located with a guarantee (docs/model-notes.md, item 16).
!>
!> Out of contact y(tau0 + s) = Re(Q e^{i Omega tau}) + sum_k mult_k Re(V_k z_k e^{lambda_k s}),
!> Q = v - i u, so every integrand of a flight (V_T times e^{i m Omega tau}, p.a, the drive power
!> a'.Re(g e^{i Omega tau}), the beam-damping power -alpha3 |a'|^2, -a'.C a' in a liquid) is a short sum of
!> exponentials e^{mu s}, and
!>
!>   int_a^b e^{mu s} ds = (e^{mu b} - e^{mu a})/mu = e^{mu a} h phi1(mu h),  h = b - a,
!>   phi1(x) = (e^x - 1)/x,
!>
!> the difference form where |Re mu h| + |Im mu h| >= 1/2 (it then loses at most a factor
!> 2 sqrt 2 of the end values' rounding, eps max|e^{mu s}| h), phi1 by its series (16 terms)
!> below, so resonances mu ~ 0 (lambda_k + i m Omega with Im lambda_k ~ -m Omega, lambda_k +
!> conj lambda_k with a small damping) cost no accuracy.  The exponents mu and 1/mu, the Gram sums V'_k.V'_l and
!> V'_k.conj(V'_l) of the velocity rows, and their products with the drive and the particular
!> solution depend only on the model: they are formed once per run, in init (the exponents of
!> the harmonics past the first as they are needed).  h phi1(mu h) and e^{mu h} of every
!> exponent that takes the series are kept for the last interval length h (O(n_terms H +
!> n_terms^2) numbers): a flight cut at the noise grid (docs/model.md, section 21) is pieces of
!> one length to the rounding of their ends, and a piece within 2^-27 of it takes them, to first
!> order in the difference (cached_segment), so a piece's integral is two complex products, not
!> 16 series terms.  An interval costs one exp and sincos per term and end (shared with the
!> scans), (2 harmonics + 1) n_terms exponential integrals for the lock-in sums (2 without them)
!> and n_terms (n_terms + 1) for |a'|^2.
!>
!> The extrema: a channel f (mode j's a_j, or V_T) is Re(c_p e^{i Omega tau}) + c_0 + sum_k
!> Re(c_k e^{lambda_k s}), with f', f'', f''' in closed form and |f''''| <= Omega^4 |c_p| +
!> sum_k |c_k| |lambda_k|^4 |e^{lambda_k s}| (largest at the left end for a decaying term).
!> Its maximum over an interval (a minimum is the maximum of -f) is found by a scan: an interval
!> [s0, s1] is cleared when the cubic Hermite interpolant of f plus its error bound
!> |f''''| (s-s0)^2 (s-s1)^2/24 stays below the running maximum (tmafm_flight's test for V_T's
!> first root, with the running maximum for the root level); an interval that is not cleared and
!> brackets a sign change of f' (+ to -) is searched by Brent on f', and a neighbourhood of the
!> maximum found is cleared by Taylor's bound there (f'' < 0); any other interval is halved.  So
!> the maximum is never below the value of f at any point of the interval, to round-off.  The
!> scan step is the largest for which the error bound is half the headroom below the running
!> maximum (or the rise of the headroom, or its curvature), so points far below it are passed in
!> large steps.  The factors of an interval's ends (e^{lambda_k s}, e^{i Omega tau}) are taken
!> once for its integrals and all its 2 + 2N scans (basis_t, keyed by the flight's start and s).
!> The same scan started at a limit finds where some |a_j| of a flight exceeds it
!> (exceeds: &solver blowup_limit), after an envelope sum_k |c_k| + |c_p| that clears most
!> flights at once.
module tmafm_flight_observables
   use tmafm_kinds, only: dp
   use tmafm_model, only: model_t
   use tmafm_flight, only: free_flight_t
   use tmafm_drive, only: max_tones
   use tmafm_events, only: hermite_minimum
   use tmafm_roots, only: bracketed_root_t
   use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
   implicit none
   private

   public :: flight_observables_t, channel_gap

   !> The channel V_T (a channel j > 0 is mode j's a_j).
   integer, parameter :: channel_gap = 0

   !> A point of a scan: the time s in the flight, sigma f, sigma f', sigma f'' (sigma = +1 for a
   !> maximum, -1 for a minimum), the size sum |terms| of f there, and the bound on |f''''| of
   !> the decaying terms (valid to the right of s) and of the growing ones (valid to its left).
   type :: scan_point_t
      real(dp) :: s = 0, f = 0, d1 = 0, d2 = 0, size = 0, decaying = 0, growing = 0
   end type scan_point_t

   !> The channel-independent factors of a point s of a flight started at tau0: e^{Re lambda_k s},
   !> e^{i Im lambda_k s}, and the drive's e^{i Omega (tau0 + s)} (a general drive: each tone's
   !> e^{i h_k Omega_0 (tau0 + s)}).  An interval's ends are kept (keyed by tau0 and s), so that
   !> the integrals and the 2 + 2N scans of one flight piece take their sines, cosines and
   !> exponentials once.
   type :: basis_t
      !> Whether the key (tau0, s) names the factors held.
      logical :: valid = .false.
      real(dp) :: tau0 = 0, s = 0
      real(dp), allocatable :: decay(:)
      complex(dp), allocatable :: turn(:)
      complex(dp) :: drive = 0
      complex(dp) :: tone(max_tones) = 0
   end type basis_t

   !> An interval of a scan still to classify, and how often it was halved.
   type :: scan_interval_t
      type(scan_point_t) :: left, right
      integer :: depth = 0
   end type scan_interval_t

   !> Deepest halving of an interval the bound does not clear; most intervals on the stack.
   integer, parameter :: max_depth = 40, stack_size = 2*max_depth + 8
   !> Most evaluations of one scan before it accepts what it has (never reached in practice).
   integer, parameter :: max_scan_points = 2000000
   !> Below this |Re(mu h)| + |Im(mu h)| an exponential integral is e^{mu a} h phi1(mu h).
   real(dp), parameter :: series_below = 0.5_dp
   !> Terms of the series of phi1 (for |x| < 1/2 the next is below 2^-60).
   integer, parameter :: series_terms = 16
   !> An interval within this fraction of the last one's length takes the last one's phi1(mu h)
   !> (observables_integrate): the first-order correction leaves under 2^-55 of |f(a)| h.
   real(dp), parameter :: reuse_within = 2.0_dp**(-27)

   !> The closed forms of one model's free flight, and their workspace.
   type :: flight_observables_t
      !> Modes N, terms kept (one per real eigenvalue or conjugate pair), lock-in harmonics H.
      integer :: n_modes = 0, n_terms = 0, harmonics = 0
      !> Omega, delta_hat, alpha2, alpha3.
      real(dp) :: omega = 0, delta_hat = 0, alpha2 = 0, alpha3 = 0
      !> Eigenvalues lambda_k, their multiplicity (1 or 2), real parts and |lambda_k|^4.
      complex(dp), allocatable :: lambda(:)
      real(dp), allocatable :: mult(:), decay_rate(:), rate4(:)
      !> mu(k, m) = lambda_k + i m Omega and 1/mu for m = -1, 0, 1 (the other harmonics' exponents
      !> are formed as they are needed: their tables would take n_terms H numbers).
      complex(dp), allocatable :: mu(:, :), inv_mu(:, :)
      !> lambda_k + lambda_l, lambda_k + conj(lambda_l) and their inverses (n_terms^2).
      complex(dp), allocatable :: mu_pair(:, :), inv_pair(:, :), mu_herm(:, :), inv_herm(:, :)
      !> V'_k . V'_l and V'_k . conj(V'_l) over the velocity rows of the eigenvectors.
      complex(dp), allocatable :: gram(:, :), herm(:, :)
      !> V'_k . g, V'_k . conj(g) (g = d_c - i d_s: the drive power is a'.Re(g e^{i Omega tau})),
      !> V'_k . Q', V'_k . conj(Q') (Q' = v' - i u': the particular a').
      complex(dp), allocatable :: drive_plus(:), drive_minus(:), part_plus(:), part_minus(:)
      !> Particular parts: V_T (drive included), p.a, Q'.g, Q'.conj(g), Q'.Q', |Q'|^2.
      complex(dp) :: tip_part = 0, deflection_part = 0, qg = 0, qcg = 0, qq = 0
      real(dp) :: q_norm2 = 0
      !> |V(j, k)| (modes x terms) and the amplitude |Q_j| of each mode's particular part: the
      !> envelope of a_j over a flight (blow-up check).
      real(dp), allocatable :: vector_size(:, :), particular_size(:)
      !> Workspace: e^{lambda_k s} at an interval's ends, the integrals J(k, m) = int
      !> e^{lambda_k s} e^{i m Omega tau} dtau for m = -1, 0, 1, a channel's coefficients
      !> (multiplicity included) and their sizes, and |z_k|.
      complex(dp), allocatable :: e_a(:), e_b(:), j_int(:, :)
      complex(dp), allocatable :: coef(:)
      real(dp), allocatable :: coef_size(:), z_size(:)
      !> The integrals' cache: the interval length cached_h it holds (0: none), for the groups and
      !> the harmonics it was taken for; per exponent mu whether the integral takes the series, and
      !> then int_0^h e^{mu s} ds = h phi1(mu h) (int_*) and e^{mu h} (exp_*): the lock-in
      !> exponents lambda_k + i m Omega (terms x -H..H), the drive's i m Omega (1..H+1), the pairs
      !> lambda_k + lambda_l and lambda_k + conj(lambda_l).
      real(dp) :: cached_h = 0
      logical :: cached_lockin = .false., cached_energy = .false.
      integer :: cached_top = -1
      complex(dp), allocatable :: int_lockin(:, :), int_drive(:), int_pair(:, :), int_herm(:, :)
      complex(dp), allocatable :: exp_lockin(:, :), exp_drive(:), exp_pair(:, :), exp_herm(:, :)
      logical, allocatable :: series_lockin(:, :), series_drive(:), series_pair(:, :), series_herm(:, :)
      !> 1/(i Omega) and 1/(2 i Omega).
      complex(dp) :: inv_turn(2) = 0
      !> The largest |j| of the exponents i j Omega (the drive's, 1..H+1; a general drive's,
      !> -span..span: the harmonics m and each tone's h_k, and their sums and differences) and
      !> lambda_k + i j Omega the cache holds; e^{i j Omega_0 tau} at an interval's ends (general).
      integer :: span = 0
      complex(dp), allocatable :: turn_a(:), turn_b(:)
      !> The factors of a scan's interior point (0) and of an interval's left (1) and right (2) end.
      type(basis_t) :: ends(0:2)
      !> |z_k| of the flight whose coefficients are z_seen (taken once per flight, not per channel),
      !> |tip_of_vector_k| and |tip_part| (the sizes of V_T's terms but for |z_k|).
      complex(dp), allocatable :: z_seen(:)
      real(dp), allocatable :: z_abs(:), tip_vector_size(:)
      real(dp) :: tip_part_size = 0
      !> The channel being scanned: its particular part c_p, its constant c_0, sigma, the size of
      !> its particular part and its share of the bound on |f''''|.
      complex(dp) :: c_part = 0
      real(dp) :: c_const = 0, sigma = 1, part_size = 0, part_bound = 0
      !> A general drive (tmafm_drive): the particular parts are one harmonic per tone, tone k
      !> at h_k Omega_0 (omega is then Omega_0): V_T's tone_tip(k), the base's tone_base(k), the
      !> state's tone_state(:, k) (the complex amplitudes of e^{i h_k Omega_0 tau}), the drive force's
      !> tone_force(:, k); the sums of their velocity rows with V' (n_terms x tones) and with each
      !> other (tones x tones).  The one-tone forms above are then unused.
      logical :: general = .false.
      integer :: n_tones = 0
      integer :: tone_harmonic(max_tones) = 0
      real(dp) :: tone_frequency(max_tones) = 0
      complex(dp) :: tone_tip(max_tones) = 0, tone_base(max_tones) = 0, tone_phase(max_tones) = 0
      complex(dp), allocatable :: tone_state(:, :), tone_force(:, :)
      complex(dp), allocatable :: tone_drive_plus(:, :), tone_drive_minus(:, :), tone_part_plus(:, :), &
         tone_part_minus(:, :)
      complex(dp) :: tone_qg(max_tones, max_tones) = 0, tone_qcg(max_tones, max_tones) = 0, &
         tone_qq(max_tones, max_tones) = 0, tone_qcq(max_tones, max_tones) = 0
      !> A channel's particular part per tone (general drive).
      complex(dp) :: c_tone(max_tones) = 0
      !> Points evaluated by the scans since init (for measurements).
      integer :: scan_points = 0
      !> Stack of intervals of a scan.
      type(scan_interval_t) :: stack(stack_size)
   contains
      !> The closed forms of a model's free flight, decomposed by `flight` (once per run).
      procedure :: init => observables_init
      !> Add the integrals over [tau_a, tau_b] of the flight under way to the lock-in sums and
      !> the mean deflection (lockin) and to the drive and beam-damping powers (energy).
      procedure :: integrate => observables_integrate
      !> Raise a running maximum (sigma = 1) or lower a running minimum (sigma = -1) of a channel
      !> by its extremum over [tau_a, tau_b] of the flight under way.
      procedure :: extremum => observables_extremum
      !> A point of [0, s_max] of the flight where some |a_j| exceeds a limit, if there is one.
      procedure :: exceeds => observables_exceeds
   end type flight_observables_t

contains

   subroutine observables_init(self, model, flight, harmonics)
      class(flight_observables_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      type(free_flight_t), intent(in) :: flight
      !> Lock-in harmonics the integrals serve (at least 1).
      integer, intent(in) :: harmonics
      complex(dp), allocatable :: g(:), q(:), qw(:)
      ! |a'|^2 weighted by each mode's damping (a liquid), or not (alpha3 I: alpha3 outside).
      real(dp), allocatable :: weight(:)
      complex(dp) :: i_omega
      integer :: n, nt, k, l, m

      n = model%n_modes
      nt = flight%n_terms
      self%n_modes = n
      self%n_terms = nt
      self%harmonics = max(harmonics, 1)
      self%omega = model%scene%omega
      self%delta_hat = model%scene%delta_hat
      self%alpha2 = model%scene%alpha2
      self%alpha3 = model%scene%alpha3
      ! In a liquid C is diagonal, not alpha3 I: the sums of |a'|^2 carry C_jj, and beam = -sq.
      if (model%has_medium) self%alpha3 = 1
      self%scan_points = 0
      if (allocated(self%z_seen)) deallocate (self%z_seen, self%z_abs, self%tip_vector_size)
      allocate (self%z_seen(nt), self%z_abs(nt), self%tip_vector_size(nt))
      ! NaN: no flight's z equals it, so the first set_channel takes |z_k|.
      self%z_seen = cmplx(ieee_value(1.0_dp, ieee_quiet_nan), 0.0_dp, dp)
      self%z_abs = 0
      self%tip_vector_size = abs(flight%tip_of_vector)
      self%span = self%harmonics + 1
      if (flight%general) then
         associate (top_tone => maxval(model%drive%harmonic(1:model%drive%n_tones)))
            self%span = max(self%harmonics, top_tone) + top_tone
         end associate
      end if
      associate (j => self%span)
         if (allocated(self%int_lockin)) deallocate (self%int_lockin, self%int_drive, self%int_pair, self%int_herm, &
                                                     self%exp_lockin, self%exp_drive, self%exp_pair, self%exp_herm, &
                                                     self%series_lockin, self%series_drive, self%series_pair, &
                                                     self%series_herm, self%turn_a, self%turn_b)
         allocate (self%int_lockin(nt, -j:j), self%int_drive(-j:j), self%int_pair(nt, nt), self%int_herm(nt, nt), &
                   self%exp_lockin(nt, -j:j), self%exp_drive(-j:j), self%exp_pair(nt, nt), self%exp_herm(nt, nt), &
                   self%turn_a(-j:j), self%turn_b(-j:j), source=(0.0_dp, 0.0_dp))
         allocate (self%series_lockin(nt, -j:j), self%series_drive(-j:j), self%series_pair(nt, nt), &
                   self%series_herm(nt, nt), source=.false.)
      end associate
      self%cached_h = 0
      self%cached_top = -1
      do k = 0, 2
         if (allocated(self%ends(k)%decay)) deallocate (self%ends(k)%decay, self%ends(k)%turn)
         allocate (self%ends(k)%decay(nt), self%ends(k)%turn(nt))
         self%ends(k)%valid = .false.
      end do
      if (allocated(self%lambda)) deallocate (self%lambda, self%mult, self%decay_rate, self%rate4, self%mu, &
                                              self%inv_mu, self%mu_pair, self%inv_pair, self%mu_herm, &
                                              self%inv_herm, self%gram, self%herm, self%drive_plus, &
                                              self%drive_minus, self%part_plus, self%part_minus, &
                                              self%vector_size, self%particular_size, self%e_a, self%e_b, &
                                              self%j_int, self%coef, self%coef_size, self%z_size)
      allocate (self%lambda(nt), self%mult(nt), self%decay_rate(nt), self%rate4(nt), self%mu(nt, -1:1), &
                self%inv_mu(nt, -1:1), self%mu_pair(nt, nt), self%inv_pair(nt, nt), self%mu_herm(nt, nt), &
                self%inv_herm(nt, nt), self%gram(nt, nt), self%herm(nt, nt), self%drive_plus(nt), &
                self%drive_minus(nt), self%part_plus(nt), self%part_minus(nt), self%vector_size(n, nt), &
                self%particular_size(n), self%e_a(nt), self%e_b(nt), self%j_int(nt, -1:1), self%coef(nt), &
                self%coef_size(nt), self%z_size(nt))
      self%lambda = flight%eigenvalue
      self%mult = flight%multiplicity
      self%decay_rate = real(flight%eigenvalue, dp)
      self%rate4 = abs(flight%eigenvalue)**4
      i_omega = cmplx(0, self%omega, dp)
      self%inv_turn(1) = 1/i_omega
      self%inv_turn(2) = 1/(2*i_omega)
      do m = -1, 1
         self%mu(:, m) = self%lambda + m*i_omega
         self%inv_mu(:, m) = reciprocal(self%mu(:, m))
      end do
      ! The drive power a'.(d_s sin + d_c cos) (model_t%energy_flow) is a'.Re(g e^{i Omega tau}).
      allocate (g(n), q(n))
      associate (s => model%scene)
         if (model%has_medium) then
            g = cmplx(-s%alpha2*s%omega*model%modal_damping*model%integral, &
                      -s%alpha2*s%omega**2*(s%alpha1*model%mass_point + (1 + model%added_mass)*model%integral), dp)
         else
            g = cmplx(-s%alpha2*s%alpha3*s%omega*model%integral, &
                      -s%alpha2*s%omega**2*(s%alpha1*model%mass_point + model%integral), dp)
         end if
      end associate
      q = cmplx(flight%v(n + 1:2*n), -flight%u(n + 1:2*n), dp)
      if (model%has_medium) then
         weight = model%modal_damping
      else
         allocate (weight(n), source=1.0_dp)
      end if
      if (model%has_medium) then
         qw = weight*q
      else
         qw = q
      end if
      do k = 1, nt
         associate (vk => flight%vectors(n + 1:2*n, k))
            self%drive_plus(k) = sum(vk*g)
            self%drive_minus(k) = sum(vk*conjg(g))
            self%part_plus(k) = sum(vk*qw)
            self%part_minus(k) = sum(vk*conjg(qw))
            do l = 1, nt
               if (model%has_medium) then
                  self%gram(k, l) = sum(vk*weight*flight%vectors(n + 1:2*n, l))
                  self%herm(k, l) = sum(vk*weight*conjg(flight%vectors(n + 1:2*n, l)))
               else
                  self%gram(k, l) = sum(vk*flight%vectors(n + 1:2*n, l))
                  self%herm(k, l) = sum(vk*conjg(flight%vectors(n + 1:2*n, l)))
               end if
               self%mu_pair(k, l) = self%lambda(k) + self%lambda(l)
               self%mu_herm(k, l) = self%lambda(k) + conjg(self%lambda(l))
            end do
         end associate
         self%inv_pair(:, k) = reciprocal(self%mu_pair(:, k))
         self%inv_herm(:, k) = reciprocal(self%mu_herm(:, k))
         self%vector_size(:, k) = abs(flight%vectors(1:n, k))
      end do
      self%qg = sum(q*g)
      self%qcg = sum(q*conjg(g))
      if (model%has_medium) then
         self%qq = sum(q*qw)
         self%q_norm2 = sum(weight*(real(q, dp)**2 + aimag(q)**2))
      else
         self%qq = sum(q*q)
         self%q_norm2 = sum(real(q, dp)**2 + aimag(q)**2)
      end if
      self%tip_part = cmplx(flight%tip_cos, -flight%tip_sin, dp)
      self%tip_part_size = abs(self%tip_part)
      self%deflection_part = cmplx(flight%tip_cos, -(flight%tip_sin - self%alpha2), dp)
      self%particular_size = hypot(flight%u(1:n), flight%v(1:n))
      self%general = flight%general
      if (self%general) call init_general(self, model, flight)
   end subroutine observables_init

   !> The particular parts of a general drive, tone by tone: A sin(psi_k) + B cos(psi_k) with
   !> psi_k = h_k Omega_0 tau + phi_k is Re((B - i A) e^{i phi_k} e^{i h_k Omega_0 tau}).
   subroutine init_general(self, model, flight)
      type(flight_observables_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      type(free_flight_t), intent(in) :: flight
      integer :: n, nt, k, l, t, m
      complex(dp) :: rot
      real(dp) :: weight(self%n_modes)
      complex(dp) :: weighted(self%n_modes)
      n = self%n_modes
      nt = self%n_terms
      m = 2*n
      self%n_tones = model%drive%n_tones
      self%omega = model%drive%fundamental
      if (allocated(self%tone_state)) deallocate (self%tone_state, self%tone_force, self%tone_drive_plus, &
                                                  self%tone_drive_minus, self%tone_part_plus, self%tone_part_minus)
      allocate (self%tone_state(m, max_tones), self%tone_force(n, max_tones), self%tone_drive_plus(nt, max_tones), &
                self%tone_drive_minus(nt, max_tones), self%tone_part_plus(nt, max_tones), &
                self%tone_part_minus(nt, max_tones), source=(0.0_dp, 0.0_dp))
      self%particular_size = 0
      do t = 1, self%n_tones
         associate (s => model%scene, a => model%drive%amplitude(t), w => model%drive%frequency(t))
            rot = cmplx(cos(model%drive%phase(t)), sin(model%drive%phase(t)), dp)
            self%tone_harmonic(t) = model%drive%harmonic(t)
            self%tone_frequency(t) = w
            self%tone_phase(t) = rot
            self%tone_tip(t) = cmplx(flight%tone_tip_cos(t), -flight%tone_tip_sin(t), dp)*rot
            self%tone_base(t) = cmplx(0.0_dp, -a, dp)*rot
            self%tone_state(:, t) = cmplx(flight%tone_v(:, t), -flight%tone_u(:, t), dp)*rot
            if (model%has_medium) then
               self%tone_force(:, t) = cmplx(-a*w*model%damped_integral, -a*w**2*model%inertial_load, dp)*rot
            else
               self%tone_force(:, t) = cmplx(-a*s%alpha3*w*model%integral, &
                                             -a*w**2*(s%alpha1*model%mass_point + model%integral), dp)*rot
            end if
         end associate
         self%particular_size = self%particular_size + abs(self%tone_state(1:n, t))
      end do
      ! |a'|^2 in a liquid is a'.C a' (C_jj per mode, as observables_init's gram and herm): the
      ! tones' velocity parts carry C_jj there too; in air 1 (alpha3 outside, the same bits).
      weight = 1
      if (model%has_medium) weight = model%modal_damping
      do t = 1, self%n_tones
         weighted = weight*self%tone_state(n + 1:m, t)
         do k = 1, nt
            associate (vk => flight%vectors(n + 1:m, k))
               self%tone_drive_plus(k, t) = sum(vk*self%tone_force(:, t))
               self%tone_drive_minus(k, t) = sum(vk*conjg(self%tone_force(:, t)))
               self%tone_part_plus(k, t) = sum(vk*weighted)
               self%tone_part_minus(k, t) = sum(vk*conjg(weighted))
            end associate
         end do
         do l = 1, self%n_tones
            associate (ql => self%tone_state(n + 1:m, l))
               self%tone_qg(l, t) = sum(ql*self%tone_force(:, t))
               self%tone_qcg(l, t) = sum(ql*conjg(self%tone_force(:, t)))
               self%tone_qq(l, t) = sum(ql*weighted)
               self%tone_qcq(l, t) = sum(ql*conjg(weighted))
            end associate
         end do
      end do
   end subroutine init_general

   !> 1/x elementwise, 0 where x = 0 (an exponent that is exactly zero only ever takes the series).
   pure elemental function reciprocal(x) result(r)
      complex(dp), intent(in) :: x
      complex(dp) :: r
      if (x == (0.0_dp, 0.0_dp)) then
         r = 0
      else
         r = 1/x
      end if
   end function reciprocal

   !> phi1(x) = (e^x - 1)/x by its series, for |Re x| + |Im x| < series_below.
   pure complex(dp) function phi1(x)
      complex(dp), intent(in) :: x
      integer :: j
      ! phi1(x) = sum_j x^j/(j+1)! = 1 + x/2 (1 + x/3 (1 + x/4 (...))).
      phi1 = 1
      do j = series_terms + 1, 2, -1
         phi1 = 1 + x*phi1*(1.0_dp/j)
      end do
   end function phi1

   !> Term k's share of the integral of |a'|^2's modal part: its products with terms l >= k
   !> (l = k once, l > k counted twice), from the ends' factors e_a, e_b and the cache (d).
   pure complex(dp) function modal_pairs(self, flight, k, d) result(x)
      type(flight_observables_t), intent(in) :: self
      type(free_flight_t), intent(in) :: flight
      integer, intent(in) :: k
      real(dp), intent(in) :: d
      complex(dp) :: l_int, m_int, zk
      integer :: l
      x = 0
      zk = flight%z(k)
      do l = k, self%n_terms
         l_int = cached_segment(self%e_a(k), self%e_a(l), self%e_b(k), self%e_b(l), self%mu_pair(k, l), d, &
                                self%int_pair(k, l), self%exp_pair(k, l), self%series_pair(k, l), &
                                self%inv_pair(k, l))
         m_int = cached_segment(self%e_a(k), conjg(self%e_a(l)), self%e_b(k), conjg(self%e_b(l)), &
                                self%mu_herm(k, l), d, self%int_herm(k, l), self%exp_herm(k, l), &
                                self%series_herm(k, l), self%inv_herm(k, l))
         x = x + (merge(0.5_dp, 1.0_dp, l == k)*self%mult(k)*self%mult(l)) &
             *(zk*flight%z(l)*self%gram(k, l)*l_int + zk*conjg(flight%z(l))*self%herm(k, l)*m_int)
      end do
   end function modal_pairs

   !> The cache for a piece of length h: kept if the last piece was as long (to reuse_within)
   !> with the same groups, then d = h - its length; else filled for h, and d = 0.
   pure subroutine cache_for(self, h, lockin, energy, top, d)
      type(flight_observables_t), intent(inout) :: self
      real(dp), intent(in) :: h
      logical, intent(in) :: lockin, energy
      integer, intent(in) :: top
      real(dp), intent(out) :: d
      d = h - self%cached_h
      if (.not. (abs(d) <= reuse_within*h .and. (lockin .eqv. self%cached_lockin) .and. &
                 (energy .eqv. self%cached_energy) .and. top == self%cached_top)) then
         call fill_cache(self, h, lockin, energy, top)
         d = 0
      end if
   end subroutine cache_for

   !> Fill the integrals' cache for the interval length h: per exponent mu whether the integral
   !> takes the series for mu h, and where it does h phi1(mu h) and e^{mu h} = 1 + mu h phi1(mu h)
   !> (the exponents as observables_integrate forms them).
   pure subroutine fill_cache(self, h, lockin, energy, top)
      type(flight_observables_t), intent(inout) :: self
      real(dp), intent(in) :: h
      logical, intent(in) :: lockin, energy
      integer, intent(in) :: top
      complex(dp) :: i_omega
      integer :: k, l, m
      self%cached_h = h
      self%cached_lockin = lockin
      self%cached_energy = energy
      self%cached_top = top
      i_omega = cmplx(0, self%omega, dp)
      if (self%general) then
         ! The exponents as integrate_general's k_int and j_of form them, every j of the span.
         do m = -self%span, self%span
            call take(cmplx(0.0_dp, m*self%omega, dp), self%int_drive(m), self%exp_drive(m), self%series_drive(m))
            do k = 1, self%n_terms
               call take(self%lambda(k) + cmplx(0.0_dp, m*self%omega, dp), self%int_lockin(k, m), &
                         self%exp_lockin(k, m), self%series_lockin(k, m))
            end do
         end do
      else
         do m = 1, max(top + 1, 2)
            call take(m*i_omega, self%int_drive(m), self%exp_drive(m), self%series_drive(m))
         end do
         do k = 1, self%n_terms
            do m = -1, 1
               call take(self%mu(k, m), self%int_lockin(k, m), self%exp_lockin(k, m), self%series_lockin(k, m))
            end do
            do m = 2, top
               call take(self%lambda(k) + m*i_omega, self%int_lockin(k, m), self%exp_lockin(k, m), &
                         self%series_lockin(k, m))
               call take(self%lambda(k) - m*i_omega, self%int_lockin(k, -m), self%exp_lockin(k, -m), &
                         self%series_lockin(k, -m))
            end do
         end do
      end if
      if (.not. energy) return
      do k = 1, self%n_terms
         do l = k, self%n_terms
            call take(self%mu_pair(k, l), self%int_pair(k, l), self%exp_pair(k, l), self%series_pair(k, l))
            call take(self%mu_herm(k, l), self%int_herm(k, l), self%exp_herm(k, l), self%series_herm(k, l))
         end do
      end do
   contains
      pure subroutine take(mu, unit_integral, growth, series)
         complex(dp), intent(in) :: mu
         complex(dp), intent(out) :: unit_integral, growth
         logical, intent(out) :: series
         complex(dp) :: x, p
         x = mu*h
         series = .not. (abs(real(x, dp)) + abs(aimag(x)) >= series_below)
         unit_integral = 0
         growth = 0
         if (.not. series) return
         p = phi1(x)
         unit_integral = h*p
         growth = 1 + x*p
      end subroutine take
   end subroutine fill_cache

   !> int over an interval hc + d of e^{mu s} from its values fa, fb at the ends, by the
   !> integrals' cache of the length hc (fill_cache): (fb - fa)/mu (times inv_mu = 1/mu when
   !> given) where |Re mu hc| + |Im mu hc| >= 1/2, else fa int_0^hc e^{mu s} ds (d = 0) or, to
   !> first order in d, fa (int_0^hc e^{mu s} ds + d e^{mu hc}): the rest, d^2 |mu|
   !> e^{|Re mu h|}/2, is below 2^-55 of |fa| hc for |d| <= reuse_within hc and |mu hc| < 1/2.
   pure complex(dp) function cached_segment(ea, pa, eb, pb, mu, d, unit_integral, growth, series, inv_mu)
      !> fa = ea pa and fb = eb pb (fb only for the difference form).
      complex(dp), intent(in) :: ea, pa, eb, pb
      complex(dp), intent(in) :: mu
      real(dp), intent(in) :: d
      complex(dp), intent(in) :: unit_integral, growth
      logical, intent(in) :: series
      complex(dp), intent(in), optional :: inv_mu
      if (.not. series) then
         if (present(inv_mu)) then
            cached_segment = (eb*pb - ea*pa)*inv_mu
         else
            cached_segment = (eb*pb - ea*pa)/mu
         end if
      else if (d == 0) then
         cached_segment = (ea*pa)*unit_integral
      else
         cached_segment = (ea*pa)*(unit_integral + d*growth)
      end if
   end function cached_segment

   subroutine observables_integrate(self, flight, tau_a, tau_b, lockin, energy, acc_sin, acc_cos, deflection, &
                                    drive, beam, tone_sin, tone_cos)
      class(flight_observables_t), intent(inout) :: self
      type(free_flight_t), intent(in) :: flight
      real(dp), intent(in) :: tau_a, tau_b
      logical, intent(in) :: lockin, energy
      !> int V_T sin(m Omega tau) and cos(m Omega tau), m = 1..size (at most H), and int p.a.
      real(dp), intent(inout) :: acc_sin(:), acc_cos(:), deflection
      !> int of the drive power and of the beam-damping power.
      real(dp), intent(inout) :: drive, beam
      !> A general drive: int V_T sin(psi_k) and cos(psi_k) per tone (and p.a less nothing: the
      !> deflection is p.a as above).
      real(dp), intent(inout), optional :: tone_sin(:), tone_cos(:)
      real(dp) :: h, sa, sb, sq, d
      complex(dp) :: x, zk, pa1, pb1, pa, pb, pa_next, pb_next, k_prev, k_now, k_next, k1, k2
      complex(dp) :: i_omega, jp, jm
      complex(dp), parameter :: one = (1.0_dp, 0.0_dp)
      integer :: k, m, top, nt

      if (.not. (lockin .or. energy)) return
      if (self%general) then
         call integrate_general(self, flight, tau_a, tau_b, lockin, energy, acc_sin, acc_cos, deflection, &
                                drive, beam, tone_sin, tone_cos)
         return
      end if
      nt = self%n_terms
      h = tau_b - tau_a
      sa = tau_a - flight%tau0
      sb = tau_b - flight%tau0
      top = 0
      if (lockin) top = min(self%harmonics, size(acc_sin))
      ! A piece as long as the last one (the noise grid's pieces, to their ends' rounding) takes
      ! its phi1(mu h) from the cache (cached_segment); any other fills the cache (hc = h, d = 0).
      call cache_for(self, h, lockin, energy, top, d)
      i_omega = cmplx(0, self%omega, dp)
      ! e^{lambda_k s} and e^{i m Omega tau} at the ends (the scans of the piece take the same
      ! factors): m = 1, 2 here, the next ones by the same products.
      call take_end(self, flight, sa, 1)
      call take_end(self, flight, sb, 2)
      pa1 = self%ends(1)%drive
      pb1 = self%ends(2)%drive
      pa_next = pa1*pa1
      pb_next = pb1*pb1
      k1 = cached_segment(one, pa1, one, pb1, i_omega, d, self%int_drive(1), self%exp_drive(1), self%series_drive(1), &
                          self%inv_turn(1))
      k2 = cached_segment(one, pa_next, one, pb_next, 2*i_omega, d, self%int_drive(2), self%exp_drive(2), &
                          self%series_drive(2), self%inv_turn(2))
      do k = 1, nt
         self%e_a(k) = self%ends(1)%decay(k)*self%ends(1)%turn(k)
         self%e_b(k) = self%ends(2)%decay(k)*self%ends(2)%turn(k)
         self%j_int(k, 1) = cached_segment(self%e_a(k), pa1, self%e_b(k), pb1, self%mu(k, 1), d, &
                                           self%int_lockin(k, 1), self%exp_lockin(k, 1), self%series_lockin(k, 1), &
                                           self%inv_mu(k, 1))
         self%j_int(k, -1) = cached_segment(self%e_a(k), conjg(pa1), self%e_b(k), conjg(pb1), self%mu(k, -1), d, &
                                            self%int_lockin(k, -1), self%exp_lockin(k, -1), self%series_lockin(k, -1), &
                                            self%inv_mu(k, -1))
         if (lockin) self%j_int(k, 0) = cached_segment(self%e_a(k), one, self%e_b(k), one, self%mu(k, 0), d, &
                                                       self%int_lockin(k, 0), self%exp_lockin(k, 0), &
                                                       self%series_lockin(k, 0), self%inv_mu(k, 0))
      end do

      if (lockin) then
         ! V_T = Re(t e^{i Omega tau}) + delta_hat + sum_k mult_k Re(w_k e^{lambda_k s}); each
         ! Re(w e^{lambda s}) e^{i m Omega tau} integrates to (w J(k, m) + conj(w J(k, -m)))/2,
         ! and Re(t e^{i Omega tau}) e^{i m Omega tau} to (t K(m+1) + conj(t) K(m-1))/2.
         k_prev = h
         k_now = k1
         k_next = k2
         pa = pa1
         pb = pb1
         do m = 1, top
            if (m > 1) then
               k_prev = k_now
               k_now = k_next
               pa = pa_next
               pb = pb_next
               pa_next = pa*pa1
               pb_next = pb*pb1
               k_next = cached_segment(one, pa_next, one, pb_next, (m + 1)*i_omega, d, self%int_drive(m + 1), &
                                       self%exp_drive(m + 1), self%series_drive(m + 1))
            end if
            x = 0.5_dp*(self%tip_part*k_next + conjg(self%tip_part)*k_prev) + (self%delta_hat + flight%held_tip)*k_now
            do k = 1, nt
               if (m == 1) then
                  jp = self%j_int(k, 1)
                  jm = self%j_int(k, -1)
               else
                  jp = cached_segment(self%e_a(k), pa, self%e_b(k), pb, self%lambda(k) + m*i_omega, d, &
                                      self%int_lockin(k, m), self%exp_lockin(k, m), self%series_lockin(k, m))
                  jm = cached_segment(self%e_a(k), conjg(pa), self%e_b(k), conjg(pb), self%lambda(k) - m*i_omega, d, &
                                      self%int_lockin(k, -m), self%exp_lockin(k, -m), self%series_lockin(k, -m))
               end if
               x = x + (0.5_dp*self%mult(k))*(flight%tip_weight(k)*jp + conjg(flight%tip_weight(k)*jm))
            end do
            acc_cos(m) = acc_cos(m) + real(x, dp)
            acc_sin(m) = acc_sin(m) + aimag(x)
         end do
         x = self%deflection_part*k1 + flight%held_tip*h
         do k = 1, nt
            x = x + self%mult(k)*flight%tip_weight(k)*self%j_int(k, 0)
         end do
         deflection = deflection + real(x, dp)
      end if

      if (energy) then
         ! a' = Re(Q' e^{i Omega tau}) + sum_k mult_k Re(z_k V'_k e^{lambda_k s}), and
         ! Re(A).Re(B) = Re(A.B + A.conj(B))/2 for complex vectors A, B.
         x = 0.5_dp*(self%qg*k2 + self%qcg*h)
         do k = 1, nt
            x = x + (0.5_dp*self%mult(k))*flight%z(k)*(self%drive_plus(k)*self%j_int(k, 1) &
                                                        + self%drive_minus(k)*self%j_int(k, -1))
         end do
         drive = drive + real(x, dp)
         ! |a'|^2: the particular part squared, twice its products with the modal terms, and
         ! the products of the modal terms in pairs (k, l), each pair once (k < l counted twice).
         sq = 0.5_dp*(real(self%qq*k2, dp) + self%q_norm2*h)
         x = 0
         do k = 1, nt
            zk = flight%z(k)
            x = x + self%mult(k)*zk*(self%part_plus(k)*self%j_int(k, 1) + self%part_minus(k)*self%j_int(k, -1))
            x = x + modal_pairs(self, flight, k, d)
         end do
         sq = sq + real(x, dp)
         beam = beam - self%alpha3*sq
      end if

   end subroutine observables_integrate

   !> observables_integrate for a general drive: the particular parts are one harmonic per tone
   !> (h_k Omega_0), so every integrand is still a short sum of e^{mu s}, with mu = lambda_k + i j
   !> Omega_0 for the integer j the products give (K(j) = int e^{i j Omega_0 tau} dtau, J(k, j) =
   !> int e^{lambda_k s} e^{i j Omega_0 tau} dtau; cached_segment).
   subroutine integrate_general(self, flight, tau_a, tau_b, lockin, energy, acc_sin, acc_cos, deflection, &
                                drive, beam, tone_sin, tone_cos)
      type(flight_observables_t), intent(inout) :: self
      type(free_flight_t), intent(in) :: flight
      real(dp), intent(in) :: tau_a, tau_b
      logical, intent(in) :: lockin, energy
      real(dp), intent(inout) :: acc_sin(:), acc_cos(:), deflection, drive, beam
      real(dp), intent(inout), optional :: tone_sin(:), tone_cos(:)
      real(dp) :: h, sa, sb, sq, d
      complex(dp) :: x, w, zk, base_a, base_b
      complex(dp), parameter :: one = (1.0_dp, 0.0_dp)
      integer :: k, m, t, u, nt, top

      nt = self%n_terms
      h = tau_b - tau_a
      sa = tau_a - flight%tau0
      sb = tau_b - flight%tau0
      top = 0
      if (lockin) top = min(size(acc_sin), self%harmonics)
      ! As observables_integrate: a piece as long as the last one takes the cache.
      call cache_for(self, h, lockin, energy, top, d)
      call take_end(self, flight, sa, 1)
      call take_end(self, flight, sb, 2)
      do k = 1, nt
         self%e_a(k) = self%ends(1)%decay(k)*self%ends(1)%turn(k)
         self%e_b(k) = self%ends(2)%decay(k)*self%ends(2)%turn(k)
      end do
      ! e^{i j Omega_0 tau} at the ends for every j of the span, by products of j = 1.
      base_a = cmplx(cos(self%omega*tau_a), sin(self%omega*tau_a), dp)
      base_b = cmplx(cos(self%omega*tau_b), sin(self%omega*tau_b), dp)
      self%turn_a(0) = one
      self%turn_b(0) = one
      do m = 1, self%span
         self%turn_a(m) = self%turn_a(m - 1)*base_a
         self%turn_b(m) = self%turn_b(m - 1)*base_b
         self%turn_a(-m) = conjg(self%turn_a(m))
         self%turn_b(-m) = conjg(self%turn_b(m))
      end do
      if (lockin) then
         do m = 1, top
            x = lockin_sum(m)
            acc_cos(m) = acc_cos(m) + real(x, dp)
            acc_sin(m) = acc_sin(m) + aimag(x)
         end do
         if (present(tone_sin) .and. present(tone_cos)) then
            do t = 1, self%n_tones
               ! int V_T e^{i psi_t} = e^{i phi_t} int V_T e^{i h_t Omega_0 tau}.
               x = self%tone_phase(t)*lockin_sum(self%tone_harmonic(t))
               tone_cos(t) = tone_cos(t) + real(x, dp)
               tone_sin(t) = tone_sin(t) + aimag(x)
            end do
         end if
         ! int p.a = int (V_T - Y - delta_hat).
         x = flight%held_tip*h
         do t = 1, self%n_tones
            x = x + (self%tone_tip(t) - self%tone_base(t))*k_int(self%tone_harmonic(t))
         end do
         do k = 1, nt
            x = x + self%mult(k)*flight%tip_weight(k)*j_of(k, 0)
         end do
         deflection = deflection + real(x, dp)
      end if
      if (energy) then
         ! a' = sum_t Re(Q'_t e^{i h_t Omega_0 tau}) + sum_k mult_k Re(z_k V'_k e^{lambda_k s}),
         ! F = sum_t Re(g_t e^{i h_t Omega_0 tau}); Re(A).Re(B) = Re(A.B + A.conj(B))/2.
         x = 0
         sq = 0
         do t = 1, self%n_tones
            do u = 1, self%n_tones
               x = x + 0.5_dp*(self%tone_qg(t, u)*k_int(self%tone_harmonic(t) + self%tone_harmonic(u)) &
                               + self%tone_qcg(t, u)*k_int(self%tone_harmonic(t) - self%tone_harmonic(u)))
               sq = sq + 0.5_dp*real(self%tone_qq(t, u)*k_int(self%tone_harmonic(t) + self%tone_harmonic(u)) &
                                     + self%tone_qcq(t, u)*k_int(self%tone_harmonic(t) - self%tone_harmonic(u)), dp)
            end do
            do k = 1, nt
               x = x + (0.5_dp*self%mult(k))*flight%z(k)*(self%tone_drive_plus(k, t)*j_of(k, self%tone_harmonic(t)) &
                                                          + self%tone_drive_minus(k, t)*j_of(k, -self%tone_harmonic(t)))
            end do
         end do
         drive = drive + real(x, dp)
         x = 0
         do k = 1, nt
            zk = flight%z(k)
            do t = 1, self%n_tones
               x = x + self%mult(k)*zk*(self%tone_part_plus(k, t)*j_of(k, self%tone_harmonic(t)) &
                                        + self%tone_part_minus(k, t)*j_of(k, -self%tone_harmonic(t)))
            end do
            x = x + modal_pairs(self, flight, k, d)
         end do
         sq = sq + real(x, dp)
         beam = beam - self%alpha3*sq
      end if

   contains

      !> K(j) = int_a^b e^{i j Omega_0 tau} dtau (|j| <= span).
      complex(dp) function k_int(j)
         integer, intent(in) :: j
         k_int = cached_segment(one, self%turn_a(j), one, self%turn_b(j), cmplx(0.0_dp, j*self%omega, dp), d, &
                                self%int_drive(j), self%exp_drive(j), self%series_drive(j))
      end function k_int

      !> J(k, j) = int_a^b e^{lambda_k s} e^{i j Omega_0 tau} dtau (|j| <= span).
      complex(dp) function j_of(k, j)
         integer, intent(in) :: k, j
         j_of = cached_segment(self%e_a(k), self%turn_a(j), self%e_b(k), self%turn_b(j), &
                               self%lambda(k) + cmplx(0.0_dp, j*self%omega, dp), d, self%int_lockin(k, j), &
                               self%exp_lockin(k, j), self%series_lockin(k, j))
      end function j_of

      !> int V_T e^{i m Omega_0 tau} dtau: Re(c e^{i h Omega_0 tau}) e^{i m ..} integrates to
      !> (c K(m + h) + conj(c) K(m - h))/2, Re(w e^{lambda s}) e^{i m ..} to (w J(k, m) + conj(w J(k, -m)))/2.
      complex(dp) function lockin_sum(m)
         integer, intent(in) :: m
         integer :: tt, kk
         lockin_sum = (self%delta_hat + flight%held_tip)*k_int(m)
         do tt = 1, self%n_tones
            lockin_sum = lockin_sum + 0.5_dp*(self%tone_tip(tt)*k_int(m + self%tone_harmonic(tt)) &
                                              + conjg(self%tone_tip(tt))*k_int(m - self%tone_harmonic(tt)))
         end do
         do kk = 1, nt
            w = flight%tip_weight(kk)
            lockin_sum = lockin_sum + (0.5_dp*self%mult(kk))*(w*j_of(kk, m) + conjg(w*j_of(kk, -m)))
         end do
      end function lockin_sum
   end subroutine integrate_general

   !> Set the channel (mode j > 0, or V_T) of the flight under way, for sigma f.
   subroutine set_channel(self, flight, channel, sigma)
      class(flight_observables_t), intent(inout) :: self
      type(free_flight_t), intent(in) :: flight
      integer, intent(in) :: channel
      real(dp), intent(in) :: sigma
      integer :: k, n
      real(dp) :: c_part_size
      n = self%n_modes
      self%sigma = sigma
      call take_z_sizes(self, flight)
      ! |coef_k| as mult_k |z_k| |V(j, k)|: the product's size to a few ulps, which the scan's
      ! bound allows for (its factor 1 + 16 eps), without a hypot per term and channel.
      if (channel == channel_gap) then
         self%coef = self%mult*flight%tip_weight
         self%c_part = self%tip_part
         self%c_const = self%delta_hat + flight%held_tip
         c_part_size = self%tip_part_size
         do k = 1, self%n_terms
            self%coef_size(k) = self%mult(k)*self%z_abs(k)*self%tip_vector_size(k)
         end do
      else
         self%coef = self%mult*flight%z*flight%vectors(channel, :)
         self%c_part = cmplx(flight%v(channel), -flight%u(channel), dp)
         self%c_const = flight%held_state(channel)
         c_part_size = self%particular_size(channel)
         do k = 1, self%n_terms
            self%coef_size(k) = self%mult(k)*self%z_abs(k)*self%vector_size(channel, k)
         end do
      end if
      self%part_size = c_part_size + abs(self%c_const)
      self%part_bound = self%omega**4*c_part_size
      if (self%general) then
         self%part_size = abs(self%c_const)
         self%part_bound = 0
         do k = 1, self%n_tones
            if (channel == channel_gap) then
               self%c_tone(k) = self%tone_tip(k)
            else
               self%c_tone(k) = self%tone_state(channel, k)
            end if
            self%part_size = self%part_size + abs(self%c_tone(k))
            self%part_bound = self%part_bound + self%tone_frequency(k)**4*abs(self%c_tone(k))
         end do
      end if
   end subroutine set_channel

   !> |z_k| of the flight under way, taken again only when its coefficients z changed.
   subroutine take_z_sizes(self, flight)
      type(flight_observables_t), intent(inout) :: self
      type(free_flight_t), intent(in) :: flight
      integer :: k
      do k = 1, self%n_terms
         if (.not. (flight%z(k) == self%z_seen(k))) exit
      end do
      if (k > self%n_terms) return
      do k = 1, self%n_terms
         self%z_seen(k) = flight%z(k)
         self%z_abs(k) = abs(flight%z(k))
      end do
   end subroutine take_z_sizes

   !> The factors of the point s of the flight under way (basis_t), keyed by tau0 and s.
   pure subroutine fill_basis(self, flight, s, basis)
      type(flight_observables_t), intent(in) :: self
      type(free_flight_t), intent(in) :: flight
      real(dp), intent(in) :: s
      type(basis_t), intent(inout) :: basis
      real(dp) :: phase, angle
      integer :: k
      basis%valid = .true.
      basis%tau0 = flight%tau0
      basis%s = s
      if (self%general) then
         do k = 1, self%n_tones
            phase = self%tone_harmonic(k)*self%omega*(flight%tau0 + s)
            basis%tone(k) = cmplx(cos(phase), sin(phase), dp)
         end do
      else
         phase = self%omega*(flight%tau0 + s)
         basis%drive = cmplx(cos(phase), sin(phase), dp)
      end if
      do k = 1, self%n_terms
         basis%decay(k) = exp(self%decay_rate(k)*s)
         angle = aimag(self%lambda(k))*s
         basis%turn(k) = cmplx(cos(angle), sin(angle), dp)
      end do
   end subroutine fill_basis

   !> The end `slot` (1 left, 2 right) of an interval at s: its factors, taken again only if
   !> they are not those of (tau0, s) already.
   subroutine take_end(self, flight, s, slot)
      type(flight_observables_t), intent(inout) :: self
      type(free_flight_t), intent(in) :: flight
      real(dp), intent(in) :: s
      integer, intent(in) :: slot
      logical :: held
      held = self%ends(slot)%valid
      if (held) held = self%ends(slot)%tau0 == flight%tau0 .and. self%ends(slot)%s == s
      if (.not. held) call fill_basis(self, flight, s, self%ends(slot))
   end subroutine take_end

   !> The channel at s (time since the flight's start): sigma f, f', f'' (and f''' if asked),
   !> its size and the two parts of the bound on |f''''|.
   subroutine evaluate(self, flight, s, point, third)
      class(flight_observables_t), intent(inout) :: self
      type(free_flight_t), intent(in) :: flight
      real(dp), intent(in) :: s
      type(scan_point_t), intent(out) :: point
      real(dp), intent(out), optional :: third
      call fill_basis(self, flight, s, self%ends(0))
      call combine(self, self%ends(0), point, third)
   end subroutine evaluate

   !> evaluate at an interval's end (slot 1 left, 2 right), from its kept factors.
   subroutine evaluate_end(self, flight, s, slot, point)
      class(flight_observables_t), intent(inout) :: self
      type(free_flight_t), intent(in) :: flight
      real(dp), intent(in) :: s
      integer, intent(in) :: slot
      type(scan_point_t), intent(out) :: point
      call take_end(self, flight, s, slot)
      call combine(self, self%ends(slot), point)
   end subroutine evaluate_end

   !> The channel at the point whose factors are basis (evaluate).
   subroutine combine(self, basis, point, third)
      class(flight_observables_t), intent(inout) :: self
      type(basis_t), intent(in) :: basis
      type(scan_point_t), intent(out) :: point
      real(dp), intent(out), optional :: third
      complex(dp) :: x, e, le, l2e
      real(dp) :: decay, f, d1, d2, d3
      integer :: k
      logical :: with_third
      with_third = present(third)
      if (self%general) then
         f = self%c_const
         d1 = 0
         d2 = 0
         d3 = 0
         do k = 1, self%n_tones
            associate (w => self%tone_frequency(k))
               x = self%c_tone(k)*basis%tone(k)
               f = f + real(x, dp)
               d1 = d1 - w*aimag(x)
               d2 = d2 - w**2*real(x, dp)
               d3 = d3 + w**3*aimag(x)
            end associate
         end do
      else
         x = self%c_part*basis%drive
         f = real(x, dp) + self%c_const
         d1 = -self%omega*aimag(x)
         d2 = -self%omega**2*real(x, dp)
         d3 = self%omega**3*aimag(x)
      end if
      point%s = basis%s
      point%size = self%part_size
      point%decaying = self%part_bound
      point%growing = 0
      do k = 1, self%n_terms
         decay = basis%decay(k)
         e = self%coef(k)*(decay*basis%turn(k))
         le = self%lambda(k)*e
         l2e = self%lambda(k)*le
         f = f + real(e, dp)
         d1 = d1 + real(le, dp)
         d2 = d2 + real(l2e, dp)
         if (with_third) d3 = d3 + real(self%lambda(k)*l2e, dp)
         point%size = point%size + self%coef_size(k)*decay
         if (self%decay_rate(k) <= 0) then
            point%decaying = point%decaying + self%coef_size(k)*self%rate4(k)*decay
         else
            point%growing = point%growing + self%coef_size(k)*self%rate4(k)*decay
         end if
      end do
      point%f = self%sigma*f
      point%d1 = self%sigma*d1
      point%d2 = self%sigma*d2
      if (present(third)) third = abs(d3)
      self%scan_points = self%scan_points + 1
   end subroutine combine

   subroutine observables_extremum(self, flight, channel, sigma, tau_a, tau_b, extreme)
      class(flight_observables_t), intent(inout) :: self
      type(free_flight_t), intent(in) :: flight
      !> channel_gap (V_T) or a mode j.
      integer, intent(in) :: channel
      !> 1: raise a running maximum; -1: lower a running minimum.
      real(dp), intent(in) :: sigma
      real(dp), intent(in) :: tau_a, tau_b
      real(dp), intent(inout) :: extreme
      real(dp) :: best, s_best
      call set_channel(self, flight, channel, sigma)
      best = sigma*extreme
      call scan(self, flight, tau_a - flight%tau0, tau_b - flight%tau0, best, s_best)
      extreme = sigma*best
   end subroutine observables_extremum

   subroutine observables_exceeds(self, flight, s_max, limit, found, s_found, mode, value)
      class(flight_observables_t), intent(inout) :: self
      type(free_flight_t), intent(in) :: flight
      real(dp), intent(in) :: s_max
      !> The limit on |a_j| (&solver blowup_limit).
      real(dp), intent(in) :: limit
      !> .true. if some |a_j| > limit was found: at s_found, a_mode = value there.
      logical, intent(out) :: found
      real(dp), intent(out) :: s_found
      integer, intent(out) :: mode
      real(dp), intent(out) :: value
      real(dp) :: envelope, best, sigma
      integer :: j, k, side
      found = .false.
      s_found = 0
      mode = 0
      value = 0
      call take_z_sizes(self, flight)
      do k = 1, self%n_terms
         self%z_size(k) = self%mult(k)*self%z_abs(k)
         ! A growing term (alpha3 < 0 only) is largest at the flight's end.
         if (self%decay_rate(k) > 0) self%z_size(k) = self%z_size(k)*exp(self%decay_rate(k)*s_max)
      end do
      do j = 1, self%n_modes
         ! |a_j| <= |Q_j| + sum_k mult_k |V_jk| |z_k| |e^{lambda_k s}|: most flights stop here.
         envelope = self%particular_size(j) + abs(flight%held_state(j))
         do k = 1, self%n_terms
            envelope = envelope + self%vector_size(j, k)*self%z_size(k)
         end do
         if (envelope <= limit) cycle
         sigma = 1
         do side = 1, 2
            call set_channel(self, flight, j, sigma)
            best = limit
            call scan(self, flight, 0.0_dp, s_max, best, s_found)
            if (best > limit) then
               found = .true.
               mode = j
               value = sigma*best
               return
            end if
            sigma = -1
         end do
      end do
   end subroutine observables_exceeds

   !> The scan of sigma f over [s_lo, s_hi] (see the module's doc): best is raised to the
   !> largest value found, s_best is where (unchanged if best was not raised).
   subroutine scan(self, flight, s_lo, s_hi, best, s_best)
      class(flight_observables_t), intent(inout) :: self
      type(free_flight_t), intent(in) :: flight
      real(dp), intent(in) :: s_lo, s_hi
      real(dp), intent(inout) :: best, s_best
      type(scan_point_t) :: a_point, b_point, last, left, right, middle, peak
      type(bracketed_root_t) :: root
      real(dp) :: h, bound, radius, third, x, width
      integer :: top, depth, first_points
      ! The interval on top of the stack was tested already (and not cleared).
      logical :: tested

      first_points = self%scan_points
      call evaluate_end(self, flight, s_lo, 1, a_point)
      call raise(a_point)
      if (.not. (s_hi > s_lo)) return
      call evaluate_end(self, flight, s_hi, 2, last)
      call raise(last)
      do while (a_point%s < s_hi)
         h = step(a_point)
         if (a_point%s + 1.25_dp*h >= s_hi) then
            b_point = last
         else
            call evaluate(self, flight, a_point%s + h, b_point)
            call raise(b_point)
         end if
         ! The stack's first test, without the stack (a short piece's interval is mostly cleared).
         width = b_point%s - a_point%s
         if (.not. (width > 0)) then
            a_point = b_point
            cycle
         end if
         bound = (a_point%decaying + b_point%growing)*(1 + 16*epsilon(1.0_dp))
         if (cleared(a_point, b_point, width, bound, best + tolerance(a_point, b_point))) then
            a_point = b_point
            cycle
         end if
         ! Classify [a_point, b_point] (not cleared), and the parts it splits into, until none is left.
         top = 1
         self%stack(1) = scan_interval_t(a_point, b_point, 0)
         tested = .true.
         do while (top > 0)
            left = self%stack(top)%left
            right = self%stack(top)%right
            depth = self%stack(top)%depth
            top = top - 1
            width = right%s - left%s
            if (.not. (width > 0)) cycle
            bound = (left%decaying + right%growing)*(1 + 16*epsilon(1.0_dp))
            if (tested) then
               tested = .false.
            else if (cleared(left, right, width, bound, best + tolerance(left, right))) then
               cycle
            end if
            if (depth >= max_depth .or. top + 2 > stack_size .or. &
                self%scan_points - first_points > max_scan_points .or. &
                width <= 4*epsilon(1.0_dp)*(abs(flight%tau0) + abs(right%s))) then
               ! Nothing left to halve: take f at the interval's middle too.
               call evaluate(self, flight, left%s + width/2, middle)
               call raise(middle)
               cycle
            end if
            if (left%d1 > 0 .and. right%d1 < 0) then
               ! f' falls through zero: Brent on f', then Taylor's bound clears a neighbourhood
               ! of the maximum found; the rest of the interval goes back on the stack.
               call root%start(left%s, left%d1, right%s, right%d1, &
                               4*epsilon(1.0_dp)*(abs(flight%tau0) + abs(right%s)))
               do while (.not. root%converged())
                  call root%next_point(x)
                  call evaluate(self, flight, x, middle)
                  call raise(middle)
                  call root%update(middle%d1)
               end do
               call evaluate(self, flight, root%b, peak, third)
               call raise(peak)
               radius = taylor_radius(peak, third, bound, best + tolerance(peak, peak))
               if (radius > 0) then
                  if (peak%s + radius < right%s) then
                     call evaluate(self, flight, peak%s + radius, middle)
                     call raise(middle)
                     top = top + 1
                     self%stack(top) = scan_interval_t(middle, right, depth + 1)
                  end if
                  if (peak%s - radius > left%s) then
                     call evaluate(self, flight, peak%s - radius, middle)
                     call raise(middle)
                     top = top + 1
                     self%stack(top) = scan_interval_t(left, middle, depth + 1)
                  end if
                  cycle
               end if
            end if
            ! Halve: the right half first on the stack, so the left one is classified first.
            call evaluate(self, flight, left%s + width/2, middle)
            call raise(middle)
            top = top + 1
            self%stack(top) = scan_interval_t(middle, right, depth + 1)
            top = top + 1
            self%stack(top) = scan_interval_t(left, middle, depth + 1)
         end do
         a_point = b_point
      end do

   contains

      !> Raise best by a point's value.
      subroutine raise(point)
         type(scan_point_t), intent(in) :: point
         if (point%f > best) then
            best = point%f
            s_best = point%s
         end if
      end subroutine raise

      !> The scan step from a point: the largest h whose Hermite error bound at mid-interval is
      !> half the headroom G = best - f (h^4 <= 192 G/B), or half its rise G' h t at t = 1/3
      !> (h^3 <= 81 G'/B), or, where G is convex and not falling (past a maximum), a quarter of
      !> its curvature (h^2 <= 6 G''/B); at least the flight's smallest scan step.  A step that
      !> reaches s_hi anyway (the scan then takes the rest whole) is s_hi - s, found without a
      !> root.
      real(dp) function step(point)
         type(scan_point_t), intent(in) :: point
         real(dp) :: g, b, rest
         b = point%decaying + point%growing
         rest = s_hi - point%s
         if (.not. (b > 0)) then
            step = rest
            return
         end if
         g = max(best - point%f, 0.0_dp) + tolerance(point, point)
         if (192*g >= b*rest**4 .or. 81*abs(point%d1) >= b*rest**3) then
            step = rest
            return
         end if
         step = sqrt(sqrt(192*g/b))
         step = max(step, (81*abs(point%d1)/b)**(1.0_dp/3))
         if (-point%d1 >= 0 .and. -point%d2 > 0) step = max(step, sqrt(6*(-point%d2)/b))
         step = max(step, flight%min_step)
      end function step
   end subroutine scan

   !> The rounding allowance of values of f at two points: 8 eps times the larger size, and at
   !> least the smallest normal number.  A channel that is exactly 0 (a mode at rest under a
   !> zero drive: free_amplitude = 0 or alpha2 = 0) has size 0; with no allowance no interval
   !> cleared (level - f = 0 is not > 0), and every scan halved until its 2 000 000 points
   !> (2.2 s of CPU a drive period on fig2_n4; issue 27, F4).
   elemental real(dp) function tolerance(p, q)
      type(scan_point_t), intent(in) :: p, q
      tolerance = max(8*epsilon(1.0_dp)*max(p%size, q%size), tiny(1.0_dp))
   end function tolerance

   !> Whether sigma f < level all over [left, right] (width apart), with |f''''| <= bound there.
   !> With c = level - (the cubic Hermite of sigma f) and K = bound width^4/24, level - sigma f >=
   !> E(t) = c(t) - K t^2 (1-t)^2 (t the fraction of the interval).  First the cheap test,
   !> K t^2 (1-t)^2 <= K t (1-t)/4: the least value of the cubic c(t) - K t (1-t)/4 (at an end or
   !> its interior minimum, in closed form); then E on a grid of 32 intervals less max|E''|/(8 32^2)
   !> between grid points.  Both less the rounding of the cubic.
   pure logical function cleared(left, right, width, bound, level)
      type(scan_point_t), intent(in) :: left, right
      real(dp), intent(in) :: width, bound, level
      integer, parameter :: n_check = 32
      real(dp) :: c0, c1, d0, d1, big_k, a3, b3, theta, cubic_min, rounding, lowest, t
      integer :: k
      cleared = .false.
      c0 = level - left%f
      c1 = level - right%f
      if (.not. (c0 > 0 .and. c1 > 0)) return
      d0 = -left%d1*width
      d1 = -right%d1*width
      big_k = bound*width**4/24
      a3 = 2*c0 + d0 - 2*c1 + d1
      b3 = -3*c0 - 2*d0 + 3*c1 - d1
      rounding = 8*epsilon(1.0_dp)*(abs(a3) + abs(b3) + abs(d0) + abs(c0) + big_k)
      call hermite_minimum(c0, d0 - big_k/4, c1, d1 + big_k/4, theta, cubic_min)
      if (.not. (theta > 0)) then
         cleared = .true.
         return
      end if
      if (cubic_min - rounding > 0) then
         cleared = .true.
         return
      end if
      lowest = min(c0, c1)
      do k = 1, n_check - 1
         t = real(k, dp)/n_check
         lowest = min(lowest, ((a3*t + b3)*t + d0)*t + c0 - big_k*(t*(1 - t))**2)
      end do
      cleared = lowest - (2*abs(b3) + 6*abs(a3) + 2*big_k)/(8*n_check**2) - rounding > 0
   end function cleared

   !> The radius r of a neighbourhood of a maximum `peak` (sigma f'' < 0 there) where sigma f
   !> stays below level, by Taylor's bound: with |f'''(peak)| = third and |f''''| <= bound,
   !> f(peak + d) <= f + f' d + f'' d^2/2 + third |d|^3/6 + bound d^4/24 <= f + f' d + f'' d^2/4
   !> <= f + f'^2/|f''| while third r/6 + bound r^2/24 <= |f''|/4; 0 when that is not below level.
   pure real(dp) function taylor_radius(peak, third, bound, level)
      type(scan_point_t), intent(in) :: peak
      real(dp), intent(in) :: third, bound, level
      real(dp) :: c2
      taylor_radius = 0
      c2 = -peak%d2
      if (.not. (c2 > 0)) return
      if (.not. (peak%f + peak%d1**2/c2 < level)) return
      taylor_radius = (c2/2)/(third/6 + sqrt(third**2/36 + bound*c2/24))
   end function taylor_radius

end module tmafm_flight_observables

!> The cantilever of the N-mode model as an experimentalist calibrates it (docs/model.md
!> section 12): its static tip stiffness k, its first resonance f0 and quality factor Q, and the
!> tip's steady free amplitude under a base drive, all computed from the model's own matrices
!> (M = I + alpha1 m m^T, C = alpha3 I, K = Lambda of the free phase, Eqs. 16-19); and the
!> inverse, the beam (E1 I, m, C, M) that gives a calibration (k, f0, Q, M/(m L)) exactly.
!>
!> Definitions (the model's free phase, tau in units of t0 = sqrt(m L^4/(E1 I))):
!> - k = E1 I/(L^3 p^T Lambda^-1 p), p = phi(xi0): the static force at the tip over the tip's
!>   deflection;
!> - lambda1, the eigenvalue of lambda^2 M + lambda alpha3 I + Lambda = 0 (the free decay
!>   a = Re(v e^(lambda tau))) of least modulus, with Im lambda1 > 0 (mode 1 underdamped);
!> - f0 = |lambda1|/(2 pi t0) and Q = |lambda1|/(2 |Re lambda1|): the natural frequency and
!>   quality factor of the one oscillator that decays as mode 1 does.  The beam damping is
!>   uniform and the tip mass undamped, so mode 1 is not a modal (real) mode: lambda1 is the
!>   complex eigenvalue itself, not alpha3 over a modal mass;
!> - the free amplitude: |p^T X - i| alpha2 d, with (Lambda - Omega^2 M + i Omega C) X
!>   = Omega^2 (alpha1 m + (1 + mu) q) (-i) - Omega C q: the first harmonic of V_T = p^T a +
!>   alpha2 sin(Omega tau) + delta_hat in steady free flight (the `amplitude` observable);
!>   C = alpha3 I and mu = 0 in air, C = diag(alpha3 + gamma_j) and mu_j in a liquid.
!> In a liquid (docs/model.md §13) f0 and Q are those of the loaded beam, the thermal peak a
!> user measures there: the calibration solves for the beam whose loaded mode 1 has them.
module tmafm_calibration
   use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
   use tmafm_kinds, only: dp
   use tmafm_errors, only: ok, err_input
   use tmafm_text, only: real_text
   use tmafm_scene, only: scene_t, physical_t, scene_from_physical, beam_rigidity, beam_mass_per_length
   use tmafm_units, only: scales_t, scales_from_physical
   use tmafm_errata, only: errata_t
   use tmafm_contact, only: law_hertz
   use tmafm_model, only: model_t, init_model
   implicit none
   private

   public :: tip_compliance, first_mode, free_response, damping_for_quality
   public :: calibrate_cantilever, drive_for_free_amplitude, physical_derived
   public :: derived_names, derived_units, derived_meanings, n_derived, continuum_first_root

   real(dp), parameter :: pi = acos(-1.0_dp)

   !> Number of derived values of a physical scene (physical_derived).
   integer, parameter :: n_derived = 22
   !> Their names, in the order of physical_derived's values.
   character(len=*), parameter :: derived_names(n_derived) = [character(len=29) :: 'rigidity', &
      'mass_per_length', 'tip_mass', 'beam_damping', 'gap', 'static_offset', 'drive_amplitude', &
      'drive_angular_frequency', 'drive_frequency', 'free_amplitude', 'spring_constant', &
      'continuum_spring_constant', 'resonance_frequency', 'undamped_resonance_frequency', &
      'quality_factor', 'length_scale', 'time_scale', 'force_scale', 'energy_scale', &
      'continuum_resonance_frequency', 'drive_amplitude_2', 'drive_angular_frequency_2']
   !> Their units.
   character(len=*), parameter :: derived_units(n_derived) = [character(len=8) :: 'N m^2', 'kg/m', &
      'kg', 'N s/m^2', 'm', 'm', 'm', 'rad/s', 'Hz', 'm', 'N/m', 'N/m', 'Hz', 'Hz', '1', 'm', 's', &
      'N', 'J', 'Hz', 'm', 'rad/s']
   !> What each one is.
   character(len=*), parameter :: derived_meanings(n_derived) = [character(len=100) :: &
      'E1 I of the beam', 'beam mass per length m', 'tip mass M', 'beam damping C per length', &
      'gap d = g0 + delta/cos(theta)', 'static tip-sample offset delta (the Z of an approach)', &
      'base drive amplitude f = alpha2 d', 'drive angular frequency omega', 'drive frequency omega/(2 pi)', &
      "tip's steady free amplitude at the drive (V_T's first harmonic, no contact)", &
      "the model's static tip stiffness E1 I/(L^3 p^T Lambda^-1 p)", 'continuum 3 E1 I/x0^3', &
      "the model's first resonance |lambda1|/(2 pi t0)", "the model's first undamped natural frequency", &
      "the model's Q = |lambda1|/(2 |Re lambda1|)", 'length scale d', 'time scale t0 = sqrt(m L^4/(E1 I))', &
      'force scale E1 I/L^2', 'energy scale E1 I d^2/L^3', &
      'continuum beam, tip mass at the free end: first undamped frequency (0 if the mass sits elsewhere)', &
      'second drive tone: base amplitude f_2 = alpha2_2 d', 'second drive tone: angular frequency omega_2']

contains

   !> p^T Lambda^-1 p: the tip's static deflection in units of F L^3/(E1 I) for a force F at the
   !> tip (Lambda a = (F L^3/(E1 I d)) p, V_T = p^T a).
   pure real(dp) function tip_compliance(model)
      type(model_t), intent(in) :: model
      tip_compliance = sum(model%tip**2/model%eigen)
   end function tip_compliance

   !> lambda1 (module comment) of the model's free phase with beam damping alpha3 (plus, in a
   !> liquid, each mode's fluid damping: model_t%modal_damping - alpha3 of the model): the
   !> companion matrix's eigenvalues (LAPACK dgeev) give the start, Newton's method on
   !> T(lambda) v = 0 (nonlinear inverse iteration, complex LU) refines it to the last bits.
   !> `underdamped` is .false. when the eigenvalue of least modulus is real.
   subroutine first_mode(model, alpha3, lambda, underdamped, ierr, errmsg)
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: alpha3
      complex(dp), intent(out) :: lambda
      logical, intent(out) :: underdamped
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      real(dp) :: companion(2*model%n_modes, 2*model%n_modes), wr(2*model%n_modes), wi(2*model%n_modes)
      real(dp) :: dummy(1, 1), work(8*model%n_modes + 64)
      complex(dp) :: t(model%n_modes, model%n_modes), x(model%n_modes), v(model%n_modes), u(model%n_modes)
      complex(dp) :: step
      real(dp) :: damping(model%n_modes)
      integer :: n, j, k, info, pivots(model%n_modes), it

      ierr = ok
      errmsg = ''
      n = model%n_modes
      companion = 0
      do j = 1, n
         companion(j, n + j) = 1
      end do
      companion(n + 1:, 1:n) = -model%inv_mass_eigen
      ! C = diag(alpha3 + the liquid's damping), alpha3 I without a liquid (the same bits).
      damping = alpha3 + (model%modal_damping - model%scene%alpha3)
      do j = 1, n
         companion(n + 1:, n + j) = -damping(j)*model%inv_mass(:, j)
      end do
      ! LAPACK is given finite numbers only: on a NaN, dgeev's balancing (DGEBAL) calls XERBLA,
      ! whose reference version prints a line and stops the program.
      if (.not. all(ieee_is_finite(companion))) then
         ierr = err_input
         write (errmsg, '(a,es12.4e3)') 'the eigenvalues of the free beam: its equations are not finite '// &
            '(beam damping alpha3 = ', alpha3
         errmsg = trim(errmsg)//')'
         return
      end if
      call dgeev('N', 'N', 2*n, companion, 2*n, wr, wi, dummy, 1, dummy, 1, work, size(work), info)
      if (info /= 0) then
         ierr = err_input
         write (errmsg, '(a,i0)') 'the eigenvalues of the free beam failed: LAPACK dgeev info = ', info
         return
      end if
      k = minloc(hypot(wr, wi), 1, mask=wi >= 0)
      lambda = cmplx(wr(k), wi(k), dp)
      underdamped = wi(k) > 0
      if (.not. underdamped) return
      ! One step of inverse iteration from the tip's shape gives mode 1's vector, then Newton.
      ! Where the modes' coupling is far below round-off (a tip mass ratio or tip position of
      ! 1e-80), dgeev's lambda1 makes T(lambda) singular to the last bits: the iteration then
      ! overflows, and lambda1 stays the last finite value (dgeev's is exact to round-off there).
      v = model%tip
      call solve(lambda, v, info)
      if (info /= 0 .or. .not. finite(v)) return
      u = v/sum(abs(v)**2)
      if (.not. finite(u)) return
      do it = 1, 30
         x = (2*lambda)*matmul(model%mass, v) + damping*v
         call solve(lambda, x, info)
         if (info /= 0 .or. .not. finite(x)) exit
         step = 1/dot_product(u, x)
         if (.not. finite([step, lambda - step])) exit
         lambda = lambda - step
         v = x*step
         if (abs(step) <= 4*epsilon(1.0_dp)*abs(lambda)) exit
      end do
      underdamped = aimag(lambda) > 0
   contains
      !> rhs <- T(lam)^-1 rhs, T(lam) = lam^2 M + lam C + Lambda (info > 0: singular).
      subroutine solve(lam, rhs, info)
         complex(dp), intent(in) :: lam
         complex(dp), intent(inout) :: rhs(:)
         integer, intent(out) :: info
         integer :: i
         t = lam**2*model%mass
         do i = 1, n
            t(i, i) = t(i, i) + lam*damping(i) + model%eigen(i)
         end do
         call zgesv(n, 1, t, n, pivots, rhs, n, info)
      end subroutine solve
      !> Whether every real and imaginary part of z is finite.
      pure logical function finite(z)
         complex(dp), intent(in) :: z(:)
         finite = all(ieee_is_finite(real(z, dp))) .and. all(ieee_is_finite(aimag(z)))
      end function finite
   end subroutine first_mode

   !> The beam damping alpha3 that gives the model's mode 1 the quality factor `quality` (and
   !> its lambda1): Illinois' regula falsi on log alpha3, bracketed first.
   subroutine damping_for_quality(model, quality, alpha3, lambda, ierr, errmsg)
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: quality
      real(dp), intent(out) :: alpha3
      complex(dp), intent(out) :: lambda
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      real(dp) :: lo, hi, f_lo, f_hi, x, f
      integer :: it, side
      logical :: under

      alpha3 = 0
      call first_mode(model, 0.0_dp, lambda, under, ierr, errmsg)
      if (ierr /= ok) return
      lo = abs(lambda)/quality
      f_lo = misfit(lo)
      if (ierr /= ok) return
      do it = 1, 200
         if (f_lo > 0) exit
         lo = lo/2
         f_lo = misfit(lo)
         if (ierr /= ok) return
      end do
      hi = 2*lo
      f_hi = misfit(hi)
      do it = 1, 200
         if (ierr /= ok) return
         if (f_hi < 0) exit
         hi = 2*hi
         f_hi = misfit(hi)
      end do
      if (.not. (f_lo > 0 .and. f_hi < 0)) then
         ierr = err_input
         errmsg = 'no beam damping gives mode 1 this quality factor'
         return
      end if
      ! Regula falsi (Illinois) in x = log alpha3; f = log(Q/quality), -1 where mode 1 is overdamped.
      lo = log(lo)
      hi = log(hi)
      side = 0
      do it = 1, 200
         x = (lo*f_hi - hi*f_lo)/(f_hi - f_lo)
         f = misfit(exp(x))
         if (ierr /= ok) return
         if (abs(f) <= 1.0e-14_dp .or. hi - lo <= 4*epsilon(1.0_dp)*abs(hi)) exit
         if (f > 0) then
            lo = x
            f_lo = f
            if (side == 1) f_hi = f_hi/2
            side = 1
         else
            hi = x
            f_hi = f
            if (side == -1) f_lo = f_lo/2
            side = -1
         end if
      end do
      alpha3 = exp(x)
      call first_mode(model, alpha3, lambda, under, ierr, errmsg)
   contains
      !> log(Q(a3)/quality) for beam damping a3, or -1 where mode 1 is overdamped.
      real(dp) function misfit(a3)
         real(dp), intent(in) :: a3
         complex(dp) :: lam
         logical :: under
         call first_mode(model, a3, lam, under, ierr, errmsg)
         misfit = -1
         if (under) misfit = log(abs(lam)/(2*abs(real(lam, dp)))/quality)
      end function misfit
   end subroutine damping_for_quality

   !> V_T's first-harmonic complex amplitude per unit alpha2 in steady free flight (module
   !> comment): the free amplitude is alpha2 |h| gap units.  At the scene's omega, or at
   !> `frequency` (a second tone's: V_T's lock-in at it is that tone's own linear response).
   function free_response(model, ierr, errmsg, frequency, modal) result(h)
      type(model_t), intent(in) :: model
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      real(dp), intent(in), optional :: frequency
      !> If present, the modal amplitudes X per unit alpha2 (a = alpha2 Re(X e^(i Omega tau))):
      !> the steady free state, which the FM loop starts from (tmafm_fm).
      complex(dp), intent(out), optional :: modal(:)
      complex(dp) :: h
      complex(dp) :: z(model%n_modes, model%n_modes), x(model%n_modes)
      complex(dp), parameter :: i = (0.0_dp, 1.0_dp)
      integer :: n, j, info, pivots(model%n_modes)
      type(scene_t) :: s

      ierr = ok
      errmsg = ''
      n = model%n_modes
      s = model%scene
      if (present(frequency)) s%omega = frequency
      block
         z = -s%omega**2*model%mass
         if (model%has_medium) then
            ! A liquid: M carries the added mass, C each mode's damping, and the base drives the
            ! liquid's added mass and damping too (docs/model.md §13, §16).
            do j = 1, n
               z(j, j) = z(j, j) + model%eigen(j) + i*s%omega*model%modal_damping(j)
            end do
            x = -i*s%omega**2*model%inertial_load - s%omega*model%damped_integral
         else
            do j = 1, n
               z(j, j) = z(j, j) + model%eigen(j) + i*s%omega*s%alpha3
            end do
            x = -i*s%omega**2*(s%alpha1*model%mass_point + model%integral) - s%alpha3*s%omega*model%integral
         end if
      end block
      call zgesv(n, 1, z, n, pivots, x, n, info)
      if (info /= 0) then
         ierr = err_input
         errmsg = 'the drive is at an undamped resonance of the free beam (no steady free amplitude)'
         h = 0
         return
      end if
      h = sum(model%tip*x) - i
      if (present(modal)) modal = x
   end function free_response

   !> The first root beta of the continuum clamped-free beam with a tip mass alpha1 at its free
   !> end, 1 + cos(b) cosh(b) + alpha1 b (cos(b) sinh(b) - sin(b) cosh(b)) = 0 (docs/model.md
   !> section 4): its first undamped frequency is beta^2/t0.  Divided by cosh(b) so that
   !> nothing overflows; bisection on (0, 1.8751...], where the function falls from 2 to < 0.
   pure real(dp) function continuum_first_root(alpha1) result(beta)
      real(dp), intent(in) :: alpha1
      real(dp) :: lo, hi
      integer :: it
      lo = 0
      hi = 1.8751040687119612_dp
      do it = 1, 200
         beta = (lo + hi)/2
         if (beta <= lo .or. beta >= hi) exit
         if (g(beta) > 0) then
            lo = beta
         else
            hi = beta
         end if
      end do
   contains
      pure real(dp) function g(b)
         real(dp), intent(in) :: b
         g = cos(b) + 1/cosh(b) + alpha1*b*(cos(b)*tanh(b) - sin(b))
      end function g
   end function continuum_first_root

   !> The free-phase model of a physical scene for N modes and a set of corrections.
   subroutine free_model(phys, n_modes, errata, model, ierr, errmsg)
      type(physical_t), intent(in) :: phys
      integer, intent(in) :: n_modes
      type(errata_t), intent(in) :: errata
      type(model_t), intent(out) :: model
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      call init_model(model, n_modes, scene_from_physical(phys), law_hertz, errata, ierr, errmsg)
   end subroutine free_model

   !> The beam of a cantilever given by its calibration (phys%spring_constant,
   !> resonance_frequency, quality_factor, tip_mass_ratio, length, tip_position): sets
   !> phys%rigidity, mass_per_length, beam_damping and tip_mass so that the N-mode model has
   !> exactly that k, f0 and Q (module comment).  Errors name no key (the reader adds it):
   !> `key` says which ('quality_factor', 'resonance_frequency', or for a beam that is not a
   !> normal number 'spring_constant', 'length' or 'tip_position').
   subroutine calibrate_cantilever(phys, n_modes, errata, ierr, errmsg, key)
      type(physical_t), intent(inout) :: phys
      integer, intent(in) :: n_modes
      type(errata_t), intent(in) :: errata
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      character(len=*), intent(out) :: key
      type(model_t) :: model
      type(scene_t) :: scene
      real(dp) :: alpha3, t0, compliance
      complex(dp) :: lambda

      key = 'quality_factor'
      scene%alpha1 = phys%tip_mass_ratio
      scene%xi0 = phys%tip_position/phys%length
      call init_model(model, n_modes, scene, law_hertz, errata, ierr, errmsg)
      if (ierr /= ok) return
      call damping_for_quality(model, phys%quality_factor, alpha3, lambda, ierr, errmsg)
      if (ierr /= ok) return
      compliance = tip_compliance(model)
      phys%rigidity = phys%spring_constant*phys%length**3*compliance
      t0 = abs(lambda)/(2*pi*phys%resonance_frequency)
      ! (E1 I is checked below; a liquid's search for t0 needs it first)
      if (.not. normal(phys%rigidity)) then
         call refuse()
         return
      end if
      if (phys%medium_density > 0) then
         ! In a liquid the loaded beam must have f0 and Q: the liquid's added mass and damping
         ! depend on the beam's own mass and time scale, so t0 is solved for (the static k is not
         ! touched by the liquid).
         call liquid_time_scale(phys, n_modes, errata, t0, alpha3, ierr, errmsg, key)
         if (ierr /= ok) return
      end if
      phys%mass_per_length = phys%rigidity*t0**2/phys%length**4
      ! E1 I, m and E1 I m (the scene's damping scale divides by it, Eq. 12) must be normal
      ! numbers.  A tip at the clamp to round-off (x0 = 1e-85 m: p is round-off noise) made
      ! E1 I m underflow, the damping groups infinite and the scene NaN.  The key named is the
      ! factor of E1 I smallest against the default beam's (calibrate_cantilever's contains).
      if (.not. (normal(phys%mass_per_length) .and. normal(phys%rigidity*phys%mass_per_length))) then
         call refuse()
         ! E1 I is normal here: m = E1 I t0^2/L^4 = k p^T Lambda^-1 p t0^2/L (t0 ~ 1/f0) or
         ! E1 I m failed, so resonance_frequency is a candidate too (f0 = 1e-300 named length).
         key = mass_factor()
         return
      end if
      phys%beam_damping = alpha3*phys%mass_per_length/t0
      phys%tip_mass = phys%tip_mass_ratio*phys%mass_per_length*phys%length
   contains
      !> The error for a calibrated beam that is not a normal number, naming smallest_factor().
      subroutine refuse()
         ierr = err_input
         key = smallest_factor()
         errmsg = 'gives the calibrated beam E1 I = k L^3 p^T Lambda^-1 p = '//real_text(phys%rigidity)// &
                  ' N m^2 (p^T Lambda^-1 p = '//real_text(compliance)//') and m = E1 I t0^2/L^4 = '// &
                  real_text(phys%rigidity*t0**2/phys%length**4)//' kg/m: E1 I, m and E1 I m must be normal numbers'
         if (key == 'tip_position') errmsg = trim(errmsg)//': the tip sits at the clamp; move it out along the beam'
      end subroutine refuse
      !> Whether x is finite and at least the smallest normal number in magnitude.
      pure logical function normal(x)
         real(dp), intent(in) :: x
         normal = ieee_is_finite(x) .and. abs(x) >= tiny(1.0_dp)
      end function normal
      !> The one of spring_constant, length, tip_position whose factor of E1 I is smallest on a
      !> log scale against the default beam's.
      function smallest_factor() result(name)
         character(len=15) :: name
         type(physical_t) :: typical
         real(dp) :: logs(3)
         character(len=15), parameter :: names(3) = [character(len=15) :: 'spring_constant', 'length', &
            'tip_position']
         ! (a compliance of 0 counts as the smallest subnormal: no log of 0)
         logs = [log(phys%spring_constant/(3*beam_rigidity(typical)/typical%length**3)), &
                 3*log(phys%length/typical%length), log(3*max(compliance, tiny(1.0_dp)*epsilon(1.0_dp)))]
         name = names(minloc(logs, 1))
      end function smallest_factor
      !> The one of spring_constant, length, tip_position, resonance_frequency that moves m (or
      !> E1 I m, when m is normal) furthest towards its failure, on a log scale against the
      !> default beam's: m ~ k c f0^-2 L^-1 and E1 I m ~ k^2 c^2 f0^-2 L^2, c = p^T Lambda^-1 p
      !> (1/3 at the free end).
      function mass_factor() result(name)
         character(len=19) :: name
         type(physical_t) :: typical
         real(dp) :: logs(4), typical_f0, power, failed
         character(len=19), parameter :: names(4) = [character(len=19) :: 'spring_constant', 'length', &
            'tip_position', 'resonance_frequency']
         typical_f0 = abs(lambda)/(2*pi*sqrt(beam_mass_per_length(typical)*typical%length**4 &
                                              /beam_rigidity(typical)))
         power = 1
         failed = phys%mass_per_length
         if (normal(phys%mass_per_length)) then
            power = 2
            failed = phys%rigidity*phys%mass_per_length
         end if
         logs = [power*log(phys%spring_constant/(3*beam_rigidity(typical)/typical%length**3)), &
                 (3*power - 4)*log(phys%length/typical%length), &
                 power*log(3*max(compliance, tiny(1.0_dp)*epsilon(1.0_dp))), &
                 -2*log(phys%resonance_frequency/typical_f0)]
         ! Towards overflow the largest term is the culprit, towards underflow the smallest.
         if (failed > 1 .or. .not. (failed >= 0)) then
            name = names(maxloc(logs, 1))
         else
            name = names(minloc(logs, 1))
         end if
      end function mass_factor
   end subroutine calibrate_cantilever

   !> The time scale t0 (s) and beam damping alpha3 of a cantilever of rigidity phys%rigidity in
   !> phys's liquid whose loaded mode 1 has the frequency phys%resonance_frequency and quality
   !> factor phys%quality_factor: for each trial t0 the beam's mass per length is E1 I t0^2/L^4,
   !> the liquid's loads follow (tmafm_scene, tmafm_hydrodynamics), alpha3 meets Q
   !> (damping_for_quality) and the loaded |lambda1|/(2 pi t0) is compared with f0; Illinois'
   !> regula falsi on log t0, bracketed by halving from the air's t0 (the liquid only lowers f0).
   subroutine liquid_time_scale(phys, n_modes, errata, t0, alpha3, ierr, errmsg, key)
      type(physical_t), intent(in) :: phys
      integer, intent(in) :: n_modes
      type(errata_t), intent(in) :: errata
      real(dp), intent(inout) :: t0
      real(dp), intent(out) :: alpha3
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      !> The key a refusal names: 'resonance_frequency' or 'quality_factor'.
      character(len=*), intent(inout) :: key
      real(dp) :: lo, hi, f_lo, f_hi, x, f, best_frequency, best_quality, step
      integer :: it, side
      logical :: feasible

      alpha3 = 0
      best_frequency = 0
      best_quality = 0
      ! hi: the air's t0, where the loaded beam rings below f0 (the liquid only lowers it).
      hi = log(t0)
      f_hi = misfit(hi, feasible)
      if (ierr /= ok) return
      if (.not. feasible) then
         ierr = err_input
         errmsg = 'the liquid alone gives mode 1 Q = '//short(best_quality)// &
                  ': quality_factor must be below it (no beam damping is negative)'
         return
      end if
      ! Step t0 down (a lighter beam, a higher loaded f0) until f0 is passed; a lighter beam is
      ! also damped more by the liquid, so a step into Q's infeasible side is halved.
      lo = hi
      f_lo = f_hi
      step = log(2.0_dp)
      do it = 1, 400
         if (f_lo > 0) exit
         x = lo - step
         f = misfit(x, feasible)
         if (ierr /= ok) return
         if (.not. feasible) then
            step = step/2
            if (step < 1.0e-12_dp) exit
            cycle
         end if
         hi = lo
         f_hi = f_lo
         lo = x
         f_lo = f
         if (lo < log(t0) - 80*log(2.0_dp)) exit
      end do
      if (.not. (f_lo > 0 .and. f_hi <= 0)) then
         ierr = err_input
         key = 'resonance_frequency'
         if (step < 1.0e-12_dp) then
            errmsg = 'with quality_factor as given the loaded mode 1 rings at most at '// &
                     short(best_frequency)//' Hz in this liquid (there the liquid alone gives Q = '// &
                     short(best_quality)//'): a lower resonance_frequency or a lower quality_factor'
         else
            errmsg = 'in this liquid no beam of this spring_constant and width resonates this high: its '// &
                     'loaded first resonance stays below '//short(best_frequency)// &
                     ' Hz however light the beam (the liquid''s added mass alone)'
         end if
         return
      end if
      side = 0
      x = hi
      f = f_hi
      do it = 1, 200
         if (abs(f) <= 1.0e-15_dp .or. abs(hi - lo) <= 4*epsilon(1.0_dp)*max(abs(hi), abs(lo))) exit
         x = (lo*f_hi - hi*f_lo)/(f_hi - f_lo)
         f = misfit(x, feasible)
         if (ierr /= ok) return
         if (f > 0) then
            lo = x
            f_lo = f
            if (side == 1) f_hi = f_hi/2
            side = 1
         else
            hi = x
            f_hi = f
            if (side == -1) f_lo = f_lo/2
            side = -1
         end if
      end do
      f = misfit(x, feasible)
      t0 = exp(x)
   contains
      !> log(f0(t0)/f0) of the loaded beam at log t0 = log_t0, with alpha3 set to meet Q;
      !> feasible = .false. where the liquid alone damps mode 1 below Q (ierr stays ok).
      real(dp) function misfit(log_t0, feasible)
         real(dp), intent(in) :: log_t0
         logical, intent(out) :: feasible
         type(physical_t) :: trial
         type(model_t) :: model
         complex(dp) :: lambda
         logical :: under
         real(dp) :: time
         time = exp(log_t0)
         trial = phys
         trial%by_calibration = .true.
         trial%mass_per_length = phys%rigidity*time**2/phys%length**4
         trial%tip_mass = phys%tip_mass_ratio*trial%mass_per_length*phys%length
         trial%beam_damping = 0
         misfit = 0
         feasible = .false.
         call init_model(model, n_modes, scene_from_physical(trial), law_hertz, errata, ierr, errmsg)
         if (ierr /= ok) return
         ! The liquid alone (no beam damping): Q must not exceed it.
         call first_mode(model, 0.0_dp, lambda, under, ierr, errmsg)
         if (ierr /= ok) return
         if (.not. under) return
         best_quality = abs(lambda)/(2*abs(real(lambda, dp)))
         if (best_quality < phys%quality_factor) then
            best_frequency = max(best_frequency, abs(lambda)/(2*pi*time))
            return
         end if
         call damping_for_quality(model, phys%quality_factor, alpha3, lambda, ierr, errmsg)
         if (ierr /= ok) return
         feasible = .true.
         misfit = log(abs(lambda)/(2*pi*time*phys%resonance_frequency))
         best_frequency = max(best_frequency, abs(lambda)/(2*pi*time))
      end function misfit

      !> x to 5 significant digits, no blanks (for the messages).
      function short(x) result(text)
         real(dp), intent(in) :: x
         character(len=:), allocatable :: text
         character(len=24) :: buffer
         write (buffer, '(es11.4e2)') x
         text = trim(adjustl(buffer))
      end function short
   end subroutine liquid_time_scale

   !> The base drive amplitude phys%drive_amplitude that gives the tip the steady free
   !> amplitude phys%free_amplitude (module comment), for N modes and a set of corrections; with
   !> tone = 2, drive_amplitude_2 from free_amplitude_2 at the second tone's frequency.
   subroutine drive_for_free_amplitude(phys, n_modes, errata, ierr, errmsg, tone)
      type(physical_t), intent(inout) :: phys
      integer, intent(in) :: n_modes
      type(errata_t), intent(in) :: errata
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      integer, intent(in), optional :: tone
      type(model_t) :: model
      type(physical_t) :: one_tone
      type(scales_t) :: scales
      complex(dp) :: h

      ! The free model of tone 1 alone (the tones' responses superpose).
      one_tone = phys
      one_tone%drive_amplitude_2 = 0
      call free_model(one_tone, n_modes, errata, model, ierr, errmsg)
      if (ierr /= ok) return
      if (present(tone)) then
         if (tone == 2) then
            scales = scales_from_physical(phys)
            h = free_response(model, ierr, errmsg, frequency=phys%drive_angular_frequency_2*scales%time)
            if (ierr /= ok) return
            phys%drive_amplitude_2 = phys%free_amplitude_2/abs(h)
            return
         end if
      end if
      h = free_response(model, ierr, errmsg)
      if (ierr /= ok) return
      phys%drive_amplitude = phys%free_amplitude/abs(h)
   end subroutine drive_for_free_amplitude

   !> The derived values of a physical scene, in the order of derived_names: the beam, the
   !> geometry and drive as the run uses them, the N-mode model's own k, f0, Q and free
   !> amplitude (n_modes >= 1), the continuum 3 E1 I/x0^3, the scales, and the continuum's
   !> first undamped frequency; f0 and Q are 0 where mode 1 is overdamped.
   subroutine physical_derived(phys, n_modes, errata, values, ierr, errmsg)
      type(physical_t), intent(in) :: phys
      integer, intent(in) :: n_modes
      type(errata_t), intent(in) :: errata
      real(dp), intent(out) :: values(n_derived)
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(model_t) :: model
      type(scales_t) :: scales
      complex(dp) :: lambda, undamped
      logical :: under
      real(dp) :: rigidity

      rigidity = beam_rigidity(phys)
      scales = scales_from_physical(phys)
      values = 0
      values(1:9) = [rigidity, beam_mass_per_length(phys), phys%tip_mass, phys%beam_damping, phys%gap, &
                     phys%static_offset, phys%drive_amplitude, phys%drive_angular_frequency, &
                     phys%drive_angular_frequency/(2*pi)]
      values(12) = 3*rigidity/phys%tip_position**3
      values(16:19) = [scales%length, scales%time, scales%force, scales%energy]
      values(21:22) = [phys%drive_amplitude_2, phys%drive_angular_frequency_2]
      ! The continuum's first frequency, where the tip mass sits at the free end.
      if (phys%tip_position == phys%length .or. .not. errata%e6_tip_mass_at_xi0) then
         values(20) = continuum_first_root(phys%tip_mass/(beam_mass_per_length(phys)*phys%length))**2 &
                      /(2*pi*scales%time)
      end if
      call free_model(phys, n_modes, errata, model, ierr, errmsg)
      if (ierr /= ok) return
      values(10) = phys%drive_amplitude*abs(free_response(model, ierr, errmsg))
      if (ierr /= ok) return
      values(11) = rigidity/(phys%length**3*tip_compliance(model))
      call first_mode(model, 0.0_dp, undamped, under, ierr, errmsg)
      if (ierr /= ok) return
      call first_mode(model, model%scene%alpha3, lambda, under, ierr, errmsg)
      if (ierr /= ok) return
      values(14) = abs(undamped)/(2*pi*scales%time)
      if (.not. under) return
      values(13) = abs(lambda)/(2*pi*scales%time)
      values(15) = abs(lambda)/(2*abs(real(lambda, dp)))
   end subroutine physical_derived

end module tmafm_calibration

!> Steady-state classification of a sequence of Poincare points (the state at each drive
!> period boundary), the jitter level a fixed-step method's points cannot repeat below, and the
!> steady phase: pure functions, testable on synthetic sequences (docs/observables.md, "Steady
!> state"; docs/model-notes.md, finding 15).
module tmafm_steady_state
   use tmafm_kinds, only: dp
   use tmafm_model, only: model_t
   use tmafm_contact, only: law_dmt
   implicit none
   private

   public :: steady_period, steady_test, steady_harmonic, jitter_t, jitter_init, jitter_level
   public :: steady_found, unsteady_short, unsteady_no_repeat, unsteady_not_distinct, unsteady_settling
   public :: jitter_factor, adaptive_factor, repeat_steps

   !> Why a sequence is not steady (steady_test's reason): steady; fewer points than any
   !> period needs; no period repeats within the tolerance; a period repeats, but its points are
   !> not distinct (a decaying flip transient); a period repeats within the method's jitter,
   !> but its steps were still shrinking (a transient).
   integer, parameter :: steady_found = 0, unsteady_short = 1, unsteady_no_repeat = 2, &
                         unsteady_not_distinct = 3, unsteady_settling = 4
   !> The jitter level is this times the state error of one misplaced switch: the repeat test
   !> compares two points, each off by up to one such error (model-notes finding 15).
   real(dp), parameter :: jitter_factor = 2
   !> A located method's points repeat to about its V_T error, 1.3-9.5 rtol (README): the
   !> relative tolerance is at least this times rtol.
   real(dp), parameter :: adaptive_factor = 10
   !> Within a jitter level, the points are still approaching the orbit while the largest step
   !> over each of three windows of settle_points points is more than settle_ratio times the
   !> next window's (function shrinking).
   integer, parameter :: settle_points = 9
   real(dp), parameter :: settle_ratio = 4

   !> What the jitter level of a fixed-step run needs: the steps that misplace a contact entry
   !> (a free step) and an exit (a contact step), and M^-1 applied to the terms that jump when
   !> the phase changes at V_T = 0 (docs/model-notes.md, finding 15).  Inactive (level 0) for
   !> the methods that locate their switches.
   type :: jitter_t
      !> .true. for a fixed-step run (rk4_paper); the level is 0 otherwise.
      logical :: active = .false.
      !> Number of modes N.
      integer :: n = 0
      !> Largest misplacement of an entry and of an exit: dtau and dtau/contact_refine.
      real(dp) :: h_entry = 0, h_exit = 0
      !> alpha4, and the contact damper's base term's bound alpha2 alpha4 max(1, Omega).
      real(dp) :: alpha4 = 0, base = 0
      !> p^T M^-1 p: |p^T a'| <= sqrt(2 E p^T M^-1 p) for a state of modal energy E.
      real(dp) :: tip_norm = 0
      !> |M^-1 p| (component-wise), the DMT pull-off's fixed jump (kappa5 4/3 times (L/d)
      !> |M^-1 p| + (g0/d) |M^-1 r|), and kappa5 4/3 |M^-1 G| for its axial stiffness.
      real(dp), allocatable :: tip(:), pull_off(:), axial(:, :)
      !> M and Lambda: the modal energy.
      real(dp), allocatable :: mass(:, :), eigen(:)
   end type jitter_t

contains

   !> The jitter data of a fixed-step run (h_entry = dtau, h_exit = dtau/contact_refine) of
   !> `model`; pass active = .false. for a method that locates its switches.
   pure function jitter_init(model, active, h_entry, h_exit) result(jitter)
      type(model_t), intent(in) :: model
      logical, intent(in) :: active
      real(dp), intent(in) :: h_entry
      real(dp), intent(in) :: h_exit
      type(jitter_t) :: jitter
      real(dp) :: pull
      integer :: n
      n = model%n_modes
      jitter%active = active
      jitter%n = n
      jitter%h_entry = h_entry
      jitter%h_exit = h_exit
      jitter%alpha4 = model%scene%alpha4
      if (model%drive%general) then
         jitter%base = sum(model%drive%amplitude(1:model%drive%n_tones)*model%scene%alpha4 &
                           *max(1.0_dp, model%drive%frequency(1:model%drive%n_tones)))
      else
         jitter%base = model%scene%alpha2*model%scene%alpha4*max(1.0_dp, model%scene%omega)
      end if
      jitter%tip_norm = dot_product(model%tip, model%inv_mass_tip)
      jitter%tip = abs(model%inv_mass_tip)
      allocate (jitter%pull_off(n), jitter%axial(n, n))
      pull = 0
      if (model%law == law_dmt) pull = model%kappa5*4.0_dp/3.0_dp
      jitter%pull_off = pull*(model%scene%l_over_d*jitter%tip + model%scene%g0_over_d*abs(model%inv_mass_moment))
      jitter%axial = pull*abs(model%inv_mass_axial)
      jitter%mass = model%mass
      jitter%eigen = model%eigen
   end function jitter_init

   !> The jitter level (absolute, in state units) of the Poincare point y = (a, a'):
   !> jitter_factor (h_entry + h_exit) max_i |jump of a''_i at a switch|, the jump bounded with
   !> the tip speed |p^T a'| <= sqrt(2 E p^T M^-1 p) of the point's modal energy E; 0 when
   !> inactive.
   pure real(dp) function jitter_level(jitter, y)
      type(jitter_t), intent(in) :: jitter
      real(dp), intent(in) :: y(:)
      real(dp) :: energy, speed, jump
      integer :: n, i, j
      jitter_level = 0
      if (.not. jitter%active) return
      n = jitter%n
      energy = 0
      do j = 1, n
         energy = energy + jitter%eigen(j)*y(j)**2
         do i = 1, n
            energy = energy + y(n + i)*jitter%mass(i, j)*y(n + j)
         end do
      end do
      energy = energy/2
      speed = sqrt(2*energy*jitter%tip_norm)
      do i = 1, n
         jump = jitter%tip(i)*(jitter%alpha4*speed + jitter%base) + jitter%pull_off(i)
         do j = 1, n
            jump = jump + jitter%axial(i, j)*abs(y(j))
         end do
         jitter_level = max(jitter_level, jump)
      end do
      jitter_level = jitter_factor*(jitter%h_entry + jitter%h_exit)*jitter_level
   end function jitter_level

   !> The smallest period p in 1..p_max such that the last `repeats` points each repeat the
   !> point p periods earlier: max_i |P_j(i) - P_(j-p)(i)| <= tol * size for j = m-repeats+1..m,
   !> where size = max |P(i)| over the points compared (the orbit's size), and, for p > 1, the
   !> orbit's p points are distinct: for every proper divisor q of p, each of those points is
   !> more than sqrt(tol) * size from the point q periods earlier (a decaying flip transient,
   !> P_j - P_(j-1) ~ (-r)^j, repeats every 2 periods long before it repeats every period, but
   !> its points are not distinct).  0 when none.  points(:, 1:m) are the points in order.
   pure function steady_period(points, p_max, tol, repeats) result(period)
      real(dp), intent(in) :: points(:, :)
      integer, intent(in) :: p_max
      real(dp), intent(in) :: tol
      integer, intent(in) :: repeats
      integer :: period
      integer :: reason, lag
      real(dp) :: closest
      call steady_test(points, p_max, tol, repeats, period, reason, closest, lag)
   end function steady_period

   !> steady_period, with the reason when there is none (unsteady_*), and the evidence: the
   !> closest repeat, min over p of max_j |P_j - P_(j-p)| / size (relative to the orbit's size,
   !> or to `scale` when given), at lag `closest_lag` (0: no lag fits).  With `floor` (one
   !> absolute jitter level per point) larger than tol * size over the points compared, its
   !> largest value decides instead: the repeats are within it, and the points of a period are
   !> distinct beyond it (a flip transient is then told from a period-2 orbit only when its
   !> points are more than the jitter apart), and the steps must have stopped shrinking (else
   !> unsteady_settling: a transient inside the jitter; function shrinking).  With `scale` (> 0)
   !> every size is `scale` (an absolute tolerance tol * scale; tmafm.analysis scales its
   !> sections itself).
   pure subroutine steady_test(points, p_max, tol, repeats, period, reason, closest, closest_lag, floor, &
                               scale)
      real(dp), intent(in) :: points(:, :)
      integer, intent(in) :: p_max
      real(dp), intent(in) :: tol
      integer, intent(in) :: repeats
      integer, intent(out) :: period
      integer, intent(out) :: reason
      real(dp), intent(out) :: closest
      integer, intent(out) :: closest_lag
      real(dp), intent(in), optional :: floor(:)
      real(dp), intent(in), optional :: scale
      integer :: m, p, q, first, k
      real(dp) :: size_orbit, threshold, apart, step
      logical :: distinct

      period = 0
      reason = unsteady_short
      closest = huge(1.0_dp)
      closest_lag = 0
      m = size(points, 2)
      k = max(repeats, 1)
      do p = 1, p_max
         if (m < p + k) exit
         first = m - k + 1
         size_orbit = orbit_size(points, first - p, m, scale)
         threshold = tol*size_orbit
         apart = sqrt(tol)*size_orbit
         if (present(floor)) then
            if (maxval(floor(first - p:m)) > threshold) then
               ! The method's jitter decides: repeats within it, points distinct beyond it.
               threshold = maxval(floor(first - p:m))
               apart = threshold
            end if
         end if
         step = largest_step(points, first, m, p)
         if (step/size_orbit < closest) then
            closest = step/size_orbit
            closest_lag = p
         end if
         if (reason == unsteady_short) reason = unsteady_no_repeat
         if (.not. (step <= threshold)) cycle
         if (apart == threshold) then
            ! Within the jitter, the points must also have stopped approaching the orbit.
            if (reason == unsteady_no_repeat) reason = unsteady_settling
            if (m < p + 3*settle_points) cycle
            if (shrinking(points, m, p)) cycle
         end if
         distinct = .true.
         do q = 1, p - 1
            if (mod(p, q) /= 0) cycle
            if (.not. (smallest_step(points, first, m, q) > apart)) then
               distinct = .false.
               exit
            end if
         end do
         if (distinct) then
            period = p
            reason = steady_found
            return
         end if
         reason = unsteady_not_distinct
      end do
   end subroutine steady_test

   !> The evidence of steady_test for every lag p = 1..p_max: max_j |P_j - P_(j-p)| over the
   !> last `repeats` points, relative to the orbit's size (or to `scale` when given); -1 for a
   !> lag the points are too few for.
   pure function repeat_steps(points, p_max, repeats, scale) result(steps)
      real(dp), intent(in) :: points(:, :)
      integer, intent(in) :: p_max
      integer, intent(in) :: repeats
      real(dp), intent(in), optional :: scale
      real(dp) :: steps(p_max)
      real(dp) :: size_orbit
      integer :: m, p, k, first
      steps = -1
      m = size(points, 2)
      k = max(repeats, 1)
      do p = 1, p_max
         if (m < p + k) exit
         first = m - k + 1
         size_orbit = orbit_size(points, first - p, m, scale)
         steps(p) = largest_step(points, first, m, p)/size_orbit
      end do
   end function repeat_steps

   !> The steady first harmonic of a p-period orbit: the harmonic of V_T over the whole orbit
   !> (p T), i.e. the mean of the per-period Fourier coefficients S_k = A_k cos(phi_k),
   !> C_k = A_k sin(phi_k) (phases in degrees), written as A sin(Omega tau + phi); phi in
   !> (-180, 180], free of the wrap at +-180.  NaN in gives NaN out.
   pure subroutine steady_harmonic(amplitude, phase, mean_amplitude, mean_phase)
      real(dp), intent(in) :: amplitude(:)
      real(dp), intent(in) :: phase(:)
      real(dp), intent(out) :: mean_amplitude
      real(dp), intent(out) :: mean_phase
      real(dp), parameter :: degree = acos(-1.0_dp)/180
      real(dp) :: s, c
      s = sum(amplitude*cos(phase*degree))/size(amplitude)
      c = sum(amplitude*sin(phase*degree))/size(amplitude)
      mean_amplitude = hypot(s, c)
      mean_phase = atan2(c, s)/degree
   end subroutine steady_harmonic

   !> max over j = first..last of max_i |P_j(i) - P_(j-lag)(i)|.
   pure real(dp) function largest_step(points, first, last, lag)
      real(dp), intent(in) :: points(:, :)
      integer, intent(in) :: first
      integer, intent(in) :: last
      integer, intent(in) :: lag
      integer :: j
      largest_step = 0
      do j = first, last
         largest_step = max(largest_step, maxval(abs(points(:, j) - points(:, j - lag))))
      end do
   end function largest_step

   !> .true. while the steps at `lag` still shrink: over three windows of settle_points points
   !> ending at `last`, each window's largest step is more than settle_ratio times the next
   !> one's.  A transient shrinks them steadily (by rho^settle_points a window); rk4_paper's
   !> jitter changes its size only in jumps, as the step grid's phase drifts (fig7_dmt's
   !> falls tenfold from one window to the next once in about 140 periods), never twice in a row.
   pure logical function shrinking(points, last, lag)
      real(dp), intent(in) :: points(:, :)
      integer, intent(in) :: last
      integer, intent(in) :: lag
      real(dp) :: window(3)
      integer :: w, stop_at
      do w = 1, 3
         stop_at = last - (3 - w)*settle_points
         window(w) = largest_step(points, stop_at - settle_points + 1, stop_at, lag)
      end do
      shrinking = window(1) > settle_ratio*window(2) .and. window(2) > settle_ratio*window(3)
   end function shrinking

   !> min over j = first..last of max_i |P_j(i) - P_(j-lag)(i)|.
   pure real(dp) function smallest_step(points, first, last, lag)
      real(dp), intent(in) :: points(:, :)
      integer, intent(in) :: first
      integer, intent(in) :: last
      integer, intent(in) :: lag
      integer :: j
      smallest_step = huge(1.0_dp)
      do j = first, last
         smallest_step = min(smallest_step, maxval(abs(points(:, j) - points(:, j - lag))))
      end do
   end function smallest_step

   !> The size tolerances are relative to: `scale` when given, else the largest |component| of
   !> points(:, first:last) (tiny when that is zero or NaN).
   pure real(dp) function orbit_size(points, first, last, scale)
      real(dp), intent(in) :: points(:, :)
      integer, intent(in) :: first
      integer, intent(in) :: last
      real(dp), intent(in), optional :: scale
      if (present(scale)) then
         orbit_size = scale
      else
         orbit_size = maxval(abs(points(:, first:last)))
      end if
      if (.not. (orbit_size > 0)) orbit_size = tiny(1.0_dp)
   end function orbit_size

end module tmafm_steady_state

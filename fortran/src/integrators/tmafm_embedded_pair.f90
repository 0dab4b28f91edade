!> What the adaptive run loop needs from an embedded Runge-Kutta pair (dopri5, dop853), and
!> the step-size controller, kept separate from the pairs.
!>
!> A pair takes one step in a frozen phase (f0 = f(tau, y) given: first same as last),
!> estimates its error in the norm of tmafm_error_scale, and builds its dense output only
!> when asked (a sample or a switch in the step), so steps that need none skip that work.
!> Registers are allocated once by `init`; a step allocates nothing.  `stage_phases` gives the
!> drive phase at every node of a step from one sin/cos of Omega tau (the pairs and rk4 use it).
!>
!> A step runs in a step variable s over [s0, s0 + h] (time_map_t): s = tau on a normal step;
!> on a warped step after a contact entry at tau_e, tau = tau_e + s^2 (s = sigma), where the
!> state w(sigma) = y(tau_e + sigma^2) is smooth although the force ~ (tau - tau_e)^(3/2) is
!> not, and the pair integrates dw/dsigma = 2 sigma f.  `stage_clock` gives each node's drive
!> phase and dtau/ds; the pair's dense output is in theta = (s - s0)/h, and every caller
!> turns a time into theta (and back) through the step's map only.
!>
!> The controller turns an error norm (and, once a phase had a rejection, the last accepted
!> one) into the next step from norm^(-1/(q+1)), q the order of the error estimate; each
!> pair computes its own norm^(-1/(q+1)) (dop853: three square roots for 1/8; dopri5: one
!> log and one exp for 1/5), see `growth`; the PI law's powers of it are square roots.
module tmafm_embedded_pair
   use tmafm_kinds, only: dp
   use tmafm_model, only: model_t
   use tmafm_error_scale, only: error_scale_t
   implicit none
   private

   public :: embedded_pair_t, step_controller_t, stage_phases, taylor_limit, time_map_t, stage_clock

   !> Largest |Omega c h| for which stage_phases sums the Taylor series instead of calling libm.
   real(dp), parameter :: taylor_limit = 1.0_dp
   !> (-1)^k/(2k+1)! and (-1)^k/(2k)!, k = 0..9: at |x| <= 1 the first omitted terms, 1/21! and
   !> 1/20!, are below 1e-18, far under the rounding of the sums.
   real(dp), parameter :: sin_series(0:9) = [1.0_dp, -1.0_dp/6, 1.0_dp/120, -1.0_dp/5040, &
      1.0_dp/362880, -1.0_dp/39916800, 1.0_dp/6227020800.0_dp, -1.0_dp/1307674368000.0_dp, &
      1.0_dp/355687428096000.0_dp, -1.0_dp/121645100408832000.0_dp]
   real(dp), parameter :: cos_series(0:9) = [1.0_dp, -1.0_dp/2, 1.0_dp/24, -1.0_dp/720, &
      1.0_dp/40320, -1.0_dp/3628800, 1.0_dp/479001600, -1.0_dp/87178291200.0_dp, &
      1.0_dp/20922789888000.0_dp, -1.0_dp/6402373705728000.0_dp]

   !> The time of a step as a function of its fraction theta: tau = s0 + theta h (normal), or
   !> tau = origin + (s0 + theta h)^2 (warped: s = sigma = sqrt(tau - origin)).
   type :: time_map_t
      !> The step variable at the step start, and the step's length in it.
      real(dp) :: s0 = 0, h = 0
      !> The warp's origin tau_e (warped steps only).
      real(dp) :: origin = 0
      !> .true. on a warped step.
      logical :: warped = .false.
   contains
      !> The time at fraction theta of the step.
      procedure :: time_at => map_time_at
      !> The fraction theta of the step at time t.
      procedure :: theta_at => map_theta_at
      !> dtau/dtheta at fraction theta.
      procedure :: rate_at => map_rate_at
   end type time_map_t

   !> An embedded pair with dense output.
   type, abstract :: embedded_pair_t
      !> Right-hand-side evaluations of one attempted step (the first stage is given, the
      !> derivative at the new state is counted).
      integer :: stage_evaluations = 0
      !> Extra right-hand-side evaluations to build the dense output of a step.
      integer :: dense_evaluations = 0
      !> Smallest and largest ratio of a new step to the old one (Hairer's fac1, fac2).
      real(dp) :: shrink_limit = 0.2_dp, grow_limit = 5.0_dp
      !> sin and cos of the drive phase Omega (tau + h) at the end of the last step (from
      !> stage_phases, as f_new used them).
      real(dp) :: sin_end = 0, cos_end = 1
      !> V_T and dV_T/dtau at the end of the last step (from the evaluation of f_new: the
      !> right-hand side forms them anyway, in the order of model_t's gap_at_phase).
      real(dp) :: vt_end = 0, rate_end = 0
      !> The time map of the last step (set by `step`): its dense output is in map's theta.
      type(time_map_t) :: map
   contains
      !> Allocate the registers for a state of size n_state.
      procedure(pair_init), deferred :: init
      !> One step over map (stored in self%map); f0 = dy/ds at its start in, f_new = dy/ds at
      !> its end out (s the step variable: dy/ds = f, or 2 sigma f on a warped step); sets
      !> sin_end, cos_end, vt_end and rate_end.
      procedure(pair_step), deferred :: step
      !> The error norm of the last step (accept when <= 1).
      procedure(pair_norm), deferred :: error_norm
      !> norm^(-1/(q+1)) for a positive norm: the raw ratio of the optimal step to h.
      procedure(pair_growth), deferred :: growth
      !> Build the dense output of the last step, over self%map (may evaluate the right-hand side).
      procedure(pair_prepare), deferred :: prepare_dense
      !> The dense-output state at fraction theta of the last step.
      procedure(pair_dense), deferred :: dense
   end type embedded_pair_t

   abstract interface
      subroutine pair_init(self, n_state)
         import :: embedded_pair_t
         class(embedded_pair_t), intent(inout) :: self
         integer, intent(in) :: n_state
      end subroutine pair_init

      subroutine pair_step(self, model, map, y, in_contact, f0, y_new, f_new)
         import :: embedded_pair_t, model_t, dp, time_map_t
         class(embedded_pair_t), intent(inout) :: self
         type(model_t), intent(in) :: model
         type(time_map_t), intent(in) :: map
         real(dp), intent(in), contiguous :: y(:)
         logical, intent(in) :: in_contact
         real(dp), intent(in), contiguous :: f0(:)
         real(dp), intent(out), contiguous :: y_new(:)
         real(dp), intent(out), contiguous :: f_new(:)
      end subroutine pair_step

      pure subroutine pair_norm(self, h, f0, f_new, scale, norm)
         import :: embedded_pair_t, error_scale_t, dp
         class(embedded_pair_t), intent(inout) :: self
         real(dp), intent(in) :: h
         real(dp), intent(in), contiguous :: f0(:)
         real(dp), intent(in), contiguous :: f_new(:)
         type(error_scale_t), intent(in) :: scale
         real(dp), intent(out) :: norm
      end subroutine pair_norm

      pure function pair_growth(self, norm) result(ratio)
         import :: embedded_pair_t, dp
         class(embedded_pair_t), intent(in) :: self
         real(dp), intent(in) :: norm
         real(dp) :: ratio
      end function pair_growth

      subroutine pair_prepare(self, model, y, y_new, in_contact, f0, f_new)
         import :: embedded_pair_t, model_t, dp
         class(embedded_pair_t), intent(inout) :: self
         type(model_t), intent(in) :: model
         real(dp), intent(in), contiguous :: y(:)
         real(dp), intent(in), contiguous :: y_new(:)
         logical, intent(in) :: in_contact
         real(dp), intent(in), contiguous :: f0(:)
         real(dp), intent(in), contiguous :: f_new(:)
      end subroutine pair_prepare

      pure subroutine pair_dense(self, theta, y)
         import :: embedded_pair_t, dp
         class(embedded_pair_t), intent(in) :: self
         real(dp), intent(in) :: theta
         real(dp), intent(out), contiguous :: y(:)
      end subroutine pair_dense
   end interface

   !> The step-size controller: classical (Hairer's DOP853/DOPRI5: safety 0.9, the pair's
   !> growth and shrink limits, no growth after a rejection) until the first rejection of a
   !> phase, then PI (Gustafsson 1991; Hairer and Wanner II, Sec. IV.2; Soderlind 2002 calls
   !> it PI3040).  With r(x) = safety x^(-1/k), k = q + 1, the classical factor of an accepted
   !> step is r(norm) and the PI factor r(norm)^i_gain / r(norm_prev)^p_gain, norm_prev the
   !> last accepted step's: in Soderlind's terms k_I = i_gain - p_gain and k_P = p_gain (in
   !> units of 1/k).  The gains are dyadic, 21/32 and 12/32 (k_I = 0.28, k_P = 0.375, near
   !> Gustafsson's 0.3 and 0.4), so that the powers are chains of square roots
   !> (dyadic_power: eight square roots, where two real powers cost about 500 instructions);
   !> on the four scenes of benchmarks/contact_steps.py they keep the steps and rejections of
   !> his gains (docs/performance.md), which other dyadic gains near them did not: the step
   !> pattern of a contact is sensitive to the gains.  In a steady state
   !> both laws are 1 at the same norm (safety^k), but the PI factor damps the accept/reject
   !> cycle of a step held at the stability boundary (a stiff contact, a high mode), where the
   !> classical law rejects every few steps; used from the start it would slow the ramp after
   !> a contact entry, whose norms are tiny.  A rejection uses r(norm).
   type :: step_controller_t
      !> Safety factor on the optimal step.
      real(dp) :: safety = 0.9_dp
      !> Integral and proportional gains, in 32nds of 1/k (0 to 32: dyadic_power's exponents).
      integer :: i_gain = 21, p_gain = 12
      !> Smallest step before the run fails (relative to max(1, tau)).
      real(dp) :: h_min_relative = 1.0e-14_dp
      !> .true. after a rejection: the next step may not grow (Hairer's DOPRI5/DOP853).
      logical :: after_rejection = .false.
      !> .true. once a step of this phase was rejected: the PI gains apply from then on.
      logical :: rejected_in_phase = .false.
      !> Accepted steps for which the PI gains apply although no step of the phase was rejected
      !> (set by the caller: the steps after a warped contact entry).
      integer :: pi_steps = 0
      !> r(norm_prev) = safety norm_prev^(-1/k) of the last accepted step in this phase, its norm
      !> floored at 1e-4 (as Hairer's facold); 0 at a phase start.
      real(dp) :: ratio_prev = 0
   contains
      !> The next step after an attempt of length h with error norm `norm` by `pair`.
      procedure :: next_step => controller_next_step
      !> Forget the history (a new phase: the last norm says nothing about the next step).
      procedure :: restart => controller_restart
   end type step_controller_t

contains

   !> sin and cos of the drive phase Omega (tau + c_i h) at the nodes c_i of a step, with one
   !> sin and cos (of Omega tau) per step instead of one per stage: when every |Omega c_i h| is
   !> at most taylor_limit, the phase at each node follows by angle addition (add_phase);
   !> otherwise each node calls libm.
   pure subroutine stage_phases(model, tau, h, nodes, sin_phase, cos_phase)
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: h
      real(dp), intent(in) :: nodes(:)
      real(dp), intent(out) :: sin_phase(:)
      real(dp), intent(out) :: cos_phase(:)
      real(dp) :: omega, sin0, cos0
      integer :: i
      omega = model%drive%fundamental
      if (abs(omega*h)*maxval(abs(nodes)) <= taylor_limit) then
         call model%phase(tau, sin0, cos0)
         do i = 1, size(nodes)
            call add_phase(sin0, cos0, omega*(nodes(i)*h), sin_phase(i), cos_phase(i))
         end do
      else
         do i = 1, size(nodes)
            call model%phase(tau + nodes(i)*h, sin_phase(i), cos_phase(i))
         end do
      end if
   end subroutine stage_phases

   !> The drive phase at the nodes s0 + c_i h of a step over `map`, and dtau/ds there (factor,
   !> set on warped steps only: a normal step's is 1 and its stages are not scaled; a normal
   !> step is stage_phases).  A warped node is at tau_0 + x_i, x_i = c_i h (2 s0 + c_i h),
   !> tau_0 = origin + s0^2: exact offsets from the step start, added to one sin/cos of
   !> Omega tau_0 as in stage_phases.
   pure subroutine stage_clock(model, map, nodes, sin_phase, cos_phase, factor)
      type(model_t), intent(in) :: model
      type(time_map_t), intent(in) :: map
      real(dp), intent(in) :: nodes(:)
      real(dp), intent(out) :: sin_phase(:)
      real(dp), intent(out) :: cos_phase(:)
      real(dp), intent(inout) :: factor(:)
      real(dp) :: omega, sin0, cos0, tau0, x
      integer :: i
      if (.not. map%warped) then
         call stage_phases(model, map%s0, map%h, nodes, sin_phase, cos_phase)
         return
      end if
      omega = model%drive%fundamental
      tau0 = map%time_at(0.0_dp)
      factor = 2*(map%s0 + nodes*map%h)
      ! The largest offset is the last node's (the nodes lie in [0, 1]).
      if (abs(omega*map%h*(2*map%s0 + map%h))*maxval(abs(nodes)) <= taylor_limit) then
         call model%phase(tau0, sin0, cos0)
         do i = 1, size(nodes)
            x = (nodes(i)*map%h)*(2*map%s0 + nodes(i)*map%h)
            call add_phase(sin0, cos0, omega*x, sin_phase(i), cos_phase(i))
         end do
      else
         do i = 1, size(nodes)
            x = (nodes(i)*map%h)*(2*map%s0 + nodes(i)*map%h)
            call model%phase(tau0 + x, sin_phase(i), cos_phase(i))
         end do
      end if
   end subroutine stage_clock

   !> sin and cos of phi0 + x from those of phi0, for |x| <= taylor_limit: sin x and cos x are
   !> Taylor sums (exact to round-off there, Horner's rule in x^2), then angle addition.
   pure subroutine add_phase(sin0, cos0, x, sin_phase, cos_phase)
      real(dp), intent(in) :: sin0
      real(dp), intent(in) :: cos0
      real(dp), intent(in) :: x
      real(dp), intent(out) :: sin_phase
      real(dp), intent(out) :: cos_phase
      real(dp) :: x2, sin_x, cos_x
      integer :: k
      x2 = x*x
      sin_x = sin_series(ubound(sin_series, 1))
      cos_x = cos_series(ubound(cos_series, 1))
      do k = ubound(sin_series, 1) - 1, 0, -1
         sin_x = sin_x*x2 + sin_series(k)
         cos_x = cos_x*x2 + cos_series(k)
      end do
      sin_x = sin_x*x
      sin_phase = sin0*cos_x + cos0*sin_x
      cos_phase = cos0*cos_x - sin0*sin_x
   end subroutine add_phase

   elemental function map_time_at(self, theta) result(t)
      class(time_map_t), intent(in) :: self
      real(dp), intent(in) :: theta
      real(dp) :: t
      if (self%warped) then
         t = self%origin + (self%s0 + theta*self%h)**2
      else
         t = self%s0 + theta*self%h
      end if
   end function map_time_at

   elemental function map_theta_at(self, t) result(theta)
      class(time_map_t), intent(in) :: self
      real(dp), intent(in) :: t
      real(dp) :: theta
      if (self%warped) then
         theta = (sqrt(max(t - self%origin, 0.0_dp)) - self%s0)/self%h
      else
         theta = (t - self%s0)/self%h
      end if
   end function map_theta_at

   elemental function map_rate_at(self, theta) result(rate)
      class(time_map_t), intent(in) :: self
      real(dp), intent(in) :: theta
      real(dp) :: rate
      if (self%warped) then
         rate = 2*(self%s0 + theta*self%h)*self%h
      else
         rate = self%h
      end if
   end function map_rate_at

   function controller_next_step(self, pair, h, norm) result(h_next)
      class(step_controller_t), intent(inout) :: self
      class(embedded_pair_t), intent(in) :: pair
      real(dp), intent(in) :: h
      real(dp), intent(in) :: norm
      !> The floor of norm_prev (Hairer's facold >= 1e-4).
      real(dp), parameter :: norm_floor = 1.0e-4_dp
      real(dp) :: h_next, factor, grow, ratio
      grow = pair%grow_limit
      if (self%after_rejection) grow = 1
      ratio = 0
      if (norm <= 0) then
         factor = grow
      else
         ! pair%growth(x) = x^(-1/k).
         ratio = self%safety*pair%growth(norm)
         factor = ratio
         if (norm <= 1 .and. self%ratio_prev > 0 .and. (self%rejected_in_phase .or. self%pi_steps > 0)) &
            factor = dyadic_power(ratio, self%i_gain)/dyadic_power(self%ratio_prev, self%p_gain)
         factor = min(grow, max(pair%shrink_limit, factor))
      end if
      if (norm <= 1) then
         if (norm < norm_floor) ratio = self%safety*pair%growth(norm_floor)
         self%ratio_prev = ratio
         self%pi_steps = self%pi_steps - 1
      end if
      self%after_rejection = .not. (norm <= 1)
      if (self%after_rejection) self%rejected_in_phase = .true.
      h_next = h*factor
   end function controller_next_step

   !> x^(m/32) for x > 0 and 0 <= m <= 32, from the square roots x^(1/2), ..., x^(1/32) that
   !> the bits of m pick (no pow: at most five square roots and five products).
   pure function dyadic_power(x, m) result(power)
      real(dp), intent(in) :: x
      integer, intent(in) :: m
      real(dp) :: power, root
      integer :: bit
      power = 1
      if (m >= 32) power = x
      root = x
      do bit = 4, 0, -1
         ! No square root past the last bit of m.
         if (iand(m, 2*2**bit - 1) == 0) exit
         root = sqrt(root)
         if (btest(m, bit)) power = power*root
      end do
   end function dyadic_power

   pure subroutine controller_restart(self)
      class(step_controller_t), intent(inout) :: self
      self%ratio_prev = 0
      self%after_rejection = .false.
      self%rejected_in_phase = .false.
      self%pi_steps = 0
   end subroutine controller_restart

end module tmafm_embedded_pair

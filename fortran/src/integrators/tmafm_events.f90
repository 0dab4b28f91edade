!> Finding a change of phase inside one step, including grazing contacts.
!>
!> Write G = sign * V_T with sign = +1 out of contact and -1 in contact, so that a step
!> starts with G >= 0 and the phase changes where G first drops to or below zero.  A sign
!> check at the step ends misses a contact that begins and ends inside the step.  The cubic
!> Hermite interpolant of G, from G and dG/dtau at both ends (both come from the state alone,
!> no right-hand side), locates an interior minimum; the caller then checks the true G there.
!> A dip shallower than the interpolation error, O(h^4 V_T''''), can still be missed: out of
!> contact the adaptive pairs bound that error and read their dense output where it does not
!> clear a step (tmafm_method_adaptive free_dip_search); flight_exact's flights have their own
!> rigorous scan (tmafm_flight).
!>
!> V_T is a sum of terms of size ~1e-3 that cancel at a switch, so near V_T = 0 its value is
!> round-off noise of a few eps times those terms.  Each phase therefore ends only once
!> V_T is across zero by a margin above that noise (switch_margin, ~1e-18 here): the
!> callers locate side V_T + margin = 0.  Without it a switch landing on V_T = 0 can
!> flip back at once on noise, a chatter of zero-length phases.
module tmafm_events
   use tmafm_kinds, only: dp
   use tmafm_model, only: model_t
   implicit none
   private

   public :: no_event, event_at_end, event_candidate, step_event_test, hermite_minimum
   public :: initial_phase, phase_sign, switch_margin

   !> G stays positive over the step.
   integer, parameter :: no_event = 0
   !> G(h) is on the other side: the bracket is [0, h].
   integer, parameter :: event_at_end = 1
   !> The interpolant dips below zero at s_test: check the true G there.
   integer, parameter :: event_candidate = 2

contains

   !> The phase at a start: contact if V_T < 0, or V_T = 0 with the tip not moving away.
   pure function initial_phase(model, tau, y) result(in_contact)
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: y(:)
      logical :: in_contact
      real(dp) :: vt
      vt = model%tip_gap(tau, y)
      in_contact = vt < 0 .or. (vt == 0 .and. model%tip_gap_rate(tau, y) <= 0)
   end function initial_phase

   !> The round-off level of V_T at a state: 64 eps times the size of the terms of V_T.  The
   !> drive counts with its amplitude alpha2 (with two tones, the sum of theirs), not its value
   !> at tau: the margin is then never zero (at rest at tau = 0 every term vanishes, and a zero
   !> margin let a phase end where it began, a zero-length step, again and again: the
   !> rk4_event dtau = 1 hang).
   pure function switch_margin(model, y) result(margin)
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: y(:)
      real(dp) :: margin
      margin = 64*epsilon(1.0_dp)*(sum(abs(model%tip*y(1:model%n_modes))) &
               + model%drive%size + abs(model%scene%delta_hat)) + tiny(1.0_dp)
   end function switch_margin

   !> +1 out of contact and -1 in contact: G = sign V_T is positive inside the phase.
   elemental function phase_sign(in_contact) result(side)
      logical, intent(in) :: in_contact
      real(dp) :: side
      side = merge(-1.0_dp, 1.0_dp, in_contact)
   end function phase_sign

   !> Classify a step of length h from G and its rate at both ends; s_test is set for a candidate.
   pure subroutine step_event_test(g0, rate0, g1, rate1, h, in_contact, status, s_test)
      real(dp), intent(in) :: g0, rate0, g1, rate1
      real(dp), intent(in) :: h
      logical, intent(in) :: in_contact
      integer, intent(out) :: status
      real(dp), intent(out) :: s_test
      real(dp) :: theta, value

      s_test = h
      if (crossed(g1, in_contact)) then
         status = event_at_end
         return
      end if
      call hermite_minimum(g0, h*rate0, g1, h*rate1, theta, value)
      if (theta > 0 .and. theta < 1 .and. value <= 0) then
         status = event_candidate
         s_test = theta*h
      else
         status = no_event
      end if
   end subroutine step_event_test

   !> Whether G (margin included) has reached the other phase.
   elemental function crossed(g, in_contact) result(yes)
      real(dp), intent(in) :: g
      logical, intent(in) :: in_contact
      logical :: yes
      if (in_contact) then
         yes = g < 0
      else
         yes = g <= 0
      end if
   end function crossed

   !> The smallest interior value of the cubic Hermite through (0, g0, d0) and (1, g1, d1),
   !> with d the derivatives per unit theta; theta = -1 if there is no interior minimum.
   pure subroutine hermite_minimum(g0, d0, g1, d1, theta, value)
      real(dp), intent(in) :: g0, d0, g1, d1
      real(dp), intent(out) :: theta
      real(dp), intent(out) :: value
      real(dp) :: a, b, c, disc, roots(2), t, v
      integer :: k

      ! c(t) = a t^3 + b t^2 + d0 t + g0
      a = 2*g0 + d0 - 2*g1 + d1
      b = -3*g0 - 2*d0 + 3*g1 - d1
      c = d0
      theta = -1
      value = huge(1.0_dp)
      roots = -1
      if (abs(a) > 0) then
         disc = b*b - 3*a*c
         if (disc < 0) return
         ! A numerically stable pair of roots of 3a t^2 + 2b t + c.
         if (b >= 0) then
            t = -(b + sqrt(disc))
         else
            t = -(b - sqrt(disc))
         end if
         if (abs(t) > 0) roots(1) = c/t
         roots(2) = t/(3*a)
      else if (abs(b) > 0) then
         roots(1) = -c/(2*b)
      end if
      do k = 1, 2
         t = roots(k)
         if (t <= 0 .or. t >= 1) cycle
         ! A minimum: second derivative 6 a t + 2 b > 0.
         if (6*a*t + 2*b <= 0) cycle
         v = ((a*t + b)*t + c)*t + g0
         if (v < value) then
            value = v
            theta = t
         end if
      end do
   end subroutine hermite_minimum

end module tmafm_events

!> The Jacobian of the equations of motion, d(a', a'')/d(a, a'), in either phase: what the
!> variational equations of a periodic orbit integrate (docs/continuation.md, section 2).
!>
!> Free of contact it is constant, [0 I; -M^-1 Lambda, -M^-1 C] with C = alpha3 I (per mode in a
!> liquid: model_t%pass_v holds -M^-1 C).  In contact
!> a'' gains tip_push M^-1 p + P2 ((g0/d) M^-1 r + M^-1 G a), with
!> tip_push = (L/d) P1 - alpha4 p.a' + base(tau), and P1, P2 depend on a only through
!> V_T = p.a + ... and the scaled slope t = (d/L) s.a.  So
!>   d a''/d a  = -M^-1 Lambda + P2 M^-1 G + (L/d) M^-1 p (dP1/dV_T p + dP1/dt (d/L) s)^T
!>                + ((g0/d) M^-1 r + M^-1 G a) (dP2/dV_T p + dP2/dt (d/L) s)^T,
!>   d a''/d a' = -M^-1 C - alpha4 M^-1 p p^T.
!> The partial derivatives of P1, P2 are those of tmafm_contact's closed forms, written with
!> r = sqrt(depth) so that none is singular at V_T = 0 (all vanish there for Hertz).
module tmafm_model_jacobian
   use tmafm_kinds, only: dp
   use tmafm_model, only: model_t
   use tmafm_contact, only: law_dmt, dmt_adhesion, contact_angle_sin_cos
   implicit none
   private

   public :: model_jacobian, contact_partials

contains

   !> The 2N x 2N Jacobian jac of (a', a'') with respect to y = (a, a') at time tau, in a phase.
   pure subroutine model_jacobian(model, tau, y, in_contact, jac)
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: y(:)
      logical, intent(in) :: in_contact
      real(dp), intent(out) :: jac(:, :)
      real(dp) :: vt, slope, p1, p2, dp1_dvt, dp1_dt, dp2_dvt, dp2_dt, sin_phase, lever, row1, row2
      integer :: n, i, j

      n = model%n_modes
      jac = 0
      do j = 1, n
         jac(j, n + j) = 1
         do i = 1, n
            jac(n + i, j) = -model%inv_mass_eigen(i, j)
            jac(n + i, n + j) = model%pass_v(i, j)
         end do
      end do
      if (.not. in_contact) return
      associate (s => model%scene)
         sin_phase = sin(s%omega*tau)
         vt = s%alpha2*sin_phase + s%delta_hat
         slope = 0
         do j = 1, n
            vt = vt + model%tip(j)*y(j)
            slope = slope + model%scaled_slope(j)*y(j)
         end do
         call contact_partials(model, vt, slope, p1, p2, dp1_dvt, dp1_dt, dp2_dvt, dp2_dt)
         do i = 1, n
            ! lever = (g0/d) M^-1 r + M^-1 G a: what P2 multiplies.
            lever = model%moment_force(i)
            do j = 1, n
               lever = lever + model%inv_mass_axial(i, j)*y(j)
            end do
            do j = 1, n
               row1 = dp1_dvt*model%tip(j) + dp1_dt*model%scaled_slope(j)
               row2 = dp2_dvt*model%tip(j) + dp2_dt*model%scaled_slope(j)
               jac(n + i, j) = jac(n + i, j) + p2*model%inv_mass_axial(i, j) &
                               + s%l_over_d*model%inv_mass_tip(i)*row1 + lever*row2
               jac(n + i, n + j) = jac(n + i, n + j) - s%alpha4*model%inv_mass_tip(i)*model%tip(j)
            end do
         end do
      end associate
   end subroutine model_jacobian

   !> The brackets P1, P2 at gap vt and scaled slope t, and their partial derivatives with
   !> respect to V_T and t (tmafm_contact: A = sqrt(depth sin theta1/beta), f_c = A^3 [- 4/3],
   !> h = A depth cos theta1, theta1 = pi/2 - theta - atan(|t|) or, under E7, + atan(t)).
   pure subroutine contact_partials(model, vt, slope, p1, p2, dp1_dvt, dp1_dt, dp2_dvt, dp2_dt)
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: vt
      real(dp), intent(in) :: slope
      real(dp), intent(out) :: p1, p2, dp1_dvt, dp1_dt, dp2_dvt, dp2_dt
      real(dp) :: sin1, cos1, depth, root, q, sq, normal, friction, dn_dd, dh_dd, dn_dth, dh_dth
      real(dp) :: dth_dt, t, k5, k6, beta

      call contact_angle_sin_cos(model%sin_theta, model%cos_theta, slope, &
                                 model%errata%e7_signed_slope, sin1, cos1)
      k5 = model%kappa5
      k6 = model%kappa6
      beta = model%scene%beta
      depth = max(-vt, 0.0_dp)
      root = sqrt(depth)
      q = sin1/beta
      sq = sqrt(q)
      ! f_c = depth^1.5 q^1.5 [- 4/3], h = depth^1.5 sqrt(q) cos1.
      normal = root**3*q*sq
      if (model%law == law_dmt) normal = normal - dmt_adhesion
      friction = root**3*sq*cos1
      dn_dd = 1.5_dp*root*q*sq
      dh_dd = 1.5_dp*root*sq*cos1
      ! d/dtheta1: d sin1 = cos1, d cos1 = -sin1.
      dn_dth = 1.5_dp*root**3*sq*cos1/beta
      dh_dth = root**3*(cos1*cos1/(2*beta*sq) - sq*sin1)
      p1 = k5*normal*sin1 + k6*friction*cos1
      p2 = -k5*normal*cos1 + k6*friction*sin1
      ! dV_T = -d depth in contact.
      dp1_dvt = -(k5*dn_dd*sin1 + k6*dh_dd*cos1)
      dp2_dvt = -(-k5*dn_dd*cos1 + k6*dh_dd*sin1)
      if (model%errata%e7_signed_slope) then
         t = -slope
         dth_dt = 1/(1 + t*t)
      else
         t = abs(slope)
         dth_dt = -sign(1.0_dp, slope)/(1 + t*t)
      end if
      dp1_dt = (k5*(dn_dth*sin1 + normal*cos1) + k6*(dh_dth*cos1 - friction*sin1))*dth_dt
      dp2_dt = (-k5*(dn_dth*cos1 - normal*sin1) + k6*(dh_dth*sin1 + friction*cos1))*dth_dt
   end subroutine contact_partials

end module tmafm_model_jacobian

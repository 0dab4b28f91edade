!> The Jacobian of the equations of motion, d(a', a''[, w'])/d(a, a'[, w]), in either phase:
!> what the variational equations of a periodic orbit integrate (docs/continuation.md, section 2).
!>
!> Free of contact (and of any force) it is constant, [0 I; -M^-1 Lambda, -M^-1 C] with
!> C = alpha3 I (per mode in a liquid: model_t%pass_v holds -M^-1 C).  Where the tip-sample force
!> acts (in contact; under 'dmt_vdw' also in flight, docs/model.md §6a)
!> a'' gains tip_push M^-1 p + P2 ((g0/d) M^-1 r + M^-1 G a), with
!> tip_push = (L/d) P1 [- alpha4 p.a' + base(tau), in contact only], and P1, P2 depend on a only
!> through V_T = p.a + Y(tau) + delta_hat (Y the drive's base signal, tmafm_drive) and the scaled
!> slope t = (d/L) s.a.  So
!>   d a''/d a  = -M^-1 Lambda + P2 M^-1 G + (L/d) M^-1 p (dP1/dV_T p + dP1/dt (d/L) s)^T
!>                + ((g0/d) M^-1 r + M^-1 G a) (dP2/dV_T p + dP2/dt (d/L) s)^T,
!>   d a''/d a' = -M^-1 C [- alpha4 M^-1 p p^T, in contact].
!> The brackets are P1 = kappa5 f sin(theta1) + kappa6 h cos(theta1), P2 = -kappa5 f cos(theta1)
!> + kappa6 h sin(theta1) with the normal-force group f and the friction group h of the law:
!>  - Hertz, DMT (tmafm_contact) and 'dmt_vdw' in contact (tmafm_vdw): f = X [- c], X = A^3 =
!>    (depth sin(theta1)/beta)^1.5, h = A depth cos(theta1), c = 4/3 or vdw_adhesion; written
!>    with r = sqrt(depth) so that none of the partials is singular at V_T = 0;
!>  - 'dmt_vdw' in flight: f = -c_H/rho^2, rho = 1 + V_T sin(theta1)/eps, h = 0, so
!>    df/dV_T = 2 c_H sin(theta1)/(eps rho^3), df/dtheta1 = 2 c_H V_T cos(theta1)/(eps rho^3)
!>    (zero where tmafm_vdw clamps rho at 1/2 or sin(theta1) at 0);
!>  - a force at a distance (tmafm_surface_forces, docs/model.md §17) in flight adds g(s) to f,
!>    s = eps + V_T sin(theta1), so df/dV_T += g'(s) sin(theta1), df/dtheta1 += g'(s) V_T cos(theta1)
!>    (zero where s is clamped at eps/2 or sin(theta1) at 0); in contact it adds the constant g(eps);
!>  - a viscoelastic sample (tmafm_viscoelastic, docs/model.md §14) in contact: f = max(X - (1 - r)
!>    w, 0) minus the law's adhesion (0, 4/3 or c_H: it does not relax, docs/model.md §16; under
!>    'dmt_vdw' the flight's attraction sees the undeformed surface), and the state has a third
!>    block, the dashpot coordinate w with w' = (max(X, (1 - r) w) - w)/T: the row of w is
!>    (X_a/T, 0, -1/T) while X > (1 - r) w and (0, 0, -r/T) otherwise (in flight X = 0), and the
!>    column of w in a'' is df/dw = -(1 - r) while X > (1 - r) w (the force's kink there is
!>    continuous: no saltation);
!>  - a capillary meniscus (tmafm_capillary, docs/model.md §19) adds its pull c_C to the adhesion
!>    in contact, and in a flight it holds f = -c_C (1 - V_T sin(theta1)/D), so df/dV_T +=
!>    c_C sin(theta1)/D, df/dtheta1 += c_C V_T cos(theta1)/D.  Whether it holds is a flag of the
!>    state (model_t%wet), the map state's last component: its row and column of J are zero;
!>  - a JKR neck (tmafm_jkr, docs/model.md §18) while it holds: f = A^3 - 2 A^1.5 and h = A (-V_T)
!>    cos(theta1) with A(D) on the stable branch of D = A^2 - (4/3) sqrt(A), D = -V_T sin(theta1)/beta,
!>    so dA/dD = 1/(2A - (2/3)/sqrt(A)) and df/dA = 3A^2 - 3 sqrt(A).  The map state ends with a flag
!>    too, 1 where the neck holds at the period boundary (the phase V_T's sign cannot tell).
!> theta1 = pi/2 - theta - atan(|t|) or, under E7, + atan(t).
module tmafm_model_jacobian
   use tmafm_kinds, only: dp
   use tmafm_model, only: model_t
   use tmafm_contact, only: law_dmt, dmt_adhesion, contact_angle_sin_cos
   use tmafm_vdw, only: law_dmt_vdw
   use tmafm_surface_forces, only: surface_force_group, surface_force_slope, flight_separation
   use tmafm_capillary, only: meniscus_force_group
   use tmafm_jkr, only: law_jkr, jkr_radius, jkr_force_group
   implicit none
   private

   public :: model_jacobian, contact_partials, map_state_size, map_to_model_state, model_to_map_state

contains

   !> The length of the state of the stroboscopic map: 2N, plus 1 with a viscoelastic sample (w),
   !> plus 1 with a capillary meniscus or a JKR neck (the phase's flag, last: the meniscus holds
   !> the tip in flight, or the neck holds): (a, a'[, w][, flag]); model_t's pad y(2N + 2) = 0
   !> without a meniscus is left out, it never changes.
   pure integer function map_state_size(model) result(m)
      type(model_t), intent(in) :: model
      m = 2*model%n_modes
      if (model%sls%on) m = m + 1
      if (model%meniscus%on .or. model%law == law_jkr) m = m + 1
   end function map_state_size

   !> The model's state y (model_t%n_state) of a map state x (map_state_size).
   pure subroutine map_to_model_state(model, x, y)
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: x(:)
      real(dp), intent(out) :: y(:)
      integer :: m
      m = map_state_size(model)
      y = 0
      if (model%meniscus%on) then
         y(1:m - 1) = x(1:m - 1)
         y(model%meniscus_slot) = x(m)
      else if (model%law == law_jkr) then
         ! The neck's flag is the run's phase, not a component of the model's state.
         y(1:m - 1) = x(1:m - 1)
      else
         y(1:m) = x(1:m)
      end if
   end subroutine map_to_model_state

   !> The map state x (map_state_size) of a model's state y.
   pure subroutine model_to_map_state(model, y, x)
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: y(:)
      real(dp), intent(out) :: x(:)
      integer :: m
      m = map_state_size(model)
      if (model%meniscus%on) then
         x(1:m - 1) = y(1:m - 1)
         x(m) = y(model%meniscus_slot)
      else if (model%law == law_jkr) then
         ! The caller sets the neck's flag x(m) from the phase.
         x(1:m - 1) = y(1:m - 1)
         x(m) = 0
      else
         x(1:m) = y(1:m)
      end if
   end subroutine model_to_map_state

   !> The Jacobian jac (map_state_size square) of the time derivative with respect to the state y
   !> (a, a'[, w]; y may hold model_t's pad too) at time tau, in a phase.
   pure subroutine model_jacobian(model, tau, y, in_contact, jac)
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: y(:)
      logical, intent(in) :: in_contact
      real(dp), intent(out) :: jac(:, :)
      real(dp) :: vt, vtdot, slope, p1, p2, dp1_dvt, dp1_dt, dp2_dvt, dp2_dt, dp1_dw, dp2_dw
      real(dp) :: sin_phase, cos_phase, lever, row1, row2, hertz, dx_dvt, dx_dt, w_rate_x, w_rate_w
      integer :: n, i, j, iw
      logical :: wet

      n = model%n_modes
      jac = 0
      do j = 1, n
         jac(j, n + j) = 1
         do i = 1, n
            jac(n + i, j) = -model%inv_mass_eigen(i, j)
            jac(n + i, n + j) = model%pass_v(i, j)
         end do
      end do
      iw = 2*n + 1
      if (model%sls%on) then
         ! In flight X = 0: w' = -r w/T.
         jac(iw, iw) = -model%sls%modulus_ratio*model%sls%rate
      end if
      wet = model%wet(y) .and. .not. in_contact
      if (.not. (in_contact .or. model%long_range .or. wet)) return
      call model%phase(tau, sin_phase, cos_phase)
      call model%gap_at_phase(y, sin_phase, cos_phase, vt, vtdot)
      slope = 0
      do j = 1, n
         slope = slope + model%scaled_slope(j)*y(j)
      end do
      dp1_dw = 0
      dp2_dw = 0
      if (.not. in_contact) then
         ! A force in flight (with a viscoelastic sample too: the attraction sees the undeformed
         ! surface, docs/model.md §16, and w relaxes on its own, as set above).
         call flight_partials(model, vt, slope, wet, p1, p2, dp1_dvt, dp1_dt, dp2_dvt, dp2_dt)
      else if (model%sls%on) then
         call sls_partials(model, vt, slope, y(iw), p1, p2, dp1_dvt, dp1_dt, dp2_dvt, dp2_dt, dp1_dw, &
                           dp2_dw, hertz, dx_dvt, dx_dt)
         ! w' = (max(X, (1 - r) w) - w)/T.
         if (hertz > model%sls%relaxing*y(iw)) then
            w_rate_x = model%sls%rate
            w_rate_w = -model%sls%rate
         else
            w_rate_x = 0
            w_rate_w = -model%sls%modulus_ratio*model%sls%rate
         end if
         do j = 1, n
            jac(iw, j) = w_rate_x*(dx_dvt*model%tip(j) + dx_dt*model%scaled_slope(j))
         end do
         jac(iw, iw) = w_rate_w
      else if (model%law == law_jkr) then
         call jkr_partials(model, vt, slope, p1, p2, dp1_dvt, dp1_dt, dp2_dvt, dp2_dt)
      else
         call contact_partials(model, vt, slope, p1, p2, dp1_dvt, dp1_dt, dp2_dvt, dp2_dt)
      end if
      associate (s => model%scene)
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
               if (in_contact) &
                  jac(n + i, n + j) = jac(n + i, n + j) - s%alpha4*model%inv_mass_tip(i)*model%tip(j)
            end do
            if (model%sls%on) jac(n + i, iw) = s%l_over_d*model%inv_mass_tip(i)*dp1_dw + lever*dp2_dw
         end do
      end associate
   end subroutine model_jacobian

   !> The brackets P1, P2 in contact at gap vt and scaled slope t, and their partial derivatives
   !> with respect to V_T and t: Hertz, DMT, or 'dmt_vdw' (the adhesion vdw_adhesion).
   pure subroutine contact_partials(model, vt, slope, p1, p2, dp1_dvt, dp1_dt, dp2_dvt, dp2_dt)
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: vt
      real(dp), intent(in) :: slope
      real(dp), intent(out) :: p1, p2, dp1_dvt, dp1_dt, dp2_dvt, dp2_dt
      real(dp) :: sin1, cos1, normal, friction, dn_dvt, dh_dvt, dn_dth, dh_dth, dth_dt

      call contact_angle_sin_cos(model%sin_theta, model%cos_theta, slope, &
                                 model%errata%e7_signed_slope, sin1, cos1)
      call hertz_groups(model, vt, sin1, cos1, normal, friction, dn_dvt, dh_dvt, dn_dth, dh_dth)
      normal = normal - law_adhesion(model)
      dth_dt = angle_rate(model, slope)
      call brackets(model, sin1, cos1, normal, friction, dn_dvt, dh_dvt, dn_dth, dh_dth, dth_dt, &
                    p1, p2, dp1_dvt, dp1_dt, dp2_dvt, dp2_dt)
   end subroutine contact_partials

   !> The brackets of a JKR neck at gap vt and scaled slope t and their partial derivatives with
   !> respect to V_T and t (the forces at a distance are not taken: the map refuses them with JKR).
   pure subroutine jkr_partials(model, vt, slope, p1, p2, dp1_dvt, dp1_dt, dp2_dvt, dp2_dt)
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: vt
      real(dp), intent(in) :: slope
      real(dp), intent(out) :: p1, p2, dp1_dvt, dp1_dt, dp2_dvt, dp2_dt
      real(dp) :: sin1, cos1, radius, root, da_dd, df_da, da_dvt, da_dth, normal, friction
      real(dp) :: dn_dvt, dn_dth, dh_dvt, dh_dth
      call contact_angle_sin_cos(model%sin_theta, model%cos_theta, slope, &
                                 model%errata%e7_signed_slope, sin1, cos1)
      radius = jkr_radius(-vt*sin1/model%scene%beta)
      root = sqrt(radius)
      ! dD/dA = 2A - (2/3)/sqrt(A) > 0 on the stable branch (A > 3^(-2/3)); it vanishes at the
      ! pull-off, where f ~ sqrt(D - D_c) (an integrable singularity of J along the orbit), and
      ! past it (a trial stage beyond the switch) tmafm_jkr holds A at A_c: there f is constant.
      if (2*radius - 2/(3*root) > sqrt(epsilon(1.0_dp))) then
         da_dd = 1/(2*radius - 2/(3*root))
      else
         da_dd = 0
      end if
      df_da = 3*radius*radius - 3*root
      da_dvt = -da_dd*sin1/model%scene%beta
      da_dth = -da_dd*vt*cos1/model%scene%beta
      normal = jkr_force_group(radius)
      friction = radius*(-vt)*cos1
      dn_dvt = df_da*da_dvt
      dn_dth = df_da*da_dth
      dh_dvt = da_dvt*(-vt)*cos1 - radius*cos1
      dh_dth = da_dth*(-vt)*cos1 + radius*vt*sin1
      call brackets(model, sin1, cos1, normal, friction, dn_dvt, dh_dvt, dn_dth, dh_dth, angle_rate(model, slope), &
                    p1, p2, dp1_dvt, dp1_dt, dp2_dvt, dp2_dt)
   end subroutine jkr_partials

   !> The brackets in flight (the van der Waals attraction under 'dmt_vdw', the forces at a
   !> distance, a meniscus that holds the tip: wet) and their partial derivatives with respect to
   !> V_T and t.
   pure subroutine flight_partials(model, vt, slope, wet, p1, p2, dp1_dvt, dp1_dt, dp2_dvt, dp2_dt)
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: vt
      real(dp), intent(in) :: slope
      logical, intent(in) :: wet
      real(dp), intent(out) :: p1, p2, dp1_dvt, dp1_dt, dp2_dvt, dp2_dt
      real(dp) :: sin1, cos1, ratio, normal, dn_dvt, dn_dth, c_h, eps, pull, separation
      call contact_angle_sin_cos(model%sin_theta, model%cos_theta, slope, &
                                 model%errata%e7_signed_slope, sin1, cos1)
      eps = model%scene%vdw_range
      dn_dvt = 0
      dn_dth = 0
      normal = 0
      if (model%law == law_dmt_vdw) then
         c_h = model%scene%vdw_adhesion
         ratio = 1 + vt*max(sin1, 0.0_dp)/eps
         if (ratio < 0.5_dp) then
            ratio = 0.5_dp
         else if (sin1 > 0) then
            pull = 2*c_h/(eps*ratio**3)
            dn_dvt = pull*sin1
            dn_dth = pull*vt*cos1
         end if
         normal = -c_h/(ratio*ratio)
      end if
      if (model%surface%on) then
         separation = flight_separation(model%surface, vt, sin1)
         normal = normal + surface_force_group(model%surface, separation)
         if (sin1 > 0 .and. eps + vt*sin1 >= eps/2) then
            pull = surface_force_slope(model%surface, separation)
            dn_dvt = dn_dvt + pull*sin1
            dn_dth = dn_dth + pull*vt*cos1
         end if
      end if
      if (wet) then
         ! -c_C (1 - V_T sin(theta1)/D): linear in the normal gap.
         normal = normal + meniscus_force_group(model%meniscus, vt*sin1)
         dn_dvt = dn_dvt + model%meniscus%strength*sin1/model%meniscus%rupture_gap
         dn_dth = dn_dth + model%meniscus%strength*vt*cos1/model%meniscus%rupture_gap
      end if
      call brackets(model, sin1, cos1, normal, 0.0_dp, dn_dvt, 0.0_dp, dn_dth, 0.0_dp, angle_rate(model, slope), &
                    p1, p2, dp1_dvt, dp1_dt, dp2_dvt, dp2_dt)
   end subroutine flight_partials

   !> The brackets of a viscoelastic sample in contact at gap vt, slope t and dashpot coordinate w,
   !> their partial derivatives with respect to V_T, t and w, and the Hertz variable X = A^3 with
   !> its partials (what w' depends on).
   pure subroutine sls_partials(model, vt, slope, w, p1, p2, dp1_dvt, dp1_dt, dp2_dvt, dp2_dt, dp1_dw, &
                                dp2_dw, hertz, dx_dvt, dx_dt)
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: vt
      real(dp), intent(in) :: slope
      real(dp), intent(in) :: w
      real(dp), intent(out) :: p1, p2, dp1_dvt, dp1_dt, dp2_dvt, dp2_dt, dp1_dw, dp2_dw, hertz, dx_dvt, dx_dt
      real(dp) :: sin1, cos1, normal, friction, dn_dvt, dh_dvt, dn_dth, dh_dth, dth_dt, dn_dw
      call contact_angle_sin_cos(model%sin_theta, model%cos_theta, slope, &
                                 model%errata%e7_signed_slope, sin1, cos1)
      call hertz_groups(model, vt, sin1, cos1, hertz, friction, dx_dvt, dh_dvt, dn_dth, dh_dth)
      dth_dt = angle_rate(model, slope)
      dx_dt = dn_dth*dth_dt
      if (hertz > model%sls%relaxing*w) then
         normal = hertz - model%sls%relaxing*w
         dn_dvt = dx_dvt
         dn_dw = -model%sls%relaxing
      else
         ! The sample has not come back to meet the tip: no normal force.
         normal = 0
         dn_dvt = 0
         dn_dth = 0
         dn_dw = 0
      end if
      ! The adhesion acts outside the contact zone and does not relax (docs/model.md §16).
      normal = normal - law_adhesion(model)
      call brackets(model, sin1, cos1, normal, friction, dn_dvt, dh_dvt, dn_dth, dh_dth, dth_dt, &
                    p1, p2, dp1_dvt, dp1_dt, dp2_dvt, dp2_dt)
      dp1_dw = model%kappa5*dn_dw*sin1
      dp2_dw = -model%kappa5*dn_dw*cos1
   end subroutine sls_partials

   !> The Hertz groups X = A^3 and h = A depth cos(theta1) at gap vt and their partials with
   !> respect to V_T and theta1 (X = depth^1.5 q^1.5, h = depth^1.5 sqrt(q) cos(theta1),
   !> q = sin(theta1)/beta; d sin1 = cos1, d cos1 = -sin1; dV_T = -d depth).
   pure subroutine hertz_groups(model, vt, sin1, cos1, normal, friction, dn_dvt, dh_dvt, dn_dth, dh_dth)
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: vt, sin1, cos1
      real(dp), intent(out) :: normal, friction, dn_dvt, dh_dvt, dn_dth, dh_dth
      real(dp) :: depth, root, q, sq, beta
      beta = model%scene%beta
      depth = max(-vt, 0.0_dp)
      root = sqrt(depth)
      q = sin1/beta
      sq = sqrt(q)
      normal = root**3*q*sq
      friction = root**3*sq*cos1
      dn_dvt = -1.5_dp*root*q*sq
      dh_dvt = -1.5_dp*root*sq*cos1
      dn_dth = 1.5_dp*root**3*sq*cos1/beta
      if (depth > 0) then
         dh_dth = root**3*(cos1*cos1/(2*beta*sq) - sq*sin1)
      else
         dh_dth = 0
      end if
   end subroutine hertz_groups

   !> The law's adhesion in contact, subtracted from the normal-force group: 0 (Hertz), 4/3 (DMT)
   !> or c_H ('dmt_vdw': the attraction's value at contact), less the forces at a distance at the
   !> contact separation, plus a meniscus's pull (tmafm_model's contact_adhesion).
   pure real(dp) function law_adhesion(model) result(adhesion)
      type(model_t), intent(in) :: model
      adhesion = 0
      if (model%law == law_dmt_vdw) then
         adhesion = model%scene%vdw_adhesion
      else if (model%law == law_dmt) then
         adhesion = dmt_adhesion
      end if
      if (model%surface%on) adhesion = adhesion - model%surface_at_contact
      if (model%meniscus%on) adhesion = adhesion + model%meniscus%strength
   end function law_adhesion

   !> dtheta1/dt: 1/(1 + t^2) under E7 (theta1 = pi/2 - theta + atan t), -sign(t)/(1 + t^2) as
   !> printed (theta1 = pi/2 - theta - atan |t|).
   pure real(dp) function angle_rate(model, slope) result(rate)
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: slope
      if (model%errata%e7_signed_slope) then
         rate = 1/(1 + slope*slope)
      else
         rate = -sign(1.0_dp, slope)/(1 + slope*slope)
      end if
   end function angle_rate

   !> P1, P2 from the groups f, h and sin, cos of theta1, and their partials with respect to V_T
   !> and t from those of f and h with respect to V_T and theta1 and dtheta1/dt.
   pure subroutine brackets(model, sin1, cos1, normal, friction, dn_dvt, dh_dvt, dn_dth, dh_dth, dth_dt, &
                            p1, p2, dp1_dvt, dp1_dt, dp2_dvt, dp2_dt)
      type(model_t), intent(in) :: model
      real(dp), intent(in) :: sin1, cos1, normal, friction, dn_dvt, dh_dvt, dn_dth, dh_dth, dth_dt
      real(dp), intent(out) :: p1, p2, dp1_dvt, dp1_dt, dp2_dvt, dp2_dt
      real(dp) :: k5, k6
      k5 = model%kappa5
      k6 = model%kappa6
      p1 = k5*normal*sin1 + k6*friction*cos1
      p2 = -k5*normal*cos1 + k6*friction*sin1
      dp1_dvt = k5*dn_dvt*sin1 + k6*dh_dvt*cos1
      dp2_dvt = -k5*dn_dvt*cos1 + k6*dh_dvt*sin1
      ! d sin1 = cos1 dtheta1, d cos1 = -sin1 dtheta1.
      dp1_dt = (k5*(dn_dth*sin1 + normal*cos1) + k6*(dh_dth*cos1 - friction*sin1))*dth_dt
      dp2_dt = (-k5*(dn_dth*cos1 - normal*sin1) + k6*(dh_dth*sin1 + friction*cos1))*dth_dt
   end subroutine brackets

end module tmafm_model_jacobian

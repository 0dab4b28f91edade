!> The Galerkin equations of motion M a'' + C a' + K a = F, docs/model.md §7,
!> paper Eqs. (15)-(23), in both phases and with each erratum as one named switch.
!>
!> Out of contact:  M = I + alpha1 m m^T, C = alpha3 I, K = Lambda,
!>                  F = alpha2 Omega^2 (alpha1 m + q) sin(Omega tau) - alpha2 alpha3 Omega q cos(Omega tau).
!> In a liquid (docs/model.md, A liquid environment, tmafm_hydrodynamics): M += diag(mu), C = diag(alpha3 + gamma),
!>                  F = alpha2 Omega^2 (alpha1 m + (1 + mu) q) sin - alpha2 Omega C q cos.
!> In contact:      C += alpha4 p p^T, K -= P2 G,
!>                  F += F_damp + (L/d) P1 p + (g0/d) P2 r.
!> With every part (a general drive, a liquid, a viscoelastic sample, van der Waals attraction in
!> flight) the terms add up (docs/model.md §16) and composed_kernel evaluates them all, with the
!> tip-sample law composed in tip_sample_forces; the elastic one-tone scenes keep the kernels below.
!> M is constant: it is factored once (LAPACK dpotrf) and M^-1 is applied to every
!> constant matrix and vector at set-up.  The elastic one-tone right-hand side is one kernel with no
!> allocation and no temporaries: a'' = B (a, a') + w_s sin(Omega tau) + w_c cos(Omega tau),
!> with B = -M^-1 [Lambda | alpha3 I] folded at set-up; in contact the axial term
!> P2 M^-1 G a and the rank-one tip and moment terms are added, from three dot products
!> (p.a, (d/L) s.a, p.a') and one call of the contact forces.  The kernel builds a'' four rows
!> at a time in registers, from copies of the folded terms padded to a multiple of four rows
!> (loops of constant length, no remainder code); for N <= 4 from copies at fixed places in
!> model_t, in one pass over the modes that also forms the dot products.  It computes the part
!> that does not depend on the contact forces while their square roots are under way.  It takes the drive phase
!> as sin/cos(Omega tau) (derivative_at_phase: the pairs compute them once per step), or
!> takes one sin/cos per evaluation (derivative); none of theta1 (see contact_angle_sin_cos).
module tmafm_model
   use tmafm_kinds, only: dp, i8
   use tmafm_errors, only: ok, err_input, err_runtime
   use tmafm_modes, only: beam_roots, mode_shape, max_modes
   use tmafm_galerkin, only: mode_integrals_closed_form, axial_matrix_closed_form, &
      axial_matrix_quadrature, quadrature_panels
   use tmafm_contact, only: contact_brackets_t, contact_brackets, law_hertz, law_dmt, dmt_adhesion, &
      contact_angle_sin_cos, contact_forces, contact_angle
   use tmafm_viscoelastic, only: sls_t, sls_force_group, sls_rate, sls_viscoelastic_part
   use tmafm_scene, only: scene_t
   use tmafm_errata, only: errata_t
   use tmafm_hydrodynamics, only: modal_fluid_loads
   use tmafm_vdw, only: law_dmt_vdw, vdw_brackets, vdw_normal_group
   use tmafm_drive, only: drive_t, init_drive
   use tmafm_surface_forces, only: surface_forces_t, surface_force_group, flight_separation
   use tmafm_jkr, only: law_jkr, jkr_radius, jkr_force_group, jkr_pull_off_depth
   use tmafm_capillary, only: capillary_t, meniscus_force_group
   use tmafm_thermal, only: thermal_t, init_thermal, standard_normals
   implicit none
   private

   public :: model_t, init_model

   !> Rows of a'' the kernel computes together (a fixed count, so that its inner loops have
   !> constant length and need no remainder code; rows past N are zero and dropped).
   integer, parameter :: rows_per_block = 4
   !> The largest n_padded.
   integer, parameter :: n_max_padded = rows_per_block*((max_modes + rows_per_block - 1)/rows_per_block)

   !> Everything fixed for a run: the scene, the Galerkin data and M^-1 applied to them.
   type :: model_t
      !> Number of Galerkin modes N.
      integer :: n_modes = 0
      !> Length of the state y: 2N, or 2N + 2 with a viscoelastic sample or a meniscus: y(2N + 1) =
      !> w, the dashpot coordinate of tmafm_viscoelastic (else 0), and y(2N + 2) = the meniscus's
      !> flag, 1 while a capillary neck holds the tip in flight (else 0); both have a zero
      !> derivative but w's under a viscoelastic sample (the integrators' registers keep an even
      !> length, which their vector loops rely on).
      integer :: n_state = 0
      !> The viscoelastic sample (off: the elastic contact of docs/model.md §6).
      type(sls_t) :: sls
      !> Contact law (law_hertz, law_dmt or law_dmt_vdw).
      integer :: law = law_hertz
      !> The dimensionless scene.
      type(scene_t) :: scene
      !> Which printed forms are corrected.
      type(errata_t) :: errata
      !> Scale of the normal force in the brackets (alpha5, or alpha5/2 under E4).
      real(dp) :: kappa5 = 0
      !> Scale of the friction force in the brackets (alpha6, or alpha6/2 under E4).
      real(dp) :: kappa6 = 0
      !> Terms that do not vanish identically for this scene; the others are skipped.
      logical :: has_contact_damping = .true., has_axial_stiffness = .true., has_moment = .true.
      !> A tip-sample force also out of contact ('dmt_vdw', tmafm_vdw, or a force at a distance,
      !> tmafm_surface_forces), so the flight is forced too.
      logical :: long_range = .false.
      !> The forces at a distance (electrostatic, double layer) that add to the law (off: none).
      type(surface_forces_t) :: surface
      !> Their normal-force group at contact (constant in contact: they see the separation a0).
      real(dp) :: surface_at_contact = 0
      !> The capillary meniscus (tmafm_capillary; off: none), and the index of its flag in y
      !> (2N + 2; 0 when off).
      type(capillary_t) :: meniscus
      integer :: meniscus_slot = 0
      !> The elastic one-tone right-hand side goes to general_kernel: N > rows_per_block.
      logical :: general = .false.
      !> Mode roots beta_j.
      real(dp), allocatable :: beta(:)
      !> Lambda = beta^4, the modal stiffnesses.
      real(dp), allocatable :: eigen(:)
      !> p = phi(xi0): where the contact acts and V_T is measured.
      real(dp), allocatable :: tip(:)
      !> s = phi'(xi0): tip slopes.
      real(dp), allocatable :: slope(:)
      !> (d/L) s: the tip slopes in the units of the contact angle (Eq. 3).
      real(dp), allocatable :: scaled_slope(:)
      !> m: where the tip mass sits, phi(1) (printed) or phi(xi0) (E6).
      real(dp), allocatable :: mass_point(:)
      !> r: the moment shape, phi''(xi0) (printed) or phi'(xi0) (E3).
      real(dp), allocatable :: moment_shape(:)
      !> q = int_0^1 phi.
      real(dp), allocatable :: integral(:)
      !> G_ij = int phi_i phi_j'' over [0,1], or [0, xi0] under E2.
      real(dp), allocatable :: axial(:, :)
      !> M = I + alpha1 m m^T.
      real(dp), allocatable :: mass(:, :)
      !> M^-1.
      real(dp), allocatable :: inv_mass(:, :)
      !> M^-1 Lambda.
      real(dp), allocatable :: inv_mass_eigen(:, :)
      !> M^-1 G.
      real(dp), allocatable :: inv_mass_axial(:, :)
      !> M^-1 p.
      real(dp), allocatable :: inv_mass_tip(:)
      !> M^-1 r.
      real(dp), allocatable :: inv_mass_moment(:)
      !> M^-1 (alpha1 m + q), in a liquid M^-1 (alpha1 m + (1 + mu) q): the inertial drive direction.
      real(dp), allocatable :: inv_mass_inertial(:)
      !> M^-1 q: the damping drive direction.
      real(dp), allocatable :: inv_mass_integral(:)
      !> alpha1 m + (1 + mu) q: what the base's acceleration -Y'' drives (mu = 0 in air).
      real(dp), allocatable :: inertial_load(:)
      !> C q, C_jj = alpha3 + gamma_j: what the base's velocity Y' drives through the beam's (and a
      !> liquid's) damping, with a minus sign.
      real(dp), allocatable :: damped_integral(:)
      !> M^-1 C q: damped_integral as a'' takes it (composed_kernel's drive column with Y').
      real(dp), allocatable :: inv_mass_damped_integral(:)
      !> The contact damper's base term in composed_kernel: damper_base_position Y +
      !> damper_base_rate Y' (-alpha4 Y printed, -alpha4 Y' under E1; 0 without contact damping).
      real(dp) :: damper_base_position = 0, damper_base_rate = 0
      !> N rounded up to a whole number of the kernel's row blocks (rows_per_block).
      integer :: n_padded = 0
      !> For N <= rows_per_block (small_kernel): the folded terms at fixed places in the model,
      !> zero below row N and past column N of each part: B's halves and M^-1 G (columns 1-4,
      !> 5-8, 9-12), then w_s, w_c, M^-1 p and the moment term (columns 13-16).
      real(dp) :: small_fold(rows_per_block, 4*rows_per_block) = 0
      !> For N <= rows_per_block: (p_j, (d/L) s_j) side by side, the two dot products with a.
      real(dp) :: small_gap(2, rows_per_block) = 0
      !> alpha2 Omega: the drive's part of dV_T/dtau is this times cos(Omega tau).
      real(dp) :: drive_rate = 0
      !> B = -[M^-1 Lambda | alpha3 M^-1]: the free a'' is B (a, a') plus the drive.  Its two
      !> halves, and M^-1 G, as the kernel reads them: n_padded x N, zero below row N.
      real(dp), allocatable :: pass_a(:, :), pass_v(:, :), pass_g(:, :)
      !> w_s, w_c, M^-1 p and the moment term (columns 1-4) as the kernel reads them: n_padded
      !> rows, zero below row N.
      real(dp), allocatable :: pass_terms(:, :)
      !> w_s = alpha2 Omega^2 M^-1 (alpha1 m + q): the drive term of a'' that goes with sin(Omega tau).
      real(dp), allocatable :: drive_sin(:)
      !> w_c = -alpha2 alpha3 Omega M^-1 q (in a liquid -alpha2 Omega M^-1 C q): the drive term of
      !> a'' that goes with cos(Omega tau).
      real(dp), allocatable :: drive_cos(:)
      !> (g0/d) M^-1 r: the moment term of a'', times P2 (zero if the moment is off).
      real(dp), allocatable :: moment_force(:)
      !> sin(theta) and cos(theta) of the tilt.
      real(dp) :: sin_theta = 0, cos_theta = 1
      !> The base contact-damping term is base_sin sin(Omega tau) + base_cos cos(Omega tau).
      real(dp) :: base_sin = 0, base_cos = 0
      !> .true. in a liquid (&scene medium_mass > 0): per-mode added mass and damping.
      logical :: has_medium = .false.
      !> Per mode: the added mass mu_j (0 without a liquid), the damping C_jj = alpha3 + gamma_j
      !> (alpha3 without a liquid), and in a liquid the frequency omega_j there and its Reynolds
      !> number R0 omega_j (0 without).
      real(dp), allocatable :: added_mass(:), modal_damping(:), medium_frequency(:), medium_reynolds(:)
      !> The drive's tones and their common frequency (tmafm_drive); the phase the fast forms
      !> take is that of drive%fundamental.
      type(drive_t) :: drive
      !> .true. when a phase ends elsewhere than at V_T = 0: the JKR neck breaks at its pull-off,
      !> a meniscus at its rupture gap (switch_offset).
      logical :: hysteretic = .false.
      !> The right-hand side goes to composed_kernel (a viscoelastic sample, a general drive or a
      !> force in flight, in any combination): the one test the entry points make before rhs_kernel.
      logical :: special_rhs = .false.
      !> The thermal bath (tmafm_thermal, docs/model.md §21; off: none).  A run with noise holds
      !> its own copy of the model and sets noise_accel at each grid interval (set_noise_interval).
      type(thermal_t) :: thermal
      !> M^-1 xi_k: the Langevin force of the current grid interval as a'' takes it (with noise).
      real(dp), allocatable :: noise_accel(:)
      !> The standard normals of the current interval (a register: no allocation per interval).
      real(dp), allocatable :: noise_normals(:)
   contains
      !> Turn the thermal bath on: theta = scene%thermal_energy, the grid step and the seed.
      procedure :: set_thermal => model_set_thermal
      !> The Langevin force of grid interval k (tau in [k Delta, (k + 1) Delta)) into noise_accel.
      procedure :: set_noise_interval => model_set_noise_interval
      !> Time derivative (a', a'') of the state y = (a, a') in a given phase.
      procedure :: derivative => model_derivative
      !> The same, for callers that already hold sin(Omega tau) and cos(Omega tau) (see phase).
      procedure :: derivative_at_phase => model_derivative_at_phase
      !> The same, and also V_T and dV_T/dtau at that state (no extra sin or cos).
      procedure :: derivative_and_gap => model_derivative_and_gap
      !> sin(Omega tau) and cos(Omega tau), the drive phase the fast forms take.
      procedure :: phase => model_phase
      !> The drive's Y, dY/dtau and d2Y/dtau2 from the drive phase (one tone: alpha2 sin(Omega tau)).
      procedure :: drive_signals => model_drive_signals
      !> The tip gap V_T = p.a + alpha2 sin(Omega tau) + delta_hat.
      procedure :: tip_gap => model_tip_gap
      !> The tip gap rate dV_T/dtau = p.a' + alpha2 Omega cos(Omega tau).
      procedure :: tip_gap_rate => model_tip_gap_rate
      !> V_T and dV_T/dtau, for callers that already hold sin(Omega tau) and cos(Omega tau).
      procedure :: gap_at_phase => model_gap_at_phase
      !> The part of dy/dtau in flight that the force at a distance adds to the free system
      !> (zero without one), and V_T, at a state and drive phase.
      procedure :: flight_force => model_flight_force
      !> gap_at_phase for a table of states, one sample per row (the same sums, the same bits).
      procedure :: gap_rows => model_gap_rows
      !> The contact state (angle, radius, brackets) for displacements a at time tau.
      procedure :: contact => model_contact
      !> The same in a given phase: under 'dmt_vdw' the attraction in flight, else contact_state.
      procedure :: forces_in_phase => model_forces_in_phase
      !> The normal force kappa5 f of the tip-sample law at a state y (a, a'[, w]) and time tau: in
      !> contact, and under 'dmt_vdw' in flight too (the phase by the sign of V_T, or as given).
      procedure :: normal_force => model_normal_force
      !> Where the phase of a state ends, as V_T = offset, and d(offset)/dtau: 0 but for a JKR neck
      !> and a meniscus in flight.
      procedure :: switch_offset => model_switch_offset
      !> The switch function of a phase at (tau, y): V_T less the phase's offset (switch_offset),
      !> positive in flight and negative in contact until the phase ends.
      procedure :: switch_gap => model_switch_gap
      !> .true. while a meniscus holds the tip of a state y in flight (its flag in y).
      procedure :: wet => model_wet
      !> At a switch in flight with the meniscus held: .true. where it breaks (V_T near its
      !> rupture gap), .false. where the tip comes back into contact (V_T near 0).
      procedure :: meniscus_breaks => model_meniscus_breaks
      !> The phase after a switch located in a phase (in_contact) at (tau, y), the meniscus's flag
      !> in y set or cleared.
      procedure :: next_phase => model_next_phase
      !> The explicit M, C, K, F of Eq. (15) at one state (a only: a viscoelastic sample's force
      !> is its elastic part, the dashpot w is not taken), for checks and analysis.
      procedure :: matrices => model_matrices
      !> The power of each generalized force on the modes, and the modal energy, at one state.
      procedure :: energy_flow => model_energy_flow
   end type model_t


   !> Indices of the powers returned by energy_flow.
   integer, parameter, public :: power_drive = 1, power_beam_damping = 2, &
      power_contact_damping = 3, power_contact_normal = 4, power_contact_friction = 5, &
      power_contact_viscoelastic = 6, power_contact_adhesion = 7, n_powers = 7

contains

   !> Build the model for n_modes modes of a scene, a contact law and a set of corrections.
   subroutine init_model(model, n_modes, scene, law, errata, ierr, errmsg)
      type(model_t), intent(out) :: model
      integer, intent(in) :: n_modes
      type(scene_t), intent(in) :: scene
      integer, intent(in) :: law
      type(errata_t), intent(in) :: errata
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      real(dp) :: rhs(n_modes, 3*n_modes + 4), axial_end
      integer :: n, j, info

      ierr = ok
      errmsg = ''
      if (n_modes < 1 .or. n_modes > max_modes) then
         ierr = err_input
         write (errmsg, '(a,i0,a,i0)') '&model n_modes = ', n_modes, ': must be 1 to ', max_modes
         return
      end if
      n = n_modes
      model%n_modes = n
      model%sls = sls_t(scene%sls_relaxation_time, scene%sls_modulus_ratio)
      model%meniscus = capillary_t(on=scene%capillary_strength > 0, strength=scene%capillary_strength, &
                                   rupture_gap=scene%capillary_range)
      model%n_state = 2*n
      if (model%sls%on .or. model%meniscus%on) model%n_state = 2*n + 2
      if (model%meniscus%on) model%meniscus_slot = 2*n + 2
      model%law = law
      model%scene = scene
      model%errata = errata
      call init_drive(scene, model%drive, ierr, errmsg)
      if (ierr /= ok) return

      model%beta = beam_roots(n)
      model%eigen = model%beta**4
      model%tip = mode_shape(model%beta, scene%xi0, 0)
      model%slope = mode_shape(model%beta, scene%xi0, 1)
      model%scaled_slope = model%slope/scene%l_over_d
      model%integral = mode_integrals_closed_form(model%beta)

      if (errata%e6_tip_mass_at_xi0) then
         model%mass_point = model%tip
      else
         model%mass_point = mode_shape(model%beta, 1.0_dp, 0)
      end if

      if (errata%e3_moment_through_slope) then
         model%moment_shape = model%slope
      else if (scene%xi0 == 1.0_dp) then
         ! The printed moment multiplies phi''(1), which is zero for every mode (free end).
         allocate (model%moment_shape(n), source=0.0_dp)
      else
         model%moment_shape = mode_shape(model%beta, scene%xi0, 2)
      end if

      if (errata%e4_half_force_scales) then
         model%kappa5 = scene%alpha5/2
         model%kappa6 = scene%alpha6/2
      else
         model%kappa5 = scene%alpha5
         model%kappa6 = scene%alpha6
      end if

      if (errata%e2_axial_span_to_tip .and. scene%xi0 < 1.0_dp) then
         axial_end = scene%xi0
         model%axial = axial_matrix_quadrature(model%beta, axial_end, &
            quadrature_panels(model%beta(n), axial_end))
      else
         model%axial = axial_matrix_closed_form(model%beta)
      end if

      model%has_contact_damping = scene%alpha4 /= 0
      model%surface = surface_forces_t(scene%electrostatic_strength, scene%electrostatic_radius, &
                                       scene%cone_half_angle, scene%g0_over_d, scene%double_layer_strength, &
                                       scene%double_layer_range, scene%vdw_range)
      if (model%surface%on) model%surface_at_contact = surface_force_group(model%surface, scene%vdw_range)
      model%long_range = law == law_dmt_vdw .or. model%surface%on
      model%general = n > rows_per_block
      ! Every part beyond the elastic one-tone contact in air-or-liquid goes to the one composed
      ! kernel; the fast kernels stay as the elastic scenes had them.
      model%hysteretic = law == law_jkr .or. model%meniscus%on
      model%special_rhs = model%sls%on .or. model%drive%general .or. model%long_range .or. model%hysteretic
      model%has_axial_stiffness = model%kappa5 /= 0 .or. model%kappa6 /= 0
      model%has_moment = model%has_axial_stiffness .and. scene%g0_over_d /= 0 &
                         .and. any(model%moment_shape /= 0)

      allocate (model%mass(n, n))
      model%mass = scene%alpha1*spread(model%mass_point, 2, n)*spread(model%mass_point, 1, n)
      do j = 1, n
         model%mass(j, j) = model%mass(j, j) + 1.0_dp
      end do

      ! A liquid: each mode's added mass and damping at its frequency in the liquid, on the
      ! diagonal (the modes stay uncoupled by the liquid; docs/model.md, A liquid environment).
      allocate (model%added_mass(n), model%medium_frequency(n), model%medium_reynolds(n), source=0.0_dp)
      allocate (model%modal_damping(n), source=scene%alpha3)
      model%has_medium = scene%medium_mass > 0 .or. scene%medium_reynolds > 0
      if (model%has_medium) then
         block
            real(dp) :: inertia(n), fluid_damping(n)
            do j = 1, n
               inertia(j) = model%mass(j, j)
            end do
            call modal_fluid_loads(model%eigen, inertia, scene%medium_mass, scene%medium_reynolds, &
                                   model%added_mass, fluid_damping, model%medium_frequency, &
                                   model%medium_reynolds, ierr, errmsg)
            if (ierr /= ok) return
            do j = 1, n
               model%mass(j, j) = model%mass(j, j) + model%added_mass(j)
            end do
            model%modal_damping = scene%alpha3 + fluid_damping
         end block
      end if
      ! Columns: I | Lambda | G | p | r | alpha1 m + q | q, all solved with one factorisation.
      rhs = 0
      do j = 1, n
         rhs(j, j) = 1.0_dp
         rhs(j, n + j) = model%eigen(j)
      end do
      rhs(:, 2*n + 1:3*n) = model%axial
      rhs(:, 3*n + 1) = model%tip
      rhs(:, 3*n + 2) = model%moment_shape
      rhs(:, 3*n + 3) = scene%alpha1*model%mass_point + model%integral
      ! The liquid's added mass moves with the base too (the liquid rests in the lab frame).
      if (model%has_medium) rhs(:, 3*n + 3) = rhs(:, 3*n + 3) + model%added_mass*model%integral
      rhs(:, 3*n + 4) = model%integral
      block
         real(dp) :: factor(n, n)
         factor = model%mass
         call dpotrf('L', n, factor, n, info)
         if (info == 0) call dpotrs('L', n, size(rhs, 2), factor, n, rhs, n, info)
      end block
      if (info /= 0) then
         ierr = err_runtime
         write (errmsg, '(a,i0)') 'mass matrix factorisation failed: LAPACK info = ', info
         return
      end if
      model%inv_mass = rhs(:, 1:n)
      model%inv_mass_eigen = rhs(:, n + 1:2*n)
      model%inv_mass_axial = rhs(:, 2*n + 1:3*n)
      model%inv_mass_tip = rhs(:, 3*n + 1)
      model%inv_mass_moment = rhs(:, 3*n + 2)
      model%inv_mass_inertial = rhs(:, 3*n + 3)
      model%inv_mass_integral = rhs(:, 3*n + 4)
      model%inertial_load = scene%alpha1*model%mass_point + (1 + model%added_mass)*model%integral
      model%damped_integral = model%modal_damping*model%integral
      model%inv_mass_damped_integral = matmul(model%inv_mass, model%damped_integral)

      ! The folded forms the right-hand side uses.
      model%n_padded = rows_per_block*((n + rows_per_block - 1)/rows_per_block)
      allocate (model%pass_a(model%n_padded, n), model%pass_v(model%n_padded, n), &
                model%pass_g(model%n_padded, n), model%pass_terms(model%n_padded, 4), source=0.0_dp)
      associate (s => scene)
         model%pass_a(1:n, :) = -model%inv_mass_eigen
         if (model%has_medium) then
            do j = 1, n
               model%pass_v(1:n, j) = -model%modal_damping(j)*model%inv_mass(:, j)
            end do
         else
            model%pass_v(1:n, :) = -s%alpha3*model%inv_mass
         end if
         model%pass_g(1:n, :) = model%inv_mass_axial
         model%drive_rate = s%alpha2*s%omega
         model%drive_sin = s%alpha2*s%omega**2*model%inv_mass_inertial
         if (model%has_medium) then
            model%drive_cos = -s%alpha2*s%omega*matmul(model%inv_mass, model%modal_damping*model%integral)
         else
            model%drive_cos = -s%alpha2*s%alpha3*s%omega*model%inv_mass_integral
         end if
         if (model%has_moment) then
            model%moment_force = s%g0_over_d*model%inv_mass_moment
         else
            allocate (model%moment_force(n), source=0.0_dp)
         end if
         model%sin_theta = sin(s%theta)
         model%cos_theta = cos(s%theta)
         if (.not. model%has_contact_damping) then
            model%base_sin = 0
            model%base_cos = 0
         else if (errata%e1_base_damping_velocity) then
            model%base_sin = 0
            model%base_cos = -s%alpha2*s%alpha4*s%omega
         else
            model%base_sin = -s%alpha2*s%alpha4
            model%base_cos = 0
         end if
      end associate
      model%pass_terms(1:n, 1) = model%drive_sin
      model%pass_terms(1:n, 2) = model%drive_cos
      if (model%has_contact_damping .and. errata%e1_base_damping_velocity) then
         model%damper_base_rate = -scene%alpha4
      else if (model%has_contact_damping) then
         model%damper_base_position = -scene%alpha4
      end if
      model%pass_terms(1:n, 3) = model%inv_mass_tip
      model%pass_terms(1:n, 4) = model%moment_force
      if (n <= rows_per_block) then
         do j = 1, n
            model%small_fold(:, j) = model%pass_a(:, j)
            model%small_fold(:, rows_per_block + j) = model%pass_v(:, j)
            model%small_fold(:, 2*rows_per_block + j) = model%pass_g(:, j)
            model%small_gap(:, j) = [model%tip(j), model%scaled_slope(j)]
         end do
         model%small_fold(:, 3*rows_per_block + 1:) = model%pass_terms
      end if
   end subroutine init_model

   pure subroutine model_phase(self, tau, sin_phase, cos_phase)
      class(model_t), intent(in) :: self
      real(dp), intent(in) :: tau
      real(dp), intent(out) :: sin_phase
      real(dp), intent(out) :: cos_phase
      real(dp) :: phase
      phase = self%drive%fundamental*tau
      sin_phase = sin(phase)
      cos_phase = cos(phase)
   end subroutine model_phase

   pure subroutine model_drive_signals(self, sin_phase, cos_phase, y, ydot, yddot)
      class(model_t), intent(in) :: self
      real(dp), intent(in) :: sin_phase
      real(dp), intent(in) :: cos_phase
      real(dp), intent(out) :: y
      real(dp), intent(out) :: ydot
      real(dp), intent(out) :: yddot
      if (self%drive%general) then
         call self%drive%base(sin_phase, cos_phase, y, ydot, yddot)
      else
         y = self%scene%alpha2*sin_phase
         ydot = self%drive_rate*cos_phase
         yddot = -(self%scene%omega**2*y)
      end if
   end subroutine model_drive_signals

   pure function model_tip_gap(self, tau, y) result(vt)
      class(model_t), intent(in) :: self
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: y(:)
      real(dp) :: vt, vtdot
      call self%gap_at_phase(y, sin(self%drive%fundamental*tau), cos(self%drive%fundamental*tau), vt, vtdot)
   end function model_tip_gap

   pure function model_tip_gap_rate(self, tau, y) result(vtdot)
      class(model_t), intent(in) :: self
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: y(:)
      real(dp) :: vtdot, vt
      call self%gap_at_phase(y, sin(self%drive%fundamental*tau), cos(self%drive%fundamental*tau), vt, vtdot)
   end function model_tip_gap_rate

   pure subroutine model_gap_at_phase(self, y, sin_phase, cos_phase, vt, vtdot)
      class(model_t), intent(in) :: self
      real(dp), intent(in) :: y(:)
      real(dp), intent(in) :: sin_phase
      real(dp), intent(in) :: cos_phase
      real(dp), intent(out) :: vt
      real(dp), intent(out) :: vtdot
      integer :: n, j
      n = self%n_modes
      vt = 0
      vtdot = 0
      do j = 1, n
         vt = vt + self%tip(j)*y(j)
         vtdot = vtdot + self%tip(j)*y(n + j)
      end do
      if (self%drive%general) then
         call add_general_drive(self, sin_phase, cos_phase, vt, vtdot)
         return
      end if
      vt = vt + self%scene%alpha2*sin_phase + self%scene%delta_hat
      vtdot = vtdot + self%scene%alpha2*self%scene%omega*cos_phase
   end subroutine model_gap_at_phase

   !> gap_at_phase's drive terms for a general drive (tmafm_drive): the base motion and its rate.
   pure subroutine add_general_drive(self, sin_phase, cos_phase, vt, vtdot)
      class(model_t), intent(in) :: self
      real(dp), intent(in) :: sin_phase
      real(dp), intent(in) :: cos_phase
      real(dp), intent(inout) :: vt
      real(dp), intent(inout) :: vtdot
      real(dp) :: base, base_rate, base_accel
      call self%drive%base(sin_phase, cos_phase, base, base_rate, base_accel)
      vt = vt + base + self%scene%delta_hat
      vtdot = vtdot + base_rate
   end subroutine add_general_drive

   !> V_T and dV_T/dtau at rows first .. first + count - 1 of a table of states, one sample per
   !> row (a and adot: rows x N), whose drive phases are sin_phase(i), cos_phase(i): gap_at_phase's
   !> sums in its order (from 0, over the modes in order, then the drive, then delta_hat: so
   !> the same bits).  From gap_rows_vector rows up, a mode at a time for all the rows (the
   !> loops run down the columns and vectorise); fewer rows (a sample or two per flight) a row
   !> at a time, with no vector set-up.  Explicit shapes: the trajectory passes its arrays whole.
   pure subroutine model_gap_rows(self, rows, first, count, a, adot, sin_phase, cos_phase, vt, vtdot)
      class(model_t), intent(in) :: self
      integer, intent(in) :: rows
      integer, intent(in) :: first
      integer, intent(in) :: count
      real(dp), intent(in) :: a(rows, self%n_modes)
      real(dp), intent(in) :: adot(rows, self%n_modes)
      real(dp), intent(in) :: sin_phase(count)
      real(dp), intent(in) :: cos_phase(count)
      real(dp), intent(inout) :: vt(rows)
      real(dp), intent(inout) :: vtdot(rows)
      integer, parameter :: gap_rows_vector = 8
      real(dp) :: p, alpha2, delta_hat, drive_rate, x, xdot, base, base_rate, base_accel
      integer :: i, j, last
      last = first + count - 1
      if (self%drive%general) then
         ! A general drive: gap_at_phase's sums, a row at a time.
         do i = first, last
            x = 0
            xdot = 0
            do j = 1, self%n_modes
               x = x + self%tip(j)*a(i, j)
               xdot = xdot + self%tip(j)*adot(i, j)
            end do
            call self%drive%base(sin_phase(i - first + 1), cos_phase(i - first + 1), base, base_rate, base_accel)
            vt(i) = x + base + self%scene%delta_hat
            vtdot(i) = xdot + base_rate
         end do
         return
      end if
      alpha2 = self%scene%alpha2
      delta_hat = self%scene%delta_hat
      drive_rate = self%scene%alpha2*self%scene%omega
      if (count < gap_rows_vector) then
         do i = first, last
            x = 0
            xdot = 0
            do j = 1, self%n_modes
               x = x + self%tip(j)*a(i, j)
               xdot = xdot + self%tip(j)*adot(i, j)
            end do
            vt(i) = x + alpha2*sin_phase(i - first + 1) + delta_hat
            vtdot(i) = xdot + drive_rate*cos_phase(i - first + 1)
         end do
         return
      end if
      p = self%tip(1)
      do i = first, last
         vt(i) = 0 + p*a(i, 1)
         vtdot(i) = 0 + p*adot(i, 1)
      end do
      do j = 2, self%n_modes
         p = self%tip(j)
         do i = first, last
            vt(i) = vt(i) + p*a(i, j)
            vtdot(i) = vtdot(i) + p*adot(i, j)
         end do
      end do
      do i = 1, count
         vt(first + i - 1) = vt(first + i - 1) + alpha2*sin_phase(i) + delta_hat
         vtdot(first + i - 1) = vtdot(first + i - 1) + drive_rate*cos_phase(i)
      end do
   end subroutine model_gap_rows

   pure function model_contact(self, tau, a) result(state)
      class(model_t), intent(in) :: self
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: a(:)
      type(contact_brackets_t) :: state
      real(dp) :: vt, scaled_slope, base, base_rate, base_accel
      if (self%drive%general) then
         call self%drive%base(sin(self%drive%fundamental*tau), cos(self%drive%fundamental*tau), base, base_rate, &
                              base_accel)
         vt = dot_product(self%tip, a) + base + self%scene%delta_hat
      else
         vt = dot_product(self%tip, a) + self%scene%alpha2*sin(self%scene%omega*tau) &
              + self%scene%delta_hat
      end if
      scaled_slope = dot_product(self%slope, a)/self%scene%l_over_d
      if (self%long_range .or. self%hysteretic) then
         ! The phase by the sign of V_T (a run's located switches put it there; a JKR neck
         ! stretched above the surface, or a meniscus in flight, needs the phase given:
         ! forces_in_phase).
         state = phase_brackets(self, vt <= 0, vt, scaled_slope, .false.)
         return
      end if
      state = contact_brackets(vt, scaled_slope, self%scene%theta, self%scene%beta, self%law, &
                               self%kappa5, self%kappa6, self%errata%e7_signed_slope)
   end function model_contact

   pure function model_forces_in_phase(self, tau, a, in_contact, wet) result(state)
      class(model_t), intent(in) :: self
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: a(:)
      logical, intent(in) :: in_contact
      !> A meniscus holds the tip in flight (default .false.).
      logical, intent(in), optional :: wet
      type(contact_brackets_t) :: state
      real(dp) :: vt, scaled_slope, base, base_rate, base_accel
      logical :: held
      held = .false.
      if (present(wet)) held = wet .and. self%meniscus%on
      if (.not. (self%long_range .or. self%hysteretic)) then
         state = self%contact(tau, a)
         return
      end if
      call model_drive_signals(self, sin(self%drive%fundamental*tau), cos(self%drive%fundamental*tau), &
                               base, base_rate, base_accel)
      vt = dot_product(self%tip, a) + base + self%scene%delta_hat
      scaled_slope = dot_product(self%slope, a)/self%scene%l_over_d
      state = phase_brackets(self, in_contact, vt, scaled_slope, held)
   end function model_forces_in_phase

   !> The brackets of the law in a phase, with a force in flight ('dmt_vdw' or a force at a
   !> distance): the law's in contact (under 'dmt_vdw' with c_H), the van der Waals tail in flight
   !> under 'dmt_vdw' (else nothing), and the forces at a distance added in both phases (at the
   !> contact separation in contact); a meniscus's pull in contact, and in flight while it holds
   !> (wet).
   pure function phase_brackets(self, in_contact, vt, scaled_slope, wet) result(state)
      type(model_t), intent(in) :: self
      logical, intent(in) :: in_contact
      real(dp), intent(in) :: vt
      real(dp), intent(in) :: scaled_slope
      logical, intent(in) :: wet
      type(contact_brackets_t) :: state
      real(dp) :: sin1, cos1, normal
      if (self%law == law_jkr .and. in_contact) then
         ! The JKR neck with the forces at a distance at its separation (tip_sample_forces).
         state%theta1 = contact_angle(self%scene%theta, scaled_slope, self%errata%e7_signed_slope)
         call contact_angle_sin_cos(self%sin_theta, self%cos_theta, scaled_slope, self%errata%e7_signed_slope, &
                                    sin1, cos1)
         call jkr_contact(self, vt, sin1, cos1, state%radius, state%normal, state%friction)
         state%transverse = self%kappa5*state%normal*sin1 + self%kappa6*state%friction*cos1
         state%axial = -self%kappa5*state%normal*cos1 + self%kappa6*state%friction*sin1
         return
      else if (self%law == law_dmt_vdw) then
         state = vdw_brackets(in_contact, vt, scaled_slope, self%scene%theta, self%scene%beta, self%kappa5, &
                              self%kappa6, self%errata%e7_signed_slope, self%scene%vdw_adhesion, &
                              self%scene%vdw_range)
      else if (in_contact) then
         state = contact_brackets(vt, scaled_slope, self%scene%theta, self%scene%beta, self%law, &
                                  self%kappa5, self%kappa6, self%errata%e7_signed_slope)
      else
         state%theta1 = contact_angle(self%scene%theta, scaled_slope, self%errata%e7_signed_slope)
      end if
      if (.not. (self%surface%on .or. self%meniscus%on)) return
      call contact_angle_sin_cos(self%sin_theta, self%cos_theta, scaled_slope, self%errata%e7_signed_slope, &
                                 sin1, cos1)
      normal = 0
      if (in_contact) then
         if (self%surface%on) normal = self%surface_at_contact
         if (self%meniscus%on) normal = normal - self%meniscus%strength
      else
         if (self%surface%on) normal = surface_force_group(self%surface, flight_separation(self%surface, vt, sin1))
         if (wet) normal = normal + meniscus_force_group(self%meniscus, vt*sin1)
      end if
      state%normal = state%normal + normal
      state%transverse = state%transverse + self%kappa5*normal*sin1
      state%axial = state%axial - self%kappa5*normal*cos1
   end function phase_brackets

   !> kappa5 f: the normal force group of the elastic law (§6), or with a viscoelastic sample
   !> and y = (a, a', w) the sample's (tmafm_viscoelastic), in the units of the brackets.
   pure function model_normal_force(self, tau, y, in_contact) result(force)
      class(model_t), intent(in) :: self
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: y(:)
      !> The phase (default: by the sign of V_T); under 'dmt_vdw' it picks the branch of the law.
      logical, intent(in), optional :: in_contact
      real(dp) :: force
      type(contact_brackets_t) :: state
      integer :: n
      n = self%n_modes
      if (present(in_contact)) then
         state = self%forces_in_phase(tau, y(1:n), in_contact, self%wet(y))
         if (.not. (in_contact .or. self%long_range .or. self%wet(y))) then
            force = 0
            return
         end if
      else if (self%wet(y)) then
         ! A meniscus holds the tip (its flag in y): the phase by the sign of V_T, its pull in both.
         state = self%forces_in_phase(tau, y(1:n), self%tip_gap(tau, y) <= 0, .true.)
      else
         state = self%contact(tau, y(1:n))
      end if
      force = self%kappa5*state%normal
      if (self%sls%on .and. size(y) > 2*n) &
         force = force + self%kappa5*sls_viscoelastic_part(self%sls, state%radius**3, y(2*n + 1))
   end function model_normal_force

   !> The tip gap at which a phase ends, V_T = offset, and the offset's rate at a state y = (a, a')
   !> whose V_T and dV_T/dtau are vt and vt_rate: 0 and 0, but for a JKR neck (in contact under
   !> 'jkr'), which breaks at the normal indentation D_c beta, V_T = -D_c beta/sin(theta1), so
   !> offset' = -offset cos(theta1)/sin(theta1) dtheta1/dtau; and for a meniscus that holds the tip
   !> in flight, which ends both where it breaks, V_T = o = D/sin(theta1), and where the tip
   !> touches again, V_T = 0: one switch V_T (1 - V_T/o) = 0, offset = V_T^2/o.
   pure subroutine model_switch_offset(self, y, in_contact, vt, vt_rate, offset, rate)
      class(model_t), intent(in) :: self
      real(dp), intent(in) :: y(:)
      logical, intent(in) :: in_contact
      real(dp), intent(in) :: vt
      real(dp), intent(in) :: vt_rate
      real(dp), intent(out) :: offset
      real(dp), intent(out) :: rate
      real(dp) :: slope, slope_rate, sin1, cos1, rupture, rupture_rate
      offset = 0
      rate = 0
      if (.not. self%hysteretic) return
      if (in_contact .and. self%law == law_jkr) then
         call angle_of_state(self, y, sin1, cos1, slope, slope_rate)
         ! A beam bent past the tilt (sin(theta1) <= 0) keeps the neck: it breaks only below it.
         sin1 = max(sin1, epsilon(1.0_dp))
         offset = -jkr_pull_off_depth*self%scene%beta/sin1
         rate = -offset*cos1/sin1*contact_angle_rate(self, slope, slope_rate)
      else if (.not. in_contact .and. self%wet(y)) then
         call angle_of_state(self, y, sin1, cos1, slope, slope_rate)
         sin1 = max(sin1, epsilon(1.0_dp))
         rupture = self%meniscus%rupture_gap/sin1
         rupture_rate = -rupture*cos1/sin1*contact_angle_rate(self, slope, slope_rate)
         offset = vt**2/rupture
         rate = (2*vt*vt_rate - offset*rupture_rate)/rupture
      end if
   end subroutine model_switch_offset

   pure real(dp) function model_switch_gap(self, tau, y, in_contact) result(gap)
      class(model_t), intent(in) :: self
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: y(:)
      logical, intent(in) :: in_contact
      real(dp) :: offset, offset_rate
      gap = self%tip_gap(tau, y)
      if (.not. self%hysteretic) return
      call self%switch_offset(y, in_contact, gap, 0.0_dp, offset, offset_rate)
      gap = gap - offset
   end function model_switch_gap

   !> sin and cos of the contact angle theta1 at a state y = (a, a'), with the slope p'.a/(L/d)
   !> and its rate.
   pure subroutine angle_of_state(self, y, sin1, cos1, slope, slope_rate)
      type(model_t), intent(in) :: self
      real(dp), intent(in) :: y(:)
      real(dp), intent(out) :: sin1
      real(dp), intent(out) :: cos1
      real(dp), intent(out) :: slope
      real(dp), intent(out) :: slope_rate
      integer :: n, j
      n = self%n_modes
      slope = 0
      slope_rate = 0
      do j = 1, n
         slope = slope + self%scaled_slope(j)*y(j)
         slope_rate = slope_rate + self%scaled_slope(j)*y(n + j)
      end do
      call contact_angle_sin_cos(self%sin_theta, self%cos_theta, slope, self%errata%e7_signed_slope, sin1, cos1)
   end subroutine angle_of_state

   !> The phase after a switch located in phase in_contact at (tau, y): the other one, but with a
   !> meniscus (model_t%meniscus), which forms at contact and holds the tip in flight until it
   !> breaks: a contact's exit leaves it holding (its flag in y set), and a held flight ends in
   !> contact, or where the meniscus breaks in a free flight (its flag cleared).
   pure subroutine model_next_phase(model, tau, y, in_contact)
      class(model_t), intent(in) :: model
      real(dp), intent(in) :: tau
      real(dp), intent(inout) :: y(:)
      logical, intent(inout) :: in_contact
      if (model%meniscus_slot == 0) then
         in_contact = .not. in_contact
      else if (in_contact) then
         in_contact = .false.
         y(model%meniscus_slot) = 1
      else if (model%wet(y) .and. model%meniscus_breaks(tau, y)) then
         y(model%meniscus_slot) = 0
      else
         in_contact = .true.
      end if
   end subroutine model_next_phase

   !> .true. while a meniscus holds the tip of y in flight: its flag y(2N + 2) is set.
   pure logical function model_wet(self, y) result(wet)
      class(model_t), intent(in) :: self
      real(dp), intent(in) :: y(:)
      wet = .false.
      if (self%meniscus_slot == 0) return
      if (size(y) < self%meniscus_slot) return
      wet = y(self%meniscus_slot) > 0.5_dp
   end function model_wet

   !> At a switch of a held flight: .true. where V_T is nearer the rupture gap D/sin(theta1) than 0.
   pure logical function model_meniscus_breaks(self, tau, y) result(breaks)
      class(model_t), intent(in) :: self
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: y(:)
      real(dp) :: sin1, cos1, slope, slope_rate
      call angle_of_state(self, y, sin1, cos1, slope, slope_rate)
      breaks = 2*self%tip_gap(tau, y)*max(sin1, epsilon(1.0_dp)) > self%meniscus%rupture_gap
   end function model_meniscus_breaks

   !> d(delta_n)/dtau for the normal indentation delta_n = -V_T sin(theta1) (§6), given sin and
   !> cos of theta1: -V_T' sin(theta1) - V_T cos(theta1) theta1', theta1' from the slope's rate
   !> (Eq. 3, or E7's signed form).
   pure function normal_indentation_rate(self, tau, a, adot, sin1, cos1) result(rate)
      type(model_t), intent(in) :: self
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: a(:)
      real(dp), intent(in) :: adot(:)
      real(dp), intent(in) :: sin1
      real(dp), intent(in) :: cos1
      real(dp) :: rate, vt, vt_rate, slope, slope_rate, base, base_rate, base_accel
      call model_drive_signals(self, sin(self%drive%fundamental*tau), cos(self%drive%fundamental*tau), &
                               base, base_rate, base_accel)
      associate (s => self%scene)
         vt = dot_product(self%tip, a) + base + s%delta_hat
         vt_rate = dot_product(self%tip, adot) + base_rate
         slope = dot_product(self%slope, a)/s%l_over_d
         slope_rate = dot_product(self%slope, adot)/s%l_over_d
      end associate
      rate = -vt_rate*sin1 - vt*cos1*contact_angle_rate(self, slope, slope_rate)
   end function normal_indentation_rate

   !> dtheta1/dtau from the scaled slope t and its rate: t'/(1 + t^2) under E7 (theta1 = pi/2 -
   !> theta + atan t), -sign(t) t'/(1 + t^2) as printed (theta1 = pi/2 - theta - atan |t|).
   pure real(dp) function contact_angle_rate(self, slope, slope_rate) result(rate)
      type(model_t), intent(in) :: self
      real(dp), intent(in) :: slope
      real(dp), intent(in) :: slope_rate
      rate = slope_rate/(1 + slope*slope)
      if (.not. self%errata%e7_signed_slope) rate = -sign(1.0_dp, slope)*rate
   end function contact_angle_rate

   !> The contact-damping base term: -alpha2 alpha4 sin(Omega tau) (printed) or E1's velocity form.
   pure function base_damping(self, tau) result(value)
      class(model_t), intent(in) :: self
      real(dp), intent(in) :: tau
      real(dp) :: value
      real(dp) :: base, base_rate, base_accel
      if (self%drive%general) then
         call self%drive%base(sin(self%drive%fundamental*tau), cos(self%drive%fundamental*tau), base, base_rate, &
                              base_accel)
         if (self%errata%e1_base_damping_velocity) then
            value = -self%scene%alpha4*base_rate
         else
            value = -self%scene%alpha4*base
         end if
         return
      end if
      associate (s => self%scene)
         if (self%errata%e1_base_damping_velocity) then
            value = -s%alpha2*s%alpha4*s%omega*cos(s%omega*tau)
         else
            value = -s%alpha2*s%alpha4*sin(s%omega*tau)
         end if
      end associate
   end function base_damping

   !> F's drive part at tau (Eq. 15, free): -Y'' (alpha1 m + (1 + mu) q) - Y' C q, the base's
   !> inertia (with a liquid's added mass) and the beam's (and liquid's) damper on the base
   !> velocity; one tone in air: alpha2 Omega^2 (alpha1 m + q) sin(Omega tau)
   !> - alpha2 alpha3 Omega q cos(Omega tau).
   pure function drive_force(self, tau) result(force)
      type(model_t), intent(in) :: self
      real(dp), intent(in) :: tau
      real(dp) :: force(self%n_modes)
      integer :: k
      do k = 1, self%n_modes
         force(k) = drive_force_of(self, tau, k)
      end do
   end function drive_force

   !> Component k of drive_force.
   pure real(dp) function drive_force_of(self, tau, k) result(force)
      type(model_t), intent(in) :: self
      real(dp), intent(in) :: tau
      integer, intent(in) :: k
      real(dp) :: base, base_rate, base_accel
      associate (s => self%scene)
         if (self%drive%general) then
            call self%drive%base(sin(self%drive%fundamental*tau), cos(self%drive%fundamental*tau), base, &
                                 base_rate, base_accel)
            force = -base_accel*self%inertial_load(k) - base_rate*self%damped_integral(k)
         else
            force = s%alpha2*s%omega**2*(s%alpha1*self%mass_point(k) + self%integral(k))*sin(s%omega*tau) &
                    - s%alpha2*s%alpha3*s%omega*self%integral(k)*cos(s%omega*tau)
         end if
      end associate
   end function drive_force_of

   pure subroutine model_derivative(self, tau, y, in_contact, dydt)
      class(model_t), intent(in) :: self
      real(dp), intent(in) :: tau
      real(dp), intent(in), contiguous :: y(:)
      logical, intent(in) :: in_contact
      real(dp), intent(out), contiguous :: dydt(:)
      real(dp) :: sin_phase, cos_phase, vt, vtdot
      call model_phase(self, tau, sin_phase, cos_phase)
      if (self%special_rhs) then
         call composed_kernel(self, y, in_contact, sin_phase, cos_phase, dydt, vt, vtdot)
      else
         call rhs_kernel(self, y, in_contact, sin_phase, cos_phase, .false., dydt, vt, vtdot)
      end if
   end subroutine model_derivative

   pure subroutine model_derivative_at_phase(self, y, in_contact, sin_phase, cos_phase, dydt)
      class(model_t), intent(in) :: self
      real(dp), intent(in), contiguous :: y(:)
      logical, intent(in) :: in_contact
      real(dp), intent(in) :: sin_phase
      real(dp), intent(in) :: cos_phase
      real(dp), intent(out), contiguous :: dydt(:)
      real(dp) :: vt, vtdot
      if (self%special_rhs) then
         call composed_kernel(self, y, in_contact, sin_phase, cos_phase, dydt, vt, vtdot)
      else
         call rhs_kernel(self, y, in_contact, sin_phase, cos_phase, .false., dydt, vt, vtdot)
      end if
   end subroutine model_derivative_at_phase

   pure subroutine model_derivative_and_gap(self, y, in_contact, sin_phase, cos_phase, dydt, vt, vtdot)
      class(model_t), intent(in) :: self
      real(dp), intent(in), contiguous :: y(:)
      logical, intent(in) :: in_contact
      real(dp), intent(in) :: sin_phase
      real(dp), intent(in) :: cos_phase
      real(dp), intent(out), contiguous :: dydt(:)
      real(dp), intent(out) :: vt
      real(dp), intent(out) :: vtdot
      if (self%special_rhs) then
         call composed_kernel(self, y, in_contact, sin_phase, cos_phase, dydt, vt, vtdot)
      else
         call rhs_kernel(self, y, in_contact, sin_phase, cos_phase, .true., dydt, vt, vtdot)
      end if
   end subroutine model_derivative_and_gap

   !> The one right-hand side: (a', a'') from y = (a, a') and the drive phase, and V_T and
   !> dV_T/dtau when want_gap (always in contact, where they are needed anyway).  N > rows_per_block
   !> and the law dmt_vdw (model_t%general) go to general_kernel.  N <= rows_per_block is done
   !> here, from small_fold and small_gap (fixed places in the model, no array descriptors): one
   !> pass over the modes forms p.a,
   !> (d/L) s.a, p.a' and the parts of a'' that do not depend on the contact forces (the drive,
   !> B (a, a'), M^-1 G a), all four rows at once, in loops of constant length rows_per_block
   !> that stop at N (the compiler unrolls them and keeps the rows in vector registers); then the
   !> contact forces and their two terms.  Every sum runs over the modes in order, from the
   !> first term.  Explicit-shape y and dydt: the callers pass bare addresses.
   pure subroutine rhs_kernel(self, y, in_contact, sin_phase, cos_phase, want_gap, dydt, vt, vtdot)
      type(model_t), intent(in) :: self
      real(dp), intent(in) :: y(2*self%n_modes)
      logical, intent(in) :: in_contact
      real(dp), intent(in) :: sin_phase
      real(dp), intent(in) :: cos_phase
      logical, intent(in) :: want_gap
      real(dp), intent(out) :: dydt(2*self%n_modes)
      real(dp), intent(out) :: vt
      real(dp), intent(out) :: vtdot
      integer, parameter :: r = rows_per_block
      real(dp) :: acc(r), stiff(r), gap(2), tip_adot, xa, xv
      real(dp) :: sin1, cos1, transverse, axial, radius, normal, friction, tip_push
      integer :: i, j, n

      n = self%n_modes
      if (self%general) then
         call general_kernel(self, y, in_contact, sin_phase, cos_phase, want_gap, dydt, vt, vtdot)
         return
      end if
      associate (f => self%small_fold, g => self%small_gap, s => self%scene)
         ! Column 1 of every sum, then columns 2..n: the loops have constant length r and stop at n.
         xa = y(1)
         xv = y(n + 1)
         do i = 1, r
            acc(i) = f(i, 3*r + 1)*sin_phase + f(i, 3*r + 2)*cos_phase
            acc(i) = acc(i) + (f(i, 1)*xa + f(i, r + 1)*xv)
         end do
         if (in_contact .or. want_gap) then
            ! gap = (p.a, (d/L) s.a).
            gap = g(:, 1)*xa
            tip_adot = g(1, 1)*xv
         end if
         if (in_contact) then
            do i = 1, r
               stiff(i) = f(i, 3*r + 4) + f(i, 2*r + 1)*xa
            end do
            do j = 2, r
               if (j > n) exit
               xa = y(j)
               xv = y(n + j)
               gap = gap + g(:, j)*xa
               tip_adot = tip_adot + g(1, j)*xv
               do i = 1, r
                  acc(i) = acc(i) + (f(i, j)*xa + f(i, r + j)*xv)
                  stiff(i) = stiff(i) + f(i, 2*r + j)*xa
               end do
            end do
            vt = gap(1) + s%alpha2*sin_phase + s%delta_hat
            vtdot = tip_adot + self%drive_rate*cos_phase
            call contact_angle_sin_cos(self%sin_theta, self%cos_theta, gap(2), &
                                       self%errata%e7_signed_slope, sin1, cos1)
            call contact_forces(vt, sin1, cos1, s%beta, self%law, self%kappa5, self%kappa6, &
                                transverse, axial, radius, normal, friction)
            ! Everything that acts along p: P1, the contact damping and its base term.
            tip_push = s%l_over_d*transverse - s%alpha4*tip_adot + self%base_sin*sin_phase &
                       + self%base_cos*cos_phase
            do i = 1, r
               acc(i) = acc(i) + tip_push*f(i, 3*r + 3) + axial*stiff(i)
            end do
         else
            do j = 2, r
               if (j > n) exit
               xa = y(j)
               xv = y(n + j)
               do i = 1, r
                  acc(i) = acc(i) + (f(i, j)*xa + f(i, r + j)*xv)
               end do
            end do
            vt = 0
            vtdot = 0
            if (want_gap) then
               do j = 2, r
                  if (j > n) exit
                  gap(1) = gap(1) + g(1, j)*y(j)
                  tip_adot = tip_adot + g(1, j)*y(n + j)
               end do
               vt = gap(1) + s%alpha2*sin_phase + s%delta_hat
               vtdot = tip_adot + self%drive_rate*cos_phase
            end if
         end if
      end associate
      do i = 1, r
         if (i > n) exit
         dydt(i) = y(n + i)
         dydt(n + i) = acc(i)
      end do
   end subroutine rhs_kernel

   !> rhs_kernel for N > rows_per_block: the dot products, the contact forces (their square roots
   !> are the longest chain), then accumulate.
   pure subroutine general_kernel(self, y, in_contact, sin_phase, cos_phase, want_gap, dydt, vt, vtdot)
      type(model_t), intent(in) :: self
      real(dp), intent(in) :: y(2*self%n_modes)
      logical, intent(in) :: in_contact
      real(dp), intent(in) :: sin_phase
      real(dp), intent(in) :: cos_phase
      logical, intent(in) :: want_gap
      real(dp), intent(out) :: dydt(2*self%n_modes)
      real(dp), intent(out) :: vt
      real(dp), intent(out) :: vtdot
      real(dp) :: tip_a, slope_a, tip_adot, sin1, cos1, transverse, axial, radius, normal, friction
      real(dp) :: tip_push
      integer :: n, j

      n = self%n_modes
      associate (s => self%scene)
         vt = 0
         vtdot = 0
         axial = 0
         tip_push = 0
         if (in_contact .or. want_gap) then
            tip_a = 0
            slope_a = 0
            tip_adot = 0
            do j = 1, n
               tip_a = tip_a + self%tip(j)*y(j)
               slope_a = slope_a + self%scaled_slope(j)*y(j)
               tip_adot = tip_adot + self%tip(j)*y(n + j)
            end do
            vt = tip_a + s%alpha2*sin_phase + s%delta_hat
            vtdot = tip_adot + s%alpha2*s%omega*cos_phase
         end if
         if (in_contact) then
            call contact_angle_sin_cos(self%sin_theta, self%cos_theta, slope_a, &
                                       self%errata%e7_signed_slope, sin1, cos1)
            call contact_forces(vt, sin1, cos1, s%beta, self%law, self%kappa5, self%kappa6, &
                                transverse, axial, radius, normal, friction)
            ! Everything that acts along p: P1, the contact damping and its base term.
            tip_push = s%l_over_d*transverse - s%alpha4*tip_adot + self%base_sin*sin_phase &
                       + self%base_cos*cos_phase
         end if
         call accumulate(n, self%n_padded, self%pass_terms, self%pass_a, self%pass_v, self%pass_g, y, &
                         in_contact, sin_phase, cos_phase, tip_push, axial, dydt)
      end associate
   end subroutine general_kernel

   !> The composed right-hand side: every part of the model at once, for any N (docs/model.md,
   !> "How the parts compose").  The equations are a sum of terms, each present only when its
   !> part is on:
   !>   a'' = -Y'' M^-1 (alpha1 m + (1 + mu) q) - Y' M^-1 C q + B (a, a')            (drive, medium)
   !>       + [forced] tip_push M^-1 p + P2 ((g0/d) M^-1 r + M^-1 G a)            (tip-sample law)
   !>   w'  = (max(X, (1 - r) w) - w)/T                                            (SLS sample)
   !> with Y, Y', Y'' the base motion of the drive (one tone or several, with phases), C and mu
   !> the medium's damping and added mass per mode, the brackets P1, P2 from tip_sample_forces
   !> (elastic or viscoelastic normal force, DMT or van der Waals adhesion, Mindlin friction; in
   !> flight the van der Waals tail, the forces at a distance, a meniscus that holds), and
   !> tip_push = (L/d) P1 - alpha4 (p.a' - base term) in contact.  y = (a, a'[, w, meniscus
   !> flag]) and dydt alike; V_T and its rate are always returned.
   pure subroutine composed_kernel(self, y, in_contact, sin_phase, cos_phase, dydt, vt, vtdot)
      type(model_t), intent(in) :: self
      real(dp), intent(in), contiguous :: y(:)
      logical, intent(in) :: in_contact
      real(dp), intent(in) :: sin_phase
      real(dp), intent(in) :: cos_phase
      real(dp), intent(out), contiguous :: dydt(:)
      real(dp), intent(out) :: vt
      real(dp), intent(out) :: vtdot
      real(dp) :: tip_a, slope_a, tip_adot, sin1, cos1, transverse, axial, hertz, w
      real(dp) :: tip_push, base, base_rate, base_accel, acc(n_max_padded), stiff(n_max_padded)
      integer :: n, i, j
      logical :: forced, wet

      n = self%n_modes
      w = 0
      if (self%sls%on) w = y(2*n + 1)
      wet = .false.
      if (self%meniscus_slot > 0) wet = y(self%meniscus_slot) > 0.5_dp .and. .not. in_contact
      call model_drive_signals(self, sin_phase, cos_phase, base, base_rate, base_accel)
      tip_a = 0
      slope_a = 0
      tip_adot = 0
      do j = 1, n
         tip_a = tip_a + self%tip(j)*y(j)
         slope_a = slope_a + self%scaled_slope(j)*y(j)
         tip_adot = tip_adot + self%tip(j)*y(n + j)
      end do
      vt = tip_a + base + self%scene%delta_hat
      vtdot = tip_adot + base_rate
      forced = in_contact .or. self%long_range .or. wet
      axial = 0
      tip_push = 0
      hertz = 0
      if (forced) then
         call contact_angle_sin_cos(self%sin_theta, self%cos_theta, slope_a, &
                                    self%errata%e7_signed_slope, sin1, cos1)
         call tip_sample_forces(self, in_contact, wet, vt, sin1, cos1, w, transverse, axial, hertz)
         tip_push = self%scene%l_over_d*transverse
         if (in_contact) tip_push = tip_push - self%scene%alpha4*tip_adot + self%damper_base_position*base &
                                    + self%damper_base_rate*base_rate
      end if
      ! Whole columns (unit stride, vectorised along the rows), as accumulate does.
      do i = 1, n
         acc(i) = -base_accel*self%inv_mass_inertial(i) - base_rate*self%inv_mass_damped_integral(i)
      end do
      do j = 1, n
         do i = 1, n
            acc(i) = acc(i) + (self%pass_a(i, j)*y(j) + self%pass_v(i, j)*y(n + j))
         end do
      end do
      if (self%thermal%on) then
         do i = 1, n
            acc(i) = acc(i) + self%noise_accel(i)
         end do
      end if
      if (forced) then
         do i = 1, n
            stiff(i) = self%moment_force(i)
         end do
         do j = 1, n
            do i = 1, n
               stiff(i) = stiff(i) + self%pass_g(i, j)*y(j)
            end do
         end do
         do i = 1, n
            acc(i) = acc(i) + tip_push*self%inv_mass_tip(i) + axial*stiff(i)
         end do
      end if
      do i = 1, n
         dydt(i) = y(n + i)
         dydt(n + i) = acc(i)
      end do
      if (self%n_state > 2*n) then
         dydt(2*n + 1) = 0
         dydt(2*n + 2) = 0
         if (self%sls%on) dydt(2*n + 1) = sls_rate(self%sls, hertz, w)
      end if
   end subroutine composed_kernel

   !> composed_kernel's forced terms out of contact alone: g = (0, tip_push M^-1 p + P2 (M^-1 m +
   !> M^-1 G a), 0) with the brackets of the flight (the van der Waals tail, the forces at a
   !> distance), so that dy/dtau in flight is the free system's A y + b(tau) plus g (the exact
   !> flight's perturbation, tmafm_lawson).  The same sums as composed_kernel, in the same order.
   pure subroutine model_flight_force(self, y, sin_phase, cos_phase, g, vt)
      class(model_t), intent(in) :: self
      real(dp), intent(in), contiguous :: y(:)
      real(dp), intent(in) :: sin_phase
      real(dp), intent(in) :: cos_phase
      real(dp), intent(out), contiguous :: g(:)
      real(dp), intent(out) :: vt
      real(dp) :: tip_a, slope_a, sin1, cos1, transverse, axial, hertz, base, base_rate, base_accel, stiff
      integer :: n, i, j
      logical :: wet

      n = self%n_modes
      g = 0
      call model_drive_signals(self, sin_phase, cos_phase, base, base_rate, base_accel)
      tip_a = 0
      slope_a = 0
      do j = 1, n
         tip_a = tip_a + self%tip(j)*y(j)
         slope_a = slope_a + self%scaled_slope(j)*y(j)
      end do
      vt = tip_a + base + self%scene%delta_hat
      ! A meniscus that holds the tip (its flag in y) pulls in flight too.
      wet = .false.
      if (self%meniscus_slot > 0) wet = y(self%meniscus_slot) > 0.5_dp
      if (.not. (self%long_range .or. wet)) return
      call contact_angle_sin_cos(self%sin_theta, self%cos_theta, slope_a, &
                                 self%errata%e7_signed_slope, sin1, cos1)
      call tip_sample_forces(self, .false., wet, vt, sin1, cos1, 0.0_dp, transverse, axial, hertz)
      do i = 1, n
         stiff = self%moment_force(i)
         do j = 1, n
            stiff = stiff + self%pass_g(i, j)*y(j)
         end do
         g(n + i) = self%scene%l_over_d*transverse*self%inv_mass_tip(i) + axial*stiff
      end do
   end subroutine model_flight_force

   !> The tip-sample law as composed from its parts, at gap vt and contact angle (sin1, cos1), in
   !> a phase: in contact the normal force group f is the elastic Hertz X = A^3 or, with a
   !> viscoelastic sample of dashpot coordinate w, the SLS's f(X, w); minus the adhesion (DMT's
   !> 4/3, or the van der Waals c_H under 'dmt_vdw'; a meniscus's pull); with Mindlin friction h.
   !> In flight it is the van der Waals tail under 'dmt_vdw', the forces at a distance and, while
   !> it holds (wet), the meniscus (no friction), else nothing.  Returns the brackets P1
   !> (transverse) and P2 (axial) and the Hertz variable X (0 in flight).
   pure subroutine tip_sample_forces(self, in_contact, wet, vt, sin1, cos1, w, transverse, axial, hertz)
      type(model_t), intent(in) :: self
      logical, intent(in) :: in_contact
      logical, intent(in) :: wet
      real(dp), intent(in) :: vt
      real(dp), intent(in) :: sin1
      real(dp), intent(in) :: cos1
      real(dp), intent(in) :: w
      real(dp), intent(out) :: transverse
      real(dp), intent(out) :: axial
      real(dp), intent(out) :: hertz
      real(dp) :: radius, friction, normal
      hertz = 0
      if (in_contact .and. self%law == law_jkr) then
         call jkr_contact(self, vt, sin1, cos1, radius, normal, friction)
         transverse = self%kappa5*normal*sin1 + self%kappa6*friction*cos1
         axial = -self%kappa5*normal*cos1 + self%kappa6*friction*sin1
         return
      end if
      if (.not. in_contact) then
         transverse = 0
         axial = 0
         if (.not. (self%long_range .or. wet)) return
         normal = 0
         if (self%law == law_dmt_vdw) &
            normal = vdw_normal_group(.false., vt, sin1, 0.0_dp, self%scene%vdw_adhesion, self%scene%vdw_range)
         if (self%surface%on) &
            normal = normal + surface_force_group(self%surface, flight_separation(self%surface, vt, sin1))
         if (wet) normal = normal + meniscus_force_group(self%meniscus, vt*sin1)
         transverse = self%kappa5*normal*sin1
         axial = -self%kappa5*normal*cos1
         return
      end if
      ! The friction brackets alone (kappa5 = 0), and X = A^3 from the Hertz law.
      call contact_forces(vt, sin1, cos1, self%scene%beta, law_hertz, 0.0_dp, self%kappa6, &
                          transverse, axial, radius, hertz, friction)
      normal = hertz
      if (self%sls%on) normal = sls_force_group(self%sls, hertz, w)
      normal = normal - contact_adhesion(self)
      transverse = transverse + self%kappa5*normal*sin1
      axial = axial - self%kappa5*normal*cos1
   end subroutine tip_sample_forces

   !> The JKR law while the neck holds (docs/model.md §18): at the normal indentation D =
   !> -V_T sin(theta1)/beta (negative with the neck stretched above the surface) the contact
   !> radius A of the stable branch, the force group f = A^3 - 2 A^(3/2), and the Mindlin friction
   !> group h = A (-V_T) cos(theta1); the forces at a distance add at the tip's separation, a0
   !> while the tip is at or below the surface.
   pure subroutine jkr_contact(self, vt, sin1, cos1, radius, normal, friction)
      type(model_t), intent(in) :: self
      real(dp), intent(in) :: vt
      real(dp), intent(in) :: sin1
      real(dp), intent(in) :: cos1
      real(dp), intent(out) :: radius
      real(dp), intent(out) :: normal
      real(dp), intent(out) :: friction
      radius = jkr_radius(-vt*sin1/self%scene%beta)
      normal = jkr_force_group(radius)
      friction = radius*(-vt*cos1)
      if (self%surface%on) normal = normal + surface_force_group(self%surface, &
         max(flight_separation(self%surface, vt, sin1), self%scene%vdw_range))
   end subroutine jkr_contact

   !> The adhesion subtracted from the normal force group in contact: DMT's 4/3, the van der
   !> Waals c_H under 'dmt_vdw' (its force at the surface), none under Hertz; less the forces at
   !> a distance at the contact separation; plus a meniscus's pull c_C.
   pure real(dp) function contact_adhesion(self) result(adhesion)
      type(model_t), intent(in) :: self
      select case (self%law)
      case (law_dmt)
         adhesion = dmt_adhesion
      case (law_dmt_vdw)
         adhesion = self%scene%vdw_adhesion
      case default
         adhesion = 0
      end select
      ! The forces at a distance at the contact separation: an attraction adds to the adhesion.
      if (self%surface%on) adhesion = adhesion - self%surface_at_contact
      if (self%meniscus%on) adhesion = adhesion + self%meniscus%strength
   end function contact_adhesion

   !> dydt = (a', a'') from the folded terms: the drive and the columns of B, which do not
   !> depend on the contact forces (so that they overlap with the contact's square roots),
   !> then, in contact, tip_push M^-1 p + P2 ((g0/d) M^-1 r + M^-1 G a), for general_kernel
   !> (N > rows_per_block): whole padded columns (unit stride, vectorised along the rows).
   !> Explicit shapes: the compiler knows the strides and that nothing aliases.
   pure subroutine accumulate(n, n_padded, terms, pa, pv, pg, y, in_contact, sin_phase, cos_phase, &
                              tip_push, axial, dydt)
      integer, intent(in) :: n
      integer, intent(in) :: n_padded
      real(dp), intent(in) :: terms(n_padded, 4)
      real(dp), intent(in) :: pa(n_padded, n)
      real(dp), intent(in) :: pv(n_padded, n)
      real(dp), intent(in) :: pg(n_padded, n)
      real(dp), intent(in) :: y(2*n)
      logical, intent(in) :: in_contact
      real(dp), intent(in) :: sin_phase
      real(dp), intent(in) :: cos_phase
      real(dp), intent(in) :: tip_push
      real(dp), intent(in) :: axial
      real(dp), intent(out) :: dydt(2*n)
      real(dp) :: acc(n_max_padded), stiff(n_max_padded), xa, xv, xa2, xv2
      integer :: i, j, last
      do i = 1, n_padded
         acc(i) = terms(i, 1)*sin_phase + terms(i, 2)*cos_phase
      end do
      ! Two columns per sweep of acc (half the loads and stores of acc), then the odd one.
      last = n - mod(n, 2)
      if (in_contact) then
         do i = 1, n_padded
            stiff(i) = terms(i, 4)
         end do
         do j = 1, last, 2
            xa = y(j)
            xv = y(n + j)
            xa2 = y(j + 1)
            xv2 = y(n + j + 1)
            do i = 1, n_padded
               acc(i) = acc(i) + ((pa(i, j)*xa + pv(i, j)*xv) + (pa(i, j + 1)*xa2 + pv(i, j + 1)*xv2))
               stiff(i) = stiff(i) + (pg(i, j)*xa + pg(i, j + 1)*xa2)
            end do
         end do
         do j = last + 1, n
            do i = 1, n_padded
               acc(i) = acc(i) + (pa(i, j)*y(j) + pv(i, j)*y(n + j))
               stiff(i) = stiff(i) + pg(i, j)*y(j)
            end do
         end do
         do i = 1, n_padded
            acc(i) = acc(i) + tip_push*terms(i, 3) + axial*stiff(i)
         end do
      else
         do j = 1, last, 2
            xa = y(j)
            xv = y(n + j)
            xa2 = y(j + 1)
            xv2 = y(n + j + 1)
            do i = 1, n_padded
               acc(i) = acc(i) + ((pa(i, j)*xa + pv(i, j)*xv) + (pa(i, j + 1)*xa2 + pv(i, j + 1)*xv2))
            end do
         end do
         do j = last + 1, n
            do i = 1, n_padded
               acc(i) = acc(i) + (pa(i, j)*y(j) + pv(i, j)*y(n + j))
            end do
         end do
      end if
      do i = 1, n
         dydt(i) = y(n + i)
         dydt(n + i) = acc(i)
      end do
   end subroutine accumulate

   pure subroutine model_matrices(self, tau, a, in_contact, mass, damping, stiffness, force)
      class(model_t), intent(in) :: self
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: a(:)
      logical, intent(in) :: in_contact
      real(dp), intent(out) :: mass(:, :)
      real(dp), intent(out) :: damping(:, :)
      real(dp), intent(out) :: stiffness(:, :)
      real(dp), intent(out) :: force(:)
      type(contact_brackets_t) :: state
      integer :: n, j

      n = self%n_modes
      mass = self%mass
      damping = 0
      stiffness = 0
      do j = 1, n
         damping(j, j) = self%modal_damping(j)
         stiffness(j, j) = self%eigen(j)
      end do
      associate (s => self%scene)
         if (self%drive%general) then
            force = drive_force(self, tau)
         else if (self%has_medium) then
            force = s%alpha2*s%omega**2*(s%alpha1*self%mass_point + (1 + self%added_mass)*self%integral) &
                    *sin(s%omega*tau) - s%alpha2*s%omega*self%modal_damping*self%integral*cos(s%omega*tau)
         else
            force = s%alpha2*s%omega**2*(s%alpha1*self%mass_point + self%integral)*sin(s%omega*tau) &
                    - s%alpha2*s%alpha3*s%omega*self%integral*cos(s%omega*tau)
         end if
         if (in_contact) then
            state = self%forces_in_phase(tau, a, .true.)
            damping = damping + s%alpha4*spread(self%tip, 2, n)*spread(self%tip, 1, n)
            stiffness = stiffness - state%axial*self%axial
            force = force + (base_damping(self, tau) + s%l_over_d*state%transverse)*self%tip &
                    + s%g0_over_d*state%axial*self%moment_shape
         else if (self%long_range) then
            ! A force in flight ('dmt_vdw', forces at a distance), with no contact damping.
            state = self%forces_in_phase(tau, a, .false.)
            stiffness = stiffness - state%axial*self%axial
            force = force + s%l_over_d*state%transverse*self%tip + s%g0_over_d*state%axial*self%moment_shape
         end if
      end associate
   end subroutine model_matrices

   !> Powers a'.Q of the drive (base inertia and base damping), the beam damping (in a liquid: with
   !> the liquid's damping, and the liquid's base terms in the drive), the contact
   !> damping (with its base term), and the normal and friction parts of the contact force
   !> (P1 along p, P2 through the moment and the axial stiffness), plus the modal energy
   !> E = a'.M a'/2 + a.Lambda a/2.  dE/dtau is the sum of the powers.  With a viscoelastic
   !> sample and its dashpot coordinate w (absent: 0), the normal force's part f - X that the
   !> sample's delay takes off the elastic X = A^3 is the separate viscoelastic power.
   pure subroutine model_energy_flow(self, tau, a, adot, in_contact, power, energy, w, wet)
      class(model_t), intent(in) :: self
      real(dp), intent(in) :: tau
      real(dp), intent(in) :: a(:)
      real(dp), intent(in) :: adot(:)
      logical, intent(in) :: in_contact
      real(dp), intent(out) :: power(n_powers)
      real(dp), intent(out) :: energy
      !> The dashpot coordinate of a viscoelastic sample (tmafm_viscoelastic).
      real(dp), intent(in), optional :: w
      !> A meniscus holds the tip in flight (default .false.).
      logical, intent(in), optional :: wet
      type(contact_brackets_t) :: state
      real(dp) :: sin1, cos1, tip_rate, p1, p2, axial_work, moment_rate, delayed, neck, base, base_rate, base_accel
      integer :: k, last
      logical :: held

      associate (s => self%scene)
         ! Explicit sums: no array temporaries (observers call this inside the step loop).
         energy = 0
         do k = 1, self%n_modes
            energy = energy + adot(k)*dot_product(self%mass(:, k), adot)
         end do
         energy = 0.5_dp*energy + 0.5_dp*sum(self%eigen*a*a)
         power = 0
         if (self%drive%general) then
            do k = 1, self%n_modes
               power(power_drive) = power(power_drive) + adot(k)*drive_force_of(self, tau, k)
               power(power_beam_damping) = power(power_beam_damping) - self%modal_damping(k)*adot(k)**2
            end do
         else if (self%has_medium) then
            ! The liquid's load as a damper and a drive (docs/model.md): the same sums, C per mode.
            power(power_drive) = 0
            power(power_beam_damping) = 0
            do k = 1, self%n_modes
               power(power_drive) = power(power_drive) + adot(k)*(s%alpha2*s%omega**2 &
                  *(s%alpha1*self%mass_point(k) + (1 + self%added_mass(k))*self%integral(k))*sin(s%omega*tau) &
                  - s%alpha2*s%omega*self%modal_damping(k)*self%integral(k)*cos(s%omega*tau))
               power(power_beam_damping) = power(power_beam_damping) - self%modal_damping(k)*adot(k)**2
            end do
         else
            power(power_drive) = dot_product(adot, &
               s%alpha2*s%omega**2*(s%alpha1*self%mass_point + self%integral)*sin(s%omega*tau) &
               - s%alpha2*s%alpha3*s%omega*self%integral*cos(s%omega*tau))
            power(power_beam_damping) = -s%alpha3*dot_product(adot, adot)
         end if
         held = .false.
         if (present(wet)) held = wet .and. self%meniscus%on .and. .not. in_contact
         if (.not. (in_contact .or. self%long_range .or. held)) return
         tip_rate = dot_product(self%tip, adot)
         ! Under 'dmt_vdw' the attraction in flight works through the normal part too.
         if (in_contact) power(power_contact_damping) = tip_rate*(-s%alpha4*tip_rate + base_damping(self, tau))
         state = self%forces_in_phase(tau, a, in_contact, held)
         call contact_angle_sin_cos(self%sin_theta, self%cos_theta, &
                                    dot_product(self%slope, a)/s%l_over_d, &
                                    self%errata%e7_signed_slope, sin1, cos1)
         moment_rate = dot_product(self%moment_shape, adot)
         axial_work = 0
         do k = 1, self%n_modes
            axial_work = axial_work + a(k)*dot_product(adot, self%axial(:, k))
         end do
         last = 2
         delayed = 0
         if (self%sls%on) then
            last = 3
            if (present(w)) delayed = sls_viscoelastic_part(self%sls, state%radius**3, w)
         end if
         do k = 1, last
            ! k = 1: the normal part (kappa5 f_c); k = 2: the friction part (kappa6 h);
            ! k = 3: the viscoelastic part of the normal force (kappa5 (f - X)).
            if (k == 1) then
               p1 = self%kappa5*state%normal*sin1
               p2 = -self%kappa5*state%normal*cos1
            else if (k == 2) then
               p1 = self%kappa6*state%friction*cos1
               p2 = self%kappa6*state%friction*sin1
            else
               p1 = self%kappa5*delayed*sin1
               p2 = -self%kappa5*delayed*cos1
            end if
            power(power_contact_normal + k - 1) = s%l_over_d*p1*tip_rate + s%g0_over_d*p2*moment_rate &
                                                  + p2*axial_work
         end do
         if (last == 3) then
            ! The sample's own loss: the delayed force kappa5 (f - X) on the normal indentation
            ! delta_n = -V_T sin(theta1), (L/d) kappa5 (f - X) d(delta_n)/dtau (the elastic X,
            ! a function of delta_n alone, closes its loop with no work).  The normal power
            ! keeps the rest of the delayed force's work on the modes, so the powers still sum
            ! to dE/dtau.
            power(power_contact_normal) = power(power_contact_normal) + power(power_contact_viscoelastic)
            power(power_contact_viscoelastic) = -s%l_over_d*self%kappa5*delayed &
                                                *normal_indentation_rate(self, tau, a, adot, sin1, cos1)
            power(power_contact_normal) = power(power_contact_normal) - power(power_contact_viscoelastic)
         end if
         if (in_contact .and. self%hysteretic) then
            ! The JKR neck's work on the normal indentation, -(L/d) kappa5 f dD_n/dtau, is its own
            ! channel: over a whole tap (D_n from 0 back to the pull-off D_c beta) it is minus the
            ! hysteresis loop's area, the energy the neck takes (docs/model.md §18).  The normal
            ! power keeps the rest, so the powers still sum to dE/dtau.
            power(power_contact_adhesion) = -s%l_over_d*self%kappa5*jkr_force_group(state%radius) &
                                            *normal_indentation_rate(self, tau, a, adot, sin1, cos1)
            power(power_contact_normal) = power(power_contact_normal) - power(power_contact_adhesion)
         end if
         if (self%meniscus%on .and. (in_contact .or. held)) then
            ! The meniscus's work on the normal indentation, the same channel: its force group is
            ! -c_C in contact and -c_C (1 - g/D) at the normal gap g = -D_n in flight, so over a tap
            ! the channel takes c_C D/2 (docs/model.md §19).
            neck = -self%meniscus%strength
            if (held) then
               call model_drive_signals(self, sin(self%drive%fundamental*tau), cos(self%drive%fundamental*tau), &
                                        base, base_rate, base_accel)
               neck = meniscus_force_group(self%meniscus, (dot_product(self%tip, a) + base + s%delta_hat)*sin1)
            end if
            power(power_contact_adhesion) = -s%l_over_d*self%kappa5*neck &
                                            *normal_indentation_rate(self, tau, a, adot, sin1, cos1)
            power(power_contact_normal) = power(power_contact_normal) - power(power_contact_adhesion)
         end if
      end associate
   end subroutine model_energy_flow

   !> Turn the thermal bath on (docs/model.md §21): theta from the scene, the modal damping
   !> C_jj (beam and liquid), a grid of spacing step (tau) and a seed; noise_accel starts at
   !> interval 0.  The right-hand side goes to composed_kernel, which adds noise_accel.
   pure subroutine model_set_thermal(self, step, seed)
      class(model_t), intent(inout) :: self
      real(dp), intent(in) :: step
      integer(i8), intent(in) :: seed
      self%thermal = init_thermal(self%scene%thermal_energy, self%modal_damping, step, seed)
      self%special_rhs = .true.
      if (allocated(self%noise_accel)) deallocate (self%noise_accel, self%noise_normals)
      allocate (self%noise_accel(self%n_modes), self%noise_normals(self%n_modes))
      call model_set_noise_interval(self, 0_i8)
   end subroutine model_set_thermal

   !> noise_accel = M^-1 xi_k, xi_k = amplitude z_k, for grid interval k.
   pure subroutine model_set_noise_interval(self, k)
      class(model_t), intent(inout) :: self
      integer(i8), intent(in) :: k
      integer :: i, j, n
      n = self%n_modes
      call standard_normals(self%thermal%seed, k, self%noise_normals)
      self%noise_normals = self%thermal%amplitude*self%noise_normals
      do i = 1, n
         self%noise_accel(i) = 0
      end do
      do j = 1, n
         do i = 1, n
            self%noise_accel(i) = self%noise_accel(i) + self%inv_mass(i, j)*self%noise_normals(j)
         end do
      end do
   end subroutine model_set_noise_interval

end module tmafm_model

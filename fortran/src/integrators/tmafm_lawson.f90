!> The Lawson (integrating-factor) form of the DOP853 pair for a flight with a force at a
!> distance (docs/model.md §20): out of contact y' = A y + b(tau) + g(y), the free system exact
!> (tmafm_flight's modal solution, drive included) and the force g (model_t%flight_force) a
!> perturbation.  With y(tau0 + s) = y_free(s) + Re(sum_k m_k V_k exp(lambda_k s) eta_k(s)),
!> m_k the multiplicity of term k, eta = 0 at the step start and
!>
!>   eta' = exp(-Lambda s) V^-1 g(y(s)),
!>
!> DOP853's tableau, error estimates and dense output are applied to eta (Hairer, Norsett and
!> Wanner I, Sec. II.10; Lawson 1967; Hochbruck and Ostermann 2010, Sec. 2.7).  In the modal
!> coordinates of the free system every factor exp(+-lambda c h) is a scalar per term, so a stage
!> is the stage sum of eta (n_terms complex numbers), one modal product back to y, the force, and
!> one product with V^-1's velocity columns: O(N^2), no matrix exponential.  The error norm is that of
!> DOP853 on the error estimates turned back to y by exp(A h) (tmafm_error_scale), and the dense
!> output of eta is turned back by exp(A theta h) onto the exact free flow, so samples, switches
!> and observers read y as from any pair.  Without a force the step is the exact free flight.
!>
!> In contact (and on warped steps) the pair is DOP853 itself (`contact`).  The stages of the
!> Lawson form are those of the classical pair for eta, so its order is 8 for smooth g; its
!> error constant holds the force's share of each mode, not the modes' own amplitudes, which a
!> free flight step of DOP853 must resolve (docs/performance.md, "Long-range forces in flight").
!> Registers are allocated once by `setup`; a step allocates nothing.
module tmafm_lawson
   use tmafm_kinds, only: dp
   use tmafm_errors, only: ok
   use tmafm_model, only: model_t
   use tmafm_modes, only: max_modes
   use tmafm_viscoelastic, only: sls_t, sls_free_relaxation
   use tmafm_drive, only: max_tones
   use tmafm_error_scale, only: error_scale_t
   use tmafm_embedded_pair, only: embedded_pair_t, time_map_t, stage_phases
   use tmafm_dop853, only: dop853_pair_t, dop853_a, dop853_b, dop853_c, dop853_d, dop853_e5, dop853_e3, dop853_norm
   use tmafm_flight, only: free_flight_t, sample_block
   implicit none
   private

   public :: lawson_pair_t

   !> Stages of a step (1-12), the new state's (13) and the dense output's (14-16).
   integer, parameter :: stages = 16
   !> Most modal terms (one per eigenvalue of a 2 max_modes system): the size of the local
   !> registers of the pure routines (fixed, so that they live on the stack).
   integer, parameter :: max_terms = 2*max_modes
   !> The tableau's rows as columns: a_rows(:, i) are the coefficients of stage i, contiguous.
   real(dp), parameter :: a_rows(stages, stages) = transpose(dop853_a)
   !> Rows 4-7 of the dense output likewise: d_rows(:, row).
   real(dp), parameter :: d_rows(stages, 4:7) = transpose(dop853_d)

   !> DOP853 in contact, its Lawson form in flight.
   type, extends(embedded_pair_t) :: lawson_pair_t
      !> The classical pair, for contact steps and warped steps.
      type(dop853_pair_t) :: contact
      !> The free system's modal solution (eigenvalues, V, V^-1, particular solution).
      type(free_flight_t) :: flight
      !> The viscoelastic sample's law (its dashpot relaxes in closed form in flight).
      type(sls_t) :: sls
      !> The drive's fundamental frequency (the phase at a dense-output point).
      real(dp) :: omega = 0
      !> .true. when the last step was a Lawson (flight) step.
      logical :: lawson_step = .false.
      !> Size of (a, a') and of the state.
      integer :: n_modal = 0, n_state = 0
      !> exp(lambda_k c_i h) per term and node (n_terms x stages) of the last step, and its inverse.
      complex(dp), allocatable :: turn(:, :), unturn(:, :)
      !> A stage's modal coefficients exp(lambda c_i h) (z + eta) (register).
      complex(dp), allocatable :: w(:)
      !> Turned stage derivatives exp(-lambda c_i h) V^-1 g(Y_i) (stages x n_terms: a term's
      !> stages contiguous, for the stage sums).
      complex(dp), allocatable :: k(:, :)
      !> Stage sums of eta, and modal coefficients z of the free flight at the step start.
      complex(dp), allocatable :: eta(:), z(:)
      !> Dense output of eta: eta(theta) = theta (r0 + (1-theta) (r1 + theta (r2 + ...))).
      complex(dp), allocatable :: r(:, :)
      !> Stage state, the force g, the error estimates in y.
      real(dp), allocatable :: stage(:), g(:), err5(:), err3(:)
      !> sin, cos of the drive phase at the nodes of the last step.
      real(dp) :: sin_node(stages) = 0, cos_node(stages) = 1
      !> Start of the last step and the dashpot coordinate there.
      real(dp) :: tau0 = 0, dashpot0 = 0
      !> A capillary meniscus's flag y(2N + 2) at the step's start (model_t%wet): constant over
      !> a step, its stages and its dense output.
      real(dp) :: flag0 = 0
   contains
      !> Decompose the free system of a model and allocate (once per run, after init).
      procedure :: setup => lawson_setup
      !> Allocate the registers for a state of size n_state.
      procedure :: init => lawson_init
      !> One step: DOP853 in contact or warped, the Lawson form in flight.
      procedure :: step => lawson_step_
      !> The error norm of the last step.
      procedure :: error_norm => lawson_error_norm
      !> norm^(-1/8).
      procedure :: growth => lawson_growth
      !> Build the dense output of the last step.
      procedure :: prepare_dense => lawson_prepare_dense
      !> The dense-output state at fraction theta of the last step.
      procedure :: dense => lawson_dense
   end type lawson_pair_t

contains

   subroutine lawson_init(self, n_state)
      class(lawson_pair_t), intent(inout) :: self
      integer, intent(in) :: n_state
      call self%contact%init(n_state)
      self%stage_evaluations = 12
      self%dense_evaluations = 3
      self%shrink_limit = self%contact%shrink_limit
      self%grow_limit = self%contact%grow_limit
      self%n_state = n_state
      if (allocated(self%stage)) deallocate (self%stage, self%g, self%err5, self%err3)
      allocate (self%stage(n_state), self%g(n_state), self%err5(n_state), self%err3(n_state))
   end subroutine lawson_init

   subroutine lawson_setup(self, model, ierr, errmsg)
      class(lawson_pair_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      integer :: m
      call self%flight%init(model, ierr, errmsg)
      if (ierr /= ok) return
      self%sls = model%sls
      self%omega = model%drive%fundamental
      self%n_modal = 2*model%n_modes
      m = self%flight%n_terms
      if (allocated(self%turn)) deallocate (self%turn, self%unturn, self%w, self%k, self%eta, self%z, self%r)
      allocate (self%turn(m, stages), self%unturn(m, stages), self%w(m), self%k(stages, m), self%eta(m), &
                self%z(m), self%r(m, 0:6))
   end subroutine lawson_setup

   subroutine lawson_step_(self, model, map, y, in_contact, f0, y_new, f_new)
      class(lawson_pair_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      type(time_map_t), intent(in) :: map
      real(dp), intent(in), contiguous :: y(:)
      logical, intent(in) :: in_contact
      real(dp), intent(in), contiguous :: f0(:)
      real(dp), intent(out), contiguous :: y_new(:)
      real(dp), intent(out), contiguous :: f_new(:)
      real(dp) :: h, vt
      integer :: i

      self%lawson_step = .not. (in_contact .or. map%warped)
      if (.not. self%lawson_step) then
         call self%contact%step(model, map, y, in_contact, f0, y_new, f_new)
         self%map = self%contact%map
         self%sin_end = self%contact%sin_end
         self%cos_end = self%contact%cos_end
         self%vt_end = self%contact%vt_end
         self%rate_end = self%contact%rate_end
         self%stage_evaluations = self%contact%stage_evaluations
         self%dense_evaluations = self%contact%dense_evaluations
         return
      end if
      self%map = map
      h = map%h
      self%tau0 = map%s0
      ! Thermal noise: the grid interval's force is held over the step (steps end on the grid),
      ! so it is part of the exact free flow, not of g.
      if (model%thermal%on) call self%flight%hold(model, model%noise_accel)
      call self%flight%start(model, map%s0, y)
      self%z = self%flight%z
      if (size(y) > self%n_modal) self%dashpot0 = y(self%n_modal + 1)
      if (size(y) > self%n_modal + 1) self%flag0 = y(self%n_modal + 2)
      call stage_phases(model, map%s0, h, dop853_c, self%sin_node, self%cos_node)
      call turns(self%flight%n_terms, self%flight%eigenvalue, h, self%turn, self%unturn)
      ! Stage 1 at the step start (eta = 0): the caller's f0 is the whole derivative, not g.
      call model%flight_force(y, self%sin_node(1), self%cos_node(1), self%g, vt)
      call modal_force(self, 1)
      do i = 2, 12
         call stage_sum(self%flight%n_terms, i - 1, h, a_rows(:, i), self%k, self%eta)
         call stage_state(self, i, self%stage)
         call model%flight_force(self%stage, self%sin_node(i), self%cos_node(i), self%g, vt)
         call modal_force(self, i)
      end do
      call stage_sum(self%flight%n_terms, 12, h, dop853_b, self%k, self%eta)
      call stage_state(self, 13, y_new)
      self%sin_end = self%sin_node(13)
      self%cos_end = self%cos_node(13)
      ! The error estimates (per unit h, as DOP853's) turned to y by exp(A h).
      call turned_back(self, dop853_e5, self%err5)
      call turned_back(self, dop853_e3, self%err3)
      call model%derivative_and_gap(y_new, .false., self%sin_end, self%cos_end, f_new, self%vt_end, self%rate_end)
      ! The force at stages 1-12 and the derivative at the new state; the dense output adds the
      ! force at the new state and stages 14-16.
      self%stage_evaluations = 13
      self%dense_evaluations = 4
   end subroutine lawson_step_

   !> k(:, i) = exp(-lambda c_i h) V^-1 g: g acts on the velocities only (model_t%flight_force).
   pure subroutine modal_force(self, i)
      type(lawson_pair_t), intent(inout) :: self
      integer, intent(in) :: i
      call turned_force(self%flight%n_terms, self%n_modal/2, self%flight%inverse, self%g, self%unturn(:, i), &
                        self%w)
      self%k(i, :) = self%w
   end subroutine modal_force

   !> modal_force on explicit shapes: k = unturn * (V^-1 (:, n+1:2n) g(n+1:2n)), in real
   !> arithmetic (a complex product also tests for NaN).
   pure subroutine turned_force(n_terms, n, inverse, g, unturn, k)
      integer, intent(in) :: n_terms, n
      complex(dp), intent(in) :: inverse(n_terms, 2*n)
      real(dp), intent(in) :: g(2*n)
      complex(dp), intent(in) :: unturn(n_terms)
      complex(dp), intent(out) :: k(n_terms)
      real(dp) :: re, im
      integer :: j, t
      do t = 1, n_terms
         re = 0
         im = 0
         do j = n + 1, 2*n
            re = re + real(inverse(t, j), dp)*g(j)
            im = im + aimag(inverse(t, j))*g(j)
         end do
         k(t) = cmplx(re*real(unturn(t), dp) - im*aimag(unturn(t)), re*aimag(unturn(t)) + im*real(unturn(t), dp), dp)
      end do
   end subroutine turned_force

   !> eta = h sum_{j <= last} a(j) k(j, :): one sum over the stages per term.
   pure subroutine stage_sum(n_terms, last, h, a, k, eta)
      integer, intent(in) :: n_terms, last
      real(dp), intent(in) :: h
      real(dp), intent(in) :: a(stages)
      complex(dp), intent(in) :: k(stages, n_terms)
      complex(dp), intent(out) :: eta(n_terms)
      real(dp) :: re, im
      integer :: j, t
      do t = 1, n_terms
         re = 0
         im = 0
         do j = 1, last
            re = re + a(j)*real(k(j, t), dp)
            im = im + a(j)*aimag(k(j, t))
         end do
         eta(t) = cmplx(h*re, h*im, dp)
      end do
   end subroutine stage_sum

   !> exp(lambda c_i h) and its inverse per term and node: one real exp and one sincos per
   !> distinct node (stage 13's node is stage 12's, c = 1; stage 1's is 1).
   pure subroutine turns(n_terms, eigenvalue, h, turn, unturn)
      integer, intent(in) :: n_terms
      complex(dp), intent(in) :: eigenvalue(n_terms)
      real(dp), intent(in) :: h
      complex(dp), intent(out) :: turn(n_terms, stages)
      complex(dp), intent(out) :: unturn(n_terms, stages)
      real(dp) :: x, grow
      integer :: i, k
      turn(:, 1) = 1
      unturn(:, 1) = 1
      do i = 2, stages
         if (i == 13) then
            turn(:, 13) = turn(:, 12)
            unturn(:, 13) = unturn(:, 12)
            cycle
         end if
         x = dop853_c(i)*h
         do k = 1, n_terms
            grow = exp(real(eigenvalue(k), dp)*x)
            turn(k, i) = grow*cmplx(cos(aimag(eigenvalue(k))*x), sin(aimag(eigenvalue(k))*x), dp)
            unturn(k, i) = cmplx(real(turn(k, i), dp)/(grow*grow), -aimag(turn(k, i))/(grow*grow), dp)
         end do
      end do
   end subroutine turns

   !> The state at node i from the stage sum self%eta: the particular solution at the node's
   !> phase plus Re(sum_k m_k V_k exp(lambda_k c_i h) (z_k + eta_k)), the dashpot relaxed.
   pure subroutine stage_state(self, i, y)
      type(lawson_pair_t), intent(inout) :: self
      integer, intent(in) :: i
      real(dp), intent(out) :: y(:)
      call turn_stage(self%flight%n_terms, self%turn(:, i), self%z, self%eta, self%w)
      call modal_state(self, self%sin_node(i), self%cos_node(i), self%w, dop853_c(i)*self%map%h, y)
   end subroutine stage_state

   !> w = turn (z + eta) on explicit shapes.
   pure subroutine turn_stage(n_terms, turn, z, eta, w)
      integer, intent(in) :: n_terms
      complex(dp), intent(in) :: turn(n_terms), z(n_terms), eta(n_terms)
      complex(dp), intent(out) :: w(n_terms)
      real(dp) :: re, im
      integer :: t
      do t = 1, n_terms
         re = real(z(t), dp) + real(eta(t), dp)
         im = aimag(z(t)) + aimag(eta(t))
         w(t) = cmplx(re*real(turn(t), dp) - im*aimag(turn(t)), re*aimag(turn(t)) + im*real(turn(t), dp), dp)
      end do
   end subroutine turn_stage

   !> y = y_p(phase) + Re(sum_k m_k V_k w_k), and the dashpot at s past the step start.
   pure subroutine modal_state(self, sin_phase, cos_phase, w, s, y)
      type(lawson_pair_t), intent(in) :: self
      real(dp), intent(in) :: sin_phase, cos_phase
      complex(dp), intent(in) :: w(:)
      real(dp), intent(in) :: s
      real(dp), intent(out) :: y(:)
      real(dp) :: sin_tone(max_tones), cos_tone(max_tones)
      integer :: k, m
      m = self%n_modal
      associate (f => self%flight)
         if (f%general) then
            call f%drive%tones(sin_phase, cos_phase, sin_tone, cos_tone)
            y(1:m) = 0
            do k = 1, f%n_tones
               y(1:m) = y(1:m) + f%tone_u(:, k)*sin_tone(k) + f%tone_v(:, k)*cos_tone(k)
            end do
         else
            call particular(m, f%u, f%v, sin_phase, cos_phase, y)
         end if
         call add_modes(m, f%n_terms, f%multiplicity, f%sample_matrix, f%sample_blocks, w, y)
         if (f%held) y(1:m) = y(1:m) + f%held_state
      end associate
      if (size(y) > m) then
         y(m + 1) = sls_free_relaxation(self%sls, self%dashpot0, s)
         y(m + 2:) = 0
         if (size(y) > m + 1) y(m + 2) = self%flag0
      end if
   end subroutine modal_state

   !> y = u sin + v cos on explicit shapes.
   pure subroutine particular(m, u, v, sin_phase, cos_phase, y)
      integer, intent(in) :: m
      real(dp), intent(in) :: u(m), v(m), sin_phase, cos_phase
      real(dp), intent(out) :: y(m)
      y = u*sin_phase + v*cos_phase
   end subroutine particular

   !> y += Re(sum_k m_k V_k w_k), with [Re V | -Im V] from the flight's sample matrix (its
   !> columns 3.. are Re V and -Im V, a block of rows at a time).
   pure subroutine add_modes(m, n_terms, multiplicity, matrix, blocks, w, y)
      integer, intent(in) :: m, n_terms, blocks
      real(dp), intent(in) :: multiplicity(n_terms)
      real(dp), intent(in) :: matrix(sample_block, 2 + 2*n_terms, blocks)
      complex(dp), intent(in) :: w(n_terms)
      real(dp), intent(inout) :: y(m)
      real(dp) :: re, im, column(sample_block)
      integer :: b, k, rows, first
      do b = 1, blocks
         column = 0
         do k = 1, n_terms
            re = multiplicity(k)*real(w(k), dp)
            im = multiplicity(k)*aimag(w(k))
            column = column + matrix(:, 2 + k, b)*re + matrix(:, 2 + n_terms + k, b)*im
         end do
         first = sample_block*(b - 1)
         rows = min(sample_block, m - first)
         y(first + 1:first + rows) = y(first + 1:first + rows) + column(1:rows)
      end do
   end subroutine add_modes

   !> e = Re(sum_k m_k V_k exp(lambda_k h) sum_j weight_j k_jk): an estimate of eta turned to y.
   pure subroutine turned_back(self, weight, e)
      type(lawson_pair_t), intent(in) :: self
      real(dp), intent(in) :: weight(stages)
      real(dp), intent(out) :: e(:)
      complex(dp) :: w(max_terms)
      integer :: n
      n = self%flight%n_terms
      call stage_sum(n, 12, 1.0_dp, weight, self%k, w)
      w(1:n) = w(1:n)*self%turn(:, 13)
      e = 0
      associate (f => self%flight)
         call add_modes(self%n_modal, n, f%multiplicity, f%sample_matrix, f%sample_blocks, w, e)
      end associate
   end subroutine turned_back

   !> DOP853's estimate (tmafm_dop853) on the turned error estimates, or the contact pair's.
   pure subroutine lawson_error_norm(self, h, f0, f_new, scale, norm)
      class(lawson_pair_t), intent(inout) :: self
      real(dp), intent(in) :: h
      real(dp), intent(in), contiguous :: f0(:)
      real(dp), intent(in), contiguous :: f_new(:)
      type(error_scale_t), intent(in) :: scale
      real(dp), intent(out) :: norm
      if (.not. self%lawson_step) then
         call self%contact%error_norm(h, f0, f_new, scale, norm)
         return
      end if
      norm = dop853_norm(h, self%err5, self%err3, scale)
   end subroutine lawson_error_norm

   pure function lawson_growth(self, norm) result(ratio)
      class(lawson_pair_t), intent(in) :: self
      real(dp), intent(in) :: norm
      real(dp) :: ratio
      ratio = self%contact%growth(norm)
   end function lawson_growth

   subroutine lawson_prepare_dense(self, model, y, y_new, in_contact, f0, f_new)
      class(lawson_pair_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      real(dp), intent(in), contiguous :: y(:)
      real(dp), intent(in), contiguous :: y_new(:)
      logical, intent(in) :: in_contact
      real(dp), intent(in), contiguous :: f0(:)
      real(dp), intent(in), contiguous :: f_new(:)
      real(dp) :: h, vt
      integer :: i, row
      if (.not. self%lawson_step) then
         call self%contact%prepare_dense(model, y, y_new, in_contact, f0, f_new)
         return
      end if
      h = self%map%h
      ! Stage 13: the force at the new state; then stages 14-16.
      call model%flight_force(y_new, self%sin_node(13), self%cos_node(13), self%g, vt)
      call modal_force(self, 13)
      do i = 14, 16
         call stage_sum(self%flight%n_terms, i - 1, h, a_rows(:, i), self%k, self%eta)
         call stage_state(self, i, self%stage)
         call model%flight_force(self%stage, self%sin_node(i), self%cos_node(i), self%g, vt)
         call modal_force(self, i)
      end do
      ! Hairer's dense-output coefficients, for eta (eta = 0 at the step start).
      call stage_sum(self%flight%n_terms, 12, h, dop853_b, self%k, self%r(:, 0))
      self%r(:, 1) = h*self%k(1, :) - self%r(:, 0)
      self%r(:, 2) = 2*self%r(:, 0) - h*(self%k(13, :) + self%k(1, :))
      do row = 4, 7
         call stage_sum(self%flight%n_terms, stages, h, d_rows(:, row), self%k, self%r(:, row - 1))
      end do
   end subroutine lawson_prepare_dense

   pure subroutine lawson_dense(self, theta, y)
      class(lawson_pair_t), intent(in) :: self
      real(dp), intent(in) :: theta
      real(dp), intent(out), contiguous :: y(:)
      complex(dp) :: w(max_terms)
      real(dp) :: s, phase
      if (.not. self%lawson_step) then
         call self%contact%dense(theta, y)
         return
      end if
      s = theta*self%map%h
      call dense_terms(self%flight%n_terms, theta, s, self%flight%eigenvalue, self%z, self%r, w)
      phase = self%omega*(self%tau0 + s)
      call modal_state(self, sin(phase), cos(phase), w, s, y)
   end subroutine lawson_dense

   !> w = exp(lambda s) (z + eta(theta)), eta(theta) from the dense coefficients r.
   pure subroutine dense_terms(n_terms, theta, s, eigenvalue, z, r, w)
      integer, intent(in) :: n_terms
      real(dp), intent(in) :: theta, s
      complex(dp), intent(in) :: eigenvalue(n_terms), z(n_terms), r(n_terms, 0:6)
      complex(dp), intent(out) :: w(n_terms)
      real(dp) :: rest, grow
      integer :: k
      rest = 1 - theta
      do k = 1, n_terms
         grow = exp(real(eigenvalue(k), dp)*s)
         w(k) = grow*cmplx(cos(aimag(eigenvalue(k))*s), sin(aimag(eigenvalue(k))*s), dp) &
                *(z(k) + theta*(r(k, 0) + rest*(r(k, 1) + theta*(r(k, 2) + rest*(r(k, 3) &
                + theta*(r(k, 4) + rest*(r(k, 5) + theta*r(k, 6))))))))
      end do
   end subroutine dense_terms

end module tmafm_lawson

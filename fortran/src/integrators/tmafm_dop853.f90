!> The Dormand-Prince 8(5,3) pair DOP853 (Hairer, Norsett and Wanner, Solving ODEs I,
!> Sec. II.10, and Hairer's code DOP853), as an embedded_pair_t, with its seventh-order
!> dense output.
!>
!> Twelve stages give the eighth-order solution; stage 1 is the caller's f0 and the
!> derivative at the new state (stage 13) is the next step's f0, so an attempted step costs
!> 12 evaluations.  The error estimate combines the fifth- and third-order differences,
!> err = h |e5|^2 / sqrt(|e5|^2 + 0.01 |e3|^2), both measured in the norm of
!> tmafm_error_scale; its order is 8 (exponent 1/8, taken as three square roots).  The
!> dense output needs three more stages (14-16): they are evaluated only for steps that
!> hold a sample or a switch.  The coefficients are Hairer's, to the last bit of a double.
!> Registers are allocated once by `init`; a step allocates nothing.  The drive phase of
!> every stage comes from one sin/cos per step (tmafm_embedded_pair stage_clock); on a warped
!> step each stage derivative is scaled by its dtau/dsigma.
module tmafm_dop853
   use tmafm_kinds, only: dp
   use tmafm_model, only: model_t
   use tmafm_modes, only: max_modes
   use tmafm_error_scale, only: error_scale_t
   use tmafm_embedded_pair, only: embedded_pair_t, time_map_t, stage_clock
   implicit none
   private

   public :: dop853_pair_t, dop853_norm

   !> Rows of the stage registers k: the longest state (2 max_modes + 2), whatever the run's.  With
   !> a leading dimension fixed at compile time the column k(:, j) is at a constant offset, and
   !> the stage sums need no address arithmetic per stage (docs/performance.md, "A dop853
   !> contact step besides its right-hand sides"); the rows past the state are never read.
   integer, parameter :: lead = 2*max_modes + 2

   ! Nodes c_i of stages 2-12 and of the dense-output stages 14-16.
   real(dp), parameter :: c2 = 0.05260015195876773_dp, c3 = 0.0789002279381516_dp, &
      c4 = 0.1183503419072274_dp, c5 = 0.2816496580927726_dp, c6 = 0.3333333333333333_dp, c7 = 0.25_dp, &
      c8 = 0.3076923076923077_dp, c9 = 0.6512820512820513_dp, c10 = 0.6_dp, c11 = 0.8571428571428571_dp, &
      c12 = 1.0_dp, c14 = 0.1_dp, c15 = 0.2_dp, c16 = 0.7777777777777778_dp
   !> The distinct nodes of stages 2-13 (stages 12 and 13 are both at c = 1), and of 14-16.
   real(dp), parameter :: step_nodes(11) = [c2, c3, c4, c5, c6, c7, c8, c9, c10, c11, c12], &
      dense_nodes(3) = [c14, c15, c16]
   real(dp), parameter :: a2_1 = 0.05260015195876773_dp
   real(dp), parameter :: a3_1 = 0.0197250569845379_dp, a3_2 = 0.0591751709536137_dp
   real(dp), parameter :: a4_1 = 0.02958758547680685_dp, a4_3 = 0.08876275643042054_dp
   real(dp), parameter :: a5_1 = 0.2413651341592667_dp, a5_3 = -0.8845494793282861_dp, &
      a5_4 = 0.924834003261792_dp
   real(dp), parameter :: a6_1 = 0.037037037037037035_dp, a6_4 = 0.17082860872947386_dp, &
      a6_5 = 0.12546768756682242_dp
   real(dp), parameter :: a7_1 = 0.037109375_dp, a7_4 = 0.17025221101954405_dp, &
      a7_5 = 0.06021653898045596_dp, a7_6 = -0.017578125_dp
   real(dp), parameter :: a8_1 = 0.03709200011850479_dp, a8_4 = 0.17038392571223998_dp, &
      a8_5 = 0.10726203044637328_dp, a8_6 = -0.015319437748624402_dp, a8_7 = 0.008273789163814023_dp
   real(dp), parameter :: a9_1 = 0.6241109587160757_dp, a9_4 = -3.3608926294469414_dp, &
      a9_5 = -0.868219346841726_dp, a9_6 = 27.59209969944671_dp, a9_7 = 20.154067550477894_dp, &
      a9_8 = -43.48988418106996_dp
   real(dp), parameter :: a10_1 = 0.47766253643826434_dp, a10_4 = -2.4881146199716677_dp, &
      a10_5 = -0.590290826836843_dp, a10_6 = 21.230051448181193_dp, a10_7 = 15.279233632882423_dp, &
      a10_8 = -33.28821096898486_dp, a10_9 = -0.020331201708508627_dp
   real(dp), parameter :: a11_1 = -0.9371424300859873_dp, a11_4 = 5.186372428844064_dp, &
      a11_5 = 1.0914373489967295_dp, a11_6 = -8.149787010746927_dp, a11_7 = -18.52006565999696_dp, &
      a11_8 = 22.739487099350505_dp, a11_9 = 2.4936055526796523_dp, a11_10 = -3.0467644718982196_dp
   real(dp), parameter :: a12_1 = 2.273310147516538_dp, a12_4 = -10.53449546673725_dp, &
      a12_5 = -2.0008720582248625_dp, a12_6 = -17.9589318631188_dp, a12_7 = 27.94888452941996_dp, &
      a12_8 = -2.8589982771350235_dp, a12_9 = -8.87285693353063_dp, a12_10 = 12.360567175794303_dp, &
      a12_11 = 0.6433927460157636_dp
   real(dp), parameter :: a14_1 = 0.056167502283047954_dp, a14_7 = 0.25350021021662483_dp, &
      a14_8 = -0.2462390374708025_dp, a14_9 = -0.12419142326381637_dp, a14_10 = 0.15329179827876568_dp, &
      a14_11 = 0.00820105229563469_dp, a14_12 = 0.007567897660545699_dp, a14_13 = -0.008298_dp
   real(dp), parameter :: a15_1 = 0.03183464816350214_dp, a15_6 = 0.028300909672366776_dp, &
      a15_7 = 0.053541988307438566_dp, a15_8 = -0.05492374857139099_dp, a15_11 = -0.00010834732869724932_dp, &
      a15_12 = 0.0003825710908356584_dp, a15_13 = -0.00034046500868740456_dp, &
      a15_14 = 0.1413124436746325_dp
   real(dp), parameter :: a16_1 = -0.42889630158379194_dp, a16_6 = -4.697621415361164_dp, &
      a16_7 = 7.683421196062599_dp, a16_8 = 4.06898981839711_dp, a16_9 = 0.3567271874552811_dp, &
      a16_13 = -0.0013990241651590145_dp, a16_14 = 2.9475147891527724_dp, a16_15 = -9.15095847217987_dp
   ! Weights of the eighth-order solution.
   real(dp), parameter :: b1 = 0.054293734116568765_dp, b6 = 4.450312892752409_dp, &
      b7 = 1.8915178993145003_dp, b8 = -5.801203960010585_dp, b9 = 0.3111643669578199_dp, &
      b10 = -0.1521609496625161_dp, b11 = 0.20136540080403034_dp, b12 = 0.04471061572777259_dp
   ! Error weights: E5 (fifth order) and E3 (third order); entry 13 multiplies f(tau+h, y_new).
   real(dp), parameter :: e5_1 = 0.01312004499419488_dp, e5_6 = -1.2251564463762044_dp, &
      e5_7 = -0.4957589496572502_dp, e5_8 = 1.6643771824549864_dp, e5_9 = -0.35032884874997366_dp, &
      e5_10 = 0.3341791187130175_dp, e5_11 = 0.08192320648511571_dp, e5_12 = -0.022355307863886294_dp
   real(dp), parameter :: e3_1 = -0.18980075407240762_dp, e3_6 = 4.450312892752409_dp, &
      e3_7 = 1.8915178993145003_dp, e3_8 = -5.801203960010585_dp, e3_9 = -0.4226823213237919_dp, &
      e3_10 = -0.1521609496625161_dp, e3_11 = 0.20136540080403034_dp, e3_12 = 0.02265179219836082_dp
   ! Dense output: rows 4-7 of the interpolant, weights of the 16 stages.
   real(dp), parameter :: d4_1 = -8.428938276109013_dp, d4_6 = 0.5667149535193777_dp, &
      d4_7 = -3.0689499459498917_dp, d4_8 = 2.38466765651207_dp, d4_9 = 2.117034582445028_dp, &
      d4_10 = -0.871391583777973_dp, d4_11 = 2.2404374302607883_dp, d4_12 = 0.6315787787694688_dp, &
      d4_13 = -0.08899033645133331_dp, d4_14 = 18.148505520854727_dp, d4_15 = -9.194632392478356_dp, &
      d4_16 = -4.436036387594894_dp
   real(dp), parameter :: d5_1 = 10.427508642579134_dp, d5_6 = 242.28349177525817_dp, &
      d5_7 = 165.20045171727028_dp, d5_8 = -374.5467547226902_dp, d5_9 = -22.113666853125306_dp, &
      d5_10 = 7.733432668472264_dp, d5_11 = -30.674084731089398_dp, d5_12 = -9.332130526430229_dp, &
      d5_13 = 15.697238121770845_dp, d5_14 = -31.139403219565178_dp, d5_15 = -9.35292435884448_dp, &
      d5_16 = 35.81684148639408_dp
   real(dp), parameter :: d6_1 = 19.985053242002433_dp, d6_6 = -387.0373087493518_dp, &
      d6_7 = -189.17813819516758_dp, d6_8 = 527.8081592054236_dp, d6_9 = -11.57390253995963_dp, &
      d6_10 = 6.8812326946963_dp, d6_11 = -1.0006050966910838_dp, d6_12 = 0.7777137798053443_dp, &
      d6_13 = -2.778205752353508_dp, d6_14 = -60.19669523126412_dp, d6_15 = 84.32040550667716_dp, &
      d6_16 = 11.99229113618279_dp
   real(dp), parameter :: d7_1 = -25.69393346270375_dp, d7_6 = -154.18974869023643_dp, &
      d7_7 = -231.5293791760455_dp, d7_8 = 357.6391179106141_dp, d7_9 = 93.40532418362432_dp, &
      d7_10 = -37.45832313645163_dp, d7_11 = 104.0996495089623_dp, d7_12 = 29.8402934266605_dp, &
      d7_13 = -43.53345659001114_dp, d7_14 = 96.32455395918828_dp, d7_15 = -39.17726167561544_dp, &
      d7_16 = -149.72683625798564_dp

   !> The tableau as arrays (for the Lawson form of the pair, tmafm_lawson): dop853_a(i, j) the
   !> coefficient of stage j in stage i (stage 13 is the derivative at the new state), the nodes,
   !> the weights of the solution, of the two error estimates and of rows 4-7 of the dense output.
   real(dp), parameter, public :: dop853_a(16, 16) = reshape([ &
      0.0_dp, a2_1, a3_1, a4_1, a5_1, a6_1, a7_1, a8_1, a9_1, a10_1, a11_1, a12_1, 0.0_dp, a14_1, a15_1, &
      a16_1, 0.0_dp, 0.0_dp, a3_2, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, &
      0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, a4_3, a5_3, 0.0_dp, 0.0_dp, &
      0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, &
      0.0_dp, a5_4, a6_4, a7_4, a8_4, a9_4, a10_4, a11_4, a12_4, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, &
      0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, a6_5, a7_5, a8_5, a9_5, a10_5, a11_5, a12_5, 0.0_dp, 0.0_dp, &
      0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, a7_6, a8_6, a9_6, a10_6, a11_6, &
      a12_6, 0.0_dp, 0.0_dp, a15_6, a16_6, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, a8_7, &
      a9_7, a10_7, a11_7, a12_7, 0.0_dp, a14_7, a15_7, a16_7, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, &
      0.0_dp, 0.0_dp, 0.0_dp, a9_8, a10_8, a11_8, a12_8, 0.0_dp, a14_8, a15_8, a16_8, 0.0_dp, 0.0_dp, &
      0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, a10_9, a11_9, a12_9, 0.0_dp, a14_9, &
      0.0_dp, a16_9, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, &
      a11_10, a12_10, 0.0_dp, a14_10, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, &
      0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, a12_11, 0.0_dp, a14_11, a15_11, 0.0_dp, 0.0_dp, 0.0_dp, &
      0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, a14_12, &
      a15_12, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, &
      0.0_dp, 0.0_dp, 0.0_dp, a14_13, a15_13, a16_13, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, &
      0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, a15_14, a16_14, 0.0_dp, 0.0_dp, &
      0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, &
      0.0_dp, a16_15, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, &
      0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp], [16, 16])
   !> Nodes c_1..c_16 (c_13 = 1: the new state).
   real(dp), parameter, public :: dop853_c(16) = [ &
      0.0_dp, c2, c3, c4, c5, c6, c7, c8, c9, c10, c11, c12, 1.0_dp, c14, c15, c16]
   !> Weights of the eighth-order solution, and of the fifth- and third-order error estimates.
   real(dp), parameter, public :: dop853_b(16) = [ &
      b1, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, b6, b7, b8, b9, b10, b11, b12, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp]
   real(dp), parameter, public :: dop853_e5(16) = [ &
      e5_1, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, e5_6, e5_7, e5_8, e5_9, e5_10, e5_11, e5_12, 0.0_dp, 0.0_dp, &
      0.0_dp, 0.0_dp]
   real(dp), parameter, public :: dop853_e3(16) = [ &
      e3_1, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, e3_6, e3_7, e3_8, e3_9, e3_10, e3_11, e3_12, 0.0_dp, 0.0_dp, &
      0.0_dp, 0.0_dp]
   !> Rows 4-7 of the dense output: dop853_d(row, j).
   real(dp), parameter, public :: dop853_d(4:7, 16) = reshape([ &
      d4_1, d5_1, d6_1, d7_1, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, &
      0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, d4_6, d5_6, d6_6, d7_6, d4_7, d5_7, d6_7, &
      d7_7, d4_8, d5_8, d6_8, d7_8, d4_9, d5_9, d6_9, d7_9, d4_10, d5_10, d6_10, d7_10, d4_11, d5_11, &
      d6_11, d7_11, d4_12, d5_12, d6_12, d7_12, d4_13, d5_13, d6_13, d7_13, d4_14, d5_14, d6_14, d7_14, &
      d4_15, d5_15, d6_15, d7_15, d4_16, d5_16, d6_16, d7_16], [4, 16])

   !> Stage registers and the dense-output coefficients of the last step.
   type, extends(embedded_pair_t) :: dop853_pair_t
      !> Stage derivatives k(1:n, j), j = 2..12 and 14..16 (1 and 13 are the caller's f0, f_new),
      !> n the state's length, in lead rows.
      real(dp), allocatable :: k(:, :)
      !> The stage state and the two error estimates of the last step.
      real(dp), allocatable :: stage(:), err5(:), err3(:)
      !> Dense output: y(x) = y0 + x (r(0) + (1-x) (r(1) + x (r(2) + (1-x) (r(3) + ...)))).
      real(dp), allocatable :: y0(:), r(:, :)
   contains
      !> Allocate the registers for a state of size n_state.
      procedure :: init => dop853_init
      !> One step over a time map in a frozen phase; f0 = dy/ds in, f_new = dy/ds at y_new out.
      procedure :: step => dop853_step
      !> The error norm of the last step.
      procedure :: error_norm => dop853_error_norm
      !> norm^(-1/8).
      procedure :: growth => dop853_growth
      !> Evaluate stages 14-16 and build the dense output of the last step.
      procedure :: prepare_dense => dop853_prepare_dense
      !> The dense-output state at fraction theta of the last step.
      procedure :: dense => dop853_dense
   end type dop853_pair_t

contains

   subroutine dop853_init(self, n_state)
      class(dop853_pair_t), intent(inout) :: self
      integer, intent(in) :: n_state
      self%stage_evaluations = 12
      self%dense_evaluations = 3
      ! Hairer's DOP853 defaults.
      self%shrink_limit = 0.333_dp
      self%grow_limit = 6.0_dp
      if (allocated(self%k)) return
      ! The state is (a, a') of a model, or (a, a', w, 0) with a viscoelastic sample:
      ! n_state <= 2 n_modes + 2 <= lead (tmafm_model's limit).
      allocate (self%k(lead, 2:16), self%stage(n_state), self%err5(n_state), &
                self%err3(n_state), self%y0(n_state), self%r(n_state, 0:6))
   end subroutine dop853_init

   subroutine dop853_step(self, model, map, y, in_contact, f0, y_new, f_new)
      class(dop853_pair_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      type(time_map_t), intent(in) :: map
      real(dp), intent(in), contiguous :: y(:)
      logical, intent(in) :: in_contact
      real(dp), intent(in), contiguous :: f0(:)
      real(dp), intent(out), contiguous :: y_new(:)
      real(dp), intent(out), contiguous :: f_new(:)
      self%map = map
      call dop853_stages(model, size(y)/2, map, y, in_contact, f0, self%k, self%stage, y_new, f_new, &
                         self%err5, self%err3, self%sin_end, self%cos_end, self%vt_end, self%rate_end)
   end subroutine dop853_step

   !> The stages of dop853_step on explicit-shape registers (the compiler sees unit strides
   !> and no aliasing; their length 2 n_modes is even, so the vectorised sums have no odd
   !> remainder): k(:n, 2:12), the new state, f_new, the fifth- and third-order error
   !> estimates (in the pass that forms the new state: they weigh the same stages) and the
   !> drive phase, V_T and dV_T/dtau at the step end.  On a warped step each stage derivative
   !> is scaled by its dtau/dsigma as soon as it is formed.
   pure subroutine dop853_stages(model, n_modes, map, y, in_contact, f0, k, stage, y_new, f_new, &
                                 err5, err3, sin_end, cos_end, vt_end, rate_end)
      type(model_t), intent(in) :: model
      integer, intent(in) :: n_modes
      type(time_map_t), intent(in) :: map
      real(dp), intent(in) :: y(2*n_modes)
      logical, intent(in) :: in_contact
      real(dp), intent(in) :: f0(2*n_modes)
      real(dp), intent(inout) :: k(lead, 2:16)
      real(dp), intent(inout) :: stage(2*n_modes)
      real(dp), intent(out) :: y_new(2*n_modes)
      real(dp), intent(out) :: f_new(2*n_modes)
      real(dp), intent(out) :: err5(2*n_modes)
      real(dp), intent(out) :: err3(2*n_modes)
      real(dp), intent(out) :: sin_end
      real(dp), intent(out) :: cos_end
      real(dp), intent(out) :: vt_end
      real(dp), intent(out) :: rate_end
      real(dp) :: sin_phase(size(step_nodes)), cos_phase(size(step_nodes)), factor(size(step_nodes))
      real(dp) :: h
      integer :: n
      integer :: i

      n = 2*n_modes
      h = map%h
      call stage_clock(model, map, step_nodes, sin_phase, cos_phase, factor)
      sin_end = sin_phase(11)
      cos_end = cos_phase(11)
      stage = y + h*a2_1*f0
      call model%derivative_at_phase(stage, in_contact, sin_phase(1), cos_phase(1), k(:n, 2))
      if (map%warped) k(:n, 2) = factor(1)*k(:n, 2)
      stage = y + h*(a3_1*f0 + a3_2*k(:n, 2))
      call model%derivative_at_phase(stage, in_contact, sin_phase(2), cos_phase(2), k(:n, 3))
      if (map%warped) k(:n, 3) = factor(2)*k(:n, 3)
      stage = y + h*(a4_1*f0 + a4_3*k(:n, 3))
      call model%derivative_at_phase(stage, in_contact, sin_phase(3), cos_phase(3), k(:n, 4))
      if (map%warped) k(:n, 4) = factor(3)*k(:n, 4)
      stage = y + h*(a5_1*f0 + a5_3*k(:n, 3) + a5_4*k(:n, 4))
      call model%derivative_at_phase(stage, in_contact, sin_phase(4), cos_phase(4), k(:n, 5))
      if (map%warped) k(:n, 5) = factor(4)*k(:n, 5)
      stage = y + h*(a6_1*f0 + a6_4*k(:n, 4) + a6_5*k(:n, 5))
      call model%derivative_at_phase(stage, in_contact, sin_phase(5), cos_phase(5), k(:n, 6))
      if (map%warped) k(:n, 6) = factor(5)*k(:n, 6)
      stage = y + h*(a7_1*f0 + a7_4*k(:n, 4) + a7_5*k(:n, 5) + a7_6*k(:n, 6))
      call model%derivative_at_phase(stage, in_contact, sin_phase(6), cos_phase(6), k(:n, 7))
      if (map%warped) k(:n, 7) = factor(6)*k(:n, 7)
      stage = y + h*(a8_1*f0 + a8_4*k(:n, 4) + a8_5*k(:n, 5) + a8_6*k(:n, 6) + a8_7*k(:n, 7))
      call model%derivative_at_phase(stage, in_contact, sin_phase(7), cos_phase(7), k(:n, 8))
      if (map%warped) k(:n, 8) = factor(7)*k(:n, 8)
      stage = y + h*(a9_1*f0 + a9_4*k(:n, 4) + a9_5*k(:n, 5) + a9_6*k(:n, 6) + a9_7*k(:n, 7) &
                     + a9_8*k(:n, 8))
      call model%derivative_at_phase(stage, in_contact, sin_phase(8), cos_phase(8), k(:n, 9))
      if (map%warped) k(:n, 9) = factor(8)*k(:n, 9)
      stage = y + h*(a10_1*f0 + a10_4*k(:n, 4) + a10_5*k(:n, 5) + a10_6*k(:n, 6) + a10_7*k(:n, 7) &
                     + a10_8*k(:n, 8) + a10_9*k(:n, 9))
      call model%derivative_at_phase(stage, in_contact, sin_phase(9), cos_phase(9), k(:n, 10))
      if (map%warped) k(:n, 10) = factor(9)*k(:n, 10)
      stage = y + h*(a11_1*f0 + a11_4*k(:n, 4) + a11_5*k(:n, 5) + a11_6*k(:n, 6) + a11_7*k(:n, 7) &
                     + a11_8*k(:n, 8) + a11_9*k(:n, 9) + a11_10*k(:n, 10))
      call model%derivative_at_phase(stage, in_contact, sin_phase(10), cos_phase(10), k(:n, 11))
      if (map%warped) k(:n, 11) = factor(10)*k(:n, 11)
      stage = y + h*(a12_1*f0 + a12_4*k(:n, 4) + a12_5*k(:n, 5) + a12_6*k(:n, 6) + a12_7*k(:n, 7) &
                     + a12_8*k(:n, 8) + a12_9*k(:n, 9) + a12_10*k(:n, 10) + a12_11*k(:n, 11))
      call model%derivative_at_phase(stage, in_contact, sin_phase(11), cos_phase(11), k(:n, 12))
      if (map%warped) k(:n, 12) = factor(11)*k(:n, 12)
      do i = 1, n
         y_new(i) = y(i) + h*(b1*f0(i) + b6*k(i, 6) + b7*k(i, 7) + b8*k(i, 8) + b9*k(i, 9) &
                              + b10*k(i, 10) + b11*k(i, 11) + b12*k(i, 12))
         err5(i) = e5_1*f0(i) + e5_6*k(i, 6) + e5_7*k(i, 7) + e5_8*k(i, 8) + e5_9*k(i, 9) &
                   + e5_10*k(i, 10) + e5_11*k(i, 11) + e5_12*k(i, 12)
         err3(i) = e3_1*f0(i) + e3_6*k(i, 6) + e3_7*k(i, 7) + e3_8*k(i, 8) + e3_9*k(i, 9) &
                   + e3_10*k(i, 10) + e3_11*k(i, 11) + e3_12*k(i, 12)
      end do
      call model%derivative_and_gap(y_new, in_contact, sin_phase(11), cos_phase(11), f_new, vt_end, rate_end)
      if (map%warped) f_new = factor(11)*f_new
   end subroutine dop853_stages

   !> Hairer's DOP853 estimate from err5 and err3 (formed by dop853_stages); f_new is not used
   !> (its weights e5_13 and e3_13 are zero).
   pure subroutine dop853_error_norm(self, h, f0, f_new, scale, norm)
      class(dop853_pair_t), intent(inout) :: self
      real(dp), intent(in) :: h
      real(dp), intent(in), contiguous :: f0(:)
      real(dp), intent(in), contiguous :: f_new(:)
      type(error_scale_t), intent(in) :: scale
      real(dp), intent(out) :: norm
      norm = dop853_norm(h, self%err5, self%err3, scale)
   end subroutine dop853_error_norm

   !> DOP853's error norm of a step of length h from its 5th- and 3rd-order error estimates (per
   !> unit h): |h| s5/sqrt(s5 + s3/100) with their weighted sums of squares (Hairer's dop853.f).
   pure real(dp) function dop853_norm(h, err5, err3, scale) result(norm)
      real(dp), intent(in) :: h
      real(dp), intent(in) :: err5(:)
      real(dp), intent(in) :: err3(:)
      type(error_scale_t), intent(in) :: scale
      real(dp) :: s5, s3
      call scale%sums_of_squares(err5, err3, s5, s3)
      if (s5 == 0 .and. s3 == 0) then
         norm = 0
      else
         norm = abs(h)*s5/sqrt(s5 + 0.01_dp*s3)
      end if
   end function dop853_norm

   pure function dop853_growth(self, norm) result(ratio)
      class(dop853_pair_t), intent(in) :: self
      real(dp), intent(in) :: norm
      real(dp) :: ratio
      ratio = 1/sqrt(sqrt(sqrt(norm)))
   end function dop853_growth

   subroutine dop853_prepare_dense(self, model, y, y_new, in_contact, f0, f_new)
      class(dop853_pair_t), intent(inout) :: self
      type(model_t), intent(in) :: model
      real(dp), intent(in), contiguous :: y(:)
      real(dp), intent(in), contiguous :: y_new(:)
      logical, intent(in) :: in_contact
      real(dp), intent(in), contiguous :: f0(:)
      real(dp), intent(in), contiguous :: f_new(:)
      call dop853_dense_stages(model, size(y)/2, self%map, y, y_new, in_contact, f0, f_new, self%k, &
                               self%stage, self%y0, self%r)
   end subroutine dop853_prepare_dense

   !> Stages 14-16 and the dense-output coefficients r(:, 0:6) of dop853_prepare_dense on
   !> explicit-shape registers, as dop853_stages: the stage sums and the rows of r are
   !> whole-array expressions the compiler vectorises without array descriptors.
   pure subroutine dop853_dense_stages(model, n_modes, map, y, y_new, in_contact, f0, f_new, k, stage, y0, r)
      type(model_t), intent(in) :: model
      integer, intent(in) :: n_modes
      type(time_map_t), intent(in) :: map
      real(dp), intent(in) :: y(2*n_modes)
      real(dp), intent(in) :: y_new(2*n_modes)
      logical, intent(in) :: in_contact
      real(dp), intent(in) :: f0(2*n_modes)
      real(dp), intent(in) :: f_new(2*n_modes)
      real(dp), intent(inout) :: k(lead, 2:16)
      real(dp), intent(inout) :: stage(2*n_modes)
      real(dp), intent(out) :: y0(2*n_modes)
      real(dp), intent(out) :: r(2*n_modes, 0:6)
      real(dp) :: sin_phase(size(dense_nodes)), cos_phase(size(dense_nodes)), factor(size(dense_nodes))
      real(dp) :: h
      integer :: n

      n = 2*n_modes
      h = map%h
      call stage_clock(model, map, dense_nodes, sin_phase, cos_phase, factor)
      stage = y + h*(a14_1*f0 + a14_7*k(:n, 7) + a14_8*k(:n, 8) + a14_9*k(:n, 9) + a14_10*k(:n, 10) &
                     + a14_11*k(:n, 11) + a14_12*k(:n, 12) + a14_13*f_new)
      call model%derivative_at_phase(stage, in_contact, sin_phase(1), cos_phase(1), k(:n, 14))
      if (map%warped) k(:n, 14) = factor(1)*k(:n, 14)
      stage = y + h*(a15_1*f0 + a15_6*k(:n, 6) + a15_7*k(:n, 7) + a15_8*k(:n, 8) + a15_11*k(:n, 11) &
                     + a15_12*k(:n, 12) + a15_13*f_new + a15_14*k(:n, 14))
      call model%derivative_at_phase(stage, in_contact, sin_phase(2), cos_phase(2), k(:n, 15))
      if (map%warped) k(:n, 15) = factor(2)*k(:n, 15)
      stage = y + h*(a16_1*f0 + a16_6*k(:n, 6) + a16_7*k(:n, 7) + a16_8*k(:n, 8) + a16_9*k(:n, 9) &
                     + a16_13*f_new + a16_14*k(:n, 14) + a16_15*k(:n, 15))
      call model%derivative_at_phase(stage, in_contact, sin_phase(3), cos_phase(3), k(:n, 16))
      if (map%warped) k(:n, 16) = factor(3)*k(:n, 16)
      y0 = y
      r(:, 0) = y_new - y
      r(:, 1) = h*f0 - r(:, 0)
      r(:, 2) = 2*r(:, 0) - h*(f_new + f0)
      r(:, 3) = h*(d4_1*f0 + d4_6*k(:n, 6) + d4_7*k(:n, 7) + d4_8*k(:n, 8) + d4_9*k(:n, 9) &
                   + d4_10*k(:n, 10) + d4_11*k(:n, 11) + d4_12*k(:n, 12) + d4_13*f_new &
                   + d4_14*k(:n, 14) + d4_15*k(:n, 15) + d4_16*k(:n, 16))
      r(:, 4) = h*(d5_1*f0 + d5_6*k(:n, 6) + d5_7*k(:n, 7) + d5_8*k(:n, 8) + d5_9*k(:n, 9) &
                   + d5_10*k(:n, 10) + d5_11*k(:n, 11) + d5_12*k(:n, 12) + d5_13*f_new &
                   + d5_14*k(:n, 14) + d5_15*k(:n, 15) + d5_16*k(:n, 16))
      r(:, 5) = h*(d6_1*f0 + d6_6*k(:n, 6) + d6_7*k(:n, 7) + d6_8*k(:n, 8) + d6_9*k(:n, 9) &
                   + d6_10*k(:n, 10) + d6_11*k(:n, 11) + d6_12*k(:n, 12) + d6_13*f_new &
                   + d6_14*k(:n, 14) + d6_15*k(:n, 15) + d6_16*k(:n, 16))
      r(:, 6) = h*(d7_1*f0 + d7_6*k(:n, 6) + d7_7*k(:n, 7) + d7_8*k(:n, 8) + d7_9*k(:n, 9) &
                   + d7_10*k(:n, 10) + d7_11*k(:n, 11) + d7_12*k(:n, 12) + d7_13*f_new &
                   + d7_14*k(:n, 14) + d7_15*k(:n, 15) + d7_16*k(:n, 16))
   end subroutine dop853_dense_stages

   pure subroutine dop853_dense(self, theta, y)
      class(dop853_pair_t), intent(in) :: self
      real(dp), intent(in) :: theta
      real(dp), intent(out), contiguous :: y(:)
      call dense_sum(size(y)/2, theta, self%y0, self%r, y)
   end subroutine dop853_dense

   !> The dense-output sum of dop853_dense on explicit-shape registers.
   pure subroutine dense_sum(n_modes, theta, y0, r, y)
      integer, intent(in) :: n_modes
      real(dp), intent(in) :: theta
      real(dp), intent(in) :: y0(2*n_modes)
      real(dp), intent(in) :: r(2*n_modes, 0:6)
      real(dp), intent(out) :: y(2*n_modes)
      real(dp) :: rest
      rest = 1 - theta
      y = y0 + theta*(r(:, 0) + rest*(r(:, 1) + theta*(r(:, 2) + rest*(r(:, 3) &
          + theta*(r(:, 4) + rest*(r(:, 5) + theta*r(:, 6)))))))
   end subroutine dense_sum

end module tmafm_dop853

!> A cantilever run one drive period at a time, while an instrument changes its setting between
!> periods (docs/instrument.md): the rest distance Z (a Z piezo, a topography under the tip), the
!> sample's material, the drive's frequency and amplitude (a phase-locked loop, an amplitude
!> controller).  Each period is one observed run (tmafm_observers) of the model of the current
!> setting from the state the last period ended in, so its observables (amplitude and phase at
!> the drive, peak force, dissipated energy, ...) are exact to the run's accuracy, as
!> tmafm.observe's are.
!>
!> Between periods the setting is a new &physical scene (set_physical): the model is rebuilt from
!> it (N kept) and the state is carried over in physical units.  The Galerkin amplitudes and
!> velocities are in units of the gap d (docs/model.md §1), which a new Z changes, so they are
!> scaled by d_old/d_new; the time unit t0 is the beam's and does not change.  A viscoelastic
!> sample's dashpot coordinate w is in units of X = (a/a0)^3 (§6, §14), which no Z changes; a new
!> material is a new sample under the tip, met relaxed (w = 0).  A capillary meniscus's flag and
!> a JKR neck's phase carry over as they are.
!>
!> With thermal noise (&solver thermal_noise = 1, docs/model.md §21) each period is a run of its
!> own, so each takes its own realisation: the seed of period k (k = 0, 1, ...) is the input's
!> noise_seed + 1 + k 2654435761 (a Weyl sequence mod 2^31, mixed again by the generator), and
!> its grid starts at the period's start (white noise on disjoint intervals is independent).
!>
!> Every period starts at the drive's phase 0 (the equations depend on time only through the
!> drive) and lasts one period of the current drive, so a drive whose frequency changes between
!> periods stays continuous in phase, as a synthesiser's that updates at the zero crossings.
module tmafm_period_stepper
   use tmafm_kinds, only: dp, i8
   use tmafm_errors, only: ok, err_input, err_runtime
   use tmafm_config, only: config_t
   use tmafm_model, only: model_t
   use tmafm_scene, only: physical_t, scene_from_physical, physical_names, physical_values
   use tmafm_keys, only: material_key_index
   use tmafm_settings, only: run_settings_t, method_rk4_paper, method_dopri5, method_dop853, &
      method_flight_exact
   use tmafm_simulation, only: prepare_model, build_model
   use tmafm_driver, only: run_trajectory
   use tmafm_trajectory, only: trajectory_t, stop_poll
   use tmafm_observers, only: observer_t, group_all, n_observables, observable_factors
   use tmafm_units, only: scales_t, scales_from_physical
   use tmafm_text, only: real_text
   use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
   implicit none
   private

   public :: period_stepper_t, init_period_stepper, with_distance

   real(dp), parameter :: pi = acos(-1.0_dp)
   !> Each period's noise seed: a Weyl sequence of this step mod 2^31 (&solver noise_seed's range).
   integer(i8), parameter :: weyl_step = 2654435761_i8, seed_modulus = 2147483648_i8

   !> A cantilever stepped period by period: its current scene, model and state.
   type :: period_stepper_t
      !> The configuration of the current setting (&physical scene; N fixed).
      type(config_t) :: config
      !> The model of the current setting.
      type(model_t) :: model
      !> How each period is integrated (the configuration's &solver; tau_end = one period).
      type(run_settings_t) :: settings
      !> The SI scales of the current setting (the gap d is the length unit).
      type(scales_t) :: scales
      !> The state at the end of the last period (model units of the current setting).
      real(dp), allocatable :: y(:)
      !> The phase the next period starts in: -1 by the sign of V_T, 1 in contact, 0 in flight
      !> (a JKR neck or a meniscus held above the surface: the hysteretic models' phase).
      integer :: phase = -1
      !> The observable groups each period computes (bits tmafm_observers group_*).
      integer :: groups = group_all
      !> Periods run, and the time they took (s).
      integer(i8) :: periods = 0
      real(dp) :: time = 0
      !> The current drive period (s).
      real(dp) :: period = 0
      !> The last period's observables, in tmafm.observe's units (nm, deg, nN, us, aJ).
      real(dp) :: values(n_observables) = 0
      !> The input's &solver noise_seed (each period's own seed derives from it).
      integer(i8) :: noise_seed = 0
   contains
      !> Change the setting to a new physical scene, carrying the state over.
      procedure :: set_physical => stepper_set_physical
      !> Run one drive period of the current setting; values holds its observables.
      procedure :: advance => stepper_advance
   end type period_stepper_t

contains

   !> A stepper of a configuration given in SI units (&physical), starting from its &initial
   !> state; N is chosen here when &model n_modes = 0.
   subroutine init_period_stepper(stepper, config, ierr, errmsg, groups, poll)
      type(period_stepper_t), intent(out) :: stepper
      type(config_t), intent(in) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      !> The observable groups each period computes (default: all).
      integer, intent(in), optional :: groups
      !> If present, an automatic N's comparison runs poll it.
      procedure(stop_poll), optional :: poll
      integer :: n

      ierr = ok
      errmsg = ''
      if (.not. config%from_physical) then
         ierr = err_input
         errmsg = '&physical: the instrument needs a scene in SI units (a &physical group, not &scene alone)'
         return
      end if
      select case (trim(config%solver%method))
      case (method_rk4_paper, method_dopri5, method_dop853, method_flight_exact)
      case default
         ierr = err_input
         errmsg = '&solver method = '''//trim(config%solver%method)//''': the instrument runs ''rk4_paper'', '// &
                  '''dopri5'', ''dop853'' or ''flight_exact'' (it observes every period)'
         return
      end select
      call prepare_model(config, stepper%config, stepper%model, ierr, errmsg, poll)
      if (ierr /= ok) return
      stepper%config%auto_modes = .false.
      if (present(groups)) stepper%groups = groups
      n = stepper%config%n_modes
      allocate (stepper%y(stepper%model%n_state))
      stepper%y = 0
      stepper%y(1:n) = stepper%config%a0(1:n)
      stepper%y(n + 1:2*n) = stepper%config%adot0(1:n)
      stepper%phase = stepper%config%solver%initial_contact
      stepper%noise_seed = stepper%config%solver%noise_seed
      call settle_setting(stepper, ierr, errmsg)
   end subroutine init_period_stepper

   !> A physical scene with the tip's rest distance Z (m): the gap d = g0 + Z/cos(theta) and the
   !> static offset follow it (docs/model.md §1).
   pure function with_distance(physical, z) result(moved)
      type(physical_t), intent(in) :: physical
      real(dp), intent(in) :: z
      type(physical_t) :: moved
      moved = physical
      moved%tip_sample_distance = z
      moved%static_offset = z
      moved%gap = physical%tip_length + z/cos(physical%tilt)
      moved%by_distance = .true.
   end function with_distance

   !> The new setting `physical` (the same cantilever: only the distance, the sample, the drive
   !> may differ; the caller's business): the model is rebuilt and the state carried over.
   subroutine stepper_set_physical(self, physical, ierr, errmsg)
      class(period_stepper_t), intent(inout) :: self
      type(physical_t), intent(in) :: physical
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      real(dp) :: scale
      real(dp) :: new_values(size(physical_names)), old_values(size(physical_names))
      integer :: n
      logical :: new_sample

      ierr = ok
      errmsg = ''
      if (.not. (physical%gap > 0 .and. physical%gap <= 1)) then
         ierr = err_input
         errmsg = '&physical tip_sample_distance = '//real_text(physical%tip_sample_distance)//': gives gap = '// &
                  real_text(physical%gap)//', must be > 0 and <= 1'
         return
      end if
      n = self%config%n_modes
      scale = self%config%physical%gap/physical%gap
      ! A new material: any of the sample's keys (those a scan's second material may set) differs.
      new_values = physical_values(physical)
      old_values = physical_values(self%config%physical)
      new_sample = any(new_values(material_key_index) /= old_values(material_key_index))
      self%config%physical = physical
      self%config%scene = scene_from_physical(physical)
      call build_model(self%config, self%model, ierr, errmsg)
      if (ierr /= ok) return
      if (size(self%y) /= self%model%n_state) then
         ierr = err_input
         errmsg = '&physical: a new setting may not switch a viscoelastic sample or a meniscus on or off '// &
                  'between periods'
         return
      end if
      self%y(1:2*n) = self%y(1:2*n)*scale
      if (new_sample .and. self%model%sls%on) self%y(2*n + 1) = 0
      call settle_setting(self, ierr, errmsg)
   end subroutine stepper_set_physical

   !> The scales, the period and the run settings of the current setting.
   subroutine settle_setting(self, ierr, errmsg)
      type(period_stepper_t), intent(inout) :: self
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      real(dp) :: period

      ierr = ok
      errmsg = ''
      if (.not. (self%model%drive%fundamental > 0)) then
         ierr = err_input
         errmsg = '&physical drive_frequency = '//real_text(self%config%physical%drive_angular_frequency/(2*pi))// &
                  ': the instrument needs a drive period (a frequency > 0)'
         return
      end if
      period = 2*pi/self%model%drive%fundamental
      self%scales = scales_from_physical(self%config%physical)
      self%period = period*self%scales%time
      self%settings = self%config%solver
      self%settings%tau_end = period
      self%settings%sample_dtau = period
      self%settings%first_sample = 0
      self%settings%last_periods = 0
      self%settings%sample_from = 0
   end subroutine settle_setting

   !> One drive period of the current setting from the current state; on success the state is
   !> the period's end and `values` its observables.  On failure the state is left as it was.
   subroutine stepper_advance(self, ierr, errmsg, poll)
      class(period_stepper_t), intent(inout) :: self
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      !> If present, the run polls it (Ctrl-C from Python).
      procedure(stop_poll), optional :: poll
      type(observer_t) :: observer
      type(trajectory_t) :: traj
      integer :: n, last

      n = self%config%n_modes
      self%settings%noise_seed = modulo(self%noise_seed + 1 + self%periods*weyl_step, seed_modulus)
      self%settings%initial_contact = -1
      if (self%model%hysteretic) self%settings%initial_contact = self%phase
      call observer%init(self%model, 1, 1, 1, 1.0e-6_dp, 1, .false., self%y, self%groups)
      call run_trajectory(self%model, self%settings, self%y(1:n), self%y(n + 1:2*n), traj, ierr, errmsg, &
                          observer=observer, poll=poll, tail=self%y(2*n + 1:))
      if (ierr /= ok) return
      if (observer%n_periods /= 1) then
         ierr = err_runtime
         errmsg = 'instrument: a drive period ended early (the run stopped after '//real_text(traj%tau(1))//')'
         return
      end if
      if (.not. all(ieee_is_finite(observer%poincare(:, 1)))) then
         ierr = err_runtime
         errmsg = 'instrument: the state is not finite after a drive period'
         return
      end if
      self%y = observer%poincare(:, 1)
      last = traj%next_sample - 1
      self%phase = -1
      if (self%model%hysteretic .and. last >= 1) self%phase = traj%contact(last)
      self%values = observer%values(1, :)*observable_factors(self%scales)
      self%periods = self%periods + 1
      self%time = self%time + self%period
   end subroutine stepper_advance

end module tmafm_period_stepper

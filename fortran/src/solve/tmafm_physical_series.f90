!> The time series of a run of a physical scene in SI units (docs/output-format.md, "SI
!> columns"): time (s), tip-sample distance and tip deflection (m), normal and friction contact
!> forces (N), each the run's dimensionless sample times its scale (tmafm_units scales_t): t =
!> t0 tau, distance = d V_T, deflection = d p^T a, F_n = (E1 I/L^2) kappa5 f_c and
!> F_h = (E1 I/L^2) kappa6 h at the samples in contact (V_T <= 0), 0 elsewhere (under
!> 'dmt_vdw' F_n is the attraction in flight too), with the model's own kappa5, kappa6 (the
!> convention's, E4) and f_c, h (docs/model.md section 6).  With a viscoelastic sample F_n is
!> the sample's force at its state (a, a', w), the delayed part included (trajectory_t%dashpot).
module tmafm_physical_series
   use tmafm_kinds, only: dp
   use tmafm_errors, only: ok, err_input
   use tmafm_contact, only: contact_brackets_t, law_hertz, law_dmt
   use tmafm_vdw, only: law_dmt_vdw
   use tmafm_jkr, only: law_jkr
   use tmafm_model, only: model_t, init_model
   use tmafm_units, only: scales_t, scales_from_physical
   use tmafm_config, only: config_t
   use tmafm_namelist, only: config_errata
   use tmafm_trajectory, only: trajectory_t
   implicit none
   private

   public :: n_series, series_names, series_units, physical_series

   !> Number of SI series.
   integer, parameter :: n_series = 5
   !> Their names (the text format's column names and the .npz arrays' names).
   character(len=*), parameter :: series_names(n_series) = [character(len=16) :: 't_s', 'distance_m', &
      'deflection_m', 'normal_force_N', 'friction_force_N']
   !> Their units.
   character(len=*), parameter :: series_units(n_series) = [character(len=2) :: 's', 'm', 'm', 'N', 'N']

contains

   !> The SI series of trajectory `traj` of physical configuration `config`, one column each in
   !> the order of series_names (series must be size(traj%tau) x n_series); err_input for a
   !> configuration given in &scene.
   subroutine physical_series(config, traj, series, ierr, errmsg)
      type(config_t), intent(in) :: config
      type(trajectory_t), intent(in) :: traj
      real(dp), intent(out) :: series(:, :)
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(model_t) :: model
      type(scales_t) :: scales
      type(contact_brackets_t) :: state
      integer :: k, law
      logical :: wet

      series = 0
      ierr = ok
      errmsg = ''
      if (.not. config%from_physical) then
         ierr = err_input
         errmsg = 'the SI series need a scene given in &physical'
         return
      end if
      law = law_hertz
      if (trim(config%contact_law) == 'dmt') law = law_dmt
      if (trim(config%contact_law) == 'dmt_vdw') law = law_dmt_vdw
      if (trim(config%contact_law) == 'jkr') law = law_jkr
      call init_model(model, config%n_modes, config%scene, law, config_errata(config), ierr, errmsg)
      if (ierr /= ok) return
      scales = scales_from_physical(config%physical)
      do k = 1, size(traj%tau)
         series(k, 1) = scales%time*traj%tau(k)
         series(k, 2) = scales%length*traj%vt(k)
         series(k, 3) = scales%length*dot_product(model%tip, traj%a(k, :))
         wet = .false.
         if (allocated(traj%meniscus)) wet = traj%meniscus(k) == 1
         if (traj%contact(k) /= 1 .and. .not. (model%long_range .or. wet)) cycle
         state = model%forces_in_phase(traj%tau(k), traj%a(k, :), traj%contact(k) == 1, wet)
         if (allocated(traj%dashpot)) then
            ! A viscoelastic sample: the force of its state (a, a', w), the delayed part included.
            series(k, 4) = scales%force*model%normal_force(traj%tau(k), &
                                                           [traj%a(k, :), traj%adot(k, :), traj%dashpot(k), &
                                                            merge(1.0_dp, 0.0_dp, wet)], &
                                                           traj%contact(k) == 1)
         else
            series(k, 4) = scales%force*model%kappa5*state%normal
         end if
         series(k, 5) = scales%force*model%kappa6*state%friction
      end do
   end subroutine physical_series

end module tmafm_physical_series

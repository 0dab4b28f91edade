!> From a resolved configuration to a sampled trajectory: builds the model, then runs it.
module tmafm_simulation
   use tmafm_errors, only: ok
   use tmafm_contact, only: law_hertz, law_dmt
   use tmafm_model, only: model_t, init_model
   use tmafm_driver, only: run_trajectory
   use tmafm_trajectory, only: trajectory_t
   use tmafm_config, only: config_t
   use tmafm_namelist, only: config_errata
   implicit none
   private

   public :: build_model, simulate

contains

   !> The model a configuration describes.
   subroutine build_model(config, model, ierr, errmsg)
      type(config_t), intent(in) :: config
      type(model_t), intent(out) :: model
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      integer :: law
      law = law_hertz
      if (trim(config%contact_law) == 'dmt') law = law_dmt
      call init_model(model, config%n_modes, config%scene, law, config_errata(config), ierr, errmsg)
   end subroutine build_model

   !> Run a configuration; `traj` holds the samples when ierr == ok.
   subroutine simulate(config, traj, ierr, errmsg, progress_unit)
      type(config_t), intent(in) :: config
      type(trajectory_t), intent(out) :: traj
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      !> If present, progress lines go to this unit.
      integer, intent(in), optional :: progress_unit
      type(model_t) :: model
      integer :: n

      call build_model(config, model, ierr, errmsg)
      if (ierr /= ok) return
      n = config%n_modes
      call run_trajectory(model, config%solver, config%a0(1:n), config%adot0(1:n), traj, ierr, &
                          errmsg, progress_unit)
   end subroutine simulate

end module tmafm_simulation

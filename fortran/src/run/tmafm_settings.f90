!> How a run is integrated and sampled: the &solver and &output settings.
module tmafm_settings
   use tmafm_kinds, only: dp, i8
   implicit none
   private

   public :: run_settings_t, sample_count
   public :: method_rk4_paper, method_rk4_event, method_dopri5, method_dop853, method_flight_exact
   public :: known_methods

   !> The paper's scheme: RK4, dtau out of contact, dtau/contact_refine in contact, no location.
   character(len=*), parameter :: method_rk4_paper = 'rk4_paper'
   !> The paper's steps, with every switch V_T = 0 located and the step restarted there.
   character(len=*), parameter :: method_rk4_event = 'rk4_event'
   !> Adaptive Dormand-Prince 5(4) with dense output and located switches.
   character(len=*), parameter :: method_dopri5 = 'dopri5'
   !> Adaptive Dormand-Prince 8(5,3) with dense output and located switches.
   character(len=*), parameter :: method_dop853 = 'dop853'
   !> Exact modal propagation out of contact, dop853 in contact.
   character(len=*), parameter :: method_flight_exact = 'flight_exact'
   !> Every method name, for validation messages.
   character(len=*), parameter :: known_methods = &
      "'rk4_paper', 'rk4_event', 'dopri5', 'dop853' or 'flight_exact'"

   !> How to integrate and sample a run.
   type :: run_settings_t
      !> Integration method name.
      character(len=64) :: method = method_rk4_paper
      !> Fixed-step methods: the step out of contact.
      real(dp) :: dtau = 2.0e-3_dp
      !> Fixed-step methods: the in-contact step is dtau/contact_refine.
      integer :: contact_refine = 16
      !> Adaptive methods: relative tolerance.
      real(dp) :: rtol = 1.0e-8_dp
      !> Adaptive methods: absolute tolerance (gap units; velocities per tau unit).
      real(dp) :: atol = 1.0e-14_dp
      !> End of the run.
      real(dp) :: tau_end = 100.0_dp
      !> Output interval.
      real(dp) :: sample_dtau = 0.01_dp
      !> A run stops with an error once some |a_j| exceeds this (units of the gap d).
      real(dp) :: blowup_limit = 1.0_dp
      !> Work budget: steps tried plus event iterations; a run that needs more fails.
      integer(i8) :: max_steps = 100000000_i8
   end type run_settings_t

contains

   !> Number of output samples for a run: tau = 0, sample_dtau, ..., up to tau_end.
   pure function sample_count(settings) result(n)
      type(run_settings_t), intent(in) :: settings
      integer :: n
      n = floor(settings%tau_end/settings%sample_dtau*(1.0_dp + 4*epsilon(1.0_dp))) + 1
   end function sample_count

end module tmafm_settings

!> How a run is integrated and sampled: the &solver and &output settings, the method names,
!> the counts (samples, worst-case fixed steps) that validation bounds before a run, and the
!> grid the automatic-N comparison runs are sampled on.
module tmafm_settings
   use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
   use tmafm_kinds, only: dp, i8
   use tmafm_errors, only: ok, err_input
   use tmafm_text, only: real_text, int_text, short_real_text
   use tmafm_modes, only: beam_roots
   implicit none
   private

   public :: run_settings_t, sample_count, sample_count_real, is_known_method, is_fixed_step_method
   public :: first_sample_at, method_choices, fixed_step_count_real
   public :: method_rk4_paper, method_rk4_event, method_dopri5, method_dop853, method_flight_exact
   public :: known_methods, sls_method_refused
   public :: method_names, default_max_steps, max_max_steps
   public :: max_samples, max_trajectory_bytes, trajectory_bytes, check_run_size
   public :: comparison_intervals, comparison_points, mode_digits, comparison_rtol, comparison_atol
   public :: search_work_budget

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
   !> Every method `&solver method` accepts: adding a method is one line here (and its case in
   !> the driver).  Fixed-step methods are also listed in fixed_step_names.
   character(len=*), parameter :: method_names(*) = [character(len=16) :: &
      method_rk4_paper, &
      method_rk4_event, &
      method_dopri5, &
      method_dop853, &
      method_flight_exact]
   !> The methods that take fixed steps dtau and dtau/contact_refine (their step count is
   !> bounded up front by max_steps).
   character(len=*), parameter :: fixed_step_names(*) = [character(len=16) :: &
      method_rk4_paper, method_rk4_event]
   !> Every method name, for messages (method_choices() builds the same text from method_names).
   character(len=*), parameter :: known_methods = &
      "'rk4_paper', 'rk4_event', 'dopri5', 'dop853' or 'flight_exact'"
   !> Default &solver max_steps: the step budget of one run.
   integer(i8), parameter :: default_max_steps = 100000000_i8
   !> Largest &solver max_steps accepted.
   integer(i8), parameter :: max_max_steps = 1000000000000_i8

   !> The most output samples one run may keep.
   integer, parameter :: max_samples = 50000000
   !> The most memory the sampled trajectory of one run may take: 2 GiB.
   real(dp), parameter :: max_trajectory_bytes = 2.0_dp**31

   !> Tolerances (dopri5) of the automatic-N search's runs, which compare N and N+1.
   real(dp), parameter :: comparison_rtol = 1.0e-10_dp, comparison_atol = 1.0e-16_dp
   !> The automatic N search's budget: the work of all its comparison runs (steps tried and
   !> event iterations, each counted N times in a run of N modes: a step's cost grows with N)
   !> may not exceed this.  The Fig. 2 scene at mode_tol = 1e-12 and mode_horizon = 20 (29
   !> comparisons, up to N = 30) spends 1.2e8 in 19.8 s of CPU; omega = 50 spends 2.5e8 in 32 s,
   !> and extreme scenes ran for minutes before the bound (issue 27, F15).  So the search costs
   !> at most about a minute (docs/reliability.md, "Automatic N").
   real(dp), parameter :: search_work_budget = 4.0e8_dp
   !> The grid on which the automatic-N search compares N and N+1 (comparison_intervals): at
   !> least this many points per period of the fastest free mode of the model with more modes.
   integer, parameter :: comparison_points = 16
   !> Fewest and most intervals of that grid over mode_horizon (powers of two): at most
   !> 2^20 + 1 samples, 537 MB for 30 modes, under the limits above for any mode_horizon.
   integer, parameter :: min_comparison_intervals = 2**7, max_comparison_intervals = 2**20
   !> Significant digits of the search's differences as reported (stderr and the header): the
   !> located values are exact to about 1e-6 (docs/model-notes.md, item 14).
   integer, parameter :: mode_digits = 6

   !> How to integrate and sample a run.
   type :: run_settings_t
      !> Integration method name.
      character(len=64) :: method = method_rk4_paper
      !> Fixed-step methods: the step out of contact.
      real(dp) :: dtau = 2.0e-3_dp
      !> Fixed-step methods: the in-contact step is dtau/contact_refine.
      integer :: contact_refine = 16
      !> Adaptive methods: relative tolerance (per mode amplitude and tip motion; see
      !> integrators/tmafm_error_scale.f90).
      real(dp) :: rtol = 1.0e-7_dp
      !> Adaptive methods: absolute tolerance, in gap units (V_T and modal displacements).
      real(dp) :: atol = 1.0e-10_dp
      !> End of the run.
      real(dp) :: tau_end = 100.0_dp
      !> Output interval.
      real(dp) :: sample_dtau = 0.01_dp
      !> &output sample_from: the output window starts at the first sample at or after this
      !> time (0: every sample).
      real(dp) :: sample_from = 0
      !> &output last_periods: the output window holds the last this many drive periods of
      !> the run (0: not asked).
      integer :: last_periods = 0
      !> The output window: the index k of its first sample, tau = k sample_dtau, from
      !> sample_from or last_periods (tmafm_namelist check_window); the samples before it are
      !> integrated and not kept.  0: every sample, from tau = 0.
      integer(i8) :: first_sample = 0
      !> &initial in_contact: the phase the run starts in, -1 by the sign of V_T (V_T <= 0: in
      !> contact), 0 in flight, 1 in contact (a JKR neck held above the surface too).
      integer :: initial_contact = -1
      !> A run stops with an error once some |a_j| exceeds this (units of the gap d).
      real(dp) :: blowup_limit = 1.0_dp
      !> Step budget of one run (accepted + rejected steps, event iterations); fixed-step runs
      !> are checked up front.
      integer(i8) :: max_steps = default_max_steps
      !> &solver thermal_noise: 1 adds the Langevin force of the scene's thermal_energy
      !> (tmafm_thermal, docs/model.md §21); 0 none.
      integer :: thermal_noise = 0
      !> &solver noise_seed: the seed of the noise's realisation.
      integer(i8) :: noise_seed = 0
      !> &solver noise_step: the noise grid's spacing in tau (0: the fastest free mode's period/32).
      real(dp) :: noise_step = 0
   end type run_settings_t

contains

   !> Whether a method refuses a viscoelastic sample (sls_relaxation_time > 0): the fixed-step
   !> RK4 schemes, which do not carry the dashpot's state (tmafm_driver refuses them too).
   pure logical function sls_method_refused(method)
      character(len=*), intent(in) :: method
      sls_method_refused = trim(method) == method_rk4_paper .or. trim(method) == method_rk4_event
   end function sls_method_refused

   !> .true. when `name` (lower case, blank padded) is one of method_names.
   pure function is_known_method(name) result(known)
      character(len=*), intent(in) :: name
      logical :: known
      known = any(method_names == trim(name))
   end function is_known_method

   !> .true. when `name` is a fixed-step method (dtau, contact_refine).
   pure function is_fixed_step_method(name) result(fixed)
      character(len=*), intent(in) :: name
      logical :: fixed
      fixed = any(fixed_step_names == trim(name))
   end function is_fixed_step_method

   !> The accepted method names as text: 'a', 'b' or 'c'.
   pure function method_choices() result(text)
      ! A length from the names, not a deferred length (not thread-safe with gfortran 12, see
      ! tmafm_text); every piece ends in a quote, so trim(text) is the text so far.  Two quotes
      ! per name; between n >= 2 names, n - 2 times ', ' and once ' or ': 2n characters.
      character(len=sum(len_trim(method_names)) + 4*size(method_names)) :: text
      integer :: k
      text = ''''//trim(method_names(1))//''''
      do k = 2, size(method_names)
         if (k == size(method_names)) then
            text = trim(text)//' or '''//trim(method_names(k))//''''
         else
            text = trim(text)//', '''//trim(method_names(k))//''''
         end if
      end do
   end function method_choices

   !> Number of output samples as a real (no overflow): tau = k sample_dtau <= tau_end, from
   !> k = first_sample (the output window; 0 without one).
   pure function sample_count_real(settings) result(n)
      type(run_settings_t), intent(in) :: settings
      real(dp) :: n
      n = aint(settings%tau_end/settings%sample_dtau*(1.0_dp + 4*epsilon(1.0_dp))) + 1 - &
          real(settings%first_sample, dp)
   end function sample_count_real

   !> Number of output samples for a run: tau = k sample_dtau, up to tau_end, from
   !> k = first_sample (the output window; 0 without one).
   !> Valid for validated settings (at most huge(1) samples; validation bounds it far below).
   pure function sample_count(settings) result(n)
      type(run_settings_t), intent(in) :: settings
      integer :: n
      real(dp) :: count
      count = settings%tau_end/settings%sample_dtau*(1.0_dp + 4*epsilon(1.0_dp)) - &
              real(settings%first_sample, dp)
      if (.not. (count < real(huge(n) - 1, dp))) then
         n = huge(n)
      else
         n = floor(count) + 1
      end if
   end function sample_count

   !> The index k of the first sample at or after tau, tau = k sample_dtau (the output window's
   !> first sample; the same 4 eps allowance as sample_count, so a window start on the grid
   !> keeps its sample).  Valid for 0 <= tau <= tau_end of validated settings.
   pure function first_sample_at(settings, tau) result(k)
      type(run_settings_t), intent(in) :: settings
      real(dp), intent(in) :: tau
      integer(i8) :: k
      k = ceiling(tau/settings%sample_dtau*(1.0_dp - 4*epsilon(1.0_dp)), i8)
      k = max(k, 0_i8)
   end function first_sample_at

   !> Worst-case step count of a fixed-step run as a real (no overflow):
   !> ceil(tau_end/dtau) * contact_refine, every step taken in contact.
   pure function fixed_step_count_real(settings) result(n)
      type(run_settings_t), intent(in) :: settings
      real(dp) :: n, steps
      steps = settings%tau_end/settings%dtau*(1.0_dp - 4*epsilon(1.0_dp))
      n = aint(steps)
      if (n < steps) n = n + 1
      n = n*settings%contact_refine
   end function fixed_step_count_real

   !> Bytes of the sampled trajectory of a run with n_modes modes: (4 + 2N) * 8 per sample.
   pure function trajectory_bytes(settings, n_modes) result(bytes)
      type(run_settings_t), intent(in) :: settings
      integer, intent(in) :: n_modes
      real(dp) :: bytes
      bytes = sample_count_real(settings)*(4 + 2*n_modes)*8
   end function trajectory_bytes

   !> Refuse a run whose samples, trajectory memory or worst-case fixed-step count exceed the
   !> limits (max_samples, max_trajectory_bytes, max_steps); the message names the keys.
   subroutine check_run_size(settings, n_modes, ierr, errmsg)
      type(run_settings_t), intent(in) :: settings
      integer, intent(in) :: n_modes
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      real(dp) :: samples, bytes, steps

      ierr = ok
      errmsg = ''
      samples = sample_count_real(settings)
      bytes = trajectory_bytes(settings, n_modes)
      if (.not. (ieee_is_finite(samples) .and. samples <= max_samples)) then
         ierr = err_input
         errmsg = '&output sample_dtau = '//real_text(settings%sample_dtau)//' with &solver '// &
                  'tau_end = '//real_text(settings%tau_end)//' gives '//short_real_text(samples, 3)// &
                  ' samples, more than '//int_text(max_samples)//': raise sample_dtau or lower tau_end'
      else if (.not. (bytes <= max_trajectory_bytes)) then
         ierr = err_input
         errmsg = '&output sample_dtau = '//real_text(settings%sample_dtau)//' with &solver '// &
                  'tau_end = '//real_text(settings%tau_end)//' and '//int_text(n_modes)// &
                  ' modes needs '//short_real_text(bytes, 3)//' bytes for the samples, more than '// &
                  '2 GiB: raise sample_dtau or lower tau_end'
      else if (is_fixed_step_method(settings%method)) then
         steps = fixed_step_count_real(settings)
         if (.not. (ieee_is_finite(steps) .and. steps <= real(settings%max_steps, dp))) then
            ierr = err_input
            errmsg = '&solver dtau = '//real_text(settings%dtau)//' with tau_end = '// &
                     real_text(settings%tau_end)//' and contact_refine = '// &
                     int_text(settings%contact_refine)//' may need '//short_real_text(steps, 3)// &
                     ' steps, more than max_steps = '//int_text(settings%max_steps)// &
                     ': raise dtau, lower tau_end or contact_refine, or raise max_steps'
         end if
      end if
   end subroutine check_run_size

   !> Intervals of the comparison grid over `horizon` for a model of n_modes modes: the
   !> smallest power of two giving at least comparison_points points per period of its
   !> fastest free mode (beta_N^2, an upper bound: the tip mass only lowers it) or of the
   !> drive (omega), if faster; at least min_comparison_intervals, at most
   !> max_comparison_intervals.  Rises with n_modes, so the grids of successive N nest.
   pure integer function comparison_intervals(horizon, n_modes, omega) result(intervals)
      real(dp), intent(in) :: horizon
      integer, intent(in) :: n_modes
      real(dp), intent(in) :: omega
      real(dp) :: beta(n_modes), needed
      beta = beam_roots(n_modes)
      needed = horizon*comparison_points*max(beta(n_modes)**2, omega)/(2*acos(-1.0_dp))
      intervals = min_comparison_intervals
      do while (intervals < needed .and. intervals < max_comparison_intervals)
         intervals = 2*intervals
      end do
   end function comparison_intervals

end module tmafm_settings

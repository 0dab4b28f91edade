!> FM-AFM (docs/instrument.md, "FM-AFM"): the cantilever driven at its own resonance by a
!> phase-locked loop and an amplitude controller, both updated once per drive period on the
!> period stepper (tmafm_period_stepper) from the period's exact lock-in amplitude and phase.
!>
!> The phase setpoint is the free cantilever's phase at the base's drive frequency f0 (its
!> resonance, as the calibration gives it), phi_set = arg(i h(f0)) of the linear free response
!> h (tmafm_calibration free_response: V_T's first harmonic per unit drive, with the base's
!> motion and every mode); with a base drive and N > 1 modes it is near but not at -90 deg.
!> The loop starts from the free steady state of that response at A = A_set, exactly.
!>
!> The loops, each period T_k (e the period's error, u the output for the next period):
!> - the PLL: e = phi_k - phi_set (rad); Δf = K_p e + K_i sum(T e) (Hz), the NCO's next
!>   frequency f0 + Δf.  Near resonance the phase answers the drive's frequency as a first-order
!>   lag -tau_r/(1 + s tau_r) (rad per rad/s), tau_r = -dphi/domega of the free response
!>   (2Q/omega0 for one mode);
!> - the amplitude controller: e = (A_set - A_k)/A_set; the drive amplitude (m) =
!>   K_p e + K_i sum(T e): A/A_set answers the drive with the lag (1/f_free)/(1 + s tau_r),
!>   f_free = A_set/|h| the free drive;
!> and each PI places its closed loop's two poles at -2 pi B (place_poles), B its bandwidth.
!> Each Z point runs settle_periods, then averages average_periods: the NCO's frequency shift
!> Δf, the drive and its rise over the free one, the period's energies and lock-in values.
module tmafm_fm
   use tmafm_kinds, only: dp
   use tmafm_errors, only: ok, err_input, err_runtime
   use tmafm_text, only: real_text, int_text
   use tmafm_config, only: config_t
   use tmafm_fm_settings, only: fm_settings_t
   use tmafm_scene, only: physical_t
   use tmafm_calibration, only: free_response
   use tmafm_observers, only: obs_amplitude, obs_phase, obs_mean_deflection, obs_min_gap, obs_peak_force, &
      obs_dissipated, obs_dissipated_beam, obs_drive_work, obs_contact_normal_work
   use tmafm_trajectory, only: stop_poll
   use tmafm_period_stepper, only: period_stepper_t, init_period_stepper, with_distance
   use tmafm_controllers, only: pi_controller_t
   use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
   implicit none
   private

   public :: fm_loop_t, init_fm_loop, fm_point, check_fm_settings
   public :: n_fm_columns, n_fm_trace, fm_column_names, fm_column_units
   public :: fm_z, fm_df, fm_drive, fm_drive_ratio, fm_dissipation, fm_drive_work, fm_dissipated, &
      fm_dissipated_beam, fm_dissipated_tip_sample, fm_amplitude, fm_phase, fm_phase_error, fm_peak_force, &
      fm_min_gap, fm_mean_deflection, fm_df_spread, fm_contact_normal_work

   real(dp), parameter :: pi = acos(-1.0_dp)

   !> Number of values per Z point (fm_point), and their columns: Z (nm), Δf (Hz), the drive
   !> amplitude (nm) and its ratio to the free one, the dissipation from the drive's rise
   !> E_free (drive/drive_free - 1) (aJ), the period's drive work, dissipated energy, the beam's
   !> and the tip-sample's part (aJ), A (nm), phase and phase error (deg), peak force (nN),
   !> minimum gap (nm), mean deflection (nm), Δf's spread over the average window (Hz), and
   !> the tip-sample force's work on the modes (aJ: drive_work + it - dissipated = 0 when steady).
   integer, parameter :: n_fm_columns = 17
   integer, parameter :: fm_z = 1, fm_df = 2, fm_drive = 3, fm_drive_ratio = 4, fm_dissipation = 5, &
      fm_drive_work = 6, fm_dissipated = 7, fm_dissipated_beam = 8, fm_dissipated_tip_sample = 9, &
      fm_amplitude = 10, fm_phase = 11, fm_phase_error = 12, fm_peak_force = 13, fm_min_gap = 14, &
      fm_mean_deflection = 15, fm_df_spread = 16, fm_contact_normal_work = 17
   !> The columns' names and units (Python's tmafm.instrument FM_COLUMNS; the executable's &fm table).
   character(len=*), parameter :: fm_column_names(n_fm_columns) = [character(len=21) :: 'z', 'df', 'drive', &
      'drive_ratio', 'dissipation', 'drive_work', 'dissipated', 'dissipated_beam', 'dissipated_tip_sample', &
      'amplitude', 'phase', 'phase_error', 'peak_force', 'min_gap', 'mean_deflection', 'df_spread', &
      'contact_normal_work']
   character(len=*), parameter :: fm_column_units(n_fm_columns) = [character(len=3) :: 'nm', 'Hz', 'nm', '1', &
      'aJ', 'aJ', 'aJ', 'aJ', 'aJ', 'nm', 'deg', 'deg', 'nN', 'nm', 'nm', 'Hz', 'aJ']
   !> Number of values per period of the loop's trace: Δf (Hz), drive (nm), A (nm), phase (deg).
   integer, parameter :: n_fm_trace = 4

   !> An FM loop around a period stepper: the controllers, the free reference, the setting.
   type :: fm_loop_t
      !> The cantilever, stepped period by period.
      type(period_stepper_t) :: stepper
      !> The loop's settings.
      type(fm_settings_t) :: settings
      !> The PLL's loop filter (output Δf, Hz) and the amplitude controller (output drive, m).
      type(pi_controller_t) :: pll, amplitude_control
      !> f0 (Hz): the base's drive frequency, the free resonance the PLL starts at.
      real(dp) :: free_frequency = 0
      !> The phase setpoint phi_set (deg): the free cantilever's phase at f0.
      real(dp) :: phase_setpoint = 0
      !> The free drive amplitude f_free (m) that gives A_set at f0.
      real(dp) :: free_drive = 0
      !> The free cantilever's drive work per period at A_set (aJ): its beam dissipation.
      real(dp) :: free_work = 0
      !> The free response's phase time constant tau_r = -dphi/domega (s).
      real(dp) :: response_time = 0
      !> The current tip-sample distance Z (m), drive frequency (Hz) and drive amplitude (m).
      real(dp) :: z = 0, frequency = 0, drive = 0
   end type fm_loop_t

contains

   !> Refuse settings out of range, in one line naming the setting and its value; f0 (Hz) bounds
   !> the bandwidths (<= f0/10: a per-period update delays the loop by one period).
   subroutine check_fm_settings(settings, f0, ierr, errmsg)
      type(fm_settings_t), intent(in) :: settings
      real(dp), intent(in) :: f0
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg

      ierr = err_input
      if (.not. (settings%amplitude > 0 .and. settings%amplitude <= 1.0e-6_dp)) then
         errmsg = 'fm amplitude = '//real_text(settings%amplitude)//': must be > 0 and <= 1e-6 (m)'
      else if (.not. (settings%pll_bandwidth > 0 .and. settings%pll_bandwidth <= f0/10)) then
         errmsg = 'fm pll_bandwidth = '//real_text(settings%pll_bandwidth)//': must be > 0 and <= f0/10 = '// &
                  real_text(f0/10)//' (Hz)'
      else if (.not. (settings%amplitude_bandwidth > 0 .and. settings%amplitude_bandwidth <= f0/10)) then
         errmsg = 'fm amplitude_bandwidth = '//real_text(settings%amplitude_bandwidth)// &
                  ': must be > 0 and <= f0/10 = '//real_text(f0/10)//' (Hz)'
      else if (settings%settle_periods < 0 .or. settings%settle_periods > 10000000) then
         errmsg = 'fm settle_periods = '//int_text(settings%settle_periods)//': must be in 0..10000000'
      else if (settings%average_periods < 1 .or. settings%average_periods > 10000000) then
         errmsg = 'fm average_periods = '//int_text(settings%average_periods)//': must be in 1..10000000'
      else if (.not. (settings%free_distance > 0 .and. settings%free_distance <= 1.0e-3_dp)) then
         errmsg = 'fm free_distance = '//real_text(settings%free_distance)//': must be > 0 and <= 1e-3 (m)'
      else
         ierr = ok
         errmsg = ''
      end if
   end subroutine check_fm_settings

   !> The loop for `config` (a &physical scene; its drive frequency is f0) and `settings`: the
   !> free reference at Z = free_distance (phase setpoint, free drive, response time, the free
   !> drive work of one period from the free steady state), the controllers at rest on it.
   subroutine init_fm_loop(loop, config, settings, ierr, errmsg, poll)
      type(fm_loop_t), intent(out) :: loop
      type(config_t), intent(in) :: config
      type(fm_settings_t), intent(in) :: settings
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      !> If present, the runs poll it (Ctrl-C from Python).
      procedure(stop_poll), optional :: poll
      complex(dp), allocatable :: x(:)
      complex(dp), parameter :: i = (0.0_dp, 1.0_dp)
      complex(dp) :: h, h_low, h_high
      real(dp) :: omega, step, alpha2
      integer :: n

      loop%settings = settings
      if (.not. config%from_physical) then
         ierr = err_input
         errmsg = 'fm: the FM loop needs a scene in SI units (a &physical group)'
         return
      end if
      if (config%physical%drive_amplitude_2 /= 0) then
         ierr = err_input
         errmsg = '&physical drive_amplitude_2 = '//real_text(config%physical%drive_amplitude_2)// &
                  ': the FM loop drives one tone (the PLL moves its frequency; a second tone would not stay '// &
                  'commensurate with it)'
         return
      end if
      loop%free_frequency = config%physical%drive_angular_frequency/(2*pi)
      call check_fm_settings(settings, loop%free_frequency, ierr, errmsg)
      if (ierr /= ok) return
      call init_period_stepper(loop%stepper, config, ierr, errmsg, poll=poll)
      if (ierr /= ok) return
      loop%frequency = loop%free_frequency
      loop%drive = config%physical%drive_amplitude
      call move_to(loop, settings%free_distance, ierr, errmsg)
      if (ierr /= ok) return
      n = loop%stepper%config%n_modes
      allocate (x(n))
      omega = loop%stepper%model%scene%omega
      h = free_response(loop%stepper%model, ierr, errmsg, modal=x)
      if (ierr /= ok) return
      step = 1.0e-6_dp*omega
      h_low = free_response(loop%stepper%model, ierr, errmsg, frequency=omega - step)
      if (ierr /= ok) return
      h_high = free_response(loop%stepper%model, ierr, errmsg, frequency=omega + step)
      if (ierr /= ok) return
      loop%phase_setpoint = atan2(aimag(i*h), real(i*h))*180/pi
      loop%response_time = -wrapped(atan2(aimag(i*h_high), real(i*h_high)) - atan2(aimag(i*h_low), real(i*h_low))) &
                           /(2*step)*loop%stepper%scales%time
      if (.not. (loop%response_time > 0 .and. abs(h) > 0)) then
         ierr = err_input
         errmsg = '&physical drive_frequency = '//real_text(loop%free_frequency)// &
                  ': the free cantilever''s phase does not fall through it (not a resonance for the PLL)'
         return
      end if
      loop%free_drive = settings%amplitude/abs(h)
      loop%drive = loop%free_drive
      call move_to(loop, settings%free_distance, ierr, errmsg)
      if (ierr /= ok) return
      ! The free steady state at A_set: a = alpha2 Re(X e^(i phi1)) at the period's start.
      alpha2 = loop%stepper%model%scene%alpha2
      x = alpha2*x*exp(i*loop%stepper%model%scene%drive_phase)
      loop%stepper%y(1:n) = real(x)
      loop%stepper%y(n + 1:2*n) = real(i*omega*x)
      loop%stepper%phase = -1
      ! E_free is the noiseless free cantilever's, as phi_set and f_free are: with thermal noise
      ! on, one period's drive work would carry that period's fluctuation into every point's
      ! dissipation channel.  (The settings come back from the configuration at the next setting.)
      loop%stepper%settings%thermal_noise = 0
      call loop%stepper%advance(ierr, errmsg, poll)
      if (ierr /= ok) return
      loop%free_work = loop%stepper%values(obs_drive_work)
      ! Hz per rad: the phase answers δω (rad/s) with the gain tau_r (rad per rad/s).
      call place_poles(settings%pll_bandwidth, loop%response_time, 2*pi*loop%response_time, &
                       loop%pll%proportional, loop%pll%integral)
      loop%pll%lower = -loop%free_frequency/2
      loop%pll%upper = loop%free_frequency/2
      ! m per unit relative amplitude error: A/A_set answers the drive (m) with the gain 1/f_free.
      call place_poles(settings%amplitude_bandwidth, loop%response_time, 1/loop%free_drive, &
                       loop%amplitude_control%proportional, loop%amplitude_control%integral)
      loop%amplitude_control%lower = 0
      loop%amplitude_control%integrator = loop%free_drive
      loop%amplitude_control%output = loop%free_drive
   end subroutine init_fm_loop

   !> Move the tip to Z = z (m) and settle the loop there from where it is (the previous point's
   !> frequency, drive and state: a warm start): settle_periods, then average_periods averaged
   !> into values (columns fm_*).  trace(k, :), if present, is period k's Δf, drive, A, phase.
   subroutine fm_point(loop, z, values, ierr, errmsg, trace, poll)
      type(fm_loop_t), intent(inout) :: loop
      real(dp), intent(in) :: z
      real(dp), intent(out) :: values(n_fm_columns)
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      real(dp), intent(inout), optional :: trace(:, :)
      procedure(stop_poll), optional :: poll
      real(dp) :: a, phi, error, df, df_low, df_high, period
      integer :: k, total, averaged

      values = 0
      total = loop%settings%settle_periods + loop%settings%average_periods
      if (present(trace)) then
         if (size(trace, 1) /= total .or. size(trace, 2) /= n_fm_trace) then
            ierr = err_input
            errmsg = 'fm_point: trace must be '//int_text(total)//' x '//int_text(n_fm_trace)
            return
         end if
      end if
      df_low = huge(1.0_dp)
      df_high = -huge(1.0_dp)
      averaged = 0
      do k = 1, total
         call move_to(loop, z, ierr, errmsg)
         if (ierr /= ok) return
         call loop%stepper%advance(ierr, errmsg, poll)
         if (ierr /= ok) return
         period = loop%stepper%period
         df = loop%frequency - loop%free_frequency
         a = loop%stepper%values(obs_amplitude)
         phi = loop%stepper%values(obs_phase)
         error = wrapped((phi - loop%phase_setpoint)*pi/180)
         if (present(trace)) trace(k, :) = [df, loop%drive*1.0e9_dp, a, phi]
         if (k > loop%settings%settle_periods) then
            averaged = averaged + 1
            df_low = min(df_low, df)
            df_high = max(df_high, df)
            values(fm_df) = values(fm_df) + df
            values(fm_drive) = values(fm_drive) + loop%drive*1.0e9_dp
            values(fm_drive_work) = values(fm_drive_work) + loop%stepper%values(obs_drive_work)
            values(fm_dissipated) = values(fm_dissipated) + loop%stepper%values(obs_dissipated)
            values(fm_dissipated_beam) = values(fm_dissipated_beam) + loop%stepper%values(obs_dissipated_beam)
            values(fm_amplitude) = values(fm_amplitude) + a
            values(fm_phase) = values(fm_phase) + phi
            values(fm_phase_error) = values(fm_phase_error) + error*180/pi
            values(fm_peak_force) = values(fm_peak_force) + loop%stepper%values(obs_peak_force)
            values(fm_min_gap) = values(fm_min_gap) + loop%stepper%values(obs_min_gap)
            values(fm_mean_deflection) = values(fm_mean_deflection) + loop%stepper%values(obs_mean_deflection)
            values(fm_contact_normal_work) = values(fm_contact_normal_work) + &
                                             loop%stepper%values(obs_contact_normal_work)
         end if
         ! The controllers act on the period just measured; their outputs hold over the next.
         loop%frequency = loop%free_frequency + loop%pll%update(error, period)
         loop%drive = loop%amplitude_control%update((loop%settings%amplitude*1.0e9_dp - a) &
                                                    /(loop%settings%amplitude*1.0e9_dp), period)
      end do
      values = values/averaged
      values(fm_z) = z*1.0e9_dp
      values(fm_drive_ratio) = values(fm_drive)/(loop%free_drive*1.0e9_dp)
      values(fm_dissipation) = loop%free_work*(values(fm_drive_ratio) - 1)
      values(fm_dissipated_tip_sample) = values(fm_dissipated) - values(fm_dissipated_beam)
      values(fm_df_spread) = df_high - df_low
      if (.not. all(ieee_is_finite(values))) then
         ierr = err_runtime
         errmsg = 'fm: the loop''s values are not finite at z = '//real_text(z)
      end if
   end subroutine fm_point

   !> The PI gains K_p, K_i (per second) for a plant G/(1 + s tau) (gain G, time constant tau, s)
   !> that give the closed loop tau s^2 + (1 + G K_p) s + G K_i a double root at -2 pi B
   !> (K_p = (2 tau w - 1)/G, K_i = tau w^2/G, w = 2 pi B): both its poles at the bandwidth,
   !> so the loop also rejects a disturbance at that rate.  If 2 tau w < 1 (a resonator faster
   !> than the loop: a liquid's low Q) K_p = 0 and K_i = w/G: an integrating loop of bandwidth ~B.
   pure subroutine place_poles(bandwidth, tau, gain, proportional, integral)
      real(dp), intent(in) :: bandwidth, tau, gain
      real(dp), intent(out) :: proportional, integral
      real(dp) :: w
      w = 2*pi*bandwidth
      if (2*tau*w >= 1) then
         proportional = (2*tau*w - 1)/gain
         integral = tau*w**2/gain
      else
         proportional = 0
         integral = w/gain
      end if
   end subroutine place_poles

   !> Set the stepper's scene to Z = z and the loop's drive frequency and amplitude.
   subroutine move_to(loop, z, ierr, errmsg)
      type(fm_loop_t), intent(inout) :: loop
      real(dp), intent(in) :: z
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(physical_t) :: moved

      moved = with_distance(loop%stepper%config%physical, z)
      moved%drive_angular_frequency = 2*pi*loop%frequency
      moved%drive_amplitude = loop%drive
      if (moved%by_drive_frequency) moved%drive_frequency = loop%frequency
      call loop%stepper%set_physical(moved, ierr, errmsg)
      if (ierr /= ok) return
      loop%z = z
   end subroutine move_to

   !> An angle (rad) wrapped into (-pi, pi].
   elemental real(dp) function wrapped(angle)
      real(dp), intent(in) :: angle
      wrapped = angle - 2*pi*ceiling((angle - pi)/(2*pi))
   end function wrapped

end module tmafm_fm

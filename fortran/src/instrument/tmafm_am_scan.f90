!> AM-AFM imaging (docs/instrument.md, "AM imaging"): a Z feedback holds the lock-in amplitude
!> at a setpoint while the tip scans a line over a topography h(x) and a map of two materials.
!>
!> Every drive period: the tip's lateral position x advances, the tip-sample distance is
!> Z_piezo - h(x) and the sample the material at x (a new setting of the period stepper); one
!> period runs; the lock-in's in-phase and quadrature outputs X = A cos(phi), Y = A sin(phi) of
!> that period (its exact observables) pass a first-order low pass of the lock-in's bandwidth
!> (tmafm_controllers lowpass_t), and a PI on A_set - A_filtered moves Z_piezo for the next
!> period.  Before the line: a ring-up at the start distance (feedback off) measures the free
!> amplitude A0 and the cantilever's amplitude time constant tau_c; a slow approach (feedback
!> off) until the filtered amplitude reaches the setpoint measures the plant's slope dA/dZ;
!> then the feedback engages at x = 0 and settles.  Gains from a closed-loop bandwidth B_fb:
!> K_i = 2 pi B_fb/(dA/dZ), K_p = K_i tau_c (the PI's zero cancels the cantilever's lag), so
!> the closed loop is first order with time constant 1/(2 pi B_fb) while the lock-in is fast.
!> A pixel's phase is the angle of its periods' mean filtered (X, Y) (mean_phase: a circular
!> mean).  With thermal noise (&solver thermal_noise = 1) the amplitude scatters by the thermal
!> rms sigma = sqrt(k_B T/k): the ring-up lasts until its transient is below sigma/e, the engage's
!> band is at least 4 sigma, and gains designed on a slope measured within the noise are refused.
module tmafm_am_scan
   use tmafm_kinds, only: dp, i8
   use tmafm_errors, only: ok, err_input, err_runtime
   use tmafm_config, only: config_t
   use tmafm_scene, only: physical_t
   use tmafm_scan_settings, only: scan_settings_t, check_scan_settings, scan_height
   use tmafm_period_stepper, only: period_stepper_t, init_period_stepper, with_distance
   use tmafm_controllers, only: lowpass_t, pi_controller_t
   use tmafm_observers, only: obs_amplitude, obs_phase, obs_peak_force, obs_dissipated, obs_contacts
   use tmafm_trajectory, only: stop_poll
   use tmafm_text, only: real_text, int_text
   use tmafm_calibration, only: tip_compliance, first_mode
   implicit none
   private

   public :: run_am_scan, scan_period_count, mean_phase
   public :: n_scan_columns, scan_column_names, scan_column_units, scan_column_meanings
   public :: n_scan_info, scan_info_names, scan_info_units
   public :: n_record_columns, record_column_names, record_column_units

   real(dp), parameter :: pi = acos(-1.0_dp)

   !> The per-pixel columns of a scan (each the mean over the pixel's drive periods).
   integer, parameter :: n_scan_columns = 9
   !> Their names.
   character(len=*), parameter :: scan_column_names(n_scan_columns) = [character(len=20) :: &
                                  'height', 'amplitude_error', 'phase', 'peak_force', 'dissipated', &
                                  'amplitude', 'topography', 'distance', 'material']
   !> Their units.
   character(len=*), parameter :: scan_column_units(n_scan_columns) = [character(len=4) :: &
                                  'nm', 'nm', 'deg', 'nN', 'aJ', 'nm', 'nm', 'nm', '1']
   !> What they are.
   character(len=*), parameter :: scan_column_meanings(n_scan_columns) = [character(len=90) :: &
      'apparent height: the piezo Z, the tip rest position above the plane h = 0', &
      'amplitude error A_set - A (A the lock-in filtered amplitude)', &
      'lock-in filtered phase at the drive: the angle of the mean filtered (X, Y)', &
      'peak repulsive force per period', &
      'energy dissipated per period', &
      'lock-in filtered amplitude', &
      'true topography h(x) at the tip', &
      'tip rest distance from the sample, Z - h(x)', &
      'fraction of the periods over the second material']

   !> The scan's summary values.
   integer, parameter :: n_scan_info = 12
   !> Their names.
   character(len=*), parameter :: scan_info_names(n_scan_info) = [character(len=24) :: &
      'free_amplitude', 'setpoint', 'slope', 'proportional_gain', 'integral_gain', 'cantilever_time', &
      'closed_loop_time', 'periods_per_pixel', 'ringup_periods', 'engage_periods', 'engaged_height', &
      'drive_period']
   !> Their units.
   character(len=*), parameter :: scan_info_units(n_scan_info) = [character(len=4) :: &
      'nm', 'nm', '1', '1', '1/s', 's', 's', '1', '1', '1', 'nm', 's']

   !> The per-period record's columns (optional).
   integer, parameter :: n_record_columns = 7
   !> Their names.
   character(len=*), parameter :: record_column_names(n_record_columns) = [character(len=16) :: &
      'time', 'x', 'height', 'distance', 'amplitude', 'amplitude_raw', 'phase']
   !> Their units.
   character(len=*), parameter :: record_column_units(n_record_columns) = [character(len=4) :: &
      's', 'nm', 'nm', 'nm', 'nm', 'nm', 'deg']

   !> The lock-in: its X and Y filters.
   type :: lockin_t
      type(lowpass_t) :: x, y
      real(dp) :: amplitude = 0, phase = 0
   end type lockin_t

   !> With thermal noise, the engage's band is this many times the thermal rms sigma (where
   !> that is wider than 1e-3 A_set): the filtered amplitude's error scatters by at most about
   !> sigma, so a band of 4 sigma is left by chance once in ~10^4 independent samples.
   real(dp), parameter :: engage_noise_band = 4

contains

   !> The number of drive periods per pixel and of the whole line (trace and retrace), for a
   !> drive period `period` (s).
   pure subroutine scan_period_count(scan, period, per_pixel, total)
      type(scan_settings_t), intent(in) :: scan
      real(dp), intent(in) :: period
      integer, intent(out) :: per_pixel, total
      per_pixel = max(1, nint(1/(scan%line_rate*merge(2, 1, scan%retrace)*scan%pixels*period)))
      total = per_pixel*scan%pixels*merge(2, 1, scan%retrace)
   end subroutine scan_period_count

   !> Scan one line of `scan` with the cantilever of `config` (a &physical scene: the first
   !> material, its tip_sample_distance the distance the engage starts from); `material_b` the
   !> &physical scene of the second material (used when scan%two_materials; only its sample may
   !> differ).  pixels(j, :, p): pixel j's columns (scan_column_names) on pass p (1 trace,
   !> 2 retrace), pixel j centred at x = (j - 1/2) L/pixels on both passes; info: the summary
   !> (scan_info_names).  record: one row per scan period (record_column_names), or no rows.
   subroutine run_am_scan(config, material_b, scan, pixels, info, record, ierr, errmsg, poll)
      type(config_t), intent(in) :: config
      type(physical_t), intent(in) :: material_b
      type(scan_settings_t), intent(in) :: scan
      real(dp), intent(inout) :: pixels(:, :, :)
      real(dp), intent(inout) :: info(:)
      real(dp), intent(inout) :: record(:, :)
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      !> If present, the runs poll it (Ctrl-C from Python).
      procedure(stop_poll), optional :: poll
      type(period_stepper_t) :: stepper
      type(lockin_t) :: lockin
      type(pi_controller_t) :: feedback
      type(physical_t) :: base
      real(dp) :: period, a0, a_set, tau_c, slope, z, z_start, tau_cl, x, h, dx, raw, sums(n_scan_columns)
      real(dp) :: sigma, band, tau_d
      real(dp), allocatable :: pixel_x(:), pixel_y(:)
      complex(dp) :: lambda1
      logical :: under
      real(dp), allocatable :: ring(:)
      integer :: passes, per_pixel, total, k, j, p, q, pixel, n_ring, n_engage, n_ramp, on_b, inside
      integer(i8) :: row
      integer :: material, cap
      logical :: noisy

      ierr = ok
      errmsg = ''
      call init_period_stepper(stepper, config, ierr, errmsg, poll=poll)
      if (ierr /= ok) return
      base = stepper%config%physical
      period = stepper%period
      call check_scan_settings(scan, period, ierr, errmsg)
      if (ierr /= ok) return
      passes = merge(2, 1, scan%retrace)
      call scan_period_count(scan, period, per_pixel, total)
      if (size(pixels, 1) /= scan%pixels .or. size(pixels, 2) /= n_scan_columns .or. size(pixels, 3) /= passes &
          .or. size(info) /= n_scan_info .or. size(record, 2) /= n_record_columns .or. &
          (size(record, 1) /= 0 .and. size(record, 1) /= total)) then
         ierr = err_input
         errmsg = 'run_am_scan: pixels must be '//int_text(scan%pixels)//' x '//int_text(n_scan_columns)//' x '// &
                  int_text(passes)//', info '//int_text(n_scan_info)//', record 0 or '//int_text(total)//' x '// &
                  int_text(n_record_columns)
         return
      end if
      if (scan%two_materials) then
         call check_same_cantilever(base, material_b, ierr, errmsg)
         if (ierr /= ok) return
      end if
      z_start = base%tip_sample_distance
      material = 1
      z = z_start
      ! The setting at x = 0.
      h = scan_height(scan, 0.0_dp)
      call move_to(0.0_dp, ierr, errmsg)
      if (ierr /= ok) return

      ! Ring-up at the start distance, feedback off.  Without noise: until the amplitude changes
      ! by at most 1e-6 of itself in a period.  With thermal noise the amplitude scatters by the
      ! thermal rms sigma = sqrt(k_B T/k) (docs/model.md §21) and never settles to 1e-6; the
      ! transient from rest decays as exp(-t/tau_d), tau_d = 1/|Re lambda1| the free mode 1's
      ! decay time (2Q/omega0), from about the amplitude A itself, so the ring-up lasts until it
      ! is below sigma/e: t >= tau_d (1 + ln(A/sigma)), and at least 3 tau_d; A0 is then the
      ! mean over the last tau_d.  tau_c = the time the amplitude took to reach 1 - 1/e of A0.
      noisy = stepper%config%solver%thermal_noise == 1
      sigma = 0
      tau_d = 0
      if (noisy) then
         sigma = stepper%scales%length*sqrt(stepper%model%scene%thermal_energy*tip_compliance(stepper%model))
         call first_mode(stepper%model, stepper%model%scene%alpha3, lambda1, under, ierr, errmsg)
         if (ierr /= ok) return
         tau_d = stepper%scales%time/abs(real(lambda1))
      end if
      cap = 2000000
      allocate (ring(1024))
      n_ring = 0
      do
         call step(ierr, errmsg)
         if (ierr /= ok) return
         n_ring = n_ring + 1
         if (n_ring > size(ring)) ring = [ring, ring]
         ring(n_ring) = raw
         if (noisy) then
            if (n_ring*period >= tau_d*max(3.0_dp, 1 + log(raw/sigma))) exit
         else if (n_ring > 2) then
            if (abs(ring(n_ring) - ring(n_ring - 1)) <= 1.0e-6_dp*ring(n_ring)) exit
         end if
         if (n_ring >= cap) then
            ierr = err_runtime
            errmsg = 'scan: the free amplitude did not settle within '//int_text(cap)//' drive periods'
            return
         end if
      end do
      a0 = ring(n_ring)
      if (noisy) then
         k = min(n_ring, max(1, nint(tau_d/period)))
         a0 = sum(ring(n_ring - k + 1:n_ring))/k
      end if
      if (stepper%values(obs_contacts) > 0) then
         ierr = err_input
         errmsg = '&physical tip_sample_distance = '//real_text(z_start)//': the tip touches the sample there; '// &
                  'the scan measures A0 and engages from a start out of contact'
         return
      end if
      tau_c = period*n_ring
      do k = 2, n_ring
         if (ring(k) >= (1 - exp(-1.0_dp))*a0) then
            tau_c = period*(k - 1 + ((1 - exp(-1.0_dp))*a0 - ring(k - 1))/(ring(k) - ring(k - 1)))
            exit
         end if
      end do
      deallocate (ring)
      a_set = scan%setpoint
      if (scan%setpoint_ratio > 0) a_set = scan%setpoint_ratio*a0
      if (.not. (a_set < a0)) then
         ierr = err_input
         errmsg = 'scan: setpoint = '//real_text(a_set)//' must be below the free amplitude A0 = '// &
                  real_text(a0)//' (m) measured at the start distance'
         return
      end if

      ! With thermal noise the slope below is a secant over 0.1 (A0 - A_set), read from the
      ! filtered amplitude, which scatters by up to sigma: its relative error is about
      ! sqrt(2) sigma/(0.1 (A0 - A_set)).  Gains designed on it need that under ~0.14.
      if (noisy .and. scan%feedback_bandwidth > 0 .and. 0.1_dp*(a0 - a_set) < 10*sigma) then
         ierr = err_input
         errmsg = 'scan: setpoint = '//real_text(a_set)//' (m): 0.1 (A0 - A_set) = '// &
                  real_text(0.1_dp*(a0 - a_set))//' (m) is under 10 thermal rms sigma = '//real_text(10*sigma)// &
                  ' (m), so the slope dA/dZ the gains are designed on would be the noise''s; '// &
                  'give a setpoint further below A0, or the gains'
         return
      end if

      ! Approach, feedback off: Z falls by 0.02 A0 per tau_c until the filtered amplitude
      ! reaches the setpoint; the plant's slope dA/dZ is that of the last 10 % of the fall
      ! from A0 to A_set (the lags of the cantilever and the lock-in delay both ends alike).
      lockin%x%bandwidth = scan%lockin_bandwidth
      lockin%y%bandwidth = scan%lockin_bandwidth
      call filter(lockin, raw, stepper%values(obs_phase), period)
      n_ramp = 0
      slope = 0
      block
         real(dp) :: z_mark, a_mark
         logical :: marked
         marked = .false.
         z_mark = z
         a_mark = lockin%amplitude
         do while (lockin%amplitude > a_set)
            z = z - 0.02_dp*a0*period/tau_c
            call move_to(0.0_dp, ierr, errmsg)
            if (ierr /= ok) return
            call step(ierr, errmsg)
            if (ierr /= ok) return
            call filter(lockin, raw, stepper%values(obs_phase), period)
            n_ramp = n_ramp + 1
            if (.not. marked .and. lockin%amplitude <= a_set + 0.1_dp*(a0 - a_set)) then
               marked = .true.
               z_mark = z
               a_mark = lockin%amplitude
            end if
            if (n_ramp >= cap .or. z < -a0 - z_start) then
               ierr = err_runtime
               errmsg = 'scan: the approach did not reach the setpoint '//real_text(a_set)// &
                        ' (m) above Z = '//real_text(z)//' (m)'
               return
            end if
         end do
         if (z_mark > z) slope = (a_mark - lockin%amplitude)/(z_mark - z)
      end block
      if (.not. (slope > 0)) then
         ierr = err_runtime
         errmsg = 'scan: the approach curve''s slope dA/dZ = '//real_text(slope)// &
                  ' at the setpoint is not positive; the Z feedback needs dA/dZ > 0'
         return
      end if
      if (scan%feedback_bandwidth > 0) then
         feedback%integral = 2*pi*scan%feedback_bandwidth/slope
         feedback%proportional = feedback%integral*tau_c
      else
         feedback%integral = scan%integral_gain
         feedback%proportional = scan%proportional_gain
      end if
      tau_cl = 1/(slope*feedback%integral)
      ! Bumpless transfer: the integrator starts at the Z the approach stopped at.
      feedback%integrator = z - feedback%proportional*(a_set - lockin%amplitude)

      ! Engage at x = 0 until the error stays within 1e-3 A_set (with thermal noise, within
      ! engage_noise_band sigma where that is wider) for 3 closed-loop times.
      band = 1.0e-3_dp*a_set
      if (noisy) band = max(band, engage_noise_band*sigma)
      n_engage = 0
      inside = 0
      do while (inside < max(1, ceiling(3*tau_cl/period)))
         z = feedback%update(a_set - lockin%amplitude, period)
         call move_to(0.0_dp, ierr, errmsg)
         if (ierr /= ok) return
         call step(ierr, errmsg)
         if (ierr /= ok) return
         call filter(lockin, raw, stepper%values(obs_phase), period)
         n_engage = n_engage + 1
         inside = merge(inside + 1, 0, abs(a_set - lockin%amplitude) <= band)
         if (n_engage >= cap) then
            ierr = err_runtime
            errmsg = 'scan: the feedback did not settle at the setpoint within '//int_text(cap)//' drive periods'
            return
         end if
      end do
      info = [a0*1.0e9_dp, a_set*1.0e9_dp, slope, feedback%proportional, feedback%integral, tau_c, tau_cl, &
              real(per_pixel, dp), real(n_ring, dp), real(n_engage, dp), z*1.0e9_dp, period]

      ! The line: trace from x = 0 to L, retrace back; x at each period's middle.
      allocate (pixel_x(per_pixel), pixel_y(per_pixel))
      dx = scan%scan_length/(per_pixel*scan%pixels)
      row = 0
      do p = 1, passes
         do j = 1, scan%pixels
            pixel = merge(j, scan%pixels + 1 - j, p == 1)
            sums = 0
            on_b = 0
            do q = 1, per_pixel
               k = (j - 1)*per_pixel + q
               x = (k - 0.5_dp)*dx
               if (p == 2) x = scan%scan_length - x
               h = scan_height(scan, x)
               call move_to(x, ierr, errmsg)
               if (ierr /= ok) return
               call step(ierr, errmsg)
               if (ierr /= ok) return
               call filter(lockin, raw, stepper%values(obs_phase), period)
               sums = sums + [z, a_set - lockin%amplitude, 0.0_dp, stepper%values(obs_peak_force), &
                              stepper%values(obs_dissipated), lockin%amplitude, h, z - h, real(material - 1, dp)]
               pixel_x(q) = lockin%x%value
               pixel_y(q) = lockin%y%value
               if (size(record, 1) > 0) then
                  row = row + 1
                  record(row, :) = [stepper%time, x*1.0e9_dp, z*1.0e9_dp, (z - h)*1.0e9_dp, &
                                    lockin%amplitude*1.0e9_dp, raw*1.0e9_dp, lockin%phase]
               end if
               z = feedback%update(a_set - lockin%amplitude, period)
            end do
            pixels(pixel, :, p) = sums/per_pixel
            pixels(pixel, 3, p) = mean_phase(pixel_x, pixel_y)
            pixels(pixel, [1, 2, 6, 7, 8], p) = pixels(pixel, [1, 2, 6, 7, 8], p)*1.0e9_dp
         end do
      end do

   contains

      !> The setting at lateral position xx with the piezo at z: distance z - h(xx), the
      !> material at xx; the stepper is told only when it changed.
      subroutine move_to(xx, ierr, errmsg)
         real(dp), intent(in) :: xx
         integer, intent(out) :: ierr
         character(len=*), intent(out) :: errmsg
         integer :: here
         real(dp) :: distance
         ierr = ok
         errmsg = ''
         here = 1
         if (scan%two_materials .and. xx >= scan%material_boundary) here = 2
         distance = z - scan_height(scan, xx)
         if (here == material .and. distance == stepper%config%physical%tip_sample_distance) return
         material = here
         if (here == 1) then
            call stepper%set_physical(with_distance(base, distance), ierr, errmsg)
         else
            call stepper%set_physical(with_distance(material_b, distance), ierr, errmsg)
         end if
         if (ierr /= ok) errmsg = 'scan: at x = '//real_text(xx)//' (m): '//trim(errmsg)
      end subroutine move_to

      !> One drive period; raw is its lock-in amplitude (m).
      subroutine step(ierr, errmsg)
         integer, intent(out) :: ierr
         character(len=*), intent(out) :: errmsg
         call stepper%advance(ierr, errmsg, poll)
         if (ierr /= ok) return
         raw = stepper%values(obs_amplitude)*1.0e-9_dp
      end subroutine step

   end subroutine run_am_scan

   !> The phase (deg) of the mean of lock-in outputs (x(k), y(k)) = A_k (cos phi_k, sin phi_k):
   !> a circular mean of the phases phi_k weighted by A_k, which holds where they wrap across
   !> +-180 deg (their arithmetic mean would not: 179 and -179 deg average to 180, not 0).
   !> 0 when the mean is the origin.
   pure real(dp) function mean_phase(x, y)
      real(dp), intent(in) :: x(:), y(:)
      mean_phase = 0
      if (sum(x) /= 0 .or. sum(y) /= 0) mean_phase = atan2(sum(y), sum(x))*180/pi
   end function mean_phase

   !> The lock-in's output filters over one period of amplitude a (m) and phase phase (deg).
   subroutine filter(lockin, a, phase, period)
      type(lockin_t), intent(inout) :: lockin
      real(dp), intent(in) :: a, phase, period
      real(dp) :: fx, fy
      fx = lockin%x%update(a*cos(phase*pi/180), period)
      fy = lockin%y%update(a*sin(phase*pi/180), period)
      lockin%amplitude = hypot(fx, fy)
      lockin%phase = atan2(fy, fx)*180/pi
   end subroutine filter

   !> The second material may change only the sample under the same cantilever and drive.
   subroutine check_same_cantilever(a, b, ierr, errmsg)
      type(physical_t), intent(in) :: a, b
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      ierr = ok
      errmsg = ''
      if (a%spring_constant /= b%spring_constant .or. a%resonance_frequency /= b%resonance_frequency .or. &
          a%quality_factor /= b%quality_factor .or. a%length /= b%length .or. a%tip_radius /= b%tip_radius .or. &
          a%drive_angular_frequency /= b%drive_angular_frequency .or. a%drive_amplitude /= b%drive_amplitude .or. &
          a%tilt /= b%tilt .or. a%tip_length /= b%tip_length .or. a%youngs_modulus_tip /= b%youngs_modulus_tip) then
         ierr = err_input
         errmsg = 'material_b: the second material may change only the sample (its keys), not the cantilever, '// &
                  'the tip or the drive'
      end if
   end subroutine check_same_cantilever

end module tmafm_am_scan

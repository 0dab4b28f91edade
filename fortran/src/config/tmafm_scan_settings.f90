!> The settings of an AM-AFM scan line (docs/instrument.md, "AM imaging"): the line, the
!> setpoint, the lock-in and the Z feedback, the topography under the tip and where a second
!> material starts; all in SI units, every value range-checked by check_scan_settings.
module tmafm_scan_settings
   use tmafm_kinds, only: dp
   use tmafm_errors, only: ok, err_input
   use tmafm_text, only: real_text, int_text
   use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
   implicit none
   private

   public :: scan_settings_t, check_scan_settings, scan_height
   public :: topography_flat, topography_step, topography_sphere

   !> The topographies a scan knows.
   character(len=*), parameter :: topography_flat = 'flat', topography_step = 'step', &
                                  topography_sphere = 'sphere'

   !> One scan line.
   type :: scan_settings_t
      !> The line's length L (m), scanned from x = 0 to x = L.
      real(dp) :: scan_length = 0
      !> The number of pixels along the line (each pixel the mean over its drive periods).
      integer :: pixels = 0
      !> The line rate (Hz): a trace and a retrace take 1/line_rate together.
      real(dp) :: line_rate = 0
      !> .true.: the line is scanned forth (trace) and back (retrace); .false.: trace only.
      logical :: retrace = .true.
      !> The amplitude setpoint A_set (m); 0 when given as setpoint_ratio.
      real(dp) :: setpoint = 0
      !> The setpoint as A_set/A0 (A0 the free amplitude measured before the engage); 0 when
      !> given as setpoint.
      real(dp) :: setpoint_ratio = 0
      !> The lock-in's output filter bandwidth (Hz, first order, -3 dB).
      real(dp) :: lockin_bandwidth = 0
      !> The Z feedback's designed closed-loop bandwidth (Hz); 0 when the gains are given.
      real(dp) :: feedback_bandwidth = 0
      !> The PI's proportional gain K_p (m of Z per m of amplitude error); with integral_gain,
      !> instead of feedback_bandwidth.
      real(dp) :: proportional_gain = 0
      !> The PI's integral gain K_i (1/s: m of Z per s and m of amplitude error).
      real(dp) :: integral_gain = 0
      !> The topography h(x): 'flat', 'step' or 'sphere'.
      character(len=16) :: topography = topography_flat
      !> A step's height H (m, may be negative) and position x_s (m): h = H for x >= x_s.
      real(dp) :: step_height = 0
      real(dp) :: step_position = 0
      !> A sphere of radius R_s (m) resting on the plane at x_c (m): h = R_s + sqrt(R_s^2 -
      !> (x - x_c)^2) within |x - x_c| < R_s.
      real(dp) :: sphere_radius = 0
      real(dp) :: sphere_position = 0
      !> .true. when a second material lies at x >= material_boundary.
      logical :: two_materials = .false.
      !> Where the second material starts, x_b (m).
      real(dp) :: material_boundary = 0
   end type scan_settings_t

contains

   !> Refuse a scan setting out of range: ierr = err_input and one line naming key and value
   !> (group 'scan').  `period` is the drive period (s).
   subroutine check_scan_settings(scan, period, ierr, errmsg)
      type(scan_settings_t), intent(in) :: scan
      real(dp), intent(in) :: period
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      real(dp) :: dwell

      ierr = err_input
      if (.not. (ieee_is_finite(scan%scan_length) .and. scan%scan_length > 0 .and. scan%scan_length <= 1.0e-3_dp)) then
         errmsg = 'scan: scan_length = '//real_text(scan%scan_length)//' must be > 0 and <= 1e-3 (m)'
      else if (scan%pixels < 1 .or. scan%pixels > 100000) then
         errmsg = 'scan: pixels = '//int_text(scan%pixels)//' must be 1..100000'
      else if (.not. (ieee_is_finite(scan%line_rate) .and. scan%line_rate > 0)) then
         errmsg = 'scan: line_rate = '//real_text(scan%line_rate)//' must be > 0 (Hz)'
      else if (.not. (ieee_is_finite(scan%setpoint) .and. scan%setpoint >= 0)) then
         errmsg = 'scan: setpoint = '//real_text(scan%setpoint)//' must be >= 0 (m)'
      else if (.not. (ieee_is_finite(scan%setpoint_ratio) .and. scan%setpoint_ratio >= 0 .and. &
                      scan%setpoint_ratio < 1)) then
         errmsg = 'scan: setpoint_ratio = '//real_text(scan%setpoint_ratio)//' must be > 0 and < 1'
      else if ((scan%setpoint > 0) .eqv. (scan%setpoint_ratio > 0)) then
         errmsg = 'scan: setpoint = '//real_text(scan%setpoint)//', setpoint_ratio = '// &
                  real_text(scan%setpoint_ratio)//': give exactly one of them (> 0)'
      else if (.not. (ieee_is_finite(scan%lockin_bandwidth) .and. scan%lockin_bandwidth > 0 .and. &
                      scan%lockin_bandwidth*period <= 0.5_dp)) then
         errmsg = 'scan: lockin_bandwidth = '//real_text(scan%lockin_bandwidth)//' must be > 0 and <= '// &
                  real_text(0.5_dp/period)//' (Hz, half the drive frequency)'
      else if (.not. (ieee_is_finite(scan%feedback_bandwidth) .and. scan%feedback_bandwidth >= 0 .and. &
                      scan%feedback_bandwidth <= scan%lockin_bandwidth/2)) then
         errmsg = 'scan: feedback_bandwidth = '//real_text(scan%feedback_bandwidth)//' must be >= 0 and <= '// &
                  real_text(scan%lockin_bandwidth/2)//' (Hz, half the lockin_bandwidth)'
      else if (.not. (ieee_is_finite(scan%proportional_gain) .and. scan%proportional_gain >= 0)) then
         errmsg = 'scan: proportional_gain = '//real_text(scan%proportional_gain)//' must be >= 0'
      else if (.not. (ieee_is_finite(scan%integral_gain) .and. scan%integral_gain >= 0)) then
         errmsg = 'scan: integral_gain = '//real_text(scan%integral_gain)//' must be >= 0 (1/s)'
      else if ((scan%feedback_bandwidth > 0) .eqv. (scan%integral_gain > 0)) then
         errmsg = 'scan: feedback_bandwidth = '//real_text(scan%feedback_bandwidth)//', integral_gain = '// &
                  real_text(scan%integral_gain)//': give exactly one of them (> 0)'
      else if (scan%feedback_bandwidth > 0 .and. scan%proportional_gain > 0) then
         errmsg = 'scan: proportional_gain = '//real_text(scan%proportional_gain)// &
                  ': the gains come from feedback_bandwidth (give the gains or the bandwidth)'
      else if (.not. (trim(scan%topography) == topography_flat .or. trim(scan%topography) == topography_step .or. &
                      trim(scan%topography) == topography_sphere)) then
         errmsg = 'scan: topography = '''//trim(scan%topography)//''' must be ''flat'', ''step'' or ''sphere'''
      else if (.not. (ieee_is_finite(scan%step_height) .and. abs(scan%step_height) <= 1.0e-6_dp)) then
         errmsg = 'scan: step_height = '//real_text(scan%step_height)//' must be within +-1e-6 (m)'
      else if (.not. (ieee_is_finite(scan%step_position) .and. scan%step_position >= 0 .and. &
                      scan%step_position <= scan%scan_length)) then
         errmsg = 'scan: step_position = '//real_text(scan%step_position)//' must be in 0..scan_length (m)'
      else if (.not. (ieee_is_finite(scan%sphere_radius) .and. scan%sphere_radius >= 0 .and. &
                      scan%sphere_radius <= 1.0e-6_dp)) then
         errmsg = 'scan: sphere_radius = '//real_text(scan%sphere_radius)//' must be in 0..1e-6 (m)'
      else if (trim(scan%topography) == topography_sphere .and. .not. scan%sphere_radius > 0) then
         errmsg = 'scan: sphere_radius = '//real_text(scan%sphere_radius)//' must be > 0 for topography = ''sphere'''
      else if (.not. (ieee_is_finite(scan%sphere_position) .and. scan%sphere_position >= 0 .and. &
                      scan%sphere_position <= scan%scan_length)) then
         errmsg = 'scan: sphere_position = '//real_text(scan%sphere_position)//' must be in 0..scan_length (m)'
      else if (.not. (ieee_is_finite(scan%material_boundary) .and. scan%material_boundary >= 0 .and. &
                      scan%material_boundary <= scan%scan_length)) then
         errmsg = 'scan: material_boundary = '//real_text(scan%material_boundary)//' must be in 0..scan_length (m)'
      else
         ierr = ok
         errmsg = ''
      end if
      if (ierr /= ok) return
      dwell = 1/(scan%line_rate*merge(2, 1, scan%retrace)*scan%pixels)
      if (dwell < period) then
         ierr = err_input
         errmsg = 'scan: line_rate = '//real_text(scan%line_rate)//' leaves less than one drive period per pixel'
      end if
   end subroutine check_scan_settings

   !> The topography's height h(x) (m) at x (m).
   pure real(dp) function scan_height(scan, x) result(h)
      type(scan_settings_t), intent(in) :: scan
      real(dp), intent(in) :: x
      real(dp) :: r
      h = 0
      select case (trim(scan%topography))
      case (topography_step)
         if (x >= scan%step_position) h = scan%step_height
      case (topography_sphere)
         r = scan%sphere_radius
         if (abs(x - scan%sphere_position) < r) h = r + sqrt(r**2 - (x - scan%sphere_position)**2)
      end select
   end function scan_height

end module tmafm_scan_settings

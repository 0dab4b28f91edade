!> Entry points of AM imaging (docs/instrument.md, "AM imaging") for the Python package: one
!> scan line with the Z feedback.  Like tmafm_api: no physics here, results copied into arrays
!> Python made (shapes checked), ierr and a one-line errmsg, no state between calls.
module tmafm_api_scan
   use tmafm, only: dp, ok, scan_settings_t, check_scan_settings, run_am_scan, scan_period_count, n_scan_columns, &
      scan_column_names, scan_column_units, scan_column_meanings, n_scan_info, scan_info_names, scan_info_units, &
      n_record_columns, record_column_names, record_column_units, init_period_stepper, period_stepper_t, &
      mean_phase
   use tmafm_config, only: config_t
   use tmafm_api_poll, only: python_interrupted
   implicit none
   private

   public :: am_scan_run, am_scan_shape, am_scan_names, am_scan_mean_phase

contains

   !> Scan one line of `scan` with the cantilever and first material of `config`, the second
   !> material of `config_b` (its &physical scene; used when scan%two_materials).  pixels,
   !> info and record as tmafm_am_scan's run_am_scan (record may have no rows).
   subroutine am_scan_run(config, config_b, scan, poll, pixels, info, record, ierr, errmsg)
      type(config_t), intent(in) :: config
      type(config_t), intent(in) :: config_b
      type(scan_settings_t), intent(in) :: scan
      !> Poll for Ctrl-C (Python's main thread only).
      logical, intent(in) :: poll
      real(dp), intent(inout) :: pixels(:, :, :)
      real(dp), intent(inout) :: info(:)
      real(dp), intent(inout) :: record(:, :)
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      if (poll) then
         call run_am_scan(config, config_b%physical, scan, pixels, info, record, ierr, errmsg, python_interrupted)
      else
         call run_am_scan(config, config_b%physical, scan, pixels, info, record, ierr, errmsg)
      end if
   end subroutine am_scan_run

   !> The drive period (s) of `config` and the periods per pixel and in all of `scan`'s line.
   subroutine am_scan_shape(config, scan, period, per_pixel, total, ierr, errmsg)
      type(config_t), intent(in) :: config
      type(scan_settings_t), intent(in) :: scan
      real(dp), intent(out) :: period
      integer, intent(out) :: per_pixel
      integer, intent(out) :: total
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(period_stepper_t) :: stepper
      period = 0
      per_pixel = 0
      total = 0
      ierr = ok
      errmsg = ''
      call init_period_stepper(stepper, config, ierr, errmsg)
      if (ierr /= ok) return
      call check_scan_settings(scan, stepper%period, ierr, errmsg)
      if (ierr /= ok) return
      period = stepper%period
      call scan_period_count(scan, period, per_pixel, total)
   end subroutine am_scan_shape

   !> A pixel's phase (deg) from its periods' filtered lock-in outputs x, y (the scan's own
   !> average: the angle of their mean).
   subroutine am_scan_mean_phase(x, y, phase)
      real(dp), intent(in) :: x(:)
      real(dp), intent(in) :: y(:)
      real(dp), intent(out) :: phase
      phase = mean_phase(x, y)
   end subroutine am_scan_mean_phase

   !> The names, units and meanings of a table ('pixels', 'info' or 'record'), each list joined
   !> by '|'.
   subroutine am_scan_names(table, names, units, meanings)
      character(len=*), intent(in) :: table
      character(len=*), intent(out) :: names
      character(len=*), intent(out) :: units
      character(len=*), intent(out) :: meanings
      integer :: k
      names = ''
      units = ''
      meanings = ''
      select case (table)
      case ('pixels')
         do k = 1, n_scan_columns
            names = trim(names)//trim(scan_column_names(k))//'|'
            units = trim(units)//trim(scan_column_units(k))//'|'
            meanings = trim(meanings)//trim(scan_column_meanings(k))//'|'
         end do
      case ('info')
         do k = 1, n_scan_info
            names = trim(names)//trim(scan_info_names(k))//'|'
            units = trim(units)//trim(scan_info_units(k))//'|'
         end do
      case ('record')
         do k = 1, n_record_columns
            names = trim(names)//trim(record_column_names(k))//'|'
            units = trim(units)//trim(record_column_units(k))//'|'
         end do
      end select
   end subroutine am_scan_names

end module tmafm_api_scan

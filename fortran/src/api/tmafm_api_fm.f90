!> Entry points of the FM-AFM loop (docs/instrument.md, "FM-AFM") for the Python package: an FM
!> approach curve, Z point by Z point, each warm-started from the last.  Like tmafm_api: no
!> physics here, results copied into arrays Python made (shapes checked), ierr and a one-line
!> errmsg, no state between calls.
module tmafm_api_fm
   use tmafm, only: dp, ok, err_input, int_text, fm_settings_t, fm_loop_t, init_fm_loop, fm_point, &
      n_fm_columns, n_fm_trace
   use tmafm_config, only: config_t
   use tmafm_api_poll, only: python_interrupted
   implicit none
   private

   public :: fm_approach_run

contains

   !> Run the FM loop of `config` through the Z points z (m), each settled from the last one's
   !> loop state: values(k, :) are point k's averages (tmafm_fm's columns fm_*), trace(j, :) each
   !> period's Δf (Hz), drive (nm), A (nm), phase (deg), point after point; reference = f0 (Hz),
   !> the phase setpoint (deg), the free drive (m), the free drive work (aJ), the response time
   !> (s).  On an error the points done are in values(1:done, :).
   subroutine fm_approach_run(config, z, amplitude, pll_bandwidth, amplitude_bandwidth, settle_periods, &
                              average_periods, free_distance, poll, values, trace, reference, done, ierr, errmsg)
      type(config_t), intent(in) :: config
      real(dp), intent(in) :: z(:)
      real(dp), intent(in) :: amplitude, pll_bandwidth, amplitude_bandwidth, free_distance
      integer, intent(in) :: settle_periods, average_periods
      !> Poll for Ctrl-C (Python's main thread only).
      logical, intent(in) :: poll
      real(dp), intent(inout) :: values(:, :)
      real(dp), intent(inout) :: trace(:, :)
      real(dp), intent(inout) :: reference(:)
      integer, intent(out) :: done
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(fm_settings_t) :: settings
      type(fm_loop_t) :: loop
      integer :: k, per_point

      done = 0
      settings%amplitude = amplitude
      settings%pll_bandwidth = pll_bandwidth
      settings%amplitude_bandwidth = amplitude_bandwidth
      settings%settle_periods = settle_periods
      settings%average_periods = average_periods
      settings%free_distance = free_distance
      per_point = max(settle_periods, 0) + max(average_periods, 0)
      if (size(values, 1) /= size(z) .or. size(values, 2) /= n_fm_columns .or. size(reference) /= 5 .or. &
          size(trace, 1) /= size(z)*per_point .or. size(trace, 2) /= n_fm_trace) then
         ierr = err_input
         errmsg = 'fm_approach_run: values must be '//int_text(size(z))//' x '//int_text(n_fm_columns)// &
                  ', trace '//int_text(size(z)*per_point)//' x '//int_text(n_fm_trace)//' and reference 5'
         return
      end if
      if (poll) then
         call init_fm_loop(loop, config, settings, ierr, errmsg, poll=python_interrupted)
      else
         call init_fm_loop(loop, config, settings, ierr, errmsg)
      end if
      if (ierr /= ok) return
      reference = [loop%free_frequency, loop%phase_setpoint, loop%free_drive, loop%free_work, loop%response_time]
      do k = 1, size(z)
         associate (window => trace((k - 1)*per_point + 1:k*per_point, :))
            if (poll) then
               call fm_point(loop, z(k), values(k, :), ierr, errmsg, trace=window, poll=python_interrupted)
            else
               call fm_point(loop, z(k), values(k, :), ierr, errmsg, trace=window)
            end if
         end associate
         if (ierr /= ok) then
            errmsg = 'z['//int_text(k - 1)//']: '//trim(errmsg)
            return
         end if
         done = k
      end do
   end subroutine fm_approach_run

end module tmafm_api_fm

!> Entry points of the instrument (docs/instrument.md) for the Python package: runs stepped
!> drive period by drive period while the instrument's setting changes.  Like tmafm_api: no
!> physics here, results copied into arrays Python made (shapes checked), ierr and a one-line
!> errmsg, no state between calls.
module tmafm_api_instrument
   use tmafm, only: dp, ok, err_input, n_observables, int_text, period_stepper_t, init_period_stepper, &
      with_distance
   use tmafm_config, only: config_t
   use tmafm_api_poll, only: python_interrupted
   implicit none
   private

   public :: z_schedule_run

contains

   !> Run `config` one drive period per entry of z (m): period k at the tip-sample distance
   !> z(k), from the state period k - 1 ended in (the first from &initial).  values(k, :) are
   !> period k's observables (tmafm.observe's columns and units) and ends(k) its end time (s).
   !> On an error the periods done are in values(1:done, :).
   subroutine z_schedule_run(config, z, poll, values, ends, done, ierr, errmsg)
      type(config_t), intent(in) :: config
      real(dp), intent(in) :: z(:)
      !> Poll for Ctrl-C (Python's main thread only).
      logical, intent(in) :: poll
      real(dp), intent(inout) :: values(:, :)
      real(dp), intent(inout) :: ends(:)
      integer, intent(out) :: done
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(period_stepper_t) :: stepper
      integer :: k

      done = 0
      if (size(values, 1) /= size(z) .or. size(values, 2) /= n_observables .or. size(ends) /= size(z)) then
         ierr = err_input
         errmsg = 'z_schedule_run: values must be '//int_text(size(z))//' x '//int_text(n_observables)// &
                  ' and ends '//int_text(size(z))
         return
      end if
      if (poll) then
         call init_period_stepper(stepper, config, ierr, errmsg, poll=python_interrupted)
      else
         call init_period_stepper(stepper, config, ierr, errmsg)
      end if
      if (ierr /= ok) return
      do k = 1, size(z)
         if (k == 1 .or. z(k) /= stepper%config%physical%tip_sample_distance) then
            call stepper%set_physical(with_distance(stepper%config%physical, z(k)), ierr, errmsg)
            if (ierr /= ok) then
               errmsg = 'z['//int_text(k - 1)//']: '//trim(errmsg)
               return
            end if
         end if
         if (poll) then
            call stepper%advance(ierr, errmsg, poll=python_interrupted)
         else
            call stepper%advance(ierr, errmsg)
         end if
         if (ierr /= ok) return
         values(k, :) = stepper%values
         ends(k) = stepper%time
         done = k
      end do
   end subroutine z_schedule_run

end module tmafm_api_instrument

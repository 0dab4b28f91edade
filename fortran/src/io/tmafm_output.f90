!> The trajectory file: '#' header lines echoing the resolved input and the version,
!> then columns tau vt vtdot contact a_1..a_N adot_1..adot_N, readable by numpy.loadtxt.
!>
!> The file is written under a temporary name and renamed at the end, so a failed
!> write never leaves a partial file under the requested name.
module tmafm_output
   use, intrinsic :: iso_c_binding, only: c_char, c_int, c_null_char
   use tmafm_errors, only: ok, err_file
   use tmafm_trajectory, only: trajectory_t
   use tmafm_config, only: config_t
   use tmafm_namelist, only: write_config
   use tmafm_version, only: tmafm_version_string
   implicit none
   private

   public :: write_trajectory_file

   interface
      !> POSIX rename(2): atomic replacement within one file system.
      function c_rename(old_path, new_path) result(status) bind(c, name='rename')
         import :: c_char, c_int
         character(kind=c_char), intent(in) :: old_path(*)
         character(kind=c_char), intent(in) :: new_path(*)
         integer(c_int) :: status
      end function c_rename
   end interface

contains

   !> Write `traj` of `config` to `path` atomically.
   subroutine write_trajectory_file(path, input_path, config, traj, ierr, errmsg)
      character(len=*), intent(in) :: path
      character(len=*), intent(in) :: input_path
      type(config_t), intent(in) :: config
      type(trajectory_t), intent(in) :: traj
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      character(len=:), allocatable :: temporary
      character(len=32) :: row_format
      character(len=256) :: iomsg
      integer :: unit, iostat, k, j, n, status

      ierr = ok
      errmsg = ''
      n = config%n_modes
      temporary = trim(path)//'.partial'
      open (newunit=unit, file=temporary, status='replace', action='write', iostat=iostat, &
            iomsg=iomsg)
      if (iostat /= 0) then
         ierr = err_file
         errmsg = 'cannot write output file '''//trim(path)//''': '//trim(iomsg)
         return
      end if
      write (unit, '(a)', iostat=iostat) '# tmafm '//tmafm_version_string
      write (unit, '(a)', iostat=iostat) '# input: '//trim(input_path)
      call write_config(unit, config, '# ')
      write (unit, '(a,5(i0,a))', iostat=iostat) '# counters: steps = ', traj%steps, &
         ', contact_steps = ', traj%contact_steps, ', rejected_steps = ', traj%rejected_steps, &
         ', rhs_evaluations = ', traj%rhs_evaluations, ', phase_switches = ', traj%n_switches, ''
      write (unit, '(a)', advance='no', iostat=iostat) '# columns: tau vt vtdot contact'
      write (unit, '(*(a,i0))', advance='no', iostat=iostat) (' a_', j, j=1, n)
      write (unit, '(*(a,i0))', iostat=iostat) (' adot_', j, j=1, n)
      write (row_format, '(a,i0,a)') '(3es25.16e3,i3,', 2*n, 'es25.16e3)'
      do k = 1, size(traj%tau)
         if (iostat /= 0) exit
         write (unit, row_format, iostat=iostat) traj%tau(k), traj%vt(k), traj%vtdot(k), &
            traj%contact(k), traj%a(k, :), traj%adot(k, :)
      end do
      if (iostat /= 0) then
         close (unit, status='delete')
         ierr = err_file
         errmsg = 'writing output file '''//trim(path)//''' failed'
         return
      end if
      close (unit, iostat=iostat)
      status = c_rename(temporary//c_null_char, trim(path)//c_null_char)
      if (status /= 0 .or. iostat /= 0) then
         ierr = err_file
         errmsg = 'cannot move the finished output to '''//trim(path)//''''
         open (newunit=unit, file=temporary, status='old', iostat=iostat)
         if (iostat == 0) close (unit, status='delete')
      end if
   end subroutine write_trajectory_file

end module tmafm_output

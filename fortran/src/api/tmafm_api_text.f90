!> Stand-in for the in-memory namelist entry points of tmafm_namelist (read_config_text and
!> config_text), until the strict reader lands there.  It goes through a scratch file, so it
!> needs a writable TMPDIR; it disappears when tmafm_namelist provides both routines.
module tmafm_api_text
   use tmafm_kinds, only: i8
   use tmafm_errors, only: ok, err_file
   use tmafm_config, only: config_t
   use tmafm_namelist, only: read_config, write_config
   implicit none
   private

   public :: read_config_text, config_text

contains

   !> Read and validate namelist text held in memory; messages name `source_label`.
   subroutine read_config_text(text, source_label, config, ierr, errmsg)
      character(len=*), intent(in) :: text
      character(len=*), intent(in) :: source_label
      type(config_t), intent(out) :: config
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      character(len=4096) :: path, folder
      integer :: unit, reserved, iostat, at, length
      integer(i8) :: clock

      ierr = ok
      errmsg = ''
      call get_environment_variable('TMPDIR', folder, length)
      if (length == 0 .or. length > len(folder)) folder = '/tmp'
      call system_clock(clock)
      ! The open scratch unit reserves its number, which makes the name unique in this process.
      open (newunit=reserved, status='scratch', iostat=iostat)
      write (path, '(2a,i0,a,i0,a)') trim(folder), '/tmafm_api_', clock, '_', abs(reserved), '.nml'
      open (newunit=unit, file=path, status='new', action='write', iostat=iostat)
      if (iostat /= 0) then
         ierr = err_file
         errmsg = trim(source_label)//': cannot hold the input in a scratch file'
         close (reserved, iostat=iostat)
         return
      end if
      write (unit, '(a)') text
      close (unit)
      call read_config(path, config, ierr, errmsg)
      open (newunit=unit, file=path, status='old', iostat=iostat)
      if (iostat == 0) close (unit, status='delete')
      close (reserved, iostat=iostat)
      at = index(errmsg, trim(path))
      if (at > 0) errmsg = errmsg(1:at - 1)//trim(source_label)//errmsg(at + len_trim(path):)
   end subroutine read_config_text

   !> The resolved input as namelist text, as write_config writes it.
   function config_text(config) result(text)
      type(config_t), intent(in) :: config
      character(len=:), allocatable :: text
      character(len=4096) :: line
      integer :: unit, iostat

      text = ''
      open (newunit=unit, status='scratch', action='readwrite', iostat=iostat)
      if (iostat /= 0) return
      call write_config(unit, config, '')
      rewind (unit)
      do
         read (unit, '(a)', iostat=iostat) line
         if (iostat /= 0) exit
         text = text//trim(line)//new_line('a')
      end do
      close (unit)
   end function config_text

end module tmafm_api_text

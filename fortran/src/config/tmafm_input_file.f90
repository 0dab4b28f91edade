!> Reading an input file whole into memory, line by line from the front: pipes, FIFOs and
!> /dev/stdin work (nothing seeks or rewinds), a directory or an unreadable file is a file
!> error, and input larger than max_input_bytes is refused instead of read forever
!> (/dev/zero, /dev/urandom).  For a tmafm output file (first line '# tmafm ...'), reading
!> stops at the first line that does not start with '#': only its header is input.
module tmafm_input_file
   use, intrinsic :: iso_fortran_env, only: iostat_end, iostat_eor
   use tmafm_errors, only: ok, err_input, err_file
   use tmafm_text, only: int_text
   use tmafm_nml_syntax, only: output_header_mark
   use tmafm_posix, only: path_kind, kind_symlink, kind_missing, error_text
   implicit none
   private

   public :: read_text_file, max_input_bytes

   !> Largest input tmafm reads (1 MiB; a namelist is a few kB).
   integer, parameter :: max_input_bytes = 2**20

contains

   !> Read the file `path` into `text` (lines joined by new_line('a')).
   subroutine read_text_file(path, text, ierr, errmsg)
      character(len=*), intent(in) :: path
      character(len=:), allocatable, intent(out) :: text
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      ! Short: each read pads the whole chunk with blanks, and a longer line comes in pieces.
      character(len=256) :: chunk
      character(len=:), allocatable :: buffer
      character(len=256) :: iomsg
      logical :: exists, is_directory, header_only, at_line_start
      integer :: unit, iostat, n, used, kind, target

      ierr = ok
      errmsg = ''
      text = ''
      if (len_trim(path) == 0) then
         call fail(err_file, 'no input file name given')
         return
      end if
      inquire (file=trim(path), exist=exists)
      if (.not. exists) then
         ! Say what is there: a symbolic link loop or a dangling link is not "not found".
         kind = path_kind(trim(path), target)
         if (kind < 0) then
            call fail(err_file, 'input file '''//trim(path)//''' cannot be used: '//error_text(kind))
         else if (kind == kind_symlink .and. target == kind_missing) then
            call fail(err_file, 'input file '''//trim(path)//''' is a symbolic link to a missing file')
         else
            call fail(err_file, 'input file '''//trim(path)//''' not found')
         end if
         return
      end if
      inquire (file=trim(path)//'/.', exist=is_directory)
      if (is_directory) then
         call fail(err_file, 'input file '''//trim(path)//''' is a directory')
         return
      end if
      open (newunit=unit, file=trim(path), status='old', action='read', form='formatted', &
            access='sequential', iostat=iostat, iomsg=iomsg)
      if (iostat /= 0) then
         call fail(err_file, 'input file '''//trim(path)//''' cannot be opened: '//trim(iomsg))
         return
      end if

      allocate (character(len=8192) :: buffer)
      used = 0
      header_only = .false.
      at_line_start = .true.
      do
         read (unit, '(a)', advance='no', iostat=iostat, iomsg=iomsg, size=n) chunk
         if (iostat /= 0 .and. iostat /= iostat_eor .and. iostat /= iostat_end) then
            close (unit)
            call fail(err_file, 'input file '''//trim(path)//''' cannot be read: '//trim(iomsg))
            return
         end if
         if (iostat == iostat_end) exit
         if (at_line_start .and. used > 0 .and. header_only) then
            ! An output file: its header ends at the first line not starting with '#'.
            if (n == 0) exit
            if (chunk(1:1) /= '#') exit
         end if
         call append(chunk(1:n))
         if (iostat == iostat_eor) call append(new_line('a'))
         if (used > max_input_bytes) then
            close (unit)
            call fail(err_input, 'input file '''//trim(path)//''' is larger than '// &
                      int_text(max_input_bytes)//' bytes: not a tmafm namelist')
            return
         end if
         if (.not. header_only .and. used >= len(output_header_mark)) then
            header_only = buffer(1:len(output_header_mark)) == output_header_mark
         end if
         at_line_start = iostat == iostat_eor
      end do
      close (unit)
      text = buffer(1:used)
   contains
      subroutine append(piece)
         character(len=*), intent(in) :: piece
         character(len=:), allocatable :: bigger
         if (used + len(piece) > len(buffer)) then
            allocate (character(len=2*(used + len(piece))) :: bigger)
            bigger(1:used) = buffer(1:used)
            call move_alloc(bigger, buffer)
         end if
         buffer(used + 1:used + len(piece)) = piece
         used = used + len(piece)
      end subroutine append
      subroutine fail(code, what)
         integer, intent(in) :: code
         character(len=*), intent(in) :: what
         ierr = code
         errmsg = what
      end subroutine fail
   end subroutine read_text_file

end module tmafm_input_file

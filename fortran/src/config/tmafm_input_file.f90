!> Reading an input file whole into memory, its bytes as they are, from the front: pipes,
!> FIFOs and /dev/stdin work (nothing seeks or rewinds), a directory or an unreadable file is
!> a file error, and input larger than max_input_bytes is refused instead of read forever
!> (/dev/zero, /dev/urandom).  For a tmafm output file (first line '# tmafm ...'), reading
!> stops at the first line that does not start with '#': only its header is input.
!>
!> The bytes are read with read(2), not Fortran's formatted input, which ends a record at a
!> lone carriage return and drops it: the parser must see every byte to refuse what is not text
!> (tmafm_nml_syntax), as it does for the same text from Python.
!>
!> A FIFO (also a pipe reached through /dev/stdin or /dev/fd/N) is opened without waiting for
!> a writer; when nothing has come after fifo_wait_ms, a line on `notice_unit` says that tmafm
!> waits for one, so that a FIFO nobody writes to never hangs without a word.
module tmafm_input_file
   use tmafm_errors, only: ok, err_input, err_file
   use tmafm_text, only: int_text
   use tmafm_nml_syntax, only: output_header_mark
   use tmafm_posix, only: path_kind, kind_symlink, kind_missing, kind_fifo, error_text, &
      open_input, open_fifo_reader, wait_input, read_some, close_descriptor
   implicit none
   private

   public :: read_text_file, max_input_bytes

   !> Largest input tmafm reads (1 MiB; a namelist is a few kB).
   integer, parameter :: max_input_bytes = 2**20
   !> How long a FIFO may stay silent before tmafm says that it waits for its writer (ms).
   integer, parameter :: fifo_wait_ms = 200

contains

   !> Read the file `path` into `text`, its bytes as they are.
   subroutine read_text_file(path, text, ierr, errmsg, notice_unit)
      character(len=*), intent(in) :: path
      character(len=:), allocatable, intent(out) :: text
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      !> Where to say that tmafm waits for a FIFO's writer (nowhere if absent).
      integer, intent(in), optional :: notice_unit
      logical :: exists, is_directory, ready
      integer :: kind, target, fd, status

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
      kind = path_kind(trim(path), target)
      if (target == kind_fifo) then
         fd = open_fifo_reader(trim(path), fifo_wait_ms, ready)
         if (fd >= 0) then
            if (.not. ready .and. present(notice_unit)) then
               write (notice_unit, '(a)') 'tmafm: waiting for input: nothing has been written to the '// &
                  'FIFO '''//trim(path)//''' yet'
               flush (notice_unit)
            end if
            status = wait_input(fd)
            if (status < 0) then
               call fail(err_file, 'input file '''//trim(path)//''' cannot be read: '//error_text(status))
               status = close_descriptor(fd)
               return
            end if
         end if
      else
         fd = open_input(trim(path))
      end if
      if (fd < 0) then
         call fail(err_file, 'input file '''//trim(path)//''' cannot be opened: '//error_text(fd))
         return
      end if
      call read_all(fd, trim(path), text, ierr, errmsg)
      status = close_descriptor(fd)
   contains
      subroutine fail(code, what)
         integer, intent(in) :: code
         character(len=*), intent(in) :: what
         ierr = code
         errmsg = what
      end subroutine fail
   end subroutine read_text_file

   !> Read descriptor `fd` (of the input `path`, for messages) to its end into `text`: at most
   !> max_input_bytes, and for an output file only its header.
   subroutine read_all(fd, path, text, ierr, errmsg)
      integer, intent(in) :: fd
      character(len=*), intent(in) :: path
      character(len=:), allocatable, intent(out) :: text
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      character(len=65536) :: chunk
      character(len=:), allocatable :: buffer
      integer :: n, used, scanned, eol
      logical :: header_ended

      ierr = ok
      errmsg = ''
      text = ''
      allocate (character(len=8192) :: buffer)
      used = 0
      scanned = 1
      header_ended = .false.
      do
         n = read_some(fd, chunk)
         if (n < 0) then
            ierr = err_file
            errmsg = 'input file '''//path//''' cannot be read: '//error_text(n)
            return
         end if
         if (n == 0) exit
         if (used + n > len(buffer)) then
            block
               character(len=:), allocatable :: bigger
               allocate (character(len=2*(used + n)) :: bigger)
               bigger(1:used) = buffer(1:used)
               call move_alloc(bigger, buffer)
            end block
         end if
         buffer(used + 1:used + n) = chunk(1:n)
         used = used + n
         if (used >= len(output_header_mark)) then
            if (buffer(1:len(output_header_mark)) == output_header_mark) then
               ! An output file: its header ends at the first line not starting with '#'.
               do
                  eol = index(buffer(scanned:used), new_line('a'))
                  if (eol == 0) exit
                  eol = scanned + eol - 1
                  if (eol == used) exit
                  scanned = eol + 1
                  if (buffer(scanned:scanned) /= '#') then
                     used = eol
                     header_ended = .true.
                     exit
                  end if
               end do
            end if
         end if
         if (header_ended) exit
         if (used > max_input_bytes) then
            ierr = err_input
            errmsg = 'input file '''//path//''' is larger than '//int_text(max_input_bytes)// &
                     ' bytes: not a tmafm namelist'
            return
         end if
      end do
      text = buffer(1:used)
   end subroutine read_all

end module tmafm_input_file

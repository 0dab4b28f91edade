!> POSIX file operations on descriptors for the output writer (C side: tmafm_posix.c).
!>
!> Each function returns 0 (or a non-negative result) on success and -errno on failure;
!> error_text turns the errno into words.  Nothing here keeps state.
module tmafm_posix
   use, intrinsic :: iso_c_binding, only: c_char, c_int, c_int32_t, c_int64_t, c_null_char
   implicit none
   private

   public :: kind_missing, kind_regular, kind_directory, kind_char_device, kind_fifo, &
             kind_symlink, kind_other
   public :: path_kind, create_temporary, open_device, open_device_now, open_input, open_fifo_reader, &
             wait_input, read_some, check_descriptor, write_bytes, &
             write_text, sync_descriptor, close_descriptor, rename_path, remove_path, &
             check_writable, same_file, error_text, crc32_table_size, crc32_table, crc32_update, crc32_text, &
             prefault

   !> Kinds of path (as tmafm_posix.c numbers them): nothing there, a regular file, ...
   integer, parameter :: kind_missing = 0, kind_regular = 1, kind_directory = 2, &
                         kind_char_device = 3, kind_fifo = 4, kind_symlink = 5, kind_other = 6
   !> Entries of the CRC-32 table (slicing by 8).
   integer, parameter :: crc32_table_size = 8*256

   interface
      function c_path_kind(path, target) result(kind) bind(c, name='tmafm_path_kind')
         import :: c_char, c_int
         character(kind=c_char), intent(in) :: path(*)
         integer(c_int), intent(out) :: target
         integer(c_int) :: kind
      end function c_path_kind
      function c_create_temporary(final_path, name_out, capacity) result(fd) &
         bind(c, name='tmafm_create_temporary')
         import :: c_char, c_int
         character(kind=c_char), intent(in) :: final_path(*)
         character(kind=c_char), intent(out) :: name_out(*)
         integer(c_int), value :: capacity
         integer(c_int) :: fd
      end function c_create_temporary
      function c_open_device(path) result(fd) bind(c, name='tmafm_open_device')
         import :: c_char, c_int
         character(kind=c_char), intent(in) :: path(*)
         integer(c_int) :: fd
      end function c_open_device
      function c_open_device_now(path, no_reader) result(fd) bind(c, name='tmafm_open_device_now')
         import :: c_char, c_int
         character(kind=c_char), intent(in) :: path(*)
         integer(c_int), intent(out) :: no_reader
         integer(c_int) :: fd
      end function c_open_device_now
      function c_open_input(path) result(fd) bind(c, name='tmafm_open_input')
         import :: c_char, c_int
         character(kind=c_char), intent(in) :: path(*)
         integer(c_int) :: fd
      end function c_open_input
      function c_open_fifo_reader(path, wait_ms, ready) result(fd) bind(c, name='tmafm_open_fifo_reader')
         import :: c_char, c_int
         character(kind=c_char), intent(in) :: path(*)
         integer(c_int), value :: wait_ms
         integer(c_int), intent(out) :: ready
         integer(c_int) :: fd
      end function c_open_fifo_reader
      !> Wait until a FIFO opened by open_fifo_reader has input (or its writer left), then
      !> make its reads blocking.
      function wait_input(fd) result(status) bind(c, name='tmafm_wait_input')
         import :: c_int
         integer(c_int), value :: fd
         integer(c_int) :: status
      end function wait_input
      function c_read_some(fd, buf, n) result(count) bind(c, name='tmafm_read_some')
         import :: c_char, c_int, c_int64_t
         integer(c_int), value :: fd
         character(kind=c_char), intent(out) :: buf(*)
         integer(c_int64_t), value :: n
         integer(c_int64_t) :: count
      end function c_read_some
      !> 0 if the descriptor is open for writing.
      function check_descriptor(fd) result(status) bind(c, name='tmafm_check_descriptor')
         import :: c_int
         integer(c_int), value :: fd
         integer(c_int) :: status
      end function check_descriptor
      !> Write n bytes of any contiguous array, all of them (partial writes resumed).
      function write_bytes(fd, buf, n) result(status) bind(c, name='tmafm_write_all')
         import :: c_int, c_int64_t
         integer(c_int), value :: fd
         type(*), intent(in) :: buf(*)
         integer(c_int64_t), value :: n
         integer(c_int) :: status
      end function write_bytes
      !> Map the memory of n bytes of a contiguous array now, in one call, rather than a page
      !> fault per page at first touch (a hint: does nothing where the kernel cannot).
      subroutine prefault(buf, n) bind(c, name='tmafm_prefault')
         import :: c_int64_t
         type(*), intent(in) :: buf(*)
         integer(c_int64_t), value :: n
      end subroutine prefault
      function c_write_text(fd, buf, n) result(status) bind(c, name='tmafm_write_all')
         import :: c_char, c_int, c_int64_t
         integer(c_int), value :: fd
         character(kind=c_char), intent(in) :: buf(*)
         integer(c_int64_t), value :: n
         integer(c_int) :: status
      end function c_write_text
      !> fsync(2); devices that cannot sync are not an error.
      function sync_descriptor(fd) result(status) bind(c, name='tmafm_sync')
         import :: c_int
         integer(c_int), value :: fd
         integer(c_int) :: status
      end function sync_descriptor
      !> close(2), checked.
      function close_descriptor(fd) result(status) bind(c, name='tmafm_close')
         import :: c_int
         integer(c_int), value :: fd
         integer(c_int) :: status
      end function close_descriptor
      function c_rename(old_path, new_path) result(status) bind(c, name='tmafm_rename')
         import :: c_char, c_int
         character(kind=c_char), intent(in) :: old_path(*), new_path(*)
         integer(c_int) :: status
      end function c_rename
      function c_unlink(path) result(status) bind(c, name='tmafm_unlink')
         import :: c_char, c_int
         character(kind=c_char), intent(in) :: path(*)
         integer(c_int) :: status
      end function c_unlink
      function c_check_writable(path) result(status) bind(c, name='tmafm_check_writable')
         import :: c_char, c_int
         character(kind=c_char), intent(in) :: path(*)
         integer(c_int) :: status
      end function c_check_writable
      function c_same_file(a, b) result(same) bind(c, name='tmafm_same_file')
         import :: c_char, c_int
         character(kind=c_char), intent(in) :: a(*), b(*)
         integer(c_int) :: same
      end function c_same_file
      !> strerror_r into buf (pure: it reads and writes nothing else).
      pure subroutine c_error_text(code, buf, capacity) bind(c, name='tmafm_error_text')
         import :: c_char, c_int
         integer(c_int), value :: code
         character(kind=c_char), intent(out) :: buf(*)
         integer(c_int), value :: capacity
      end subroutine c_error_text
      !> Fill the CRC-32 tables (crc32_table_size entries).
      subroutine crc32_table(table) bind(c, name='tmafm_crc32_table')
         import :: c_int32_t
         integer(c_int32_t), intent(out) :: table(*)
      end subroutine crc32_table
      !> Continue the ZIP CRC-32 `crc` (0 to start) over n bytes of buf.
      function crc32_update(table, crc, buf, n) result(updated) bind(c, name='tmafm_crc32_update')
         import :: c_int32_t, c_int64_t
         integer(c_int32_t), intent(in) :: table(*)
         integer(c_int32_t), value :: crc
         type(*), intent(in) :: buf(*)
         integer(c_int64_t), value :: n
         integer(c_int32_t) :: updated
      end function crc32_update
      function c_crc32_text(table, crc, buf, n) result(updated) bind(c, name='tmafm_crc32_text')
         import :: c_char, c_int32_t, c_int64_t
         integer(c_int32_t), intent(in) :: table(*)
         integer(c_int32_t), value :: crc
         character(kind=c_char), intent(in) :: buf(*)
         integer(c_int64_t), value :: n
         integer(c_int32_t) :: updated
      end function c_crc32_text
   end interface

contains

   !> What `path` is (kind_*), without following a final symbolic link; `target` is the kind
   !> of what a symbolic link points to.  Negative: -errno.
   function path_kind(path, target) result(kind)
      character(len=*), intent(in) :: path
      integer, intent(out) :: target
      integer :: kind
      integer(c_int) :: c_target
      kind = c_path_kind(path//c_null_char, c_target)
      target = c_target
   end function path_kind

   !> Create a new empty file under a unique name in the folder of `final_path`, exclusively
   !> (never following a symbolic link); its name goes to `name`.  Returns the descriptor.
   function create_temporary(final_path, name) result(fd)
      character(len=*), intent(in) :: final_path
      character(len=:), allocatable, intent(out) :: name
      integer :: fd
      character(kind=c_char, len=len(final_path) + 64) :: buffer
      fd = c_create_temporary(final_path//c_null_char, buffer, len(buffer, kind=c_int))
      name = ''
      if (fd >= 0) name = buffer(1:index(buffer, c_null_char) - 1)
   end function create_temporary

   !> Open an existing character device or FIFO for writing (no truncation).
   function open_device(path) result(fd)
      character(len=*), intent(in) :: path
      integer :: fd
      fd = c_open_device(path//c_null_char)
   end function open_device

   !> Open a character device or FIFO for writing without waiting for a FIFO's reader:
   !> `no_reader` is .true. (and the result negative) when a FIFO has none yet.
   function open_device_now(path, no_reader) result(fd)
      character(len=*), intent(in) :: path
      logical, intent(out) :: no_reader
      integer :: fd
      integer(c_int) :: flag
      fd = c_open_device_now(path//c_null_char, flag)
      no_reader = flag /= 0
   end function open_device_now

   !> Open an input file for reading (read_some reads it).
   function open_input(path) result(fd)
      character(len=*), intent(in) :: path
      integer :: fd
      fd = c_open_input(path//c_null_char)
   end function open_input

   !> Open a FIFO (or pipe) for reading without waiting for a writer, and wait at most
   !> `wait_ms` milliseconds for input: `ready` tells whether any came.
   function open_fifo_reader(path, wait_ms, ready) result(fd)
      character(len=*), intent(in) :: path
      integer, intent(in) :: wait_ms
      logical, intent(out) :: ready
      integer :: fd
      integer(c_int) :: flag
      fd = c_open_fifo_reader(path//c_null_char, int(wait_ms, c_int), flag)
      ready = flag /= 0
   end function open_fifo_reader

   !> read(2) into `buffer`: the number of bytes read (0 at the end), or -errno.
   function read_some(fd, buffer) result(count)
      integer, intent(in) :: fd
      character(len=*), intent(inout) :: buffer
      integer :: count
      count = int(c_read_some(fd, buffer, int(len(buffer), c_int64_t)))
   end function read_some

   !> Write all of `text`.
   function write_text(fd, text) result(status)
      integer, intent(in) :: fd
      character(len=*), intent(in) :: text
      integer :: status
      status = c_write_text(fd, text, int(len(text), c_int64_t))
   end function write_text

   !> Continue a CRC-32 over the characters of `text`.
   function crc32_text(table, crc, text) result(updated)
      integer(c_int32_t), intent(in) :: table(:)
      integer(c_int32_t), intent(in) :: crc
      character(len=*), intent(in) :: text
      integer(c_int32_t) :: updated
      updated = c_crc32_text(table, crc, text, int(len(text), c_int64_t))
   end function crc32_text

   !> rename(2): atomic within one file system.
   function rename_path(old_path, new_path) result(status)
      character(len=*), intent(in) :: old_path, new_path
      integer :: status
      status = c_rename(old_path//c_null_char, new_path//c_null_char)
   end function rename_path

   !> unlink(2).
   function remove_path(path) result(status)
      character(len=*), intent(in) :: path
      integer :: status
      status = c_unlink(path//c_null_char)
   end function remove_path

   !> 0 if this user may write the existing file `path`.
   function check_writable(path) result(status)
      character(len=*), intent(in) :: path
      integer :: status
      status = c_check_writable(path//c_null_char)
   end function check_writable

   !> .true. if `a` and `b` name the same existing file (the same inode, links followed).
   function same_file(a, b) result(same)
      character(len=*), intent(in) :: a, b
      logical :: same
      same = c_same_file(a//c_null_char, b//c_null_char) == 1
   end function same_file

   !> The words for a failure status -errno (strerror).
   !> (Its length is computed from the argument: a deferred-length result is not thread-safe
   !> with gfortran 12, see tmafm_text.)
   pure function error_text(status) result(text)
      integer, intent(in) :: status
      character(len=index(error_buffer(status), c_null_char) - 1) :: text
      character(kind=c_char, len=200) :: buffer
      buffer = error_buffer(status)
      text = buffer(1:len(text))
   end function error_text

   !> The words for -errno `status`, NUL-terminated in a 200-character buffer.
   pure function error_buffer(status) result(buffer)
      integer, intent(in) :: status
      character(kind=c_char, len=200) :: buffer
      buffer = c_null_char
      call c_error_text(int(abs(status), c_int), buffer, len(buffer, kind=c_int) - 1)
   end function error_buffer

end module tmafm_posix

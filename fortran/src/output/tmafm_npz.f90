!> The .npz archive numpy reads with numpy.load: a ZIP file of .npy members, stored without
!> compression, each with its CRC-32.  Written front to back on a descriptor (no seeking,
!> so a pipe works): every member's CRC is computed before its local header is written.
!>
!> No zip64: an archive is at most max_npz_bytes (4 GiB - 2); npz_bytes tells the size in
!> advance so a caller can refuse before writing anything.
module tmafm_npz
   use, intrinsic :: iso_c_binding, only: c_int32_t, c_int64_t
   use tmafm_kinds, only: i8
   use tmafm_posix, only: write_bytes, write_text, crc32_table_size, crc32_table, crc32_update, &
                          crc32_text
   implicit none
   private

   public :: npz_archive_t, npy_header, npz_begin, npz_add, npz_add_text, npz_finish, npz_bytes, &
             max_npz_bytes, native_descr

   !> Largest archive without zip64 (0xFFFFFFFF marks a zip64 field).
   integer(i8), parameter :: max_npz_bytes = 4294967294_i8
   !> Most members an archive holds.
   integer, parameter :: max_members = 32
   integer, parameter :: local_header_bytes = 30, central_header_bytes = 46, end_record_bytes = 22
   !> 1980-01-01 00:00 in MS-DOS form: a fixed stamp, so equal runs give equal files.
   integer, parameter :: dos_date = 33, dos_time = 0

   !> An archive being written to a descriptor.
   type :: npz_archive_t
      !> The descriptor written to.
      integer :: fd = -1
      !> Bytes written so far.
      integer(i8) :: offset = 0
      !> Members written so far, and their names, offsets, sizes and CRCs.
      integer :: n_members = 0
      character(len=32) :: names(max_members) = ''
      integer(i8) :: offsets(max_members) = 0, sizes(max_members) = 0
      integer(c_int32_t) :: crcs(max_members) = 0
      !> CRC-32 tables.
      integer(c_int32_t) :: table(crc32_table_size) = 0
   end type npz_archive_t

contains

   !> The .npy type code of a native `kind_code` ('f8', 'i8', 'i1'): '<f8' on little-endian hosts.
   pure function native_descr(kind_code) result(descr)
      character(len=*), intent(in) :: kind_code
      character(len=len(kind_code) + 1) :: descr
      if (kind_code == 'i1') then
         descr = '|i1'
      else if (transfer(1_i8, 'a') == achar(1)) then
         descr = '<'//kind_code
      else
         descr = '>'//kind_code
      end if
   end function native_descr

   !> The .npy (version 1.0) preamble of an array: magic, header length and the header dict,
   !> padded with blanks to a multiple of 64 bytes.  shape: one entry per dimension (none for 0-d).
   !> (Its length is computed from the arguments: a deferred-length result is not thread-safe
   !> with gfortran 12, see tmafm_text.)
   pure function npy_header(descr, fortran_order, shape) result(header)
      character(len=*), intent(in) :: descr
      logical, intent(in) :: fortran_order
      integer(i8), intent(in) :: shape(:)
      character(len=npy_header_length(descr, fortran_order, shape)) :: header
      character(len=:), allocatable :: dict
      integer :: total

      call npy_dict(descr, fortran_order, shape, dict)
      total = len(header)
      header = char(147)//'NUMPY'//achar(1)//achar(0)//le(int(total - 10, i8), 2)//dict// &
               repeat(' ', total - 10 - len(dict) - 1)//achar(10)
   end function npy_header

   !> Length of npy_header(descr, fortran_order, shape): a multiple of 64.
   pure integer function npy_header_length(descr, fortran_order, shape) result(total)
      character(len=*), intent(in) :: descr
      logical, intent(in) :: fortran_order
      integer(i8), intent(in) :: shape(:)
      character(len=:), allocatable :: dict
      call npy_dict(descr, fortran_order, shape, dict)
      total = 10 + len(dict) + 1
      total = 64*((total + 63)/64)
   end function npy_header_length

   !> The header dict of an .npy array.
   pure subroutine npy_dict(descr, fortran_order, shape, dict)
      character(len=*), intent(in) :: descr
      logical, intent(in) :: fortran_order
      integer(i8), intent(in) :: shape(:)
      character(len=:), allocatable, intent(out) :: dict
      character(len=:), allocatable :: dims
      character(len=24) :: number
      integer :: j

      dims = ''
      do j = 1, size(shape)
         write (number, '(i0)') shape(j)
         if (j > 1) dims = dims//', '
         dims = dims//trim(number)
      end do
      if (size(shape) == 1) dims = dims//','
      dict = "{'descr': '"//descr//"', 'fortran_order': "//merge('True ', 'False', fortran_order)
      dict = trim(dict)//", 'shape': ("//dims//'), }'
   end subroutine npy_dict

   !> Size of an archive whose members have these names and byte counts (header + data).
   pure function npz_bytes(name_lengths, member_bytes) result(total)
      integer, intent(in) :: name_lengths(:)
      integer(i8), intent(in) :: member_bytes(:)
      integer(i8) :: total
      total = sum(member_bytes) + sum(int(name_lengths, i8))*2 + &
              size(name_lengths)*int(local_header_bytes + central_header_bytes, i8) + end_record_bytes
   end function npz_bytes

   !> Start an archive on descriptor fd.
   subroutine npz_begin(archive, fd)
      type(npz_archive_t), intent(out) :: archive
      integer, intent(in) :: fd
      archive%fd = fd
      call crc32_table(archive%table)
   end subroutine npz_begin

   !> Add member `name` (e.g. 'tau.npy'): the .npy `header`, then nbytes of `data`.
   !> status: 0, or -errno of the failed write.
   subroutine npz_add(archive, name, header, data, nbytes, status)
      type(npz_archive_t), intent(inout) :: archive
      character(len=*), intent(in) :: name, header
      type(*), intent(in) :: data(*)
      integer(i8), intent(in) :: nbytes
      integer, intent(out) :: status
      integer(c_int32_t) :: crc
      crc = crc32_text(archive%table, 0_c_int32_t, header)
      crc = crc32_update(archive%table, crc, data, int(nbytes, c_int64_t))
      call put_local_header(archive, name, crc, len(header) + nbytes, status)
      if (status == 0) status = write_text(archive%fd, header)
      if (status == 0 .and. nbytes > 0) status = write_bytes(archive%fd, data, int(nbytes, c_int64_t))
      archive%offset = archive%offset + len(header) + nbytes
   end subroutine npz_add

   !> Add member `name` whose data are the characters of `text` (a 0-d |S array).
   subroutine npz_add_text(archive, name, header, text, status)
      type(npz_archive_t), intent(inout) :: archive
      character(len=*), intent(in) :: name, header, text
      integer, intent(out) :: status
      integer(c_int32_t) :: crc
      crc = crc32_text(archive%table, 0_c_int32_t, header)
      crc = crc32_text(archive%table, crc, text)
      call put_local_header(archive, name, crc, int(len(header) + len(text), i8), status)
      if (status == 0) status = write_text(archive%fd, header//text)
      archive%offset = archive%offset + len(header) + len(text)
   end subroutine npz_add_text

   !> Write the central directory and the end record.
   subroutine npz_finish(archive, status)
      type(npz_archive_t), intent(inout) :: archive
      integer, intent(out) :: status
      character(len=:), allocatable :: directory
      integer :: m
      directory = ''
      do m = 1, archive%n_members
         directory = directory//'PK'//achar(1)//achar(2)//le(20_i8, 2)//le(20_i8, 2)//le(0_i8, 2)// &
                     le(0_i8, 2)//le(int(dos_time, i8), 2)//le(int(dos_date, i8), 2)// &
                     le(unsigned(archive%crcs(m)), 4)//le(archive%sizes(m), 4)//le(archive%sizes(m), 4)// &
                     le(int(len_trim(archive%names(m)), i8), 2)//le(0_i8, 2)//le(0_i8, 2)//le(0_i8, 2)// &
                     le(0_i8, 2)//le(0_i8, 4)//le(archive%offsets(m), 4)//trim(archive%names(m))
      end do
      directory = directory//'PK'//achar(5)//achar(6)//le(0_i8, 2)//le(0_i8, 2)// &
                  le(int(archive%n_members, i8), 2)//le(int(archive%n_members, i8), 2)// &
                  le(int(len(directory), i8), 4)//le(archive%offset, 4)//le(0_i8, 2)
      status = write_text(archive%fd, directory)
      archive%offset = archive%offset + len(directory)
   end subroutine npz_finish

   subroutine put_local_header(archive, name, crc, nbytes, status)
      type(npz_archive_t), intent(inout) :: archive
      character(len=*), intent(in) :: name
      integer(c_int32_t), intent(in) :: crc
      integer(i8), intent(in) :: nbytes
      integer, intent(out) :: status
      integer :: m
      m = archive%n_members + 1
      archive%n_members = m
      archive%names(m) = name
      archive%offsets(m) = archive%offset
      archive%sizes(m) = nbytes
      archive%crcs(m) = crc
      status = write_text(archive%fd, 'PK'//achar(3)//achar(4)//le(20_i8, 2)//le(0_i8, 2)//le(0_i8, 2)// &
                          le(int(dos_time, i8), 2)//le(int(dos_date, i8), 2)//le(unsigned(crc), 4)// &
                          le(nbytes, 4)//le(nbytes, 4)//le(int(len(name), i8), 2)//le(0_i8, 2)//name)
      archive%offset = archive%offset + local_header_bytes + len(name)
   end subroutine put_local_header

   !> The CRC as the unsigned number it stands for.
   pure function unsigned(crc) result(value)
      integer(c_int32_t), intent(in) :: crc
      integer(i8) :: value
      value = iand(int(crc, i8), 4294967295_i8)
   end function unsigned

   !> The low `bytes` bytes of value, least significant first (ZIP and .npy are little-endian).
   pure function le(value, bytes) result(text)
      integer(i8), intent(in) :: value
      integer, intent(in) :: bytes
      character(len=bytes) :: text
      integer :: j
      do j = 1, bytes
         text(j:j) = char(int(ibits(value, 8*(j - 1), 8)))
      end do
   end function le

end module tmafm_npz

!> Small text helpers shared by the reader, the writer and the error messages: numbers as
!> text that reads back exactly (always with an E exponent, 3-digit exponents included),
!> integers as text, and ASCII lower case.
module tmafm_text
   use tmafm_kinds, only: dp, i8
   implicit none
   private

   public :: real_text, real_text_padded, int_text, lower, upper, short_real_text, printable_text

   !> An integer (default or i8) as text without blanks.
   interface int_text
      module procedure int_text_default, int_text_i8
   end interface int_text

contains

   ! Every function below that returns text gives its result a length computed from its
   ! arguments (a specification function), not a deferred length: gfortran 12 keeps the length
   ! of a deferred-length function result in a `static` variable of the caller, which two
   ! threads calling the same line at once overwrite (docs/model-notes.md, finding 11).

   !> The shortest scientific text that reads back to exactly `value` (e.g. 1.0E-300, 2.5E+000).
   pure function real_text(value) result(text)
      real(dp), intent(in) :: value
      character(len=len_trim(real_text_padded(value))) :: text
      text = real_text_padded(value)
   end function real_text

   !> real_text(value) blank-padded to 40 characters (one formatting, where real_text does two).
   pure function real_text_padded(value) result(buffer)
      real(dp), intent(in) :: value
      character(len=40) :: buffer
      character(len=40) :: fmt
      real(dp) :: back
      integer :: digits, iostat

      do digits = 1, 17
         ! e3: room for three exponent digits, so the E is never dropped (1.0E-300, not 1.0-300).
         write (fmt, '(a,i0,a,i0,a)') '(es', digits + 10, '.', digits, 'e3)'
         write (buffer, fmt) value
         read (buffer, *, iostat=iostat) back
         if (iostat == 0 .and. back == value) exit
      end do
      buffer = adjustl(buffer)
   end function real_text_padded

   !> `value` with `digits` significant digits and an E exponent (e.g. 3.2E-001), for evidence.
   pure function short_real_text(value, digits) result(text)
      real(dp), intent(in) :: value
      integer, intent(in) :: digits
      character(len=len_trim(short_real(value, digits))) :: text
      text = short_real(value, digits)
   end function short_real_text

   !> short_real_text left-adjusted in a 40-character buffer.
   pure function short_real(value, digits) result(buffer)
      real(dp), intent(in) :: value
      integer, intent(in) :: digits
      character(len=40) :: buffer
      character(len=40) :: fmt
      write (fmt, '(a,i0,a,i0,a)') '(es', max(digits, 1) + 10, '.', max(digits - 1, 1), 'e3)'
      write (buffer, fmt) value
      buffer = adjustl(buffer)
   end function short_real

   pure function int_text_i8(value) result(text)
      integer(i8), intent(in) :: value
      character(len=len_trim(int_buffer(value))) :: text
      text = int_buffer(value)
   end function int_text_i8

   pure function int_text_default(value) result(text)
      integer, intent(in) :: value
      character(len=len_trim(int_buffer(int(value, i8)))) :: text
      text = int_buffer(int(value, i8))
   end function int_text_default

   !> `value` in i0 format, left-adjusted in a 24-character buffer.
   pure function int_buffer(value) result(buffer)
      integer(i8), intent(in) :: value
      character(len=24) :: buffer
      write (buffer, '(i0)') value
   end function int_buffer

   !> `text` with every byte outside printable ASCII written as \xNN, so that a message
   !> quoting the user's bytes stays one printable line.
   pure function printable_text(text) result(shown)
      character(len=*), intent(in) :: text
      character(len=len(text) + 3*count_unprintable(text)) :: shown
      character(len=*), parameter :: hex = '0123456789abcdef'
      integer :: i, code, k
      k = 0
      do i = 1, len(text)
         code = iachar(text(i:i))
         if (code >= 32 .and. code < 127) then
            shown(k + 1:k + 1) = text(i:i)
            k = k + 1
         else
            shown(k + 1:k + 4) = '\x'//hex(code/16 + 1:code/16 + 1)//hex(mod(code, 16) + 1:mod(code, 16) + 1)
            k = k + 4
         end if
      end do
   end function printable_text

   !> Number of bytes of `text` outside printable ASCII.
   pure integer function count_unprintable(text)
      character(len=*), intent(in) :: text
      integer :: i, code
      count_unprintable = 0
      do i = 1, len(text)
         code = iachar(text(i:i))
         if (code < 32 .or. code >= 127) count_unprintable = count_unprintable + 1
      end do
   end function count_unprintable

   !> `text` with ASCII upper-case letters turned to lower case.
   pure function lower(text) result(low)
      character(len=*), intent(in) :: text
      character(len=len(text)) :: low
      integer :: i, code
      low = text
      do i = 1, len(text)
         code = iachar(text(i:i))
         if (code >= iachar('A') .and. code <= iachar('Z')) low(i:i) = achar(code + 32)
      end do
   end function lower

   !> `text` with ASCII lower-case letters turned to upper case.
   pure function upper(text) result(up)
      character(len=*), intent(in) :: text
      character(len=len(text)) :: up
      integer :: i, code
      up = text
      do i = 1, len(text)
         code = iachar(text(i:i))
         if (code >= iachar('a') .and. code <= iachar('z')) up(i:i) = achar(code - 32)
      end do
   end function upper

end module tmafm_text

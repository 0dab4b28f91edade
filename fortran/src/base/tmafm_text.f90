!> Small text helpers shared by the reader, the writer and the error messages: numbers as
!> text that reads back exactly (always with an E exponent, 3-digit exponents included),
!> integers as text, and ASCII lower case.
module tmafm_text
   use tmafm_kinds, only: dp, i8
   implicit none
   private

   public :: real_text, int_text, lower, upper, short_real_text, printable_text

   !> An integer (default or i8) as text without blanks.
   interface int_text
      module procedure int_text_default, int_text_i8
   end interface int_text

contains

   !> The shortest scientific text that reads back to exactly `value` (e.g. 1.0E-300, 2.5E+000).
   function real_text(value) result(text)
      real(dp), intent(in) :: value
      character(len=:), allocatable :: text
      character(len=40) :: buffer, fmt
      real(dp) :: back
      integer :: digits, iostat

      do digits = 1, 17
         ! e3: room for three exponent digits, so the E is never dropped (1.0E-300, not 1.0-300).
         write (fmt, '(a,i0,a,i0,a)') '(es', digits + 10, '.', digits, 'e3)'
         write (buffer, fmt) value
         read (buffer, *, iostat=iostat) back
         if (iostat == 0 .and. back == value) exit
      end do
      text = trim(adjustl(buffer))
   end function real_text

   !> `value` with `digits` significant digits and an E exponent (e.g. 3.2E-001), for evidence.
   function short_real_text(value, digits) result(text)
      real(dp), intent(in) :: value
      integer, intent(in) :: digits
      character(len=:), allocatable :: text
      character(len=40) :: buffer, fmt
      write (fmt, '(a,i0,a,i0,a)') '(es', max(digits, 1) + 10, '.', max(digits - 1, 1), 'e3)'
      write (buffer, fmt) value
      text = trim(adjustl(buffer))
   end function short_real_text

   pure function int_text_i8(value) result(text)
      integer(i8), intent(in) :: value
      character(len=:), allocatable :: text
      character(len=24) :: buffer
      write (buffer, '(i0)') value
      text = trim(buffer)
   end function int_text_i8

   pure function int_text_default(value) result(text)
      integer, intent(in) :: value
      character(len=:), allocatable :: text
      text = int_text_i8(int(value, i8))
   end function int_text_default

   !> `text` with every byte outside printable ASCII written as \xNN, so that a message
   !> quoting the user's bytes stays one printable line.
   pure function printable_text(text) result(shown)
      character(len=*), intent(in) :: text
      character(len=:), allocatable :: shown
      character(len=*), parameter :: hex = '0123456789abcdef'
      integer :: i, code
      shown = ''
      do i = 1, len(text)
         code = iachar(text(i:i))
         if (code >= 32 .and. code < 127) then
            shown = shown//text(i:i)
         else
            shown = shown//'\x'//hex(code/16 + 1:code/16 + 1)//hex(mod(code, 16) + 1:mod(code, 16) + 1)
         end if
      end do
   end function printable_text

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

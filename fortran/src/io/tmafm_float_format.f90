!> Fast text for reals in the output's fixed layout: the characters gfortran writes for the
!> edit descriptor es25.16e3 (17 significant digits, so every double reads back exactly).
!>
!> Formatted write costs about 0.5 us per number; this costs a small fraction of that.  The
!> 17 digits are round(|v| 10^q) for the q that gives 17 of them, computed in double-double
!> arithmetic from a table of 10^q rounded to 113 bits at compile time: the error is below
!> 1e-12 of a unit in the last digit.  When the rounding is that close to a tie (or |v| is
!> outside [1e-270, 1e290], or not finite) the number goes through Fortran's own es25.16e3,
!> so the result is always gfortran's.
module tmafm_float_format
   use tmafm_kinds, only: dp, i8
   implicit none
   private

   public :: put_es25, es25_width

   !> Characters per number.
   integer, parameter :: es25_width = 25

   !> Quadruple precision, used only at compile time for the table of powers of ten.
   integer, parameter :: qp = selected_real_kind(33)
   !> Range of q in the table, and of |v| handled without Fortran's formatter.
   integer, parameter :: q_min = -280, q_max = 290
   real(dp), parameter :: fast_min = 1.0e-270_dp, fast_max = 1.0e290_dp
   !> Distance from a rounding tie, in units of the last digit, below which the fast path
   !> defers to Fortran's formatter (the double-double error is below 1e-13).
   real(dp), parameter :: tie_margin = 1.0e-9_dp

contains

   !> Write value at text(pos:pos+24) exactly as write(text(pos:pos+24), '(es25.16e3)') does.
   subroutine put_es25(text, pos, value)
      character(len=*), intent(inout) :: text
      integer, intent(in) :: pos
      real(dp), intent(in) :: value
      integer(i8), parameter :: ten8 = 10_i8**8, ten16 = 10_i8**16, ten17 = 10_i8**17
      real(dp) :: a
      integer(i8) :: digits
      integer :: e10, q, j, upper, lower
      logical :: exact
      character(len=es25_width) :: c

      a = abs(value)
      if (a == 0) then
         text(pos:pos + 24) = '  0.0000000000000000E+000'
         if (sign(1.0_dp, value) < 0) text(pos + 1:pos + 1) = '-'
         return
      end if
      if (.not. (a >= fast_min .and. a <= fast_max)) then
         write (text(pos:pos + 24), '(es25.16e3)') value
         return
      end if
      ! floor(log10(2^(e-1))) for a in [2^(e-1), 2^e): the decimal exponent, or one less
      ! (78913/2^18 is log10(2) closely enough for |e| < 1650; shifta rounds down).
      e10 = int(shifta((ibits(transfer(a, 0_i8), 52, 11) - 1023)*78913_i8, 18))
      q = 16 - e10
      call scaled_digits(a, q, digits, exact)
      if (digits >= ten17) then
         e10 = e10 + 1
         q = q - 1
         call scaled_digits(a, q, digits, exact)
      end if
      if (.not. exact) then
         write (text(pos:pos + 24), '(es25.16e3)') value
         return
      end if
      ! Layout: 2 blanks (or blank and sign), d, '.', 16 digits, 'E', sign, 3 digits.  One
      ! character at a time into a local buffer: single-byte stores, no memmove calls.
      c(1:1) = ' '
      c(2:2) = merge('-', ' ', value < 0)
      c(3:3) = achar(48 + int(digits/ten16))
      c(4:4) = '.'
      upper = int(mod(digits, ten16)/ten8)
      lower = int(mod(digits, ten8))
      do j = 19, 12, -1
         c(j + 1:j + 1) = achar(48 + mod(lower, 10))
         lower = lower/10
         c(j - 7:j - 7) = achar(48 + mod(upper, 10))
         upper = upper/10
      end do
      c(21:21) = 'E'
      c(22:22) = merge('-', '+', e10 < 0)
      j = abs(e10)
      c(23:23) = achar(48 + j/100)
      c(24:24) = achar(48 + mod(j/10, 10))
      c(25:25) = achar(48 + mod(j, 10))
      text(pos:pos + es25_width - 1) = c
   end subroutine put_es25

   !> digits = round(a 10^q) for a in [fast_min, fast_max]; exact = .false. when the rounding
   !> is too near a tie to be decided in double-double arithmetic.
   subroutine scaled_digits(a, q, digits, exact)
      real(dp), intent(in) :: a
      integer, intent(in) :: q
      integer(i8), intent(out) :: digits
      logical, intent(out) :: exact
      integer :: k
      ! 10^k in double-double: high part split into 26-bit halves, and the low part.
      real(dp), parameter :: pow_hi(q_min:q_max) = [(real(10.0_qp**k, dp), k = q_min, q_max)]
      real(dp), parameter :: pow_lo(q_min:q_max) = &
         [(real(10.0_qp**k - real(real(10.0_qp**k, dp), qp), dp), k = q_min, q_max)]
      real(dp), parameter :: pow_hh(q_min:q_max) = &
         scale(anint(scale(pow_hi, 26 - exponent(pow_hi))), exponent(pow_hi) - 26)
      real(dp), parameter :: pow_hl(q_min:q_max) = pow_hi - pow_hh
      ! Clearing the low 27 of the 52 stored bits leaves 26 significant bits.
      integer(i8), parameter :: high_bits = not(2_i8**27 - 1)
      real(dp) :: ah, al, p, e, s, whole, r, below, fraction

      ! Exact product a*pow_hi = p + e (Dekker): a = ah + al (26 and 27 bits), pow_hi =
      ! pow_hh + pow_hl (26 bits each), so every partial product is exact (at most 53 bits)
      ! whether or not the compiler fuses multiply-adds.
      ah = transfer(iand(transfer(a, 0_i8), high_bits), 1.0_dp)
      al = a - ah
      p = a*pow_hi(q)
      e = ((ah*pow_hh(q) - p) + ah*pow_hl(q) + al*pow_hh(q)) + al*pow_hl(q)
      e = e + a*pow_lo(q)
      s = p + e
      e = e - (s - p)
      p = s
      ! p + e is a 10^q to about 1e-30 relative; split it into integer and fraction.
      whole = aint(p)
      r = (p - whole) + e
      below = real(floor(r), dp)
      fraction = r - below
      digits = int(whole, i8) + int(below, i8)
      exact = abs(fraction - 0.5_dp) > tie_margin
      if (fraction > 0.5_dp) digits = digits + 1
   end subroutine scaled_digits

end module tmafm_float_format

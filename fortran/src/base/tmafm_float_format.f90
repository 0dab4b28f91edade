!> Fast text for reals in the output's fixed layout: the characters gfortran writes for the
!> edit descriptor es25.16e3 (17 significant digits, so every double reads back exactly).
!>
!> Formatted write costs about 0.5 us per number; this costs a small fraction of that.  The
!> 17 digits are round(|v| 10^q) for the q that gives 17 of them, computed in double-double
!> arithmetic from a table of 10^q rounded to 113 bits at compile time: the error is below
!> 1e-12 of a unit in the last digit.  When the rounding is that close to a tie (or |v| is
!> outside [1e-270, 1e290], or not finite) the number goes through Fortran's own es25.16e3,
!> so the result is always gfortran's.
!>
!> shortest_text_padded gives the text tmafm_text's real_text_padded gives (the first of 2 .. 17
!> significant digits whose correctly rounded text reads back exactly) with the same digits
!> and a read-back test in double-double arithmetic, instead of up to 16 formatted writes and
!> reads; where a decision is too close to call it is real_text_padded itself.
module tmafm_float_format
   use tmafm_kinds, only: dp, i8
   use tmafm_text, only: real_text_padded
   implicit none
   private

   public :: put_es25, es25_width, shortest_text_padded

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
   !> Range of |v| that shortest_text_padded handles itself: 10^(e10 - d + 1) and 10^(d - 1 - e10)
   !> stay inside the table for every d in 2 .. 17.
   real(dp), parameter :: short_min = 1.0e-260_dp, short_max = 1.0e260_dp
   !> 10^k as 8-byte integers, k = 0 .. 18.
   integer(i8), parameter :: ten_power(0:18) = [10_i8**0, 10_i8**1, 10_i8**2, 10_i8**3, &
      10_i8**4, 10_i8**5, 10_i8**6, 10_i8**7, 10_i8**8, 10_i8**9, 10_i8**10, 10_i8**11, &
      10_i8**12, 10_i8**13, 10_i8**14, 10_i8**15, 10_i8**16, 10_i8**17, 10_i8**18]
   ! Clearing the low 27 of the 52 stored bits leaves 26 significant bits.
   integer(i8), parameter :: high_bits = not(2_i8**27 - 1)

contains

   !> Write value at text(pos:pos+24) exactly as write(text(pos:pos+24), '(es25.16e3)') does.
   subroutine put_es25(text, pos, value)
      character(len=*), intent(inout) :: text
      integer, intent(in) :: pos
      real(dp), intent(in) :: value
      integer(i8), parameter :: ten8 = 10_i8**8, ten16 = 10_i8**16
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
      call leading_digits(a, 17, e10, q, digits, exact)
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

   !> The d significant digits of a in [fast_min, fast_max]: digits = round(a 10^q), q = d - 1 - e10,
   !> e10 the decimal exponent of a; exact = .false. near a tie (scaled_digits).
   pure subroutine leading_digits(a, d, e10, q, digits, exact)
      real(dp), intent(in) :: a
      integer, intent(in) :: d
      integer, intent(out) :: e10
      integer, intent(out) :: q
      integer(i8), intent(out) :: digits
      logical, intent(out) :: exact
      ! floor(log10(2^(e-1))) for a in [2^(e-1), 2^e): the decimal exponent, or one less
      ! (78913/2^18 is log10(2) closely enough for |e| < 1650; shifta rounds down).
      e10 = int(shifta((ibits(transfer(a, 0_i8), 52, 11) - 1023)*78913_i8, 18))
      q = d - 1 - e10
      call scaled_digits(a, q, digits, exact)
      if (digits >= ten_power(d)) then
         e10 = e10 + 1
         q = q - 1
         call scaled_digits(a, q, digits, exact)
      end if
   end subroutine leading_digits

   !> digits = round(a 10^q) for a in [fast_min, fast_max]; exact = .false. when the rounding
   !> is too near a tie to be decided in double-double arithmetic.
   pure subroutine scaled_digits(a, q, digits, exact)
      real(dp), intent(in) :: a
      integer, intent(in) :: q
      integer(i8), intent(out) :: digits
      logical, intent(out) :: exact
      real(dp) :: ah, al, p, e, s, whole, r, below, fraction, pow_hi, pow_lo, pow_hh, pow_hl

      call power_of_ten(q, pow_hi, pow_lo, pow_hh, pow_hl)
      ! Exact product a*pow_hi = p + e (Dekker): a = ah + al (26 and 27 bits), pow_hi =
      ! pow_hh + pow_hl (26 bits each), so every partial product is exact (at most 53 bits)
      ! whether or not the compiler fuses multiply-adds.
      ah = transfer(iand(transfer(a, 0_i8), high_bits), 1.0_dp)
      al = a - ah
      p = a*pow_hi
      e = ((ah*pow_hh - p) + ah*pow_hl + al*pow_hh) + al*pow_hl
      e = e + a*pow_lo
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

   !> real_text_padded(value): the shortest of the es(d+10).(d-1)e3 texts (d = 2 .. 17 significant
   !> digits) that reads back to exactly value, left-adjusted in 40 characters.
   pure function shortest_text_padded(value) result(buffer)
      real(dp), intent(in) :: value
      character(len=40) :: buffer
      real(dp) :: a, half_up, half_down
      integer(i8) :: digits
      integer :: e10, q, d, j, n
      logical :: exact, back

      a = abs(value)
      if (a == 0) then
         buffer = merge('-0.0E+000', ' 0.0E+000', sign(1.0_dp, value) < 0)
         buffer = adjustl(buffer)
         return
      end if
      if (.not. (a >= short_min .and. a <= short_max)) then
         buffer = real_text_padded(value)
         return
      end if
      ! Half the gaps to the neighbouring doubles: a text reads back to a when its value is
      ! nearer to a than these (the gap below a power of two is half the gap above).
      half_up = spacing(a)/2
      half_down = merge(half_up/2, half_up, fraction(a) == 0.5_dp)
      do d = 2, 17
         call leading_digits(a, d, e10, q, digits, exact)
         if (.not. exact) then
            buffer = real_text_padded(value)
            return
         end if
         ! 17 significant digits always read back.
         if (d == 17) exit
         call reads_back(a, digits, -q, half_up, half_down, back, exact)
         if (.not. exact) then
            buffer = real_text_padded(value)
            return
         end if
         if (back) exit
      end do
      ! [-]d.ddd...E+xxx: d significant digits, then the exponent in three digits.
      buffer = ''
      n = 0
      if (value < 0) then
         buffer(1:1) = '-'
         n = 1
      end if
      do j = n + d + 1, n + 3, -1
         buffer(j:j) = achar(48 + int(mod(digits, 10_i8)))
         digits = digits/10
      end do
      buffer(n + 1:n + 1) = achar(48 + int(digits))
      buffer(n + 2:n + 2) = '.'
      n = n + d + 1
      buffer(n + 1:n + 1) = 'E'
      buffer(n + 2:n + 2) = merge('-', '+', e10 < 0)
      j = abs(e10)
      buffer(n + 3:n + 3) = achar(48 + j/100)
      buffer(n + 4:n + 4) = achar(48 + mod(j/10, 10))
      buffer(n + 5:n + 5) = achar(48 + mod(j, 10))
   end function shortest_text_padded

   !> back = .true. when digits*10^p, read as a double, is a: when it lies within half_up above
   !> a or half_down below it.  exact = .false. when the distance is too near that bound to be
   !> decided in double-double arithmetic.  digits < 10^16, p within the table.
   pure subroutine reads_back(a, digits, p, half_up, half_down, back, exact)
      real(dp), intent(in) :: a
      integer(i8), intent(in) :: digits
      integer, intent(in) :: p
      real(dp), intent(in) :: half_up, half_down
      logical, intent(out) :: back, exact
      real(dp) :: dh, dl, hh, hl, x, e, r, bound, pow_hi, pow_lo, pow_hh, pow_hl

      ! digits = dh + dl exactly (dh holds all of it below 2^53), dh = hh + hl (26 + 27 bits).
      dh = real(digits, dp)
      dl = real(digits - int(dh, i8), dp)
      hh = transfer(iand(transfer(dh, 0_i8), high_bits), 1.0_dp)
      hl = dh - hh
      ! x + e = digits 10^p to about 1e-30 relative (Dekker's exact product of dh and pow_hi).
      call power_of_ten(p, pow_hi, pow_lo, pow_hh, pow_hl)
      x = dh*pow_hi
      e = ((hh*pow_hh - x) + hh*pow_hl + hl*pow_hh) + hl*pow_hl
      e = e + dh*pow_lo + dl*pow_hi
      ! x is within 5 % of a, so x - a is exact (Sterbenz); r is the distance to about 1e-30 a.
      r = (x - a) + e
      bound = merge(half_up, half_down, r >= 0)
      exact = abs(abs(r) - bound) > tie_margin*bound
      back = abs(r) < bound
   end subroutine reads_back

   !> 10^k = hi + lo in double-double (lo rounds the rest), and hi = hh + hl in 26-bit halves.
   pure subroutine power_of_ten(k, hi, lo, hh, hl)
      integer, intent(in) :: k
      real(dp), intent(out) :: hi, lo, hh, hl
      integer :: j
      real(dp), parameter :: pow_hi(q_min:q_max) = [(real(10.0_qp**j, dp), j = q_min, q_max)]
      real(dp), parameter :: pow_lo(q_min:q_max) = &
         [(real(10.0_qp**j - real(real(10.0_qp**j, dp), qp), dp), j = q_min, q_max)]
      real(dp), parameter :: pow_hh(q_min:q_max) = &
         scale(anint(scale(pow_hi, 26 - exponent(pow_hi))), exponent(pow_hi) - 26)
      real(dp), parameter :: pow_hl(q_min:q_max) = pow_hi - pow_hh
      hi = pow_hi(k)
      lo = pow_lo(k)
      hh = pow_hh(k)
      hl = pow_hl(k)
   end subroutine power_of_ten

end module tmafm_float_format

!> The base drive as a sum of tones (docs/model.md §1, §3, §7 and "The multifrequency drive"):
!> the clamp moves by y0 = sum_k f_k sin(omega_k t + phi_k), in gap units
!>
!>   Y(tau) = sum_k alpha_k sin(Omega_k tau + phi_k),   k = 1 (alpha2, omega, drive_phase) and
!>                                                       k = 2 (alpha2_2, omega_2, drive_phase_2).
!>
!> The tones must be commensurate: Omega_2/Omega_1 = p/q in lowest terms with q <= max_denominator,
!> to a relative 1e-9.  Their common angular frequency is Omega_0 = Omega_1/q (the common period
!> 2 pi/Omega_0 is q periods of tone 1 and p of tone 2) and tone k is harmonic h_k of it
!> (h_1 = q, h_2 = p; Omega_2 is taken as exactly p Omega_0).  Every caller carries the phase of
!> Omega_0 as (sin Omega_0 tau, cos Omega_0 tau), as it always carried that of the one tone; the
!> tones' phases are their harmonics, formed by binary powering of cos + i sin (about log2 h_k
!> complex products, relative error a few h_k ulp, as sin(Omega_k tau) itself has).
!> A one-tone drive at phase 0 is `general = .false.`: model_t then keeps its own folded
!> one-tone forms (the same bits as before the drive had tones), and Omega_0 = Omega.
!> A tone of zero amplitude is no tone: with alpha2_2 = 0 the drive is the one tone, whatever
!> omega_2 says.
module tmafm_drive
   use tmafm_kinds, only: dp
   use tmafm_errors, only: ok, err_input
   use tmafm_text, only: real_text, int_text
   use tmafm_scene, only: scene_t
   implicit none
   private

   public :: drive_t, init_drive, max_tones, max_denominator, max_harmonic, ratio_tolerance

   !> Most tones of a drive.
   integer, parameter :: max_tones = 2
   !> Largest q of a frequency ratio p/q (so the common period is at most this many periods of
   !> tone 1).
   integer, parameter :: max_denominator = 64
   !> Largest harmonic of the common frequency a tone may be (p and q).
   integer, parameter :: max_harmonic = 4096
   !> Relative tolerance of omega_2/omega = p/q.
   real(dp), parameter :: ratio_tolerance = 1.0e-9_dp

   !> The tones of the drive and their common frequency.
   type :: drive_t
      !> Tones with a nonzero amplitude (tone 1 always counts).
      integer :: n_tones = 1
      !> .false. for one tone at phase 0 (model_t's one-tone fast forms); .true. otherwise.
      logical :: general = .false.
      !> Omega_0: the common angular frequency; the period of the drive is 2 pi/Omega_0.
      real(dp) :: fundamental = 0
      !> h_k: tone k's frequency is h_k Omega_0.
      integer :: harmonic(max_tones) = 1
      !> alpha_k (gap units), Omega_k = h_k Omega_0 (tone 1: omega itself) and phi_k (rad).
      real(dp) :: amplitude(max_tones) = 0, frequency(max_tones) = 0, phase(max_tones) = 0
      !> cos phi_k and sin phi_k.
      real(dp) :: phase_cos(max_tones) = 1, phase_sin(max_tones) = 0
      !> sum_k |alpha_k|: the largest |Y|.
      real(dp) :: size = 0
      !> sum_k |alpha_k| Omega_k^4: a bound on |Y''''|.
      real(dp) :: bound4 = 0
      !> The largest Omega_k.
      real(dp) :: top_frequency = 0
   contains
      !> sin and cos of Omega_k tau + phi_k for each tone, from sin and cos of Omega_0 tau.
      procedure :: tones => drive_tones
      !> Y, dY/dtau and d2Y/dtau2 from sin and cos of Omega_0 tau.
      procedure :: base => drive_base
   end type drive_t

contains

   !> The drive of a scene, or a one-line error naming the group (scene or physical) and key:
   !> a second tone needs omega > 0 and omega_2 > 0, commensurate with omega.
   subroutine init_drive(scene, drive, ierr, errmsg, group, shown, names)
      type(scene_t), intent(in) :: scene
      type(drive_t), intent(out) :: drive
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      !> 'physical' to name the &physical keys in the messages (default: &scene).
      character(len=*), intent(in), optional :: group
      !> The two frequencies as the input gave them (default: omega and omega_2), for the messages.
      real(dp), intent(in), optional :: shown(2)
      !> With group 'physical': the keys the input gave the frequencies by (drive_frequency or
      !> drive_angular_frequency, and _2), for the messages.
      character(len=*), intent(in), optional :: names(2)
      character(len=:), allocatable :: key1, key2
      real(dp) :: ratio, as_given(2)
      integer :: p, q, k

      ierr = ok
      errmsg = ''
      drive%n_tones = 1
      drive%fundamental = scene%omega
      drive%harmonic = 1
      drive%amplitude(1) = scene%alpha2
      drive%frequency(1) = scene%omega
      drive%phase(1) = scene%drive_phase
      if (scene%alpha2_2 /= 0) then
         as_given = [scene%omega, scene%omega_2]
         if (present(shown)) as_given = shown
         key1 = '&scene omega'
         key2 = '&scene omega_2'
         if (present(group)) then
            if (group == 'physical') then
               key1 = '&physical drive_angular_frequency'
               key2 = '&physical drive_angular_frequency_2'
               if (present(names)) then
                  key1 = '&physical '//trim(names(1))
                  key2 = '&physical '//trim(names(2))
               end if
            end if
         end if
         if (.not. (scene%omega_2 > 0)) then
            ierr = err_input
            errmsg = key2//' = '//real_text(as_given(2))//': a second tone (nonzero amplitude) '// &
                     'needs a frequency > 0'
            return
         end if
         if (.not. (scene%omega > 0)) then
            ierr = err_input
            errmsg = key1//' = '//real_text(as_given(1))//': a second tone needs the first one''s '// &
                     'frequency > 0'
            return
         end if
         ratio = scene%omega_2/scene%omega
         call commensurate(ratio, p, q)
         if (q == 0) then
            call nearest_ratio(ratio, p, q)
            ierr = err_input
            errmsg = key2//' = '//real_text(as_given(2))//': not commensurate with '// &
                     key1(index(key1, ' ') + 1:)//' = '//real_text(as_given(1))//' (ratio '// &
                     real_text(ratio)//'; tones need a ratio p/q, q <= '//int_text(max_denominator)// &
                     ', p <= '//int_text(max_harmonic)//', to 1e-9; nearest '//int_text(p)//'/'// &
                     int_text(q)//': '//key2(index(key2, ' ') + 1:)//' = '// &
                     real_text(as_given(2)*(real(p, dp)/(q*ratio)))//')'
            return
         end if
         drive%n_tones = 2
         drive%fundamental = scene%omega/q
         drive%harmonic(1:2) = [q, p]
         drive%amplitude(2) = scene%alpha2_2
         drive%frequency(2) = p*drive%fundamental
         drive%phase(2) = scene%drive_phase_2
      end if
      drive%general = drive%n_tones > 1 .or. drive%phase(1) /= 0
      do k = 1, drive%n_tones
         drive%phase_cos(k) = cos(drive%phase(k))
         drive%phase_sin(k) = sin(drive%phase(k))
      end do
      if (drive%general) then
         drive%size = sum(abs(drive%amplitude(1:drive%n_tones)))
         drive%bound4 = sum(abs(drive%amplitude(1:drive%n_tones))*drive%frequency(1:drive%n_tones)**4)
      else
         drive%size = abs(scene%alpha2)
         drive%bound4 = abs(scene%alpha2)*scene%omega**4
      end if
      drive%top_frequency = maxval(drive%frequency(1:drive%n_tones))
   end subroutine init_drive

   !> p/q = ratio in lowest terms with q <= max_denominator and p <= max_harmonic, to a relative
   !> ratio_tolerance (the smallest such q); q = 0 if there is none.
   pure subroutine commensurate(ratio, p, q)
      real(dp), intent(in) :: ratio
      integer, intent(out) :: p, q
      integer :: k
      real(dp) :: x
      p = 0
      q = 0
      do k = 1, max_denominator
         x = ratio*k
         if (x > max_harmonic + 0.5_dp) return
         if (nint(x) >= 1 .and. abs(x - nint(x)) <= ratio_tolerance*x) then
            p = nint(x)
            q = k
            return
         end if
      end do
   end subroutine commensurate

   !> The p/q (q <= max_denominator, 1 <= p <= max_harmonic) nearest to ratio.
   pure subroutine nearest_ratio(ratio, p, q)
      real(dp), intent(in) :: ratio
      integer, intent(out) :: p, q
      real(dp) :: best
      integer :: k, m
      best = huge(1.0_dp)
      p = 1
      q = 1
      do k = 1, max_denominator
         m = min(max(nint(min(ratio*k, real(max_harmonic, dp))), 1), max_harmonic)
         if (abs(ratio - real(m, dp)/k) < best) then
            best = abs(ratio - real(m, dp)/k)
            p = m
            q = k
         end if
      end do
   end subroutine nearest_ratio

   !> sin and cos of h theta from those of theta: (cos + i sin)^h by binary powering.
   pure subroutine multiple_angle(h, sin0, cos0, sin_h, cos_h)
      integer, intent(in) :: h
      real(dp), intent(in) :: sin0, cos0
      real(dp), intent(out) :: sin_h, cos_h
      real(dp) :: br, bi, t
      integer :: e
      br = cos0
      bi = sin0
      cos_h = 1
      sin_h = 0
      e = h
      if (e == 1) then
         cos_h = cos0
         sin_h = sin0
         return
      end if
      do while (e > 0)
         if (iand(e, 1) == 1) then
            t = cos_h*br - sin_h*bi
            sin_h = cos_h*bi + sin_h*br
            cos_h = t
         end if
         e = ishft(e, -1)
         if (e > 0) then
            t = br*br - bi*bi
            bi = 2*br*bi
            br = t
         end if
      end do
   end subroutine multiple_angle

   pure subroutine drive_tones(self, sin0, cos0, sin_tone, cos_tone)
      class(drive_t), intent(in) :: self
      real(dp), intent(in) :: sin0, cos0
      real(dp), intent(out) :: sin_tone(max_tones), cos_tone(max_tones)
      real(dp) :: s, c
      integer :: k
      sin_tone = 0
      cos_tone = 0
      do k = 1, self%n_tones
         call multiple_angle(self%harmonic(k), sin0, cos0, s, c)
         sin_tone(k) = s*self%phase_cos(k) + c*self%phase_sin(k)
         cos_tone(k) = c*self%phase_cos(k) - s*self%phase_sin(k)
      end do
   end subroutine drive_tones

   pure subroutine drive_base(self, sin0, cos0, y, ydot, yddot)
      class(drive_t), intent(in) :: self
      real(dp), intent(in) :: sin0, cos0
      real(dp), intent(out) :: y, ydot, yddot
      real(dp) :: sin_tone(max_tones), cos_tone(max_tones)
      integer :: k
      call self%tones(sin0, cos0, sin_tone, cos_tone)
      y = 0
      ydot = 0
      yddot = 0
      do k = 1, self%n_tones
         associate (a => self%amplitude(k), w => self%frequency(k))
            y = y + a*sin_tone(k)
            ydot = ydot + a*w*cos_tone(k)
            yddot = yddot - a*w*w*sin_tone(k)
         end associate
      end do
   end subroutine drive_base

end module tmafm_drive

!> A beam in a viscous liquid (docs/model.md, A liquid environment): the hydrodynamic function of a rectangular
!> beam (J. E. Sader, J. Appl. Phys. 84, 64 (1998)) and the added mass and damping it gives
!> each Galerkin mode at that mode's own frequency in the liquid.
!>
!> Gamma_circ(Re) = 1 + 4 K1(z)/(z K0(z)),  z = -i sqrt(i Re) = sqrt(Re) e^{-i pi/4}   (Sader Eq. 17)
!> Gamma_rect(Re) = Omega(Re) Gamma_circ(Re)                                           (Sader Eq. 20)
!> with Omega(Re) Sader's rational fit in log10(Re) (Eq. 21; 0.1 % over 1e-6 <= Re <= 1e4).
!> K0 and K1 of complex argument (Re z > 0): the power series (A&S 9.6.13, 9.6.11) for |z| <= 2,
!> Temme's continued fraction CF2 by Steed's algorithm (Numerical Recipes §6.7) beyond; both
!> agree with scipy.special.kv to ~1e-14 relative over the range (tests/test_liquid.py).
!>
!> Per mode j, with the structural modal mass M_jj = 1 + alpha1 m_j^2 and stiffness Lambda_j, the
!> frequency in the liquid solves omega_j^2 = Lambda_j/(M_jj + mu0 Gamma_r(R0 omega_j)) (Sader
!> Eq. 25, iterated to a fixed point); then added mass mu_j = mu0 Gamma_r and damping
!> gamma_j = mu0 omega_j Gamma_i, with mu0 = &scene medium_mass and R0 = &scene medium_reynolds.
module tmafm_hydrodynamics
   use tmafm_kinds, only: dp
   use tmafm_errors, only: ok, err_input, err_runtime
   use tmafm_text, only: real_text, int_text
   implicit none
   private

   public :: bessel_k01, gamma_circular, gamma_rectangular, sader_correction, modal_fluid_loads

   !> The Reynolds numbers over which Sader's fit of Omega(Re) holds (to 0.1 %).
   real(dp), parameter, public :: sader_re_min = 1.0e-6_dp, sader_re_max = 1.0e4_dp

   real(dp), parameter :: pi = acos(-1.0_dp)
   real(dp), parameter :: euler_gamma = 0.577215664901532860606512090082402431_dp
   !> |z| at and below which K0, K1 come from the power series; CF2 above.
   real(dp), parameter :: series_radius = 2.0_dp
   !> Iteration limits: series terms, continued-fraction terms, fixed-point steps.
   integer, parameter :: max_series_terms = 60, max_fraction_terms = 10000, max_fixed_point = 200

contains

   !> K0(z) and K1(z), the modified Bessel functions of the second kind, for Re z > 0;
   !> converged is .false. if the series or the fraction did not meet its tolerance.
   pure subroutine bessel_k01(z, k0, k1, converged)
      complex(dp), intent(in) :: z
      complex(dp), intent(out) :: k0
      complex(dp), intent(out) :: k1
      logical, intent(out) :: converged
      if (abs(z) <= series_radius) then
         call k01_series(z, k0, k1, converged)
      else
         call k01_fraction(z, k0, k1, converged)
      end if
   end subroutine bessel_k01

   !> The series: with t = z^2/4, H_k the harmonic numbers and L = log(z/2),
   !> K0 = -(L + gamma) I0 + sum_{k>=1} H_k t^k/(k!)^2,
   !> K1 = 1/z + L I1 - (z/4) sum_{k>=0} (2 H_k + 1/(k+1) - 2 gamma) t^k/(k! (k+1)!).
   pure subroutine k01_series(z, k0, k1, converged)
      complex(dp), intent(in) :: z
      complex(dp), intent(out) :: k0
      complex(dp), intent(out) :: k1
      logical, intent(out) :: converged
      complex(dp) :: t, log_half, term0, term1, i0, i1_sum, s0, s1
      real(dp) :: harmonic
      integer :: k

      t = z*z/4
      log_half = log(z/2)
      term0 = 1
      term1 = 1
      i0 = 1
      i1_sum = 1
      s0 = 0
      s1 = 1 - 2*euler_gamma
      harmonic = 0
      converged = .false.
      do k = 1, max_series_terms
         term0 = term0*t/real(k*k, dp)
         term1 = term1*t/real(k*(k + 1), dp)
         harmonic = harmonic + 1.0_dp/k
         i0 = i0 + term0
         s0 = s0 + harmonic*term0
         i1_sum = i1_sum + term1
         s1 = s1 + (2*harmonic + 1.0_dp/(k + 1) - 2*euler_gamma)*term1
         ! The terms fall faster than geometrically once k^2 > |t|: stop below round-off.
         if (abs(term0)*(harmonic + abs(log_half) + 1) <= epsilon(1.0_dp)*abs(i0) .and. &
             k*k > 4*abs(t)) then
            converged = .true.
            exit
         end if
      end do
      k0 = -(log_half + euler_gamma)*i0 + s0
      k1 = 1/z + log_half*(z/2)*i1_sum - (z/4)*s1
   end subroutine k01_series

   !> Temme's CF2 for nu = 0 by Steed's algorithm (Numerical Recipes §6.7, bessik), complex z:
   !> K0 = sqrt(pi/(2z)) e^{-z}/S, K1 = K0 (z + 1/2 - h)/z.
   pure subroutine k01_fraction(z, k0, k1, converged)
      complex(dp), intent(in) :: z
      complex(dp), intent(out) :: k0
      complex(dp), intent(out) :: k1
      logical, intent(out) :: converged
      complex(dp) :: b, d, h, delh, q1, q2, qnew, q, s, dels
      real(dp) :: a, a1, c
      integer :: i

      b = 2*(1 + z)
      d = 1/b
      h = d
      delh = d
      q1 = 0
      q2 = 1
      a1 = 0.25_dp
      q = a1
      c = a1
      a = -a1
      s = 1 + q*delh
      converged = .false.
      do i = 2, max_fraction_terms
         a = a - 2*(i - 1)
         c = -a*c/i
         qnew = (q1 - b*q2)/a
         q1 = q2
         q2 = qnew
         q = q + c*qnew
         b = b + 2
         d = 1/(b + a*d)
         delh = (b*d - 1)*delh
         h = h + delh
         dels = q*delh
         s = s + dels
         if (abs(dels) <= epsilon(1.0_dp)*abs(s) .and. abs(delh) <= epsilon(1.0_dp)*abs(h)) then
            converged = .true.
            exit
         end if
      end do
      h = a1*h
      k0 = sqrt(pi/(2*z))*exp(-z)/s
      k1 = k0*(z + 0.5_dp - h)/z
   end subroutine k01_fraction

   !> The hydrodynamic function of a circular cylinder of diameter b (Sader Eq. 17), Re > 0.
   pure complex(dp) function gamma_circular(re)
      real(dp), intent(in) :: re
      complex(dp) :: z, k0, k1
      logical :: converged
      z = sqrt(re/2)*cmplx(1, -1, dp)
      call bessel_k01(z, k0, k1, converged)
      gamma_circular = 1 + 4*k1/(z*k0)
   end function gamma_circular

   !> Sader's correction Omega(Re) = Gamma_rect/Gamma_circ for a thin rectangle of width b
   !> (Eq. 21, a rational fit in tau = log10(Re), to 0.1 % over sader_re_min..sader_re_max).
   pure complex(dp) function sader_correction(re)
      real(dp), intent(in) :: re
      real(dp), parameter :: real_num(0:6) = [0.91324_dp, -0.48274_dp, 0.46842_dp, -0.12886_dp, &
                                              0.044055_dp, -0.0035117_dp, 0.00069085_dp]
      real(dp), parameter :: real_den(0:6) = [1.0_dp, -0.56964_dp, 0.48690_dp, -0.13444_dp, &
                                              0.045155_dp, -0.0035862_dp, 0.00069085_dp]
      real(dp), parameter :: imag_num(0:5) = [-0.024134_dp, -0.029256_dp, 0.016294_dp, &
                                              -0.00010961_dp, 0.000064577_dp, -0.000044510_dp]
      real(dp), parameter :: imag_den(0:6) = [1.0_dp, -0.59702_dp, 0.55182_dp, -0.18357_dp, &
                                              0.079156_dp, -0.014369_dp, 0.0028361_dp]
      real(dp) :: tau
      tau = log10(re)
      sader_correction = cmplx(horner(real_num, tau)/horner(real_den, tau), &
                               horner(imag_num, tau)/horner(imag_den, tau), dp)
   end function sader_correction

   !> The hydrodynamic function of a thin rectangular beam of width b (Sader Eq. 20), Re > 0.
   pure complex(dp) function gamma_rectangular(re)
      real(dp), intent(in) :: re
      gamma_rectangular = sader_correction(re)*gamma_circular(re)
   end function gamma_rectangular

   !> sum_k c(k) x^k.
   pure real(dp) function horner(c, x)
      real(dp), intent(in) :: c(0:)
      real(dp), intent(in) :: x
      integer :: k
      horner = c(ubound(c, 1))
      do k = ubound(c, 1) - 1, 0, -1
         horner = horner*x + c(k)
      end do
   end function horner

   !> Each mode's added mass and damping in a liquid of mass number mu0 = medium_mass and
   !> Reynolds scale R0 = medium_reynolds (Re = R0 omega), at the mode's frequency in the liquid
   !> (the fixed point of omega^2 = Lambda_j/(M_jj + mu0 Gamma_r(R0 omega))); err_input when a
   !> mode's Reynolds number lies outside Sader's fit.
   pure subroutine modal_fluid_loads(stiffness, inertia, medium_mass, medium_reynolds, added_mass, &
                                     damping, frequency, reynolds, ierr, errmsg)
      !> Lambda_j, the modal stiffnesses.
      real(dp), intent(in) :: stiffness(:)
      !> M_jj, the structural modal masses (beam and tip).
      real(dp), intent(in) :: inertia(:)
      real(dp), intent(in) :: medium_mass
      real(dp), intent(in) :: medium_reynolds
      real(dp), intent(out) :: added_mass(:)
      real(dp), intent(out) :: damping(:)
      real(dp), intent(out) :: frequency(:)
      real(dp), intent(out) :: reynolds(:)
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      complex(dp) :: g
      real(dp) :: w, w_next
      integer :: j, step
      logical :: converged

      ierr = ok
      errmsg = ''
      added_mass = 0
      damping = 0
      frequency = 0
      reynolds = 0
      if (.not. (medium_mass > 0 .and. medium_reynolds > 0)) then
         ierr = err_input
         errmsg = '&scene medium_mass = '//real_text(medium_mass)//' and medium_reynolds = '// &
                  real_text(medium_reynolds)//': a liquid needs both > 0'
         return
      end if
      do j = 1, size(stiffness)
         ! The map w -> sqrt(Lambda/(M + mu0 Gamma_r(R0 w))) contracts by at least 1/2 (Gamma_r
         ! falls at most like 1/Re); the iterates stay inside Sader's range by clamping, and
         ! the fixed point is checked against it below.
         w = sqrt(stiffness(j)/inertia(j))
         converged = .false.
         do step = 1, max_fixed_point
            g = gamma_rectangular(min(max(medium_reynolds*w, sader_re_min), sader_re_max))
            w_next = sqrt(stiffness(j)/(inertia(j) + medium_mass*real(g, dp)))
            if (abs(w_next - w) <= 4*epsilon(1.0_dp)*w_next) then
               w = w_next
               converged = .true.
               exit
            end if
            w = w_next
         end do
         reynolds(j) = medium_reynolds*w
         if (.not. (reynolds(j) >= sader_re_min .and. reynolds(j) <= sader_re_max)) then
            ierr = err_input
            errmsg = '&scene medium_reynolds = '//real_text(medium_reynolds)//': mode '//int_text(j)// &
                     ' in the liquid has Re = '//real_text(reynolds(j))//', outside '// &
                     real_text(sader_re_min)//'..'//real_text(sader_re_max)// &
                     ' where Sader''s hydrodynamic function holds (use fewer modes; docs/model.md)'
            return
         end if
         if (.not. converged) then
            ierr = err_runtime
            errmsg = 'the frequency of mode '//int_text(j)//' in the liquid did not converge'
            return
         end if
         g = gamma_rectangular(reynolds(j))
         frequency(j) = w
         added_mass(j) = medium_mass*real(g, dp)
         damping(j) = medium_mass*w*aimag(g)
      end do
   end subroutine modal_fluid_loads

end module tmafm_hydrodynamics

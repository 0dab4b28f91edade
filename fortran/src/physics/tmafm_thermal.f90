!> Thermal noise (docs/model.md §21): the Langevin force xi on the Galerkin modes, with
!> <xi(tau) xi(tau')^T> = 2 theta C delta(tau - tau') (the fluctuation-dissipation theorem for the
!> modal damping C = diag(alpha3 + gamma_j), beam and liquid), theta = k_B T L^3/(E1 I d^2) the
!> thermal energy in the model's units.  The force is realised on a fixed grid of spacing Delta
!> (&solver noise_step) as a zero-order hold: on [k Delta, (k + 1) Delta) it is the constant
!> xi_k = sqrt(2 theta C/Delta) z_k, z_k standard normals from a counter-based generator keyed by
!> (seed, k, mode), so that the realisation depends on neither the steps nor the thread and the
!> module holds no state.
module tmafm_thermal
   use tmafm_kinds, only: dp, i8
   implicit none
   private

   public :: thermal_t, init_thermal, standard_normals, noise_points_per_period, automatic_noise_step

   !> The automatic noise_step is the fastest free mode's period over this many intervals.
   integer, parameter :: noise_points_per_period = 32

   real(dp), parameter :: two_pi = 2*acos(-1.0_dp)
   integer(i8), parameter :: mask32 = 4294967295_i8, mask16 = 65535_i8
   !> The multipliers of the 32-bit mixer (C. Wellons' lowbias32) and the offsets that keep the
   !> chain of mixes away from its fixed point 0 (the golden ratio's and sqrt(3)'s fractions).
   integer(i8), parameter :: mix_a = 2146121005_i8, mix_b = 2221713035_i8
   integer(i8), parameter :: offset_seed = 2654435769_i8, offset_count = 3144134277_i8

   !> The thermal bath of a run (off: no noise, the deterministic model).
   type :: thermal_t
      !> .true. when the Langevin force acts.
      logical :: on = .false.
      !> theta = k_B T L^3/(E1 I d^2): the thermal energy in units of E1 I d^2/L^3.
      real(dp) :: energy = 0
      !> Delta: the grid spacing of the zero-order hold, in tau.
      real(dp) :: step = 0
      !> The seed of the realisation (&solver noise_seed).
      integer(i8) :: seed = 0
      !> sqrt(2 theta C_jj/Delta): the standard deviation of mode j's force on one interval.
      real(dp), allocatable :: amplitude(:)
   end type thermal_t

contains

   !> The bath of thermal energy theta for the modal damping `damping` (C_jj), on a grid of
   !> spacing step, from seed.
   pure function init_thermal(energy, damping, step, seed) result(bath)
      real(dp), intent(in) :: energy
      real(dp), intent(in) :: damping(:)
      real(dp), intent(in) :: step
      integer(i8), intent(in) :: seed
      type(thermal_t) :: bath
      bath%on = .true.
      bath%energy = energy
      bath%step = step
      bath%seed = seed
      allocate (bath%amplitude(size(damping)))
      bath%amplitude = sqrt(2*energy*damping/step)
   end function init_thermal

   !> The automatic grid spacing: the period 2 pi/omega_N of the fastest free mode (omega_N the
   !> largest free frequency) over noise_points_per_period.
   pure real(dp) function automatic_noise_step(omega_max) result(step)
      real(dp), intent(in) :: omega_max
      step = two_pi/(omega_max*noise_points_per_period)
   end function automatic_noise_step

   !> (a b) mod 2^32 for a, b in [0, 2^32), with no overflow of 64-bit integers (b split in
   !> 16-bit halves).
   elemental integer(i8) function mul32(a, b) result(c)
      integer(i8), intent(in) :: a
      integer(i8), intent(in) :: b
      c = iand(a*iand(b, mask16) + iand(a*ishft(b, -16), mask16)*65536_i8, mask32)
   end function mul32

   !> The 32-bit mixer lowbias32: a bijection of [0, 2^32) with good avalanche.
   elemental integer(i8) function mix32(x0) result(x)
      integer(i8), intent(in) :: x0
      x = iand(x0, mask32)
      x = ieor(x, ishft(x, -16))
      x = mul32(x, mix_a)
      x = ieor(x, ishft(x, -15))
      x = mul32(x, mix_b)
      x = ieor(x, ishft(x, -16))
   end function mix32

   !> A uniform number in (0, 1) from the counter (seed, interval, c): 32 bits, (h + 1/2)/2^32.
   elemental real(dp) function uniform_of(seed, interval, c) result(u)
      integer(i8), intent(in) :: seed
      integer(i8), intent(in) :: interval
      integer(i8), intent(in) :: c
      integer(i8) :: x
      x = mix32(iand(seed + offset_seed, mask32))
      x = mix32(ieor(x, iand(interval, mask32)))
      x = mix32(ieor(x, iand(ishft(interval, -32), mask32)) + offset_count)
      x = mix32(ieor(x, iand(c, mask32)))
      u = (real(x, dp) + 0.5_dp)/4294967296.0_dp
   end function uniform_of

   !> n standard normal numbers z(1:n) of grid interval `interval` for `seed` (Box-Muller on pairs
   !> of counter-based uniforms): the same numbers for the same (seed, interval, n) on every
   !> method, step pattern and thread.
   pure subroutine standard_normals(seed, interval, z)
      integer(i8), intent(in) :: seed
      integer(i8), intent(in) :: interval
      real(dp), intent(out) :: z(:)
      real(dp) :: radius, angle
      integer :: j
      integer(i8) :: pair
      do j = 1, size(z), 2
         pair = (j - 1)/2
         radius = sqrt(-2*log(uniform_of(seed, interval, 2*pair)))
         angle = two_pi*uniform_of(seed, interval, 2*pair + 1)
         z(j) = radius*cos(angle)
         if (j < size(z)) z(j + 1) = radius*sin(angle)
      end do
   end subroutine standard_normals

end module tmafm_thermal

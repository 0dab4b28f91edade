!> What an FM-AFM measurement asks for (docs/instrument.md, "FM-AFM"): the amplitude the
!> amplitude controller holds, the bandwidths of the phase-locked loop and of the amplitude
!> controller, how many drive periods each Z point settles and averages, and where the free
!> cantilever's reference is taken.  tmafm_fm runs it; the executable's &fm group and Python's
!> tmafm.instrument.fm_approach keywords fill it.
module tmafm_fm_settings
   use tmafm_kinds, only: dp
   implicit none
   private

   public :: fm_settings_t

   !> The settings of an FM-AFM loop and approach (SI units).
   type :: fm_settings_t
      !> The amplitude setpoint A (m): the tip's lock-in amplitude the amplitude controller holds.
      real(dp) :: amplitude = 0
      !> The phase-locked loop's closed-loop bandwidth B_PLL (Hz): Δf follows a step of the
      !> resonance as 1 - exp(-2 pi B_PLL t).
      real(dp) :: pll_bandwidth = 1000.0_dp
      !> The amplitude controller's closed-loop bandwidth B_A (Hz).
      real(dp) :: amplitude_bandwidth = 500.0_dp
      !> Drive periods each Z point runs before its average, and the periods averaged.
      integer :: settle_periods = 1000
      integer :: average_periods = 100
      !> The tip-sample distance (m) of the free cantilever's reference period (its drive work).
      real(dp) :: free_distance = 1.0e-6_dp
   end type fm_settings_t

end module tmafm_fm_settings

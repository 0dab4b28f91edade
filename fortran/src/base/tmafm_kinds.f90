!> Real and integer kinds used throughout tmafm.
module tmafm_kinds
   use, intrinsic :: iso_fortran_env, only: real64, int64
   implicit none
   private

   public :: dp, i8

   !> Double precision real kind used for every floating-point quantity.
   integer, parameter :: dp = real64
   !> Wide integer kind for step and evaluation counters.
   integer, parameter :: i8 = int64

end module tmafm_kinds

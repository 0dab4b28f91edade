!> Timing driver for benchmarks/rhs_cost.py: CPU ns per call of model%derivative (which takes
!> one sin/cos of Omega tau per call) and of model%derivative_at_phase (the phase given, as the
!> pairs' stages call it), out of and in contact, for one namelist and N.  Uses only the
!> library's public interface, so the same file builds against older versions of the core
!> (derivative_at_phase exists since e9a82f9).
!>    rhs_cost_driver INPUT.nml N REPEATS [KIND]
!> prints: N ns_free ns_contact ns_free_at_phase ns_contact_at_phase checksum
!> KIND (1 free, 2 contact, 3 free_at_phase, 4 contact_at_phase) runs that loop alone, for
!> instruction counts (benchmarks/rhs_instructions.py); the other columns are then 0.
program rhs_cost_driver
   use tmafm, only: dp, model_t, load_model, ok
   implicit none
   type(model_t) :: model
   character(len=4096) :: path, arg
   character(len=512) :: errmsg
   integer :: n, repeats, ierr, k, phase, only
   real(dp), allocatable :: y(:), dydt(:)
   real(dp) :: t0, t1, ns(4), checksum, tau0, vt, sin_phase, cos_phase
   logical :: in_contact

   call get_command_argument(1, path)
   call get_command_argument(2, arg)
   read (arg, *) n
   call get_command_argument(3, arg)
   read (arg, *) repeats
   only = 0
   if (command_argument_count() >= 4) then
      call get_command_argument(4, arg)
      read (arg, *) only
   end if
   call load_model(trim(path), n, model, ierr, errmsg)
   if (ierr /= ok) then
      write (*, '(a)') 'error: '//trim(errmsg)
      call exit(1)
   end if
   allocate (y(2*n), dydt(2*n))
   checksum = 0
   ns = 0
   tau0 = 0.3_dp
   do phase = 1, 2
      in_contact = phase == 2
      do k = 1, n
         y(k) = 2.0e-4_dp*(-1)**k/k**2
         y(n + k) = 1.0e-3_dp*(-1)**(k + 1)/k
      end do
      ! In contact: shift mode 1 so that V_T = -1e-4 at tau0.
      if (in_contact) then
         vt = model%tip_gap(tau0, y)
         y(1) = y(1) - (vt + 1.0e-4_dp)/model%tip(1)
      end if
      if (only == 0 .or. only == phase) then
         call cpu_time(t0)
         do k = 1, repeats
            call model%derivative(tau0 + 1.0e-9_dp*k, y, in_contact, dydt)
            checksum = checksum + dydt(2*n)
         end do
         call cpu_time(t1)
         ns(phase) = (t1 - t0)/repeats*1.0e9_dp
      end if
      call model%phase(tau0, sin_phase, cos_phase)
      if (only == 0 .or. only == 2 + phase) then
         call cpu_time(t0)
         do k = 1, repeats
            ! The phase moves a little per call, as from stage to stage.
            call model%derivative_at_phase(y, in_contact, sin_phase, cos_phase + 1.0e-12_dp*k, dydt)
            checksum = checksum + dydt(2*n)
         end do
         call cpu_time(t1)
         ns(2 + phase) = (t1 - t0)/repeats*1.0e9_dp
      end if
   end do
   write (*, '(i0,4(1x,f0.2),1x,es24.16)') n, ns, checksum
end program rhs_cost_driver

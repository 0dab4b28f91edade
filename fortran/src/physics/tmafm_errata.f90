!> The printed errata of the paper and the two conventions, docs/model.md §8.
!>
!> Each erratum is one named switch.  `paper` keeps every printed form; `consistent`
!> corrects all of them.  The model reads these switches in exactly one place each.
module tmafm_errata
   use tmafm_errors, only: ok, err_input
   use tmafm_text, only: upper
   implicit none
   private

   public :: errata_t, errata_for_convention, parse_errata, errata_label

   !> Which printed forms are corrected (.true.) or kept as printed (.false.).
   type :: errata_t
      !> E1: contact-damping base term -a2 a4 Omega p cos(Omega tau), not -a2 a4 p sin(Omega tau).
      logical :: e1_base_damping_velocity = .false.
      !> E2: the axial force acts on [0, xi0] only (matters only for xi0 < 1).
      logical :: e2_axial_span_to_tip = .false.
      !> E3: the moment of the axial force enters through phi'(xi0), not phi''(xi0).
      logical :: e3_moment_through_slope = .false.
      !> E4: the brackets carry alpha5/2 and alpha6/2.
      logical :: e4_half_force_scales = .false.
      !> E6: the tip mass sits at xi0, not at xi = 1.
      logical :: e6_tip_mass_at_xi0 = .false.
      !> E7: the contact angle uses the signed tip slope.
      logical :: e7_signed_slope = .false.
   end type errata_t

contains

   !> The corrections implied by a convention name ('paper' or 'consistent').
   pure function errata_for_convention(convention) result(errata)
      character(len=*), intent(in) :: convention
      type(errata_t) :: errata
      logical :: fix
      fix = trim(convention) == 'consistent'
      errata = errata_t(fix, fix, fix, fix, fix, fix)
   end function errata_for_convention

   !> Parse a list such as 'E1,E4', 'none' or 'all' into corrections; ierr /= 0 on a bad name.
   pure subroutine parse_errata(text, errata, ierr, bad_item)
      character(len=*), intent(in) :: text
      type(errata_t), intent(out) :: errata
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: bad_item
      integer :: first, last, length, k
      character(len=len(text)) :: item
      character(len=4) :: seen(16)
      integer :: n_seen

      ierr = ok
      bad_item = ''
      errata = errata_t()
      n_seen = 0
      length = len_trim(text)
      first = 1
      do while (first <= length)
         last = index(text(first:length), ',')
         if (last == 0) then
            last = length
         else
            last = first + last - 2
         end if
         item = adjustl(text(first:last))
         ! A name given twice is a typo more often than not: refuse it rather than fold it.
         if (len_trim(item) > 0) then
            do k = 1, n_seen
               if (seen(k) == upper(item(1:min(4, len(item))))) then
                  ierr = err_input
                  bad_item = trim(item)//' (repeated)'
                  return
               end if
            end do
            if (n_seen < size(seen)) then
               n_seen = n_seen + 1
               seen(n_seen) = upper(item(1:min(4, len(item))))
            end if
         end if
         select case (trim(upper(item)))
         case ('E1')
            errata%e1_base_damping_velocity = .true.
         case ('E2')
            errata%e2_axial_span_to_tip = .true.
         case ('E3')
            errata%e3_moment_through_slope = .true.
         case ('E4')
            errata%e4_half_force_scales = .true.
         case ('E6')
            errata%e6_tip_mass_at_xi0 = .true.
         case ('E7')
            errata%e7_signed_slope = .true.
         case ('ALL')
            errata = errata_for_convention('consistent')
         case ('NONE', '')
         case default
            ierr = err_input
            bad_item = trim(item)
            return
         end select
         first = last + 2
      end do
   end subroutine parse_errata

   !> The corrections as a list of names, 'none' if there are none.
   pure function errata_label(errata) result(label)
      type(errata_t), intent(in) :: errata
      ! A length from the flags, not a deferred length (not thread-safe with gfortran 12, see
      ! tmafm_text).
      character(len=merge(4, 3*count(flags(errata)) - 1, count(flags(errata)) == 0)) :: label
      character(len=*), parameter :: names(6) = ['E1', 'E2', 'E3', 'E4', 'E6', 'E7']
      logical :: set(6)
      integer :: k, n
      set = flags(errata)
      if (.not. any(set)) then
         label = 'none'
         return
      end if
      n = 0
      do k = 1, size(set)
         if (.not. set(k)) cycle
         if (n > 0) label(n + 1:n + 1) = ','
         if (n > 0) n = n + 1
         label(n + 1:n + 2) = names(k)
         n = n + 2
      end do
   end function errata_label

   !> The six flags of `errata` in label order (E1, E2, E3, E4, E6, E7).
   pure function flags(errata) result(set)
      type(errata_t), intent(in) :: errata
      logical :: set(6)
      set = [errata%e1_base_damping_velocity, errata%e2_axial_span_to_tip, errata%e3_moment_through_slope, &
             errata%e4_half_force_scales, errata%e6_tip_mass_at_xi0, errata%e7_signed_slope]
   end function flags

end module tmafm_errata

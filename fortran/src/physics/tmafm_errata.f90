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

   !> Parse &model errata into corrections: exactly 'all' or 'none', or a comma-separated list
   !> of distinct known names (E1, E2, E3, E4, E6, E7), case-insensitive, with no blank and no
   !> empty item ('convention' is the caller's business).  On anything else ierr = err_input
   !> and `bad_item` says which item is wrong and why.
   pure subroutine parse_errata(text, errata, ierr, bad_item)
      character(len=*), intent(in) :: text
      type(errata_t), intent(out) :: errata
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: bad_item
      character(len=*), parameter :: names(6) = ['E1', 'E2', 'E3', 'E4', 'E6', 'E7']
      logical :: seen(size(names))
      integer :: first, last, k

      ierr = err_input
      bad_item = ''
      errata = errata_t()
      if (scan(text, ' '//achar(9)) > 0) then
         bad_item = "'"//text//"' (a blank: write the names without blanks, e.g. 'E1,E4')"
         return
      end if
      select case (upper(text))
      case ('ALL')
         errata = errata_for_convention('consistent')
         ierr = ok
         return
      case ('NONE')
         ierr = ok
         return
      case ('')
         bad_item = "'' (empty: write 'none' for no correction)"
         return
      end select
      seen = .false.
      first = 1
      do
         last = index(text(first:), ',')
         if (last == 0) then
            last = len(text)
         else
            last = first + last - 2
         end if
         if (last < first) then
            bad_item = "'' (an empty item: two commas in a row, or a comma at an end)"
            return
         end if
         k = findloc(names, upper(text(first:last)), dim=1)
         if (k == 0) then
            if (upper(text(first:last)) == 'ALL' .or. upper(text(first:last)) == 'NONE') then
               bad_item = "'"//text(first:last)//"' (inside a list: give it alone)"
            else
               bad_item = "'"//text(first:last)//"' (not a known erratum)"
            end if
            return
         end if
         ! A name given twice is a typo more often than not: refuse it rather than fold it.
         if (seen(k)) then
            bad_item = "'"//text(first:last)//"' (repeated)"
            return
         end if
         seen(k) = .true.
         if (last >= len(text)) exit
         first = last + 2
      end do
      errata = errata_t(seen(1), seen(2), seen(3), seen(4), seen(5), seen(6))
      ierr = ok
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

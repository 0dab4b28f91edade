!> The table of the observables an observed run reports (what Python's tmafm.observe tables and
!> docs/observables.md come from): one row per observable, with its group (and the group's bit
!> of observer_t%groups), its model unit, its SI-derived unit and the scale that converts it.
!>
!> The columns, bits and extrema indices are tmafm_observers' own (obs_*, group_*, ext_*);
!> tests/test_tables.py checks the conversion against observable_factors.
module tmafm_observable_table
   use tmafm_kinds, only: dp
   use tmafm_units, only: scales_t
   use tmafm_observers, only: n_observables, group_lockin, group_extrema, group_peak_force, group_energy, &
      obs_amplitude, obs_phase, obs_mean_deflection, obs_min_gap, obs_peak_force, obs_min_force, obs_contact_time, &
      obs_contacts, obs_dissipated, obs_dissipated_beam, obs_dissipated_contact_damping, &
      obs_dissipated_friction, obs_drive_work, obs_virial, obs_contact_normal_work, &
      obs_dissipated_viscoelastic, obs_dissipated_adhesion, ext_max_contact, &
      ext_min_contact, ext_max_free, ext_min_free, obs_tone_amplitude, obs_tone_phase
   implicit none
   private

   public :: observable_row_t, observable_rows, n_observable_rows, observable_group_name, observable_si_factor
   public :: kind_column, kind_harmonic, kind_extremum, kind_modal, kind_points, observable_kind_names
   public :: scale_none, scale_one, scale_length, scale_time, scale_force, scale_energy, scale_force_length, &
      observable_scale_names

   !> Where a row's values are: a column of observer_t%values (index = obs_*), one per harmonic,
   !> one per period (max V_T), one per mode (index = ext_*), the Poincare points.
   integer, parameter :: kind_column = 1, kind_harmonic = 2, kind_extremum = 3, kind_modal = 4, kind_points = 5
   !> The names of the kinds.
   character(len=*), parameter :: observable_kind_names(5) = [character(len=9) :: 'column', 'harmonic', &
      'extremum', 'modal', 'points']

   !> The scale (tmafm_units scales_t) a row's model values are multiplied by to give its SI-derived
   !> unit: none (no SI-derived value), 1, the length (to nm), the time (to us), the force (to nN),
   !> the energy (to aJ), the force times a length (to aJ).
   integer, parameter :: scale_none = 0, scale_one = 1, scale_length = 2, scale_time = 3, scale_force = 4, &
      scale_energy = 5, scale_force_length = 6
   !> The names of the scales (scales_t components; 'one' for 1, '' for none).
   character(len=*), parameter :: observable_scale_names(0:6) = [character(len=12) :: '', 'one', 'length', &
      'time', 'force', 'energy', 'force_length']

   !> One observable.
   type :: observable_row_t
      !> Its name, as Python reports it.
      character(len=26) :: name = ''
      !> Its group's bit of observer_t%groups (group_*); 0: always computed.
      integer :: bit = 0
      !> Its model unit and its SI-derived unit ('' when it has none).
      character(len=12) :: unit = ''
      character(len=4) :: si_unit = ''
      !> Its scale (scale_*).
      integer :: scale = scale_none
      !> Where its values are (kind_*), and their column (obs_*) or modal index (ext_*); 0 else.
      integer :: kind = kind_column
      integer :: index = 0
   end type observable_row_t

   character(len=*), parameter :: energy_unit = 'E1 I d^2/L^3'

   !> Every observable: the columns in their order, the harmonics, the Poincare points, max V_T and
   !> the modal extrema in their order.
   type(observable_row_t), parameter :: observable_rows(*) = [ &
      observable_row_t('amplitude', group_lockin, 'd', 'nm', scale_length, kind_column, obs_amplitude), &
      observable_row_t('phase', group_lockin, 'deg', 'deg', scale_one, kind_column, obs_phase), &
      observable_row_t('mean_deflection', group_lockin, 'd', 'nm', scale_length, kind_column, &
                       obs_mean_deflection), &
      observable_row_t('min_gap', group_extrema, 'd', 'nm', scale_length, kind_column, obs_min_gap), &
      observable_row_t('peak_force', group_peak_force, 'E1 I/L^2', 'nN', scale_force, kind_column, &
                       obs_peak_force), &
      observable_row_t('min_force', group_peak_force, 'E1 I/L^2', 'nN', scale_force, kind_column, &
                       obs_min_force), &
      observable_row_t('contact_time', 0, 'tau', 'us', scale_time, kind_column, obs_contact_time), &
      observable_row_t('contacts_per_period', 0, '1', '1', scale_one, kind_column, obs_contacts), &
      observable_row_t('dissipated_energy', group_energy, energy_unit, 'aJ', scale_energy, kind_column, &
                       obs_dissipated), &
      observable_row_t('dissipated_beam', group_energy, energy_unit, 'aJ', scale_energy, kind_column, &
                       obs_dissipated_beam), &
      observable_row_t('dissipated_contact_damping', group_energy, energy_unit, 'aJ', scale_energy, kind_column, &
                       obs_dissipated_contact_damping), &
      observable_row_t('dissipated_friction', group_energy, energy_unit, 'aJ', scale_energy, kind_column, &
                       obs_dissipated_friction), &
      observable_row_t('drive_work', group_energy, energy_unit, 'aJ', scale_energy, kind_column, obs_drive_work), &
      observable_row_t('virial', group_energy, 'E1 I d/L^2', 'aJ', scale_force_length, kind_column, obs_virial), &
      observable_row_t('contact_normal_work', group_energy, energy_unit, 'aJ', scale_energy, kind_column, &
                       obs_contact_normal_work), &
      observable_row_t('dissipated_viscoelastic', group_energy, energy_unit, 'aJ', scale_energy, kind_column, &
                       obs_dissipated_viscoelastic), &
      observable_row_t('dissipated_adhesion', group_energy, energy_unit, 'aJ', scale_energy, kind_column, &
                       obs_dissipated_adhesion), &
      observable_row_t('tone1_amplitude', group_lockin, 'd', 'nm', scale_length, kind_column, &
                       obs_tone_amplitude(1)), &
      observable_row_t('tone1_phase', group_lockin, 'deg', 'deg', scale_one, kind_column, obs_tone_phase(1)), &
      observable_row_t('tone2_amplitude', group_lockin, 'd', 'nm', scale_length, kind_column, &
                       obs_tone_amplitude(2)), &
      observable_row_t('tone2_phase', group_lockin, 'deg', 'deg', scale_one, kind_column, obs_tone_phase(2)), &
      observable_row_t('harmonic_amplitude', group_lockin, 'd', 'nm', scale_length, kind_harmonic, 0), &
      observable_row_t('harmonic_phase', group_lockin, 'deg', 'deg', scale_one, kind_harmonic, 0), &
      observable_row_t('poincare', 0, '(d, d/tau)', '', scale_none, kind_points, 0), &
      observable_row_t('max_gap', group_extrema, 'd', 'nm', scale_length, kind_extremum, 0), &
      observable_row_t('modal_max_contact', group_extrema, 'd', 'nm', scale_length, kind_modal, ext_max_contact), &
      observable_row_t('modal_min_contact', group_extrema, 'd', 'nm', scale_length, kind_modal, ext_min_contact), &
      observable_row_t('modal_max_free', group_extrema, 'd', 'nm', scale_length, kind_modal, ext_max_free), &
      observable_row_t('modal_min_free', group_extrema, 'd', 'nm', scale_length, kind_modal, ext_min_free)]

   !> Number of rows of the table.
   integer, parameter :: n_observable_rows = size(observable_rows)

contains

   !> The name of a group bit: 'lockin', 'extrema', 'peak_force', 'energy'; 'always' for 0.
   pure function observable_group_name(bit) result(name)
      integer, intent(in) :: bit
      character(len=:), allocatable :: name
      select case (bit)
      case (group_lockin)
         name = 'lockin'
      case (group_extrema)
         name = 'extrema'
      case (group_peak_force)
         name = 'peak_force'
      case (group_energy)
         name = 'energy'
      case default
         name = 'always'
      end select
   end function observable_group_name

   !> The factor from a model value of `scale` (scale_*) to its SI-derived unit (nm, us, nN, aJ;
   !> 1 for scale_one; 0 for scale_none, which has no SI-derived value).
   pure function observable_si_factor(scales, scale) result(factor)
      type(scales_t), intent(in) :: scales
      integer, intent(in) :: scale
      real(dp) :: factor
      select case (scale)
      case (scale_one)
         factor = 1
      case (scale_length)
         factor = scales%length*1.0e9_dp
      case (scale_time)
         factor = scales%time*1.0e6_dp
      case (scale_force)
         factor = scales%force*1.0e9_dp
      case (scale_energy)
         factor = scales%energy*1.0e18_dp
      case (scale_force_length)
         factor = scales%force_length*1.0e18_dp
      case default
         factor = 0
      end select
   end function observable_si_factor

end module tmafm_observable_table

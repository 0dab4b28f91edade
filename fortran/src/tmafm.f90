!> Public API of the tmafm library: a facade that re-exports what users call.
!>
!> Read a namelist with read_config, run it with simulate, write it with
!> write_trajectory_file (or prepare_output before the run, then begin_output and
!> write_output); or build a model_t directly and call run_trajectory.
module tmafm
   use tmafm_kinds, only: dp, i8
   use tmafm_errors, only: ok, err_input, err_file, err_blowup, err_runtime, errmsg_len
   use tmafm_version, only: tmafm_version_string
   use tmafm_modes, only: max_modes, beam_roots, mode_shape
   use tmafm_scene, only: scene_t, physical_t, scene_from_physical
   use tmafm_errata, only: errata_t, errata_for_convention
   use tmafm_contact, only: law_hertz, law_dmt, contact_brackets_t, contact_brackets
   use tmafm_model, only: model_t, init_model, n_powers
   use tmafm_settings, only: run_settings_t, is_known_method, method_names, max_samples, &
      max_trajectory_bytes, check_run_size, sample_count, max_max_steps
   ! The key table (what Python's key types and README's input table come from), and the
   ! limits Python checks against.
   use tmafm_keys, only: n_keys, describe_key, max_mode_horizon
   use tmafm_batch, only: max_harmonics, max_p_max, max_observed_periods
   ! Observed runs and the steady-state rule (what tmafm_api's batches and tests call).
   use tmafm_batch, only: observe_options_t, observe_batch, observe_states, config_scales, steady_harmonics, &
      steady_evidence, steady_window
   use tmafm_observers, only: observer_t, n_observables, observable_factors, obs_amplitude, obs_phase, &
      obs_tone_amplitude, obs_tone_phase
   ! The observable table (what Python's observable tables and docs/observables.md come from).
   use tmafm_observable_table, only: observable_row_t, observable_rows, n_observable_rows, &
      observable_group_name, observable_si_factor, observable_kind_names, observable_scale_names
   use tmafm_units, only: scales_t
   use tmafm_calibration, only: physical_derived, derived_names, derived_units, derived_meanings, n_derived
   use tmafm_steady_state, only: steady_test, repeat_steps, steady_harmonic
   use tmafm_trajectory, only: trajectory_t
   use tmafm_physical_series, only: physical_series, n_series, series_names, series_units
   use tmafm_driver, only: run_trajectory
   ! Periodic orbits: the stroboscopic map and its monodromy matrix (tmafm_api, continuation).
   use tmafm_monodromy, only: stroboscopic_map, n_orbit_stats, map_state_size
   use tmafm_model_jacobian, only: model_jacobian, map_to_model_state
   ! A base input patched by overrides (tmafm_api), and the rename held apart (the executable).
   use tmafm_namelist, only: read_config_document
   use tmafm_nml_syntax, only: patch_document
   use tmafm_output, only: commit_output
   use tmafm_config, only: config_t, path_len
   use tmafm_namelist, only: read_config, read_config_text, write_config, config_text, config_errata, &
      material_b_physical, fm_z_points
   use tmafm_text, only: real_text, int_text, lower, printable_text
   use tmafm_posix, only: write_text, error_text
   use tmafm_nml_syntax, only: nml_document_t, parse_namelist, entry_text
   use tmafm_simulation, only: build_model, simulate, choose_mode_count, load_model
   use tmafm_period_stepper, only: period_stepper_t, init_period_stepper, with_distance
   use tmafm_controllers, only: lowpass_t, pi_controller_t
   use tmafm_scan_settings, only: scan_settings_t, check_scan_settings, scan_height
   use tmafm_am_scan, only: run_am_scan, scan_period_count, n_scan_columns, scan_column_names, &
      scan_column_units, scan_column_meanings, n_scan_info, scan_info_names, scan_info_units, &
      n_record_columns, record_column_names, record_column_units, mean_phase
   use tmafm_fm_settings, only: fm_settings_t
   use tmafm_fm, only: fm_loop_t, init_fm_loop, fm_point, check_fm_settings, n_fm_columns, n_fm_trace, &
      fm_column_names, fm_column_units
   use tmafm_output, only: write_trajectory_file, output_sink_t, prepare_output, check_output_size, &
      begin_output, write_output, discard_output, target_file, target_device, target_stdout, write_table
   implicit none
   private

   public :: dp, i8, ok, err_input, err_file, err_blowup, err_runtime, errmsg_len
   public :: tmafm_version_string, max_modes, beam_roots, mode_shape
   public :: scene_t, physical_t, scene_from_physical, errata_t, errata_for_convention
   public :: law_hertz, law_dmt, contact_brackets_t, contact_brackets
   public :: model_t, init_model, n_powers, run_settings_t, trajectory_t, run_trajectory
   public :: config_t, path_len, read_config, write_config, build_model, simulate, choose_mode_count
   public :: read_config_text, config_text, real_text, int_text, lower, printable_text
   public :: write_text, error_text
   public :: nml_document_t, parse_namelist, entry_text
   public :: is_known_method, method_names, max_samples, max_trajectory_bytes, check_run_size
   public :: load_model
   public :: stroboscopic_map, n_orbit_stats, map_state_size, model_jacobian, map_to_model_state
   public :: n_keys, describe_key, max_mode_horizon, max_max_steps, max_harmonics, max_p_max, &
             max_observed_periods
   public :: read_config_document, patch_document, commit_output
   public :: observe_options_t, observe_batch, observe_states, config_scales, steady_harmonics, &
             steady_evidence, steady_window, observer_t, n_observables, observable_factors, obs_amplitude, obs_phase, &
             scales_t, steady_test, repeat_steps, steady_harmonic, obs_tone_amplitude, obs_tone_phase
   public :: observable_row_t, observable_rows, n_observable_rows, observable_group_name, &
             observable_si_factor, observable_kind_names, observable_scale_names
   public :: write_trajectory_file, output_sink_t, prepare_output, check_output_size, begin_output, &
             write_output, discard_output, sample_count, target_file, target_device, target_stdout
   public :: physical_derived, derived_names, derived_units, derived_meanings, n_derived, config_errata
   public :: physical_series, n_series, series_names, series_units
   public :: period_stepper_t, init_period_stepper, with_distance, lowpass_t, pi_controller_t
   public :: scan_settings_t, check_scan_settings, scan_height, run_am_scan, scan_period_count, n_scan_columns, &
             scan_column_names, scan_column_units, scan_column_meanings, n_scan_info, scan_info_names, &
             scan_info_units, n_record_columns, record_column_names, record_column_units, mean_phase
   public :: fm_settings_t, fm_loop_t, init_fm_loop, fm_point, check_fm_settings, n_fm_columns, n_fm_trace
   ! The instrument in the executable (&scan, &fm): its inputs and its table.
   public :: fm_column_names, fm_column_units, material_b_physical, fm_z_points, write_table

end module tmafm

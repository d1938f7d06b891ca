"""The names of the metrics one run reports, so a ``[[spec]]`` row can be checked before
the run: a misspelled metric is refused up front (one line, exit 2) instead of
simulating and then failing the spec as "missing".

:data:`METRIC_NAMES` is every key :func:`~ballbot_casadi.analysis.metrics.run_metrics`
(and :func:`~ballbot_casadi.analysis.bandwidth.chirp_metrics`) can return; which of them
a given run has depends on its scenario (estimators, COM observer, sine, pushes, ...).
``tests/analysis/test_metric_names.py`` keeps this list equal to what the runs return.
"""

from __future__ import annotations

import difflib
from typing import Any, Mapping, Sequence

from ballbot_casadi.errors import ScenarioFileError

__all__ = ["METRIC_NAMES", "check_spec_metrics"]

METRIC_NAMES = frozenset("""
bandwidth_criterion bandwidth_hz cross_axis_error_max_deg cross_axis_onset_hz cross_axis_onset_s
estimator_q2_error_max estimator_q3_error_max estimator_vx_drift_mps estimator_vx_error_rms_mps
estimator_vy_error_rms_mps estimator_x_error_final_m max_yaw_rate_rps yaw_error_mean_deg max_acceleration_mps2
max_yaw_accel_rps2 bandwidth_reason chirp_axis com_estimate_error_max_mm
com_estimate_error_mm com_estimate_raw_error_mm com_estimate_settle_s com_hat_x_mm com_hat_y_mm
com_height_error_mm com_observable_x_mm com_observable_y_mm covariance_repairs duration_s
equilibrium_error_deg equilibrium_pitch_analytic_deg equilibrium_pitch_deg
equilibrium_roll_analytic_deg equilibrium_roll_deg estimator_heading_drift_deg
estimator_heading_max_deg estimator_pitch_rms_deg estimator_rate_rms_dps estimator_roll_rms_deg
estimator_tilt_max_deg estimator_tilt_rms_deg estimator_velocity_max_mps
estimator_velocity_rms_mps fell_at_hz fell_at_s final_position_drift_m final_position_error_m
final_rpy_deg final_speed_mps gate_rejections final_tilt_deg final_velocity_error_mps finite first_saturation_hz
first_saturation_motor first_saturation_s heading_error_max_deg hold_position_error_m
initial_tilt_deg initial_tilt_rate_deg_s max_abs_roll_pitch_deg max_abs_torque_nm max_error_deg
max_speed_mps max_tilt_deg missing_reading_fraction nis_attitude_mean nis_velocity_mean
peak_tilt_deg peak_tilt_rate_deg_s peak_torque_nm pitch_error_max_deg position_drift_m
push_max_tilt_deg quat_norm_dev_per_hour quat_norm_error_max quat_norm_max_dev recovery_time_s reference_peak_tilt_deg
reference_peak_tilt_rate_deg_s response roll_amplitude_ratio roll_error_max_deg roll_lag_s
saturation_fraction saturation_hz_per_motor saturation_s_per_motor settling_time_s
standing_tilt_error_deg standing_tilt_error_est_deg standing_tilt_error_rms_deg
standstill_start_s steady_state_error_deg tau_max_nm tilt_error_max_deg tilt_error_rms_deg
torque_saturated_fraction torque_total_variation torque_tv_ratio velocity_error_max_delayed_mps
velocity_error_max_mps velocity_error_rms_delayed_mps velocity_error_rms_mps velocity_lag_s
yaw_error_max_deg yaw_rate_error_max_rps
path_lateral_rms_m path_lateral_rms_settled_m path_lateral_max_m path_longitudinal_lag_max_m
path_min_clearance_m path_collision path_completed path_progress_fraction
""".split())


def check_spec_metrics(specs: Sequence[Mapping[str, Any]], where: str) -> None:
    """Refuse a ``[[spec]]`` row whose metric no run reports (with the closest names).

    Raises
    ------
    ScenarioFileError
        ``where: key 'spec[i].metric': unknown metric 'x'; did you mean ...``.
    """
    for i, s in enumerate(specs):
        name = s.get("metric")
        if name not in METRIC_NAMES:
            close = difflib.get_close_matches(str(name), sorted(METRIC_NAMES), n=3)
            hint = f"did you mean {', '.join(close)}?" if close else \
                "see the metric list in the scenario-file documentation"
            raise ScenarioFileError(f"{where}: key 'spec[{i}].metric': unknown metric {name!r}; {hint}",
                                    key=f"spec[{i}].metric")

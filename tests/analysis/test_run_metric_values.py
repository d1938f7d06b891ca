"""Velocity, overshoot, robustness and standing metrics against hand-computed values on
synthetic logs whose axes all differ (so swapped axes, a missing division by Ts, a sign
or the wrong run as the denominator give other numbers)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.analysis.metrics import (
    _smooth_fit,
    overshoot_deg,
    robustness_metrics,
    standing_metrics,
    velocity_metrics,
)
from ballbot_casadi.core.params import load_params

TS = 0.01


def _q(roll, pitch, yaw):
    """ZYX quaternion rows by hand (angles in rad, arrays)."""
    cr, sr = np.cos(roll / 2), np.sin(roll / 2)
    cp, sp = np.cos(pitch / 2), np.sin(pitch / 2)
    cy, sy = np.cos(yaw / 2), np.sin(yaw / 2)
    return np.column_stack([cy * cp * cr + sy * sp * sr, cy * cp * sr - sy * sp * cr,
                            cy * sp * cr + sy * cp * sr, sy * cp * cr - cy * sp * sr])


def _log(roll_deg, pitch_deg, yaw_deg, n=None):
    r, p, y = (np.radians(np.broadcast_to(np.asarray(a, float), (n or np.size(roll_deg),))) for a in
               (roll_deg, pitch_deg, yaw_deg))
    m = r.size
    state = np.zeros((m + 1, 12))
    state[:-1, 2:6] = _q(r, p, y)
    state[-1] = state[-2]
    return {"time": np.arange(m + 1) * TS, "state": state, "q_ref": np.tile([1.0, 0, 0, 0], (m, 1))}


def test_velocity_metrics_accelerations_rates_and_heading_by_hand():
    n = 100
    t = np.arange(n) * TS
    yaw = 0.3 * t + 0.1 * t**2          # yaw rate 0.3 + 0.2 t, yaw acceleration 0.2
    rate = 0.3 + 0.2 * t
    q = _q(np.zeros(n), np.zeros(n), yaw)
    state = np.zeros((n + 1, 12))
    state[:-1, 2:6] = q
    # dq = 1/2 (0, 0, 0, r) o q  (a rate about the vertical)
    state[:-1, 8:12] = 0.5 * rate[:, None] * np.column_stack([-q[:, 3], -q[:, 2], q[:, 1], q[:, 0]])
    state[:-1, 6] = 0.5 * t              # ball acceleration 0.5 m/s^2 along x
    state[:-1, 7] = -0.25 * t            # and -0.25 along y: |a| = 0.559
    v_ref = np.column_stack([0.5 * t, -0.25 * t, np.full(n, 0.3)])
    log = {"time": np.arange(n + 1) * TS, "state": state, "v_ref": v_ref,
           "q_ref": np.tile([1.0, 0, 0, 0], (n, 1))}
    m = velocity_metrics(log)
    assert m["max_acceleration_mps2"] == pytest.approx(math.hypot(0.5, 0.25), rel=1e-9)
    assert m["max_speed_mps"] == pytest.approx(math.hypot(0.5, 0.25) * t[-1], rel=1e-12)
    assert m["max_yaw_rate_rps"] == pytest.approx(rate[-1], rel=1e-9)
    assert m["max_yaw_accel_rps2"] == pytest.approx(0.2, rel=1e-6)
    assert m["yaw_rate_error_max_rps"] == pytest.approx(0.2 * t[-1], rel=1e-9)
    assert m["yaw_error_mean_deg"] == pytest.approx(float(np.mean(np.degrees(yaw))), rel=1e-9)
    assert m["velocity_error_max_mps"] == pytest.approx(0.0, abs=1e-15)
    assert m["max_tilt_deg"] == pytest.approx(0.0, abs=1e-9)


def test_overshoot_is_the_largest_swing_past_zero_on_axes_that_start_off_it():
    n = 50
    k = np.arange(n)
    roll = np.where(k < 20, 2.0 - 0.125 * k, -0.5 + 0.5 * (k - 20) / 30)   # +2 -> -0.5 -> 0: 0.5
    pitch = np.where(k < 10, 0.05, -1.0)          # starts inside 0.1 deg: not counted
    yaw = np.where(k < 25, -1.0 + 0.068 * k, 0.7)  # -1 -> +0.7 (past zero by 0.7)
    assert overshoot_deg(_log(roll, pitch, yaw)) == pytest.approx(0.7, rel=1e-9)
    assert overshoot_deg(_log(roll, pitch, np.zeros(n))) == pytest.approx(0.5, rel=1e-9)
    # never past zero: 0
    assert overshoot_deg(_log(np.linspace(2, 0.01, n), np.zeros(n), np.zeros(n))) == pytest.approx(0.0, abs=1e-12)


def test_robustness_deviations_are_relative_to_the_nominal_runs_own_excursion():
    n = 60
    s = np.exp(-np.arange(n) / 10.0)
    nominal = _log(2.0 * s, -1.0 * s, 0.1 * s)
    perturbed = _log(2.2 * s, -1.0 * s, 0.15 * s)
    m = robustness_metrics(nominal, perturbed)
    assert m["deviation_roll_deg"] == pytest.approx(0.2, rel=1e-9)
    assert m["deviation_pitch_deg"] == pytest.approx(0.0, abs=1e-9)
    assert m["deviation_yaw_deg"] == pytest.approx(0.05, rel=1e-9)
    assert m["relative_deviation_roll"] == pytest.approx(0.1, rel=1e-9)
    assert m["relative_deviation_yaw"] == pytest.approx(0.5, rel=1e-9)
    assert (m["most_affected_axis"], m["most_affected_axis_relative"]) == ("roll", "yaw")
    assert m["yaw_affected_most"] is False and m["yaw_affected_most_relative"] is True
    # settling: first sample after which the largest error stays inside 0.1 deg
    k_nom = int(np.nonzero(2.0 * s > 0.1)[0][-1]) + 1
    k_per = int(np.nonzero(2.2 * s > 0.1)[0][-1]) + 1
    assert m["nominal_settling_time_s"] == pytest.approx(k_nom * TS, abs=1e-12)
    assert m["settling_time_ratio"] == pytest.approx(k_per / k_nom, rel=1e-12)
    assert m["nominal_max_error_deg"] == pytest.approx(2.0, rel=1e-9)


def test_robustness_deviation_compares_the_runs_over_their_common_samples():
    """Runs of different lengths are compared sample by sample over the shorter one: a
    deviation late in the common part counts, one after the shorter run ends does not."""
    n = 60
    s = np.exp(-np.arange(n) / 10.0)
    nominal = _log(2.0 * s, -1.0 * s, 0.1 * s)
    # the nominal log holds n + 1 states (the last one repeated): 40 deg after them
    late = np.concatenate([2.0 * s, [2.0 * s[-1]], np.full(19, 40.0)])
    late[45] += 0.3                                        # and 0.3 deg well inside them
    perturbed = _log(late, np.concatenate([-1.0 * s, [-s[-1]], np.full(19, 9.0)]),
                     np.concatenate([0.1 * s, [0.1 * s[-1]], np.zeros(19)]))
    m = robustness_metrics(nominal, perturbed)
    assert m["deviation_roll_deg"] == pytest.approx(0.3, rel=1e-9)
    assert m["deviation_pitch_deg"] == pytest.approx(0.0, abs=1e-9)
    m = robustness_metrics(perturbed, nominal)  # either run may be the shorter
    assert m["deviation_roll_deg"] == pytest.approx(0.3, rel=1e-9)


def test_standing_metrics_mean_roll_and_pitch_over_the_last_window():
    p = load_params().replace(com_x=-0.02, com_y=-0.03)
    n = 400
    roll = np.where(np.arange(n) < 150, 0.0, -3.5)      # the last 2 s (t >= 2.0) hold -3.5 / 2.25
    pitch = np.where(np.arange(n) < 150, 1.0, 2.25)
    log = _log(roll, pitch, np.full(n, 30.0))
    log["state"][-1, 0:2] = [0.3, -0.4]
    m = standing_metrics(log, p, window_s=2.0)
    assert m["equilibrium_roll_deg"] == pytest.approx(-3.5, rel=1e-9)
    assert m["equilibrium_pitch_deg"] == pytest.approx(2.25, rel=1e-9)
    roll_a = math.degrees(math.atan2(-0.03, p.l))
    pitch_a = math.degrees(math.atan2(0.02, math.hypot(-0.03, p.l)))
    assert (m["equilibrium_roll_analytic_deg"], m["equilibrium_pitch_analytic_deg"]) == \
        pytest.approx((roll_a, pitch_a), rel=1e-12)
    assert m["equilibrium_error_deg"] == pytest.approx(max(abs(-3.5 - roll_a), abs(2.25 - pitch_a)), rel=1e-9)
    assert m["final_position_drift_m"] == pytest.approx(0.5, rel=1e-12)


def test_the_torque_fit_keeps_five_harmonics_and_drops_the_sixth():
    """The smooth reference of torque_tv_ratio is the least-squares fit by the mean and
    harmonics 1..5 of the sine: over whole periods it keeps those exactly and drops the
    sixth (chattering-like content) entirely."""
    f = 0.5
    t = np.arange(0.0, 4.0, 0.001)       # two whole periods
    kept = 0.3 + np.sin(2 * np.pi * f * t) + 0.2 * np.cos(2 * np.pi * 5 * f * t)
    u = np.column_stack([kept + 0.7 * np.sin(2 * np.pi * 6 * f * t), -kept])
    fit = _smooth_fit(t, u, f)
    np.testing.assert_allclose(fit[:, 0], kept, atol=1e-9)
    np.testing.assert_allclose(fit[:, 1], -kept, atol=1e-9)

"""Estimation metrics of a robot that moved (true and estimated paths differ in start
and end, every axis a different error) and the bandwidth crossing interpolation, against
hand-computed values."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.analysis.bandwidth import bandwidth_from_response
from ballbot_casadi.analysis.estimates import estimation_metrics


def _q(roll, pitch, yaw):
    cr, sr, cp, sp, cy, sy = (f(a / 2) for a in (roll, pitch, yaw) for f in (math.cos, math.sin))
    return np.array([cy * cp * cr + sy * sp * sr, cy * cp * sr - sy * sp * cr,
                     cy * sp * cr + sy * cp * sr, sy * cp * cr - cy * sp * sr])


def test_estimation_metrics_of_a_moving_robot_by_hand():
    n = 8
    x = np.zeros((n + 1, 12))
    x[:, 2:6] = _q(0.0, 0.0, 0.3)
    x[:, 0] = np.linspace(1.0, 2.0, n + 1)          # the robot moved from (1, -1) to (2, 0.5)
    x[:, 1] = np.linspace(-1.0, 0.5, n + 1)
    x[:, 6], x[:, 7] = 0.4, -0.2
    xh = x[:n].copy()
    xh[:, 2:6] = _q(math.radians(1.0), math.radians(-2.0), 0.3)
    xh[:, 6] += np.array([0.03, -0.01] * (n // 2))  # vx error alternating: mean 0.01, rms sqrt(5e-4)
    xh[:, 7] += 0.02
    xh[-1, 0:2] = x[n - 1, 0:2] + np.array([0.06, -0.08])   # 0.1 m off at the end
    log = {"x_hat": xh, "state": x, "nis": np.ones((n, 2)), "repairs": np.zeros(n),
           "time": np.arange(n + 1) * 0.005}
    m = estimation_metrics(log)
    assert m["position_drift_m"] == pytest.approx(0.1, rel=1e-12)
    assert m["estimator_x_error_final_m"] == pytest.approx(0.06, rel=1e-12)
    assert m["estimator_vx_drift_mps"] == pytest.approx(0.01, rel=1e-12)
    assert m["estimator_vx_error_rms_mps"] == pytest.approx(math.sqrt(5e-4), rel=1e-12)
    assert m["estimator_vy_error_rms_mps"] == pytest.approx(0.02, rel=1e-12)
    assert m["estimator_roll_rms_deg"] == pytest.approx(1.0, rel=1e-9)
    assert m["estimator_pitch_rms_deg"] == pytest.approx(2.0, rel=1e-9)
    assert m["estimator_heading_max_deg"] < 0.05


@pytest.mark.parametrize("g,p,want,reason", [
    # gain crosses -3 dB between 2 Hz (-1 dB) and 3 Hz (-5 dB): halfway, 2.5 Hz
    ([0.0, -1.0, -5.0, -9.0], [0.0, -10.0, -20.0, -30.0], 2.5, "gain"),
    # phase crosses -90 deg between 2 Hz (-60) and 3 Hz (-150): a third of the way
    ([0.0, 0.0, 0.0, -4.0], [-10.0, -60.0, -150.0, -200.0], 2.0 + 1 / 3, "phase"),
    # lost at the first point: that frequency
    ([-4.0, -5.0, -6.0, -7.0], [0.0, 0.0, 0.0, 0.0], 1.0, "gain"),
])
def test_bandwidth_interpolates_the_criterion_that_fired(g, p, want, reason):
    bw, why = bandwidth_from_response(np.array([1.0, 2.0, 3.0, 4.0]), np.array(g), np.array(p))
    assert why == reason
    assert bw == pytest.approx(want, rel=1e-12)


@pytest.mark.parametrize("f,g,p,want", [
    ([], [], [], (None, None)),                    # no sweep: nothing to say
    ([1.5], [-4.0], [0.0], (1.5, "gain")),         # one point, lost by gain: its frequency
    ([1.5], [0.0], [-100.0], (1.5, "phase")),      # one point, lost by phase
    ([1.5], [-1.0], [-10.0], (None, None)),        # one point, tracked
])
def test_bandwidth_of_an_empty_or_one_point_sweep(f, g, p, want):
    assert bandwidth_from_response(np.array(f), np.array(g), np.array(p)) == want

"""analysis/estimates.py: tilt/heading split, tracking and estimation metrics, checked
against rotations whose angles are known by construction."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.analysis.estimates import estimation_metrics, tilt_heading_error_deg, tracking_metrics
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import STATE, STATE_DXY, STATE_XY


def _q(roll_deg=0.0, pitch_deg=0.0, yaw_deg=0.0) -> np.ndarray:
    return np.asarray(Q.from_rpy(*np.radians([roll_deg, pitch_deg, yaw_deg])), float).reshape(4)


def test_tilt_and_heading_of_known_rotations():
    ref = np.tile(_q(), (4, 1))
    q = np.array([_q(yaw_deg=30.0), _q(roll_deg=10.0), _q(pitch_deg=-7.0), -_q(yaw_deg=-170.0)])
    tilt, heading = tilt_heading_error_deg(ref, q)
    np.testing.assert_allclose(tilt, [0.0, 10.0, 7.0, 0.0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(heading, [30.0, 0.0, 0.0, -170.0], rtol=0, atol=1e-12)  # sign of q ignored
    # relative to a turned reference, the same body tilt reads the same
    tilt2, heading2 = tilt_heading_error_deg(_q(yaw_deg=40.0), _q(yaw_deg=40.0) * 1.001)  # norm error
    np.testing.assert_allclose([tilt2[0], heading2[0]], [0.0, 0.0], rtol=0, atol=1e-12)


def test_tiny_tilt_keeps_full_precision():
    # 1e-9 rad: an arccos of the quaternion's scalar part would read exactly 0
    tilt, _ = tilt_heading_error_deg(_q(), _q(roll_deg=math.degrees(1e-9)))
    assert tilt[0] == pytest.approx(math.degrees(1e-9), rel=1e-6)


def _state(n: int, q: np.ndarray) -> np.ndarray:
    x = np.zeros((n, STATE.size))
    x[:, STATE["q"]] = q
    return x


def test_tracking_metrics_of_a_constant_offset():
    n = 20
    state = _state(n + 1, _q(roll_deg=2.0))
    state[:, STATE_DXY] = (0.3, 0.4)
    log = {"q_ref": np.tile(_q(yaw_deg=0.0), (n, 1)), "state": state, "v_ref": np.zeros((n, 3))}
    m = tracking_metrics(log)
    assert m["tilt_error_rms_deg"] == pytest.approx(2.0, rel=1e-12)
    assert m["tilt_error_max_deg"] == pytest.approx(2.0, rel=1e-12)
    assert m["heading_error_max_deg"] == pytest.approx(0.0, abs=1e-12)
    assert m["velocity_error_rms_mps"] == pytest.approx(0.5, rel=1e-12)   # |(0.3, 0.4)|


def test_estimation_metrics_of_a_heading_offset_and_counters():
    n = 10
    x = _state(n, _q())
    xh = _state(n, _q(yaw_deg=5.0))
    xh[:, STATE_DXY] = (0.0, 0.1)
    xh[-1, STATE_XY] = (0.3, 0.4)
    valid = np.ones((n, 3))
    valid[:3, 2] = 0.0
    log = {"x_hat": xh, "state": x, "nis": np.column_stack([np.full(n, 3.0), np.full(n, 6.0)]),
           "repairs": np.array([0, 1, 0, 2]), "valid": valid}
    m = estimation_metrics(log)
    assert m["estimator_tilt_max_deg"] == pytest.approx(0.0, abs=1e-12)
    assert m["estimator_heading_drift_deg"] == pytest.approx(5.0, rel=1e-12)
    assert m["estimator_velocity_rms_mps"] == pytest.approx(0.1, rel=1e-12)
    assert m["position_drift_m"] == pytest.approx(0.5, rel=1e-12)
    assert m["estimator_rate_rms_dps"] == pytest.approx(0.0, abs=1e-12)
    assert (m["nis_attitude_mean"], m["nis_velocity_mean"]) == (3.0, 6.0)
    assert m["covariance_repairs"] == 3
    assert m["gate_rejections"] == 0  # a log without the rejections output (older runs)
    rej = np.zeros((n, 4))
    rej[2, 1], rej[7, [0, 3]] = 1, 1
    assert estimation_metrics({**log, "rejections": rej})["gate_rejections"] == 3
    assert m["missing_reading_fraction"] == pytest.approx(3 / 30, rel=1e-12)
    # the heading sensor's column (every 20th period, or off) is not a missing reading
    heading = np.zeros((n, 1))
    heading[::5] = 1.0
    m4 = estimation_metrics({**log, "valid": np.hstack([valid, heading])})
    assert m4["missing_reading_fraction"] == pytest.approx(3 / 30, rel=1e-12)
    assert m["quat_norm_max_dev"] == pytest.approx(0.0, abs=1e-15)


def test_quaternion_component_errors_are_sign_aligned_and_the_rate_error_is_the_body_rate():
    """Thesis §6.1's q2/q3 errors: an estimate stored as -q (the same attitude) counts by its
    aligned sign.  The truth is turned by 30 deg of yaw (q3 = sin 15 deg), so a wrong
    alignment shows in q3.  The rate error is the body rate of dq = 1/2 q o [0, omega]."""
    n = 6
    qt = _q(yaw_deg=30.0)
    x = _state(n, qt)
    qh = np.array([_q(pitch_deg=2.0, yaw_deg=30.0)] * 3 + [_q(yaw_deg=34.0)] * 3)
    err = qh - qt  # aligned: every dot product with the truth is positive
    qh[1] *= -1.0  # the other sign of the same attitude
    qh[4] *= -1.0
    xh = _state(n, qh)
    w = np.array([0.1, -0.2, 0.3])  # rad/s in {B}
    xh[:, STATE["dq"]] = [0.5 * Q.mul(q, np.r_[0.0, w]) for q in qh]
    m = estimation_metrics({"x_hat": xh, "state": x, "nis": np.zeros((n, 2)),
                            "repairs": np.zeros(n)})
    assert m["estimator_q2_error_max"] == pytest.approx(np.abs(err[:, 2]).max(), rel=1e-12)
    assert m["estimator_q3_error_max"] == pytest.approx(np.abs(err[:, 3]).max(), rel=1e-12)
    # yaw 34 vs 30 deg: q3 = sin 17 deg - sin 15 deg
    assert np.abs(err[3:, 3]).max() == pytest.approx(math.sin(math.radians(17)) - math.sin(math.radians(15)))
    assert m["estimator_rate_rms_dps"] == pytest.approx(math.degrees(np.linalg.norm(w)), rel=1e-12)
    assert m["estimator_tilt_max_deg"] == pytest.approx(2.0, rel=1e-9)
    assert m["estimator_heading_max_deg"] == pytest.approx(4.0, rel=1e-9)


def test_the_rate_of_an_estimate_off_the_unit_sphere_is_still_its_body_rate():
    """omega = 2 (q* o dq) / |q|^2: an estimate scaled by 1.2 (a filter between its
    renormalisations) with dq = 1/2 q o [0, omega] has the body rate omega, not 1.2^4 times it."""
    n = 4
    x = _state(n, _q())
    qh = 1.2 * np.asarray(_q(roll_deg=3.0), float)
    xh = _state(n, qh)
    w = np.array([0.2, 0.1, -0.4])
    xh[:, STATE["dq"]] = 0.5 * Q.mul(qh, np.r_[0.0, w])
    m = estimation_metrics({"x_hat": xh, "state": x, "nis": np.zeros((n, 2)), "repairs": np.zeros(n)})
    assert m["estimator_rate_rms_dps"] == pytest.approx(math.degrees(np.linalg.norm(w)), rel=1e-12)

"""The heading study's synthetic data (``analysis/heading.py``) against the models it is
meant to match: the true attitude advances by the logged body rate under the filter's
constant-rate process model and follows the documented sweep, the gyro bias is a random
walk with the sensor's density (per sqrt(s)), the gyroscope reads rate + bias + white
noise, and a sensor loss removes a half-open window of readings."""

from __future__ import annotations

import numpy as np

from ballbot_casadi.analysis.heading import heading_readings, heading_truth
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.sensor_params import load_sensor_params

TS = 0.005


def test_true_attitude_advances_by_the_logged_body_rate():
    """q(t_k) = q(t_{k-1}) o exp(omega_k Ts / 2) with omega_k the row of period k: the
    body-frame rate the filters' process model (thesis 4.14-4.18) integrates exactly."""
    q, rate = heading_truth(100, 400)
    assert rate.shape == (300, 3) and q.shape == (301, 4)
    for k in range(1, 300):
        q_next = Q.mul(q[k - 1], Q.from_rotation_vector(rate[k] * TS))
        np.testing.assert_allclose(q_next, q[k], rtol=0, atol=1e-12)
    # both tilt and yaw move, so a rate in {K} would differ from the body rate
    rpy = np.array([Q.to_rpy(a) for a in q])
    assert np.ptp(rpy[:, 0]) > 0.005 and np.ptp(rpy[:, 2]) > 0.001


def test_gyro_bias_is_a_random_walk_with_the_sensor_density_and_readings_add_it():
    s = load_sensor_params()
    n = 6000
    z, _, bias, _ = heading_readings(0, n, 11, s, np.array([0.0, 0.0, 0.01]))
    q, rate = heading_truth(0, n)
    assert bias[0, 2] == 0.01  # starts at bias0
    steps = np.diff(bias, axis=0) / np.sqrt(TS)
    np.testing.assert_allclose(np.std(steps, axis=0), s.gyro_bias_rw, rtol=0.05)
    noise = z[:, 3:6] - rate - bias
    np.testing.assert_allclose(np.std(noise, axis=0), np.sqrt(s.gyro_noise_var), rtol=0.05)
    assert np.all(np.abs(np.mean(noise, axis=0)) < 4 * np.sqrt(np.array(s.gyro_noise_var) / n))


def test_heading_loss_window_is_half_open():
    """``loss = (t0, t1)`` removes the readings in [t0, t1): the 10 Hz reading at t0 is gone,
    the one at t1 is back."""
    s = load_sensor_params()
    z, _, _, _ = heading_readings(0, 300, 5, s, np.zeros(3), loss=(0.5, 1.0))
    t = np.round(np.arange(300) * TS, 12)
    have = np.isfinite(z[:, 6])
    np.testing.assert_array_equal(t[have], [0.0, 0.1, 0.2, 0.3, 0.4, 1.0, 1.1, 1.2, 1.3, 1.4])


def test_true_attitude_is_the_documented_sweep():
    """heading_truth's ZYX angles at t_k = k Ts: roll 1 deg sin(2 pi 0.5 t), pitch
    1 deg cos(2 pi 0.3 t), yaw 0.3 / w (1 - cos(w t)), w = 2 pi / 120 s."""
    k0, k1 = 7, 2407
    q, _ = heading_truth(k0, k1)
    t = np.arange(k0, k1 + 1) * TS
    w = 2 * np.pi / 120.0
    want = np.column_stack([np.radians(1.0) * np.sin(2 * np.pi * 0.5 * t),
                            np.radians(1.0) * np.cos(2 * np.pi * 0.3 * t),
                            0.3 / w * (1 - np.cos(w * t))])
    rpy = np.array([Q.to_rpy(a) for a in q])
    rpy[:, 2] = np.unwrap(rpy[:, 2])
    np.testing.assert_allclose(rpy, want, rtol=0, atol=1e-12)

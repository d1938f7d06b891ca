"""The predecessor's QEKF with heading correction and gyro-bias states (estimation/predecessor.py)
against an independent numpy transcription of the V2019 algorithm (QEKF.m: forward Euler,
F P F^T + Q, the heading as the azimuth of the body x axis, renormalisation)."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.params import load_params
from ballbot_casadi.core.sensor_params import load_sensor_params
from ballbot_casadi.estimation import DEFAULT_TUNING, initial_state
from ballbot_casadi.estimation.predecessor import QEKF_HEADING_STATE, make_qekf_heading

P = load_params()
DT = 0.005


def _num_jac(f, x, eps=1e-7):
    y0 = f(x)
    J = np.zeros((y0.size, x.size))
    for i in range(x.size):
        d = np.zeros(x.size)
        d[i] = eps
        J[:, i] = (f(x + d) - f(x - d)) / (2 * eps)
    return J


def _reference(x, Pm, z, Qn, R, a):
    """One period of the V2019 QEKF (non-sensor-driven, bias estimation on) in numpy, with
    the heading innovation wrapped and numerical Jacobians."""
    g = P.g

    def f(x):
        q, w = x[:4], x[4:7]
        return np.r_[q + DT * 0.5 * Q.mul(q, np.r_[0.0, w]), w, x[7:]]

    def h(x):
        q, w, b = x[:4], x[4:7], x[7:]
        yaw = np.arctan2(2 * (q[0] * q[3] + q[1] * q[2]), q[0]**2 + q[1]**2 - q[2]**2 - q[3]**2)
        return np.r_[Q.rotate_inv(q, [0, 0, 1.0]) + Q.rotate_inv(x_prior[:4], a) / g, w + b, yaw]

    x_prior = x
    xp = f(x)
    F = _num_jac(f, x)
    Pp = F @ Pm @ F.T + Qn
    H = _num_jac(h, xp)
    nu = np.r_[z[:3] / g, z[3:6], 0.0] - h(xp)
    nu[6] = np.angle(np.exp(1j * (z[6] - h(xp)[6])))
    S = H @ Pp @ H.T + R
    K = Pp @ H.T @ np.linalg.inv(S)
    xn = xp + K @ nu
    xn[:4] /= np.linalg.norm(xn[:4])
    return xn, Pp - K @ S @ K.T, nu


def test_one_period_is_the_v2019_algorithm():
    f = make_qekf_heading()
    tun = DEFAULT_TUNING["qekf_heading"]
    x = np.r_[Q.from_rpy(0.03, -0.02, 3.1), 0.2, -0.1, 0.4, 0.001, -0.002, 0.003]
    _, Pm = initial_state("qekf_heading", x)
    Pm = Pm * 50
    acc = Q.rotate_inv(Q.from_rpy(0.04, -0.02, 3.1), [0, 0, P.g]) + [0.05, -0.02, 0.01]
    z = np.r_[acc, 0.21, -0.12, 0.41, -3.13]  # the reading across the +-pi cut
    a = np.array([0.3, -0.1, 0.0])
    out = f(x, Pm, z, tun.Q, tun.R, DT, P.to_vector(), a)
    xn, Pn, nu = (np.asarray(o).squeeze() for o in out[:3])
    xr, Pr, nur = _reference(x, Pm, z, np.asarray(tun.Q), np.asarray(tun.R), a)
    np.testing.assert_allclose(nu, nur, rtol=0, atol=1e-8)
    assert nu[6] == pytest.approx(np.angle(np.exp(1j * (-3.13 - 3.1 - DT * 0))), abs=2e-3)
    assert abs(nu[6]) < 0.1  # wrapped: not -6.2 rad
    np.testing.assert_allclose(xn, xr, rtol=0, atol=1e-8)
    np.testing.assert_allclose(Pn, Pr, rtol=0, atol=1e-9)
    assert np.linalg.norm(xn[:4]) == pytest.approx(1.0, abs=1e-15)  # forced unit norm
    assert float(out[4]) == 7
    # P_att: the covariance of the body rotation vector dtheta = 2 vec(conj(q) * dq) of
    # the updated quaternion (first order), each column of the map from a unit dq
    T = np.column_stack([2 * np.asarray(Q.mul(Q.conj(xn[:4]), e), float).ravel()[1:]
                         for e in np.eye(4)])
    np.testing.assert_allclose(np.asarray(out[6]), T @ Pn[:4, :4] @ T.T, rtol=1e-9, atol=1e-18)


def test_heading_reading_moves_heading_and_bias_with_the_right_signs():
    """A heading reading 1 deg ahead of the estimate turns the estimate towards it; a run of
    readings that fall behind at a constant rate (the gyroscope reads a z bias) moves the
    z bias state towards that rate."""
    f = make_qekf_heading()
    tun = DEFAULT_TUNING["qekf_heading"]
    p = P.to_vector()
    x, Pm = initial_state("qekf_heading")
    g = np.r_[0, 0, P.g]
    z = np.r_[g, 0, 0, 0, np.radians(1.0)]
    out = f(x, Pm * 100, z, tun.Q, tun.R, DT, p, np.zeros(3))
    yaw = Q.to_rpy(np.asarray(out[0]).ravel()[:4])[2]
    assert 0 < yaw < np.radians(1.0)
    # a z gyro bias of 0.003 rad/s, heading at 10 Hz, 60 s standing still
    s = load_sensor_params()
    bias = 0.003
    rng = np.random.default_rng(4)
    xk, Pk = x.copy(), np.array(Pm)
    for k in range(12000):
        gyro = np.r_[0, 0, bias] + np.sqrt(s.gyro_noise_var) * rng.standard_normal(3)
        yaw_z = np.sqrt(s.heading_noise_var[0]) * rng.standard_normal() if k % 20 == 0 else np.nan
        o = f(xk, Pk, np.r_[g, gyro, yaw_z], tun.Q, tun.R, DT, p, np.zeros(3))
        xk, Pk = np.asarray(o[0]).ravel(), np.asarray(o[1])
    # the rate state's random walk (3e-5 (rad/s)^2 per period) shares the gyroscope's offset
    # with the bias state for a while: measured 0.00345 after 60 s
    assert 0.7 * bias < xk[QEKF_HEADING_STATE["b"]][2] < 1.3 * bias
    assert abs(Q.to_rpy(xk[:4])[2]) < np.radians(0.5)

"""One step of the velocity controller against a numpy reference written from thesis §7.3
and the module docstring: a chosen gain, limits far away (then each limit on its own),
centred COM (balance point exactly 0).

State ``X = [v - v_ref, theta, dtheta, theta_r, dtheta_r, p_e]``, ``a = -K X``; the
reference model ``theta_r+ = theta_r + Ts dtheta_r + Ts^2 a / 2``, ``dtheta_r+ =
dtheta_r + Ts a``; the integrators ``p_e+ = p_e + Ts (v - v_ref)``; the heading reference
``psi_r+ = psi_r + Ts r_r + Ts^2 alpha / 2``, ``r_r+ = r_r + Ts alpha`` with ``alpha =
k_r (r_ref - r_r)``.
"""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.control.velocity import (
    VELOCITY_LIMIT_NAMES,
    make_velocity_controller,
    measured_tilt,
    tilt_heading_quaternion,
)
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import STATE, STATE_DXY
from ballbot_casadi.core.layout import VELOCITY_CONTROLLER_STATE as Z
from ballbot_casadi.core.params import load_params

TS = 0.005
FAR = {"tilt_max": 10.0, "tilt_rate_max": 100.0, "tilt_acc_max": 1e4, "v_max": 100.0,
       "yaw_rate_max": 100.0, "p_e_max": 100.0, "yaw_acc_max": 1e4, "k_r": 3.0}


@pytest.fixture(scope="module")
def vel():
    return make_velocity_controller()


def _gains(K, **limits):
    lim = dict(FAR, **limits)
    return np.concatenate([np.asarray(K, float).reshape(-1), [lim[n] for n in VELOCITY_LIMIT_NAMES]])


def _case():
    rng = np.random.default_rng(21)
    K = 0.5 * rng.normal(size=(2, 12))
    q = np.asarray(Q.from_rpy(0.02, -0.015, 0.4), float).reshape(4)
    w = np.array([0.1, -0.05, 0.2])
    x = np.zeros(12)
    x[STATE["q"]] = q
    x[STATE["dq"]] = 0.5 * np.asarray(Q.mul(q, np.r_[0.0, w]), float).reshape(4)
    x[STATE_DXY] = [0.3, -0.2]
    z = np.zeros(Z.size)
    z[Z["theta_r"]], z[Z["dtheta_r"]], z[Z["p_e"]] = [0.01, -0.02], [0.03, 0.01], [0.05, -0.04]
    z[Z.index("psi_r")], z[Z.index("r_r")] = 0.35, 0.1
    return K, x, z


def _run(vel, x, v_ref, z, k):
    p = load_params().replace(com_x=0.0, com_y=0.0).to_vector()
    return [np.asarray(o, float).ravel() for o in vel(x, v_ref, z, p, k, TS)]


def _reference(K, x, v_ref, z, k_r=FAR["k_r"]):
    q, dq = x[STATE["q"]], x[STATE["dq"]]
    th = measured_tilt(q)
    h = 1e-7
    dth = (measured_tilt(q + h * dq) - measured_tilt(q - h * dq)) / (2 * h)
    verr = x[STATE_DXY] - v_ref[:2]
    X = np.concatenate([verr, th, dth, z[Z["theta_r"]], z[Z["dtheta_r"]], z[Z["p_e"]]])
    a = -K @ X
    alpha = k_r * (v_ref[2] - z[Z.index("r_r")])
    th_r, dth_r = z[Z["theta_r"]], z[Z["dtheta_r"]]
    psi, r = z[Z.index("psi_r")], z[Z.index("r_r")]
    z_next = np.concatenate([th_r + TS * dth_r + 0.5 * TS**2 * a, dth_r + TS * a,
                             z[Z["p_e"]] + TS * verr,
                             [psi + TS * r + 0.5 * TS**2 * alpha, r + TS * alpha]])
    return a, alpha, z_next


def test_unconstrained_step_matches_the_reference_model(vel):
    K, x, z = _case()
    v_ref = np.array([0.1, 0.25, 0.4])
    q_ref, dq_ref, ddq_ref, z_next = _run(vel, x, v_ref, z, _gains(K))
    _, _, want = _reference(K, x, v_ref, z)
    np.testing.assert_allclose(z_next, want, rtol=1e-7, atol=1e-12)
    # the reference attitude is the tilt-heading quaternion of the *current* reference
    th_r, psi = z[Z["theta_r"]], z[Z.index("psi_r")]
    np.testing.assert_allclose(q_ref, tilt_heading_quaternion(th_r[0], th_r[1], psi), atol=1e-15)
    s_dot = np.r_[z[Z["dtheta_r"]], z[Z.index("r_r")]]
    h = 1e-6
    s = np.r_[th_r, psi]
    num = (tilt_heading_quaternion(*(s + h * s_dot)) - tilt_heading_quaternion(*(s - h * s_dot))) / (2 * h)
    np.testing.assert_allclose(dq_ref, num, rtol=1e-6, atol=1e-10)


def test_speed_command_is_scaled_to_v_max_keeping_its_direction(vel):
    K, x, z = _case()
    v_ref = np.array([0.6, -0.8, 0.0])  # 1 m/s, limit 0.5 m/s -> (0.3, -0.4)
    _, _, _, z_next = _run(vel, x, v_ref, z, _gains(K, v_max=0.5))
    _, _, want = _reference(K, x, np.array([0.3, -0.4, 0.0]), z)
    np.testing.assert_allclose(z_next, want, rtol=1e-7, atol=1e-12)


def test_yaw_rate_command_is_clipped_and_its_acceleration_limited(vel):
    K, x, z = _case()
    _, _, _, z1 = _run(vel, x, np.array([0.0, 0.0, 5.0]), z, _gains(K, yaw_rate_max=0.7))
    _, _, want = _reference(K, x, np.array([0.0, 0.0, 0.7]), z)
    np.testing.assert_allclose(z1[6:], want[6:], rtol=1e-9, atol=1e-14)
    _, _, _, z2 = _run(vel, x, np.array([0.0, 0.0, -5.0]), z, _gains(K, yaw_acc_max=0.2))
    alpha = -0.2
    r = z[Z.index("r_r")]
    np.testing.assert_allclose(z2[6:], [0.35 + TS * r + 0.5 * TS**2 * alpha, r + TS * alpha],
                               rtol=1e-12)


def test_acceleration_is_clipped_per_axis_and_integrators_saturate(vel):
    K, x, z = _case()
    v_ref = np.array([0.1, 0.25, 0.0])
    a, _, _ = _reference(K, x, v_ref, z)
    acc_max = 0.5 * np.min(np.abs(a))
    _, _, _, z_next = _run(vel, x, v_ref, z, _gains(K, tilt_acc_max=acc_max, p_e_max=0.045))
    a_c = np.clip(a, -acc_max, acc_max)
    np.testing.assert_allclose(z_next[Z["dtheta_r"]], z[Z["dtheta_r"]] + TS * a_c, rtol=1e-9)
    np.testing.assert_allclose(z_next[Z["theta_r"]],
                               z[Z["theta_r"]] + TS * z[Z["dtheta_r"]] + 0.5 * TS**2 * a_c, rtol=1e-9)
    verr = x[STATE_DXY] - v_ref[:2]
    np.testing.assert_allclose(z_next[Z["p_e"]], np.clip(z[Z["p_e"]] + TS * verr, -0.045, 0.045),
                               rtol=1e-12)
    assert abs(z_next[Z["p_e"]][0]) == pytest.approx(0.045)  # x integrator at its bound


def test_tilt_reference_stops_at_the_limit_moving_outward_only(vel):
    """theta_r just inside the limit and moving out: clamped there with its rate zeroed; the
    other axis moving back in keeps its rate."""
    K = np.zeros((2, 12))
    x = np.zeros(12)
    x[STATE["q"]] = [1.0, 0.0, 0.0, 0.0]
    z = np.zeros(Z.size)
    z[Z["theta_r"]] = [0.0999, -0.0999]
    z[Z["dtheta_r"]] = [0.05, 0.05]
    _, _, _, z_next = _run(vel, x, np.zeros(3), z, _gains(K, tilt_max=0.1))
    np.testing.assert_allclose(z_next[Z["theta_r"]], [0.1, -0.0999 + TS * 0.05], rtol=1e-12)
    np.testing.assert_allclose(z_next[Z["dtheta_r"]], [0.0, 0.05], rtol=1e-12)


def test_a_tilt_reference_beyond_the_limit_moving_back_keeps_its_rate(vel):
    """After a limit change theta_r lies beyond tilt_max: it is clamped to the limit, but a
    rate pointing back inside is kept (only an outward rate is zeroed)."""
    K = np.zeros((2, 12))
    x = np.zeros(12)
    x[STATE["q"]] = [1.0, 0.0, 0.0, 0.0]
    z = np.zeros(Z.size)
    z[Z["theta_r"]] = [0.12, -0.12]
    z[Z["dtheta_r"]] = [-0.01, 0.01]
    _, _, _, z_next = _run(vel, x, np.zeros(3), z, _gains(K, tilt_max=0.1))
    np.testing.assert_allclose(z_next[Z["theta_r"]], [0.1, -0.1], rtol=1e-12)
    np.testing.assert_allclose(z_next[Z["dtheta_r"]], [-0.01, 0.01], rtol=1e-12)

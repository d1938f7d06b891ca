"""Tests of the noise-free sensor models (thesis §3.1)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi import load_params
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.errors import BallbotTypeError, ShapeError
from ballbot_casadi.model.dynamics import make_model_functions
from ballbot_casadi.model.numeric import make_state
from ballbot_casadi.model.sensors import make_sensors

P = load_params()
PV = P.to_vector()


@pytest.fixture(scope="module")
def fns():
    f = make_model_functions()
    return f, make_sensors(f["ode"])


def _eval(sens, x, tau=(0.0, 0.0, 0.0), p=PV):
    acc, gyro, enc = sens(x, np.asarray(tau, float), p)
    return np.asarray(acc).ravel(), np.asarray(gyro).ravel(), np.asarray(enc).ravel()


def test_upright_at_rest_reads_plus_g(fns):
    _, sens = fns
    acc, gyro, enc = _eval(sens, make_state(yaw=0.7))
    np.testing.assert_allclose(acc, [0, 0, P.g], rtol=0, atol=1e-12)
    np.testing.assert_allclose(gyro, 0, atol=1e-15)
    np.testing.assert_allclose(enc, 0, atol=1e-9)


def test_tilted_at_rest_reads_rotated_gravity_plus_ball_acceleration(fns):
    f, sens = fns
    x = make_state(roll=0.1, pitch=-0.05, yaw=0.3)
    acc, _, _ = _eval(sens, x)
    xdot = np.asarray(f["ode"](x, np.zeros(3), PV)).ravel()
    R = Q.rotation_matrix(x[2:6])
    # specific force = R^T (a_ball + [0, 0, g]); the ball accelerates when the body tilts
    np.testing.assert_allclose(R @ acc, [xdot[6], xdot[7], P.g], rtol=0, atol=1e-12)
    # gravity part alone is the rotated gravity vector
    np.testing.assert_allclose(acc - R.T @ [xdot[6], xdot[7], 0.0], R.T @ [0, 0, P.g],
                               rtol=0, atol=1e-12)
    assert abs(np.linalg.norm(acc - R.T @ [xdot[6], xdot[7], 0.0]) - P.g) < 1e-12


def test_gyro_equals_make_state_angular_velocity(fns):
    _, sens = fns
    rng = np.random.default_rng(3)
    for _ in range(5):
        w = rng.normal(size=3)
        x = make_state(roll=rng.normal() * 0.2, pitch=rng.normal() * 0.2, yaw=rng.normal(),
                       dx=rng.normal(), dy=rng.normal(), omega_body=w)
        _, gyro, _ = _eval(sens, x)
        np.testing.assert_allclose(gyro, w, rtol=0, atol=1e-13)


def test_encoders_are_wheel_speeds_in_ticks(fns):
    f, sens = fns
    x = make_state(roll=0.05, dx=0.3, dy=-0.2, omega_body=(0.1, -0.2, 0.4))
    _, _, enc = _eval(sens, x)
    dphi = np.asarray(f["wheel_speeds"](x, PV)).ravel()
    np.testing.assert_allclose(enc, P.n_ticks / (2 * math.pi) * dphi, rtol=1e-14, atol=1e-9)


def test_imu_offset_matches_finite_difference_of_position(fns):
    """Acceleration of an off-centre IMU = second time derivative of its position."""
    f, _ = fns
    r = np.array([0.05, -0.02, 0.3])
    sens = make_sensors(f["ode"], imu_position=r)
    x0 = make_state(roll=0.08, pitch=0.03, dx=0.1, omega_body=(0.2, -0.1, 0.3))
    tau = np.array([0.3, -0.2, 0.1])
    ode = f["ode"]

    def flow(x, t):  # RK4 with small steps; accurate to far below the FD error
        n = max(1, int(round(abs(t) / 1e-4)))
        h = t / n
        for _ in range(n):
            k1 = np.asarray(ode(x, tau, PV)).ravel()
            k2 = np.asarray(ode(x + h / 2 * k1, tau, PV)).ravel()
            k3 = np.asarray(ode(x + h / 2 * k2, tau, PV)).ravel()
            k4 = np.asarray(ode(x + h * k3, tau, PV)).ravel()
            x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        return x

    def pos(x):
        return np.array([x[0], x[1], 0.0]) + Q.rotate(x[2:6], r)

    dt = 1e-3
    a_fd = (pos(flow(x0, dt)) - 2 * pos(x0) + pos(flow(x0, -dt))) / dt**2
    acc, _, _ = _eval(sens, x0, tau)
    R = Q.rotation_matrix(x0[2:6])
    np.testing.assert_allclose(R @ acc, a_fd + [0, 0, P.g], rtol=0, atol=1e-5)


def test_bad_arguments(fns):
    f, _ = fns
    with pytest.raises(BallbotTypeError):
        make_sensors(f["energy"])
    with pytest.raises(ShapeError):
        make_sensors(f["ode"], imu_position=(0.0, 1.0))
    with pytest.raises(ShapeError):
        make_sensors(f["ode"], imu_position=(0.0, float("nan"), 0.0))

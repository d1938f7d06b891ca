"""Noise-free sensor models of the ballbot (thesis §3.1): IMU and wheel encoders.

The thesis' sensor set is a body-mounted IMU (three-axis accelerometer and gyroscope)
and three wheel encoders.  The models here are the calibrated, noise- and bias-free
parts of thesis (3.6), (3.10) and (3.15)/(3.17):

* **Gyroscope** (3.10): the body angular velocity in the body frame,
  ``gyro = omega_B = v(2 Phi(q)^T dq)`` (B.16).  The ball frame {K} only translates
  with respect to the inertial frame {I}, so ``omega_{B|I} = omega_{B|K}``.
* **Accelerometer** (3.6): the specific force at the IMU location expressed in the body
  frame, ``acc = R(q)^T (a_IMU - g_I)`` with ``g_I = [0, 0, -g]``, i.e. at rest and
  upright the accelerometer reads ``+g`` along body z.  The IMU location is a point
  ``r_imu`` fixed in the body frame, measured from the body-frame origin, which is the
  ball centre (the point the body rotates about).  **Default: ``r_imu = 0``, the IMU at
  the ball centre**, so ``a_IMU = [ddx, ddy, 0]``; any other mounting point is given to
  :func:`make_sensors` and adds ``d^2/dt^2 (R(q) r_imu)``.  The ball-centre acceleration
  ``ddx, ddy`` and ``ddq`` come from calling the ODE Function.
* **Encoders** (3.15, 3.17): the wheel (motor-shaft) speeds of the inverse kinematics
  (B.47) converted to encoder ticks per second, ``enc = n_ticks / (2 pi) * dphi``.  The
  thesis' tick count over a sample ``Δt`` is ``enc * Δt`` before rounding.
"""

from __future__ import annotations

import math
from typing import Any

import casadi as ca
import numpy as np

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.params import ParamView
from ballbot_casadi.errors import BallbotTypeError, ShapeError
from ballbot_casadi.model import kinematics as K

__all__ = ["make_sensors", "SENSOR_NAMES"]

#: Output names of :func:`make_sensors` and the number of entries of each.
SENSOR_NAMES = ("acc", "gyro", "enc")


def make_sensors(ode: ca.Function, imu_position: Any = (0.0, 0.0, 0.0)) -> ca.Function:
    """Sensor Function ``ballbot_sensors(x, tau, p) -> (acc, gyro, enc)`` (thesis §3.1).

    Parameters
    ----------
    ode
        The state equation ``(x, tau, p) -> xdot`` (``make_model_functions()["ode"]``);
        it is called (not inlined) for the accelerations.
    imu_position
        IMU location in the body frame relative to the ball centre, in m (3 numbers).
        Default: the ball centre.

    Returns
    -------
    casadi.Function
        ``acc`` (3, m/s^2, specific force in {B}), ``gyro`` (3, rad/s, body angular
        velocity in {B}), ``enc`` (3, ticks/s, wheel encoder rates in thesis wheel order).

    Raises
    ------
    BallbotTypeError
        ``ode`` is not a CasADi Function with inputs (x, tau, p) of sizes (12, 3, NP).
    ShapeError
        ``imu_position`` does not have 3 finite entries.
    """
    if not isinstance(ode, ca.Function) or ode.n_in() != 3 or ode.n_out() != 1:
        raise BallbotTypeError("ode must be a CasADi Function (x, tau, p) -> xdot")
    nx, nu, np_ = ode.size1_in(0), ode.size1_in(1), ode.size1_in(2)
    if (nx, nu) != (12, 3):
        raise BallbotTypeError(f"ode must take x (12) and tau (3), got sizes {nx}, {nu}")
    r_imu = np.asarray(imu_position, dtype=float).reshape(-1)
    if r_imu.shape != (3,) or not np.all(np.isfinite(r_imu)):
        raise ShapeError(f"imu_position must be 3 finite numbers, got {imu_position!r}")

    x, tau, p = ca.MX.sym("x", nx), ca.MX.sym("tau", nu), ca.MX.sym("p", np_)
    P = ParamView(p)
    q, dq = x[2:6], x[8:12]
    xdot = ode(x, tau, p)
    ddxy, ddq = xdot[6:8], xdot[8:12]

    # Inertial acceleration of the IMU point: ball centre plus the rotating lever arm.
    a_imu = ca.vertcat(ddxy, 0)
    if np.any(r_imu != 0.0):
        qs, dqs = ca.MX.sym("q", 4), ca.MX.sym("dq", 4)
        r_k = Q.rotate(qs, ca.DM(r_imu))
        v_k = ca.mtimes(ca.jacobian(r_k, qs), dqs)
        a_k = ca.mtimes(ca.jacobian(v_k, qs), dqs)
        lever = ca.Function("imu_lever", [qs, dqs], [v_k, a_k, ca.jacobian(v_k, dqs)])
        _, a_vel, j_acc = lever(q, dq)
        a_imu = a_imu + a_vel + ca.mtimes(j_acc, ddq)
    specific_force_k = a_imu + ca.vertcat(0, 0, P.g)  # a - g_I, g_I = [0, 0, -g] (3.5)
    acc = Q.rotate_inv(q, specific_force_k)  # (3.6)
    gyro = K.body_angular_velocity(q, dq)  # (3.10), (B.16)
    dphi = K.wheel_speeds(q, dq, x[6], x[7], P)  # (B.47)
    enc = P.n_ticks / (2 * math.pi) * dphi  # (3.15), (3.17) per unit time
    return ca.Function(
        "ballbot_sensors", [x, tau, p], [acc, gyro, enc], ["x", "tau", "p"], list(SENSOR_NAMES)
    )

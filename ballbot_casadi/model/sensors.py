"""Sensor models of the ballbot (thesis §3.1): IMU and wheel encoders, ideal and realistic.

The thesis' sensor set is a body-mounted IMU (three-axis accelerometer and gyroscope)
and three wheel encoders.  The ideal models (:func:`make_sensors`) are the calibrated,
noise- and bias-free parts of thesis (3.6), (3.10) and (3.15)/(3.17):

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

Realistic sensors (noise, bias, scale, misalignment, lever arm, quantisation) are built
by :func:`make_imu`, :func:`make_gyro_bias_step`, :func:`make_encoders` and
:func:`make_wheel_angle_ode` further down.  They take the sensor parameter vector ``s``
(:class:`~ballbot_casadi.core.sensor_params.SensorParams`) and the noise as *inputs*
(standard normal samples, e.g. from :class:`~ballbot_casadi.core.rng.NoiseStream`), so
a compiled mission receives noise as input sequences and stays deterministic.
"""

from __future__ import annotations

import math
from types import MappingProxyType
from typing import Any, Mapping

import casadi as ca
import numpy as np

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.params import PARAM_NAMES, ParamView
from ballbot_casadi.core.sensor_params import NS, SensorView
from ballbot_casadi.errors import BallbotTypeError, ShapeError
from ballbot_casadi.model import kinematics as K

__all__ = [
    "make_sensors",
    "SENSOR_NAMES",
    "NOISE_STREAMS",
    "make_specific_force",
    "make_imu",
    "make_gyro_bias_step",
    "make_encoders",
    "make_encoder_model",
    "make_wheel_angle_ode",
    "encoder_count",
    "make_heading_sensor",
    "heading_schedule",
    "HEADING_SCHEDULE_EPS",
    "yaw_of",
    "wrap_angle",
]

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
    nx, nu, np_ = _check_ode(ode)
    r_imu = np.asarray(imu_position, dtype=float).ravel()
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


# --------------------------------------------------------------------------- realistic sensors

#: Rounding margin of :func:`heading_schedule` (a sample instant ``j / rate`` within it
#: before ``k Ts`` counts as at ``k Ts``); the plant FMU's schedule uses the same.
HEADING_SCHEDULE_EPS = 1e-9
#: Suggested :class:`~ballbot_casadi.core.rng.NoiseStream` stream ids, one per noise
#: source, so that adding a source never changes the numbers of another.
NOISE_STREAMS: Mapping[str, int] = MappingProxyType(
    {"acc": 0, "gyro": 1, "gyro_bias_rw": 2, "enc": 3, "heading": 4}
)


def _check_ode(ode: Any) -> tuple[int, int, int]:
    if not isinstance(ode, ca.Function) or ode.n_in() != 3 or ode.n_out() != 1:
        raise BallbotTypeError("ode must be a CasADi Function (x, tau, p) -> xdot")
    nx, nu, np_ = ode.size1_in(0), ode.size1_in(1), ode.size1_in(2)
    if (nx, nu) != (12, 3) or ode.size1_out(0) != 12:
        raise BallbotTypeError(
            f"ode must map x (12), tau (3), p -> xdot (12), got sizes {nx}, {nu}"
        )
    return nx, nu, np_


def _check_wheel_speeds(wheel_speeds: Any) -> int:
    if (not isinstance(wheel_speeds, ca.Function) or wheel_speeds.n_in() != 2
            or wheel_speeds.n_out() != 1 or wheel_speeds.size1_in(0) != 12
            or wheel_speeds.size1_out(0) != 3):
        raise BallbotTypeError(
            "wheel_speeds must be a CasADi Function (x (12), p) -> dphi (3), "
            "e.g. make_model_functions()['wheel_speeds']"
        )
    return wheel_speeds.size1_in(1)


def make_specific_force(ode: ca.Function) -> ca.Function:
    """``ballbot_specific_force(x, tau, p, r_imu) -> (f, omega)``: IMU point kinematics.

    ``f`` (3, m/s^2) is the specific force ``R(q)^T (a_IMU - g_I)`` at the body-fixed
    point ``r_imu`` (3, m, body frame from the ball centre) expressed in the body frame,
    thesis (3.3), (3.5), (3.6); ``omega`` (3, rad/s) is the body angular velocity
    ``v(2 Phi(q)^T dq)`` (B.16), the rate a body-fixed gyroscope senses (3.10).

    The IMU point accelerates with the ball centre plus the rigid lever arm::

        f = R(q)^T [ddx, ddy, g] + domega x r_imu + omega x (omega x r_imu)

    with ``domega = v(2 Phi(q)^T ddq)``, the exact time derivative of ``omega``
    (the vector part of ``2 dq* o dq`` is zero).  ``ddx, ddy, ddq`` come from calling
    ``ode``.
    """
    nx, nu, np_ = _check_ode(ode)
    x, tau, p = ca.MX.sym("x", nx), ca.MX.sym("tau", nu), ca.MX.sym("p", np_)
    r = ca.MX.sym("r_imu", 3)
    P = ParamView(p)
    q, dq = x[2:6], x[8:12]
    xdot = ode(x, tau, p)
    omega = K.body_angular_velocity(q, dq)  # (B.16)
    domega = K.body_angular_velocity(q, xdot[8:12])  # d/dt of (B.16)
    f = (Q.rotate_inv(q, ca.vertcat(xdot[6], xdot[7], P.g))  # (3.5), (3.6)
         + ca.cross(domega, r) + ca.cross(omega, ca.cross(omega, r)))
    return ca.Function("ballbot_specific_force", [x, tau, p, r], [f, omega],
                       ["x", "tau", "p", "r_imu"], ["f", "omega"])


def make_imu(ode: ca.Function) -> ca.Function:
    """Noisy IMU ``ballbot_imu(x, tau, p, s, bias_gyro, n_acc, n_gyro) -> (acc, gyro)``.

    Accelerometer, thesis (3.3) with (3.4)-(3.6), and gyroscope, thesis (3.7), (3.8),
    (3.10)::

        acc  = K_acc  R_m^T f     + b_acc  + sqrt(Sigma_acc)  n_acc
        gyro = K_gyro R_m^T omega + b_gyro + sqrt(Sigma_gyro) n_gyro

    where ``f``, ``omega`` are the specific force and body rate at ``s.imu_position``
    (``ballbot_specific_force``, called), ``R_m`` the rotation of the IMU frame in the
    body frame (``exp`` of the rotation vector ``s.imu_misalignment``), ``K`` the
    diagonal scale factors, ``Sigma`` the diagonal noise covariances of ``s``.  With
    the default (calibrated) ``s`` and zero bias and noise this is the noise-free
    :func:`make_sensors`.

    Parameters
    ----------
    ode
        The state equation ``(x, tau, p) -> xdot`` (``make_model_functions()["ode"]``).

    Returns
    -------
    casadi.Function
        Inputs ``x`` (12), ``tau`` (3, N m), ``p`` (NP), ``s`` (NS sensor parameters),
        ``bias_gyro`` (3, rad/s, the current gyroscope bias, a state of
        :func:`make_gyro_bias_step` starting at ``s.gyro_bias0``), ``n_acc``,
        ``n_gyro`` (3 each, standard normal samples).  Outputs ``acc`` (3, m/s^2, IMU
        frame), ``gyro`` (3, rad/s, IMU frame).
    """
    nx, nu, np_ = _check_ode(ode)
    sf = make_specific_force(ode)
    x, tau, p = ca.MX.sym("x", nx), ca.MX.sym("tau", nu), ca.MX.sym("p", np_)
    s, b_gyro = ca.MX.sym("s", NS), ca.MX.sym("bias_gyro", 3)
    n_acc, n_gyro = ca.MX.sym("n_acc", 3), ca.MX.sym("n_gyro", 3)
    S = SensorView(s)
    f, omega = sf(x, tau, p, S.imu_position)
    q_m = Q.from_rotation_vector(S.imu_misalignment)  # {IMU} in {B}
    acc = (S.acc_scale * Q.rotate_inv(q_m, f) + S.acc_bias
           + ca.sqrt(S.acc_noise_var) * n_acc)  # (3.3)
    gyro = (S.gyro_scale * Q.rotate_inv(q_m, omega) + b_gyro
            + ca.sqrt(S.gyro_noise_var) * n_gyro)  # (3.7)
    return ca.Function(
        "ballbot_imu",
        [x, tau, p, s, b_gyro, n_acc, n_gyro],
        [acc, gyro],
        ["x", "tau", "p", "s", "bias_gyro", "n_acc", "n_gyro"],
        ["acc", "gyro"],
    )


def make_gyro_bias_step() -> ca.Function:
    """Gyroscope bias random walk ``ballbot_gyro_bias_step(bias_gyro, s, Ts, n_rw) -> bias_next``.

    Exact discretisation of thesis (3.9), ``db/dt = w_bias`` with white ``w_bias`` of
    intensity ``Sigma_bias = diag(sigma_rw^2)``, over a period ``Ts``::

        b_{k+1} = b_k + sqrt(Ts) sigma_rw n_k,    n_k ~ N(0, I)

    so ``Var(b_k - b_0) = sigma_rw^2 k Ts``.  Inputs ``bias_gyro`` (3, rad/s), ``s``
    (NS), ``Ts`` (s), ``n_rw`` (3, standard normal); output ``bias_next`` (3, rad/s).
    """
    b, s = ca.SX.sym("bias_gyro", 3), ca.SX.sym("s", NS)
    Ts, n = ca.SX.sym("Ts"), ca.SX.sym("n_rw", 3)
    b_next = b + ca.sqrt(Ts) * SensorView(s).gyro_bias_rw * n
    return ca.Function("ballbot_gyro_bias_step", [b, s, Ts, n], [b_next],
                       ["bias_gyro", "s", "Ts", "n_rw"], ["bias_next"])


def encoder_count(phi: Any, n_ticks: Any) -> Any:
    """Accumulated tick count ``round(n_ticks / (2 pi) phi)``, thesis (3.11), (3.13).

    ``round(x) = sgn(x) floor(|x| + 0.5)`` (halves away from zero), on numpy arrays or
    CasADi expressions.
    """
    if isinstance(phi, (ca.SX, ca.MX, ca.DM)) or isinstance(n_ticks, (ca.SX, ca.MX, ca.DM)):
        c = n_ticks / (2 * math.pi) * phi
        return ca.sign(c) * ca.floor(ca.fabs(c) + 0.5)
    c = np.asarray(n_ticks, dtype=float) / (2 * math.pi) * np.asarray(phi, dtype=float)
    return np.sign(c) * np.floor(np.abs(c) + 0.5)


def make_encoders(np_: int | None = None) -> ca.Function:
    """Quantised encoders ``ballbot_encoders(phi, phi_prev, p, Ts) -> (enc, dticks)``.

    The thesis' encoder (3.11)-(3.14): the accumulated count of each wheel is the wheel
    angle quantised to ``n_ticks`` per revolution with ``round`` (3.13), and the reading
    over a sample period is the change of the count::

        dticks = round(n_ticks/(2 pi) phi) - round(n_ticks/(2 pi) phi_prev)     (3.14)
        enc    = dticks / Ts

    Quantising the accumulated angle (not each increment) means the counts never drift:
    the sum of ``dticks`` over any run is the count difference of its end points.  The
    quantisation error of ``dticks`` is below one tick (3.16); the filters model it as
    white noise of variance ``Sigma_enc = I/9`` ticks^2 (3.17), see
    :func:`make_encoder_model`.  No further noise is added here.  (When the wheel turns
    through many ticks per sample the two rounding errors are independent and uniform
    on [-1/2, 1/2], so the actual error variance is 1/12 + 1/12 = 1/6 tick^2, somewhat
    more than the thesis' 3-sigma estimate 1/9; it is also correlated between samples,
    since consecutive readings share a count.)

    Parameters
    ----------
    np_
        Length of the model parameter vector ``p`` (default: the package's ``NP``).

    Returns
    -------
    casadi.Function
        Inputs ``phi``, ``phi_prev`` (3 each, rad: wheel (motor-shaft) angles at the
        current and previous sample, integrated from the wheel speeds, see
        :func:`make_wheel_angle_ode`), ``p`` (NP; uses ``n_ticks``), ``Ts`` (s).
        Outputs ``enc`` (3, ticks/s) and ``dticks`` (3, ticks per sample, integers:
        the thesis' ``z_enc = Delta i_ticks``).
    """
    n = len(PARAM_NAMES) if np_ is None else np_
    phi, phi_prev = ca.SX.sym("phi", 3), ca.SX.sym("phi_prev", 3)
    p, Ts = ca.SX.sym("p", n), ca.SX.sym("Ts")
    n_ticks = ParamView(p).n_ticks
    dticks = encoder_count(phi, n_ticks) - encoder_count(phi_prev, n_ticks)  # (3.14)
    return ca.Function("ballbot_encoders", [phi, phi_prev, p, Ts], [dticks / Ts, dticks],
                       ["phi", "phi_prev", "p", "Ts"], ["enc", "dticks"])


def make_encoder_model(wheel_speeds: ca.Function) -> ca.Function:
    """Gaussian encoder model ``ballbot_encoder_model(x, p, s, Ts, n_enc) -> dticks``.

    Thesis (3.15), (3.17): ``z_enc = n_ticks/(2 pi) Ts dphi + sqrt(Sigma_enc) n_enc``,
    the continuous approximation of the quantised count change the filters use (the
    VUKF measurement (5.17) is this with ``n_enc = 0``).  ``dphi`` comes from calling
    ``wheel_speeds`` (B.47).  Inputs ``x`` (12), ``p`` (NP), ``s`` (NS), ``Ts`` (s),
    ``n_enc`` (3, standard normal); output ``dticks`` (3, ticks per sample).
    """
    np_ = _check_wheel_speeds(wheel_speeds)
    x, p, s = ca.MX.sym("x", 12), ca.MX.sym("p", np_), ca.MX.sym("s", NS)
    Ts, n = ca.MX.sym("Ts"), ca.MX.sym("n_enc", 3)
    dphi = wheel_speeds(x, p)
    z = (ParamView(p).n_ticks / (2 * math.pi) * Ts * dphi
         + ca.sqrt(SensorView(s).enc_noise_var) * n)
    return ca.Function("ballbot_encoder_model", [x, p, s, Ts, n], [z],
                       ["x", "p", "s", "Ts", "n_enc"], ["dticks"])


def make_wheel_angle_ode(ode: ca.Function, wheel_speeds: ca.Function) -> ca.Function:
    """State equation with wheel angles ``ballbot_ode_wheel_angles(xw, tau, p) -> xwdot``.

    ``xw = [x; phi]`` (15): the model state (12) and the three wheel (motor-shaft)
    angles (rad), with ``dphi/dt`` the inverse kinematics (B.47) from calling
    ``wheel_speeds``; the first 12 derivatives come from calling ``ode``.  Integrate it
    with :func:`~ballbot_casadi.model.integrators.make_rk4` to get the angles
    :func:`make_encoders` quantises.
    """
    nx, nu, np_ = _check_ode(ode)
    if _check_wheel_speeds(wheel_speeds) != np_:
        raise BallbotTypeError("ode and wheel_speeds take parameter vectors of different sizes")
    xw, tau, p = ca.MX.sym("xw", nx + 3), ca.MX.sym("tau", nu), ca.MX.sym("p", np_)
    x = xw[:nx]
    xwdot = ca.vertcat(ode(x, tau, p), wheel_speeds(x, p))
    return ca.Function("ballbot_ode_wheel_angles", [xw, tau, p], [xwdot],
                       ["xw", "tau", "p"], ["xwdot"])


# --------------------------------------------------------------------------- heading sensor


def yaw_of(q: Any) -> Any:
    """ZYX yaw of the body in {K} (rad, in (-pi, pi]) of a unit quaternion (numpy or CasADi):
    the angle a heading sensor reads."""
    return Q.to_rpy(q)[2]


def wrap_angle(a: Any) -> Any:
    """An angle (or array of angles) wrapped to ``(-pi, pi]`` (numpy or CasADi)."""
    if isinstance(a, (ca.SX, ca.MX)):
        return ca.atan2(ca.sin(a), ca.cos(a))
    return np.arctan2(np.sin(a), np.cos(a))


def make_heading_sensor() -> ca.Function:
    """Heading sensor ``ballbot_heading(q, s, n_heading) -> yaw`` (not in the thesis's robot).

    An absolute reading of the body's ZYX yaw in {K} (:func:`yaw_of`), the quantity the
    thesis's attitude filter cannot observe (§3.1, §4.2; ch. 11 "heading correction")::

        yaw_meas = wrap(yaw(q) + s.heading_bias + sqrt(s.heading_noise_var) n_heading)

    ``q`` (4, the plant attitude), ``s`` (NS sensor parameters), ``n_heading`` (standard
    normal, stream ``NOISE_STREAMS["heading"]``); output in rad, wrapped to ``(-pi, pi]``.
    The sensor samples at ``s.heading_rate`` (:func:`heading_schedule` gives the periods
    with a reading; the others are missing, like a dropout).
    """
    q, s, n = ca.SX.sym("q", 4), ca.SX.sym("s", NS), ca.SX.sym("n_heading")
    S = SensorView(s)
    yaw = wrap_angle(yaw_of(q) + S.heading_bias + ca.sqrt(S.heading_noise_var) * n)
    return ca.Function("ballbot_heading", [q, s, n], [yaw], ["q", "s", "n_heading"], ["yaw"])


def heading_schedule(k0: int, k1: int, Ts: float, rate: float) -> np.ndarray:
    """Availability (1/0) of the heading reading in control periods ``k0 .. k1-1``.

    The sensor samples at ``rate`` Hz (0: never); period ``k`` (time ``k Ts``) has a
    reading when a sample instant ``j / rate`` falls in ``[k Ts, (k+1) Ts)`` - at 10 Hz
    and ``Ts = 5 ms`` every 20th period, the first at ``t = 0``.  A chunked run gets the
    same readings (the schedule depends on the period index only).
    """
    k = np.arange(int(k0), int(k1))
    if not (math.isfinite(rate) and rate >= 0 and math.isfinite(Ts) and Ts > 0):
        raise ShapeError(f"heading schedule needs rate >= 0 and Ts > 0, got {rate!r}, {Ts!r}")
    if rate == 0:
        return np.zeros(k.size)
    eps = HEADING_SCHEDULE_EPS
    return (np.floor((k + 1) * Ts * rate - eps) > np.floor(k * Ts * rate - eps)).astype(float)

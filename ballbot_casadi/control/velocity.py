"""LQR velocity controller with integral action, the outer loop (thesis §7.1, §7.3).

``ballbot_velocity(x, v_ref, z, p, k, Ts) -> (q_ref, dq_ref, ddq_ref, z_next)``,
executed once per control period ``Ts``.

Structure
---------
The controller owns a *tilt reference model*, a double integrator per tilt axis whose
input is the tilt-reference acceleration ``a``; the LQR chooses ``a``.  The quaternion
reference and its derivatives are then exact functions of the reference-model state,
so the balance controller receives a consistent, smooth ``(q_ref, dq_ref, ddq_ref)``
and the inclination limits of thesis §7.1 are enforced on the model states:

* tilt ``theta_r = (theta_rx, theta_ry)``: rotations about the *inertial* x and y axes,
  ``q_ref = q_x(theta_rx) o q_y(theta_ry) o q_z(psi_r)``.  The body z axis,
  ``R(q_ref) e_z = (sin theta_ry, -sin theta_rx cos theta_ry, cos theta_rx cos theta_ry)``,
  does not depend on the heading, so one LQR gain serves every heading;
* heading ``psi_r`` and heading rate ``r_r``: a rate-limited first-order model of the
  heading-rate reference, ``dr_r = clip(k_r (r_ref - r_r), +-yaw_acc_max)``, so the
  heading acceleration fed forward to the balance controller is known exactly;
* position error ``p_e = integral (v - v_ref) dt`` (integral action: at standstill the
  ball holds its position, thesis §7.3; it also removes the run-away of a COM offset).

State ``z = [theta_rx, theta_ry, dtheta_rx, dtheta_ry, p_ex, p_ey, psi_r, r_r]`` (NZ = 8).

Inclination limits: the tilt acceleration is clipped so that the reference model's
rate stays within ``tilt_rate_max`` and never exceeds the braking rate
``sqrt(2 tilt_acc_max (tilt_max -+ theta_r))`` (in its exact discrete form), so the
reference reaches the tilt limit with zero rate (no jump in ``dq_ref``); a final
clamp guards the limit.

Feedback ``a = -K X`` with
``X = [dx - vx_ref, dy - vy_ref, theta - theta_eq, dtheta, theta_r - theta_eq, dtheta_r, p_e]``,
where ``theta = (theta_x, theta_y)``, ``theta_x = atan2(-n_y, n_z)``, ``theta_y = asin(n_x)``
are the measured inertial tilts from the body z axis ``n = R(q) e_z``, their rates
follow by automatic differentiation along ``dq``, and ``theta_eq`` is the balance point
of the controller model's centre of mass (:func:`equilibrium_tilt`: the tilt that puts
``(com_x, com_y, l)`` above the ball centre at the reference heading).  With a centred
COM ``theta_eq = +0`` exactly (the loop of thesis §7.3); with a known (or estimated,
:mod:`ballbot_casadi.estimation.com_observer`) offset the equilibrium tilt is
*commanded* instead of being integrated by ``p_e``, so at standstill ``p_e``, i.e. the
position error, returns to zero (position hold).

Design (:func:`design_velocity_lqr`): the model's Jacobians at the upright equilibrium
(``jac`` Function) reduced to ``[dx, dy, theta, dtheta]`` (at zero yaw
``q1 = theta_x/2``, ``q2 = theta_y/2``), closed by the *linearised* balance controller
(thesis 8.26 with 8.44: ``ddy = ddy_ref - K_p e - K_d de``, ``y = vec q``), augmented
with the reference model and the integrators, discretised exactly (ZOH, ``Ts``) and
solved with ``control.dlqr``.  The limits (``k`` tail) are, by default, the thesis §7.1
specifications: ``|theta_r| <= 5 deg`` per axis, ``|dtheta_r| <= 20 deg/s``,
``|a| <= 2 rad/s^2`` (torque budget, see :data:`VELOCITY_DEFAULT_LIMITS`),
``|v_ref| <= 0.5 m/s``, ``|psi_dot_ref| <= 1 rad/s``, heading acceleration
``<= 10 rad/s^2``; the
position-error integrator is clamped at ``p_e_max`` (anti-windup).

Gains ``k = [K (2x12, row-major), tilt_max, tilt_rate_max, tilt_acc_max, v_max,
yaw_rate_max, p_e_max, yaw_acc_max, k_r]`` (NKV = 32).
"""

from __future__ import annotations

import math
from typing import Any

import casadi as ca
import numpy as np
import scipy.linalg

from ballbot_casadi.core.layout import STATE, STATE_DXY, planar_maps
from ballbot_casadi.core.layout import VELOCITY_CONTROLLER_STATE as Z
from ballbot_casadi.control.dlqr import stabilising_dlqr
from ballbot_casadi.control.flc import FLC_DEFAULT_GAINS
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.constants import THESIS_LIMITS, TS_CONTROL
from ballbot_casadi.core.params import PARAM_NAMES
from ballbot_casadi.errors import (
    ArgumentError,
    BallbotTypeError,
    ParameterError,
    ShapeError,
)

__all__ = [
    "VELOCITY_NZ",
    "VELOCITY_NKV",
    "VELOCITY_LIMIT_NAMES",
    "VELOCITY_DEFAULT_LIMITS",
    "design_model",
    "design_velocity_lqr",
    "default_velocity_gains",
    "make_velocity_controller",
    "velocity_initial_state",
    "check_velocity_gains",
    "measured_tilt",
    "equilibrium_tilt",
    "tilt_heading_quaternion",
    "tilt_heading_reference",
]

VELOCITY_NZ = Z.size
_NX_LQR = 12  # [v_err(2), theta(2), dtheta(2), theta_r(2), dtheta_r(2), p_e(2)]
VELOCITY_LIMIT_NAMES = (
    "tilt_max", "tilt_rate_max", "tilt_acc_max", "v_max", "yaw_rate_max", "p_e_max",
    "yaw_acc_max", "k_r",
)
#: Thesis §7.1 specifications (5 deg, 20 deg/s, 0.5 m/s, 1 rad/s, 10 rad/s^2 heading
#: acceleration); ``p_e_max`` = 2 m anti-windup bound; heading-rate model bandwidth
#: ``k_r`` = 10 1/s.  The tilt-reference acceleration is limited to 2 rad/s^2, below the
#: 10 rad/s^2 of the specification: the wheels (1.98 N m) give the default robot about
#: 3.4 rad/s^2 of tilt acceleration, of which gravity uses ~0.9 rad/s^2 at 5 deg, so a
#: faster reference would only saturate the torques.
VELOCITY_DEFAULT_LIMITS = np.array([
    THESIS_LIMITS["tilt_max"], THESIS_LIMITS["tilt_rate_max"], 2.0, THESIS_LIMITS["v_max"],
    THESIS_LIMITS["yaw_rate_max"], 2.0, THESIS_LIMITS["yaw_acc_max"], 10.0,
])
VELOCITY_NKV = 2 * _NX_LQR + len(VELOCITY_LIMIT_NAMES)

#: Default LQR weights (Bryson's rule: 1/max^2 of the acceptable excursion).
_Q_DEFAULT = 1.0 / np.array(
    [0.04, 0.04, 1.0, 1.0, 1.0, 1.0, math.radians(5), math.radians(5),
     math.radians(20), math.radians(20), 0.1, 0.1]
) ** 2
_R_DEFAULT = 1.0 / np.array([1.0, 1.0]) ** 2
#: Inner-loop (balance) gains assumed by the design, FLC defaults (tilt axes).
_INNER_DEFAULT = (float(FLC_DEFAULT_GAINS[0]), float(FLC_DEFAULT_GAINS[3]))


def _check_jac(jac: ca.Function) -> None:
    if not (isinstance(jac, ca.Function) and jac.n_in() == 3 and jac.n_out() == 2
            and jac.size1_in(0) == 12):
        raise BallbotTypeError(
            "jac must be the model's CasADi Function jac(x[12], tau[3], p) -> (A, B) "
            "(e.g. make_model_functions()['jac'])"
        )


def design_model(
    jac: ca.Function, p: Any, Ts: float, inner: tuple[float, float] = _INNER_DEFAULT
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Continuous and ZOH-discretised design model ``(A, B, Ad, Bd)`` of the outer loop.

    State ``X`` as in the module docstring (12), input the tilt-reference acceleration
    (2).  ``inner = (K_p, K_d)`` are the balance controller's tilt gains.
    """
    _check_jac(jac)
    p = np.asarray(p, dtype=float).ravel()
    x0 = np.zeros(12)
    x0[2] = 1.0
    A, B = (np.asarray(M) for M in jac(x0, np.zeros(3), p))
    T, S = planar_maps()  # reduced plant s = [dx, dy, th_x, th_y, dth_x, dth_y]
    As, Bs = S @ A @ T, S @ B
    # linearised FLC: u = E^-1 (v - A_y x), y = vec q, v on the tilt outputs (8.26, 8.44)
    E = B[9:12]
    Ay = A[9:12] @ T
    kp, kd = inner
    # v (3) as a function of X = [s(6), th_r(2), dth_r(2), p_e(2)] and a (2)
    Vx = np.zeros((3, _NX_LQR))
    Va = np.zeros((3, 2))
    for i in range(2):
        Vx[i, 2 + i] = -kp * 0.5
        Vx[i, 4 + i] = -kd * 0.5
        Vx[i, 6 + i] = kp * 0.5
        Vx[i, 8 + i] = kd * 0.5
        Va[i, i] = 0.5
    Einv = np.linalg.inv(E)
    Ux = Einv @ (Vx - np.hstack([Ay, np.zeros((3, 6))]))
    Ua = Einv @ Va
    Ac = np.zeros((_NX_LQR, _NX_LQR))
    Bc = np.zeros((_NX_LQR, 2))
    Ac[0:6, 0:6] = As
    Ac[0:6] += Bs @ Ux
    Bc[0:6] = Bs @ Ua
    Ac[6:8, 8:10] = np.eye(2)
    Bc[8:10] = np.eye(2)
    Ac[10:12, 0:2] = np.eye(2)
    M = np.zeros((_NX_LQR + 2, _NX_LQR + 2))
    M[:_NX_LQR, :_NX_LQR] = Ac
    M[:_NX_LQR, _NX_LQR:] = Bc
    Md = scipy.linalg.expm(M * Ts)
    return Ac, Bc, Md[:_NX_LQR, :_NX_LQR], Md[:_NX_LQR, _NX_LQR:]


def design_velocity_lqr(
    jac: ca.Function,
    p: Any,
    Ts: float = TS_CONTROL,
    Qw: Any = None,
    Rw: Any = None,
    inner: tuple[float, float] = _INNER_DEFAULT,
) -> np.ndarray:
    """Discrete LQR gain (2x12) of the velocity loop, ``control.dlqr`` on :func:`design_model`.

    Parameters
    ----------
    jac
        The model's ``jac(x, tau, p) -> (A, B)`` Function.
    p
        Parameter vector of the design model.
    Ts
        Control period (s).
    Qw, Rw
        Diagonal state (12) and input (2) weights.  Default, Bryson's rule (weight =
        1/acceptable excursion^2): 0.04 m/s velocity error, 1 rad / 1 rad/s on the
        plant's tilt and tilt rate (left free: the balance loop owns them), the
        thesis §7.1 limits 5 deg and 20 deg/s on the tilt reference and its rate,
        0.1 m position error, against a tilt-reference acceleration of 1 rad/s^2.
        Closed-loop poles (default robot, Ts = 5 ms, double: one per axis):
        -0.4 (position-error integral), -2.7, -3.2 (velocity/tilt), -21 (tilt-reference
        model, a pre-filter the balance loop follows through its feedforward) and the
        balance loop's own -10: the velocity dynamics are >= 3x slower than the inner
        loop (thesis §7.1).  The velocity-to-position-error weight ratio trades the
        velocity-ramp shape against the speed of offset rejection (the ``velocity`` and
        ``com`` studies measure both; their reports hold the numbers).
    inner
        ``(K_p, K_d)`` of the balance controller's tilt channels (FLC defaults).

    Raises
    ------
    ParameterError
        "no stabilising velocity gain exists for these parameters": the design model
        cannot be built or is not finite, the discrete Riccati equation has no
        stabilising solution (e.g. ``g = 0``), or the closed loop is not stable.
    """

    if not (isinstance(Ts, (int, float)) and math.isfinite(Ts) and Ts > 0):
        raise ArgumentError(f"Ts must be a finite number > 0, got {Ts!r}")
    Qw = _Q_DEFAULT if Qw is None else np.asarray(Qw, dtype=float).ravel()
    Rw = _R_DEFAULT if Rw is None else np.asarray(Rw, dtype=float).ravel()
    if Qw.shape != (_NX_LQR,) or Rw.shape != (2,):
        raise ShapeError(f"Qw must have {_NX_LQR} and Rw 2 diagonal entries")
    none = "no stabilising velocity gain exists for these parameters"
    try:
        with np.errstate(all="ignore"):
            _, _, Ad, Bd = design_model(jac, p, Ts, inner)
    except np.linalg.LinAlgError:
        raise ParameterError(f"{none}: the balance loop of the design model cannot be "
                             "linearised (the wheel torques do not reach the tilt axes)") from None
    if not (np.all(np.isfinite(Ad)) and np.all(np.isfinite(Bd))):
        raise ParameterError(f"{none}: the discretised design model is not finite")
    return stabilising_dlqr(Ad, Bd, Qw, Rw, f"{none} (velocity LQR)")


def default_velocity_gains(jac: ca.Function, p: Any, Ts: float = TS_CONTROL) -> np.ndarray:
    """Default ``k`` (NKV = 30): the LQR gain of :func:`design_velocity_lqr` and the limits."""
    K = design_velocity_lqr(jac, p, Ts)
    return np.concatenate([K.ravel(), VELOCITY_DEFAULT_LIMITS])


def check_velocity_gains(k: Any) -> np.ndarray:
    """Validate a velocity-controller gain vector (NKV entries, finite, limits > 0).

    Raises
    ------
    ArgumentError
        Wrong length, non-finite entries or non-positive limits.
    """
    try:
        arr = np.asarray(k, dtype=float).ravel()
    except (TypeError, ValueError):
        raise ArgumentError(f"velocity gains must be numbers, got {k!r}") from None
    if arr.size != VELOCITY_NKV:
        raise ArgumentError(
            f"velocity gains need {VELOCITY_NKV} entries (2x{_NX_LQR} LQR gain, then "
            f"{', '.join(VELOCITY_LIMIT_NAMES)}), got {arr.size}"
        )
    if not np.all(np.isfinite(arr)):
        raise ArgumentError("velocity gains must be finite (NaN or inf found)")
    lim = arr[2 * _NX_LQR:]
    bad = [n for n, v in zip(VELOCITY_LIMIT_NAMES, lim) if not v > 0]
    if bad:
        raise ArgumentError(f"velocity limits must be > 0; invalid: {', '.join(bad)}")
    return arr


def tilt_heading_quaternion(th_x: Any, th_y: Any, psi: Any) -> Any:
    """``q_x(th_x) o q_y(th_y) o q_z(psi)`` for numpy or CasADi scalars."""
    cas = any(isinstance(a, (ca.SX, ca.MX)) for a in (th_x, th_y, psi))
    cos, sin = (ca.cos, ca.sin) if cas else (np.cos, np.sin)
    qx = [cos(th_x / 2), sin(th_x / 2), 0 * th_x, 0 * th_x]
    qy = [cos(th_y / 2), 0 * th_y, sin(th_y / 2), 0 * th_y]
    qz = [cos(psi / 2), 0 * psi, 0 * psi, sin(psi / 2)]
    col = ca.vertcat if cas else (lambda *a: np.array(a, dtype=float))
    return Q.mul(Q.mul(col(*qx), col(*qy)), col(*qz))


def equilibrium_tilt(p: Any, psi: Any) -> Any:
    """Inertial tilts ``(theta_x, theta_y)`` of the balance point at heading ``psi``.

    The balance point puts the body COM ``p_com = (com_x, com_y, l)`` of the parameter
    vector ``p`` straight above the ball centre (zero gravity torque, thesis C.21): with
    ``u = R_z(psi) p_com``, ``q_x(theta_x) o q_y(theta_y) o q_z(psi)`` maps ``p_com`` to
    the vertical iff ``theta_x = atan2(u_y, hypot(u_x, u_z))`` and
    ``theta_y = atan2(-u_x, u_z)``.  For a centred COM both are exactly ``+0`` (so
    subtracting them leaves every tilt bit for bit unchanged).  numpy or CasADi.
    """
    cas = any(isinstance(a, (ca.SX, ca.MX)) for a in (p, psi))
    i = PARAM_NAMES.index
    cx, cy, l = p[i("com_x")], p[i("com_y")], p[i("l")]
    if cas:
        c, s = ca.cos(psi), ca.sin(psi)
        ux, uy = c * cx - s * cy, s * cx + c * cy
        th = ca.vertcat(ca.atan2(uy, ca.sqrt(ux**2 + l**2)), ca.atan2(-ux, l))
        return ca.if_else(ca.fabs(th) > 0, th, 0)
    c, s = np.cos(psi), np.sin(psi)
    ux, uy = c * cx - s * cy, s * cx + c * cy
    th = np.array([np.arctan2(uy, np.hypot(ux, l)), np.arctan2(-ux, l)], dtype=float)
    return np.where(np.abs(th) > 0, th, 0.0)


def measured_tilt(q: Any) -> Any:
    """Inertial tilts ``(theta_x, theta_y)`` of the body z axis ``n = R(q) e_z``."""
    cas = isinstance(q, (ca.SX, ca.MX))
    q0, q1, q2, q3 = (q[i] for i in range(4))
    nx = 2 * (q1 * q3 + q0 * q2)
    ny = 2 * (q2 * q3 - q0 * q1)
    nz = q0**2 - q1**2 - q2**2 + q3**2
    if cas:
        return ca.vertcat(ca.atan2(-ny, nz), ca.asin(ca.fmin(ca.fmax(nx, -1), 1)))
    return np.array([np.arctan2(-ny, nz), np.arcsin(np.clip(nx, -1, 1))])


def velocity_initial_state(x0: Any) -> np.ndarray:
    """Controller state ``z`` matching a plant state: reference = measured tilt and heading.

    Tilt rates and the position error start at zero, so starting the loop is bumpless.
    """
    x0 = np.asarray(x0, dtype=float).ravel()
    if x0.shape != (STATE.size,) or not np.all(np.isfinite(x0)):
        raise ShapeError(f"x0 must be a finite 12-state, got shape {x0.shape}")
    q = x0[STATE["q"]] / np.linalg.norm(x0[STATE["q"]])
    th = measured_tilt(q)
    qt = tilt_heading_quaternion(th[0], th[1], 0.0)
    qz = Q.mul(Q.conj(qt), q)
    z = np.zeros(Z.size)
    z[Z["theta_r"]] = th
    z[Z.index("psi_r")] = 2 * np.arctan2(qz[3], qz[0])
    return z


def tilt_heading_reference(name: str = "tilt_heading_reference") -> ca.Function:
    """``(s, ds, dds) -> (q, dq, ddq)`` for ``s = [theta_x, theta_y, psi]``, by AD: the
    quaternion reference of a tilt and heading and its first two derivatives (Function
    ``name``; the velocity controller's and the balance-feed guidance's references)."""
    s, ds, dds = ca.SX.sym("s", 3), ca.SX.sym("ds", 3), ca.SX.sym("dds", 3)
    q = tilt_heading_quaternion(s[0], s[1], s[2])
    dq = ca.jtimes(q, s, ds)
    ddq = ca.jtimes(dq, ca.vertcat(s, ds), ca.vertcat(ds, dds))
    return ca.Function(name, [s, ds, dds], [q, dq, ddq])


def make_velocity_controller() -> ca.Function:
    """Build ``ballbot_velocity`` (thesis §7.3; see the module docstring).

    Returns
    -------
    casadi.Function
        ``ballbot_velocity(x[12], v_ref[3], z[8], p[NP], k[32], Ts) ->
        (q_ref[4], dq_ref[4], ddq_ref[4], z_next[8])``.  ``v_ref = [vx, vy, yaw_rate]``
        (inertial, m/s and rad/s); ``p`` is the controller's internal model: its
        centre of mass sets the balance point ``theta_eq`` (:func:`equilibrium_tilt`),
        the rest of the model enters through the gain ``k``.
    """

    x = ca.SX.sym("x", 12)
    v_ref = ca.SX.sym("v_ref", 3)
    z = ca.SX.sym("z", VELOCITY_NZ)
    p = ca.SX.sym("p", len(PARAM_NAMES))
    k = ca.SX.sym("k", VELOCITY_NKV)
    Ts = ca.SX.sym("Ts")
    K = ca.reshape(k[: 2 * _NX_LQR], _NX_LQR, 2).T  # row-major 2x12
    tilt_max, rate_max, acc_max, v_max, r_max, pe_max, yacc_max, k_r = (
        k[2 * _NX_LQR + i] for i in range(len(VELOCITY_LIMIT_NAMES))
    )

    # reference limits (thesis §7.1)
    speed = ca.sqrt(v_ref[0] ** 2 + v_ref[1] ** 2)
    scale = ca.fmin(1, v_max / ca.fmax(speed, 1e-12))
    vr = ca.vertcat(v_ref[0] * scale, v_ref[1] * scale)
    rr = ca.fmin(ca.fmax(v_ref[2], -r_max), r_max)

    # measurements
    q, dq = x[STATE["q"]], x[STATE["dq"]]
    th = measured_tilt(q)
    dth = ca.jtimes(th, q, dq)
    th_r, dth_r, pe = z[Z["theta_r"]], z[Z["dtheta_r"]], z[Z["p_e"]]
    psi_r, r_r = z[Z.index("psi_r")], z[Z.index("r_r")]
    verr = x[STATE_DXY] - vr
    # tilts about the balance point of the model's COM (exactly +0 for a centred COM)
    th_eq = equilibrium_tilt(p, psi_r)
    X = ca.vertcat(verr, th - th_eq, dth, th_r - th_eq, dth_r, pe)
    a = -ca.mtimes(K, X)
    a = ca.fmin(ca.fmax(a, -acc_max), acc_max)
    # braking bound: the next rate v_n must allow stopping at +-tilt_max with acc_max:
    # th_n + v_n^2 / (2 acc_max) <= tilt_max with th_n = th + Ts (dth + v_n) / 2
    h = 0.5 * acc_max * Ts
    ub = ca.fmin(rate_max, -h + ca.sqrt(h**2 + 2 * acc_max * ca.fmax(
        tilt_max - th_r - 0.5 * Ts * dth_r, 0)))
    lb = -ca.fmin(rate_max, -h + ca.sqrt(h**2 + 2 * acc_max * ca.fmax(
        tilt_max + th_r + 0.5 * Ts * dth_r, 0)))
    a = ca.fmin(ca.fmax(a, (lb - dth_r) / Ts), (ub - dth_r) / Ts)
    alpha = ca.fmin(ca.fmax(k_r * (rr - r_r), -yacc_max), yacc_max)

    # quaternion reference and its exact derivatives along the reference model
    q_ref, dq_ref, ddq_ref = tilt_heading_reference()(
        ca.vertcat(th_r, psi_r), ca.vertcat(dth_r, r_r), ca.vertcat(a, alpha)
    )

    # reference-model update with the inclination limits, integrators with anti-windup
    th_n = th_r + Ts * dth_r + 0.5 * Ts**2 * a
    dth_n = dth_r + Ts * a
    over = ca.fabs(th_n) > tilt_max
    outward = th_n * dth_n > 0
    dth_n = ca.if_else(over * outward, 0, dth_n)
    th_n = ca.fmin(ca.fmax(th_n, -tilt_max), tilt_max)
    pe_n = ca.fmin(ca.fmax(pe + Ts * verr, -pe_max), pe_max)
    z_next = ca.vertcat(
        th_n, dth_n, pe_n, psi_r + Ts * r_r + 0.5 * Ts**2 * alpha, r_r + Ts * alpha
    )
    return ca.Function(
        "ballbot_velocity",
        [x, v_ref, z, p, k, Ts],
        [q_ref, dq_ref, ddq_ref, z_next],
        ["x", "v_ref", "z", "p", "k", "Ts"],
        ["q_ref", "dq_ref", "ddq_ref", "z_next"],
    )

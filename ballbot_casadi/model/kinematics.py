"""Ballbot kinematics (thesis App. B): wheel geometry, inverse and forward kinematics.

All functions take a :class:`~ballbot_casadi.core.params.ParamView` (or anything with the
parameter names as attributes) and work on numpy arrays or CasADi expressions.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from ballbot_casadi.core import quaternion as Q

__all__ = [
    "W_tilde",
    "W",
    "contact_points",
    "ball_angular_velocity",
    "body_angular_velocity",
    "ball_body_angular_velocity",
    "wheel_speeds",
    "forward_kinematics",
]


def _cas(*a: Any) -> bool:
    return any(isinstance(x, (ca.SX, ca.MX, ca.DM)) for x in a)


def W_tilde(P: Any) -> Any:
    """Wheel map W~ (3x4), ``dphi = W~ ^omega_{K'|B}`` (thesis B.45, B.46).

    Row i is ``(rk/rw) [0, -cos(i gamma) cos(alpha), -sin(i gamma) cos(alpha), sin(alpha)]``
    for wheels i = 0, 1, 2 (thesis wheel order).
    """
    cas = _cas(P.alpha, P.gamma, P.rk, P.rw)
    cos, sin = (ca.cos, ca.sin) if cas else (np.cos, np.sin)
    k = P.rk / P.rw
    ca_, sa = cos(P.alpha), sin(P.alpha)
    cg, sg = cos(P.gamma), sin(P.gamma)
    # cos/sin of i*gamma by the double-angle identities: one sin/cos pair per parameter
    # keeps the generated C free of redundant trigonometric calls.
    cs = [(1.0, 0.0), (cg, sg), (cg * cg - sg * sg, 2 * sg * cg)]
    rows = [[0 * k, -k * ci * ca_, -k * si * ca_, k * sa] for ci, si in cs]
    if cas:
        return ca.vertcat(*[ca.horzcat(*r) for r in rows])
    return np.array(rows, dtype=float)


def W(P: Any) -> Any:
    """Square wheel map W = W~ [0; I3] (3x3), ``dphi = W omega_{K'|B}`` (thesis B.50)."""
    return W_tilde(P)[:, 1:]


def contact_points(P: Any) -> np.ndarray:
    """Body-frame wheel contact points p_Ci (rows; thesis B.30), numeric parameters only."""
    return np.array(
        [
            P.rk
            * np.array(
                [
                    np.cos(i * P.gamma) * np.sin(P.alpha),
                    np.sin(i * P.gamma) * np.sin(P.alpha),
                    np.cos(P.alpha),
                ]
            )
            for i in range(3)
        ]
    )


def ball_angular_velocity(dx: Any, dy: Any, P: Any) -> Any:
    """Ball angular velocity in {K} from no-slip rolling: ``(1/rk) [-dy, dx, 0]`` (thesis B.9)."""
    if _cas(dx, dy, P.rk):
        return ca.vertcat(-dy, dx, 0) / P.rk
    return np.array([-dy, dx, 0.0]) / P.rk


def body_angular_velocity(q: Any, dq: Any) -> Any:
    """Body angular velocity in {B}: ``v(2 Phi(q)^T dq)`` (thesis B.16, E.33)."""
    if _cas(q, dq):
        return Q.vee(2 * ca.mtimes(Q.Phi(q).T, dq))
    return Q.vee(2 * Q.Phi(q).T @ np.asarray(dq, dtype=float))


def ball_body_angular_velocity(q: Any, dq: Any, dx: Any, dy: Any, P: Any) -> Any:
    """Ball angular velocity relative to the body, in {B} (thesis B.21).

    ``omega_{K'|B} = v(Phi(q)^T Gamma(q) ^omega_K - 2 Phi(q)^T dq)``.
    """
    wk = ball_angular_velocity(dx, dy, P)
    if _cas(q, dq, wk):
        return Q.vee(ca.mtimes(Q.Phi(q).T, ca.mtimes(Q.Gamma(q), Q.hat(wk)) - 2 * dq))
    return Q.vee(Q.Phi(q).T @ (Q.Gamma(q) @ Q.hat(wk) - 2 * np.asarray(dq, dtype=float)))


def wheel_speeds(q: Any, dq: Any, dx: Any, dy: Any, P: Any) -> Any:
    """Wheel (motor-shaft) angular velocities dphi (inverse kinematics, thesis B.47)."""
    w = ball_body_angular_velocity(q, dq, dx, dy, P)
    if _cas(w, P.rk):
        return ca.mtimes(W(P), w)
    return W(P) @ w


def forward_kinematics(q: Any, dq: Any, dphi: Any, P: Any) -> Any:
    """Ball velocity (dx, dy) from wheel speeds and attitude (forward kinematics, B.51-B.55).

    ``omega_{K'|B} = W^-1 dphi``; rotating ``omega_{K'|B} + omega_{B|K}`` to {K} gives
    the ball angular velocity, and (B.9) gives ``dx = rk w_y``, ``dy = -rk w_x``.
    (The printed B.54/B.55 write ``q* o q`` where ``q* o dq`` is meant.)
    """
    if _cas(q, dq, dphi, P.rk):
        wkb = ca.solve(W(P), dphi)
        wk = Q.rotate(q, wkb + body_angular_velocity(q, dq))
        return ca.vertcat(P.rk * wk[1], -P.rk * wk[0])
    wkb = np.linalg.solve(W(P), np.asarray(dphi, dtype=float))
    wk = Q.rotate(q, wkb + body_angular_velocity(q, dq))
    return np.array([P.rk * wk[1], -P.rk * wk[0]])

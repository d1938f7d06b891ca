"""Body-frame quaternion tracking error (thesis §7.4) and its time derivatives.

The error of the attitude ``q = ^K_B q`` with respect to the reference ``q_ref`` is
expressed in the body frame by left-multiplying the conjugate reference (thesis 7.4)::
    q_e = q_ref* o q

Its derivatives follow from the product rule (thesis 7.5, E.35)::
    dq_e  = dq_ref* o q + q_ref* o dq
    ddq_e = ddq_ref* o q + 2 dq_ref* o dq + q_ref* o ddq

Because of the double cover, ``q_e`` and ``-q_e`` describe the same rotation; the
shortest path (rotation angle <= 180 deg) is the one with a non-negative scalar part,
so every error and derivative is multiplied by ``sigma = sign(q_e0)`` (``+1`` for
``q_e0 = 0``), the sign fix of thesis §7.4.

Every function works on numpy arrays and on CasADi SX/MX columns alike.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from ballbot_casadi.core import quaternion as Q

__all__ = [
    "shortest_path_sign",
    "quaternion_error",
    "quaternion_error_rate",
    "quaternion_error_accel",
    "make_quaternion_error",
]


def _is_ca(*a: Any) -> bool:
    return any(isinstance(v, (ca.SX, ca.MX, ca.DM)) for v in a)


def _mul(a: Any, b: Any) -> Any:
    if _is_ca(a, b):
        return ca.mtimes(Q.Phi(a), b)
    return Q.Phi(a) @ np.asarray(b, dtype=float)


def shortest_path_sign(q_e: Any) -> Any:
    """``+1`` if the scalar part of ``q_e`` is >= 0, else ``-1`` (thesis §7.4).

    Multiplying an error quaternion (and its derivatives) by this sign selects the
    representation with rotation angle <= 180 deg.
    """
    if _is_ca(q_e):
        return ca.if_else(q_e[0] < 0, -1, 1)
    return -1.0 if float(np.asarray(q_e, dtype=float)[0]) < 0 else 1.0


def quaternion_error(q: Any, q_ref: Any) -> Any:
    """Raw body-frame error ``q_e = q_ref* o q`` (thesis 7.4), no sign fix."""
    return _mul(Q.conj(q_ref), q)


def quaternion_error_rate(q: Any, dq: Any, q_ref: Any, dq_ref: Any) -> Any:
    """Raw error derivative ``dq_e = dq_ref* o q + q_ref* o dq`` (thesis 7.5), no sign fix."""
    return _mul(Q.conj(dq_ref), q) + _mul(Q.conj(q_ref), dq)


def quaternion_error_accel(
    q: Any, dq: Any, ddq: Any, q_ref: Any, dq_ref: Any, ddq_ref: Any
) -> Any:
    """Raw second derivative ``ddq_e = ddq_ref* o q + 2 dq_ref* o dq + q_ref* o ddq``.

    The time derivative of thesis (7.5); no sign fix.
    """
    return _mul(Q.conj(ddq_ref), q) + 2 * _mul(Q.conj(dq_ref), dq) + _mul(Q.conj(q_ref), ddq)


def make_quaternion_error() -> ca.Function:
    """``ballbot_quaternion_error(q, dq, q_ref, dq_ref) -> (q_e, dq_e, sigma)``.

    Body-frame error (thesis 7.4) and its derivative (thesis 7.5) after the
    shortest-path sign fix (thesis §7.4); ``sigma`` is the applied sign (+1 or -1).
    """
    q, dq, q_ref, dq_ref = (ca.SX.sym(n, 4) for n in ("q", "dq", "q_ref", "dq_ref"))
    qe = quaternion_error(q, q_ref)
    sigma = shortest_path_sign(qe)
    dqe = quaternion_error_rate(q, dq, q_ref, dq_ref)
    return ca.Function(
        "ballbot_quaternion_error",
        [q, dq, q_ref, dq_ref],
        [sigma * qe, sigma * dqe, sigma],
        ["q", "dq", "q_ref", "dq_ref"],
        ["q_e", "dq_e", "sigma"],
    )

"""Quaternion operators of thesis App. E, for numpy arrays and CasADi SX/MX alike.

Quaternions are scalar-first Hamilton quaternions ``q = [q0, q1, q2, q3]``.  The
attitude quaternion of the model is q = ^K_B q: it rotates body-frame vectors into
the ball frame {K}, ``p_K = q o p_B o q*`` (E.24).

Every function accepts either a numpy array (shape (4,) or (3,)) and then returns numpy
arrays, or a CasADi ``SX``/``MX``/``DM`` column and then returns CasADi expressions.
"""

from __future__ import annotations

from typing import Any, Sequence

import casadi as ca
import numpy as np

__all__ = [
    "Phi",
    "Gamma",
    "conj",
    "mul",
    "hat",
    "vee",
    "rotate",
    "rotate_inv",
    "rotation_matrix",
    "exp",
    "log",
    "from_rotation_vector",
    "to_rotation_vector",
    "from_rpy",
    "to_rpy",
    "norm",
]

_CASADI = (ca.SX, ca.MX, ca.DM)


def _is_ca(*args: Any) -> bool:
    return any(isinstance(a, _CASADI) for a in args)


def _elems(v: Any, n: int) -> list:
    """Components of a length-n vector as a list (numpy floats or CasADi scalars)."""
    if isinstance(v, _CASADI):
        if v.numel() != n:
            raise ValueError(f"expected a CasADi vector with {n} elements, got shape {v.shape}")
        return [v[i] for i in range(n)]
    arr = np.asarray(v, dtype=float)
    if arr.shape != (n,):
        raise ValueError(f"expected an array of shape ({n},), got shape {arr.shape}")
    return list(arr)


def _mat(rows: Sequence[Sequence[Any]], cas: bool) -> Any:
    if cas:
        return ca.vertcat(*[ca.horzcat(*r) for r in rows])
    return np.array(rows, dtype=float)


def _col(items: Sequence[Any], cas: bool) -> Any:
    return ca.vertcat(*items) if cas else np.array(items, dtype=float)


def Phi(q: Any) -> Any:
    """Left-multiplication matrix, ``q o p = Phi(q) p`` (thesis E.11)."""
    cas = _is_ca(q)
    q0, q1, q2, q3 = _elems(q, 4)
    return _mat(
        [[q0, -q1, -q2, -q3], [q1, q0, -q3, q2], [q2, q3, q0, -q1], [q3, -q2, q1, q0]], cas
    )


def Gamma(p: Any) -> Any:
    """Right-multiplication matrix, ``q o p = Gamma(p) q`` (thesis E.12)."""
    cas = _is_ca(p)
    p0, p1, p2, p3 = _elems(p, 4)
    return _mat(
        [[p0, -p1, -p2, -p3], [p1, p0, p3, -p2], [p2, -p3, p0, p1], [p3, p2, -p1, p0]], cas
    )


def conj(q: Any) -> Any:
    """Conjugate ``q* = [q0, -q1, -q2, -q3]`` (thesis E.15)."""
    cas = _is_ca(q)
    q0, q1, q2, q3 = _elems(q, 4)
    return _col([q0, -q1, -q2, -q3], cas)


def mul(q: Any, p: Any) -> Any:
    """Quaternion product ``q o p`` (thesis E.9, E.10)."""
    return Phi(q) @ p if not _is_ca(q, p) else ca.mtimes(Phi(q), p)


def hat(v: Any) -> Any:
    """Pure quaternion of a 3-vector, ``^v = [0, v]`` (thesis E.6)."""
    cas = _is_ca(v)
    return _col([0.0, *_elems(v, 3)], cas)


def vee(q: Any) -> Any:
    """Vector part of a quaternion, ``v(q) = [q1, q2, q3]`` (thesis E.7)."""
    cas = _is_ca(q)
    return _col(_elems(q, 4)[1:], cas)


def norm(q: Any) -> Any:
    """Euclidean norm (thesis E.18)."""
    return ca.norm_2(q) if _is_ca(q) else float(np.linalg.norm(np.asarray(q, dtype=float)))


def rotate(q: Any, v: Any) -> Any:
    """Rotate a body-frame vector into {K}: ``v(Phi(q) Gamma(q)^T ^v)`` (thesis E.24, B.11)."""
    if _is_ca(q, v):
        return vee(ca.mtimes(ca.mtimes(Phi(q), Gamma(q).T), hat(v)))
    return vee(Phi(q) @ Gamma(q).T @ hat(v))


def rotate_inv(q: Any, v: Any) -> Any:
    """Rotate a {K}-frame vector into the body frame: ``v(Phi(q)^T Gamma(q) ^v)`` (E.25-E.27)."""
    if _is_ca(q, v):
        return vee(ca.mtimes(ca.mtimes(Phi(q).T, Gamma(q)), hat(v)))
    return vee(Phi(q).T @ Gamma(q) @ hat(v))


def rotation_matrix(q: Any) -> Any:
    """3x3 rotation matrix R(q) with ``rotate(q, v) = R(q) v`` (lower-right block of Phi Gamma^T)."""
    if _is_ca(q):
        return ca.mtimes(Phi(q), Gamma(q).T)[1:, 1:]
    return (Phi(q) @ Gamma(q).T)[1:, 1:]


def _cos_sinc(n2: Any, cas: bool) -> tuple[Any, Any]:
    """cos(n) and sin(n)/n of n = sqrt(n2), with Taylor branches near 0 (finite derivatives)."""
    if cas:
        small = n2 < 1e-12
        n = ca.sqrt(ca.if_else(small, 1, n2))
        c = ca.if_else(small, 1 - n2 / 2, ca.cos(n))
        sinc = ca.if_else(small, 1 - n2 / 6, ca.sin(n) / n)
        return c, sinc
    if n2 < 1e-12:
        return 1 - n2 / 2, 1 - n2 / 6
    n = float(np.sqrt(n2))
    return float(np.cos(n)), float(np.sin(n) / n)


def exp(v: Any) -> Any:
    """Quaternion exponential of the pure quaternion ``^v``: ``[cos|v|, sin|v| v/|v|]``.

    ``exp(r/2)`` is the unit quaternion of a rotation by the rotation vector ``r``.
    """
    cas = _is_ca(v)
    vx, vy, vz = _elems(v, 3)
    c, s = _cos_sinc(vx**2 + vy**2 + vz**2, cas)
    return _col([c, s * vx, s * vy, s * vz], cas)


def log(q: Any) -> Any:
    """Logarithm of a unit quaternion, the 3-vector ``v`` with ``exp(v) = q``.

    The result is taken on the shortest path (``q0 >= 0`` branch), so ``|v| <= pi/2``.
    """
    cas = _is_ca(q)
    q0, q1, q2, q3 = _elems(q, 4)
    if cas:
        sgn = ca.if_else(q0 < 0, -1, 1)
        q0, q1, q2, q3 = sgn * q0, sgn * q1, sgn * q2, sgn * q3
        nv = ca.sqrt(q1**2 + q2**2 + q3**2)
        ang = ca.atan2(nv, q0)
        k = ca.if_else(nv < 1e-9, 1 / q0, ang / ca.if_else(nv < 1e-9, 1, nv))
        return ca.vertcat(k * q1, k * q2, k * q3)
    if q0 < 0:
        q0, q1, q2, q3 = -q0, -q1, -q2, -q3
    nv = float(np.sqrt(q1**2 + q2**2 + q3**2))
    ang = float(np.arctan2(nv, q0))
    k = 1.0 / q0 if nv < 1e-9 else ang / nv
    return np.array([k * q1, k * q2, k * q3])


def from_rotation_vector(r: Any) -> Any:
    """Unit quaternion of the rotation vector ``r`` (axis * angle): ``exp(r/2)``."""
    return exp(r * 0.5) if _is_ca(r) else exp(np.asarray(r, dtype=float) * 0.5)


def to_rotation_vector(q: Any) -> Any:
    """Rotation vector (axis * angle, angle in [0, pi]) of a unit quaternion: ``2 log(q)``."""
    return 2 * log(q)


def from_rpy(roll: Any, pitch: Any, yaw: Any) -> Any:
    """Quaternion of ZYX Euler angles: ``q = qz(yaw) o qy(pitch) o qx(roll)``."""
    cas = _is_ca(roll, pitch, yaw) or any(isinstance(a, (ca.SX, ca.MX)) for a in (roll, pitch, yaw))
    cos, sin = (ca.cos, ca.sin) if cas else (np.cos, np.sin)
    cr, sr = cos(roll / 2), sin(roll / 2)
    cp, sp = cos(pitch / 2), sin(pitch / 2)
    cy, sy = cos(yaw / 2), sin(yaw / 2)
    return _col(
        [
            cr * cp * cy + sr * sp * sy,
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
        ],
        cas,
    )


def to_rpy(q: Any) -> Any:
    """ZYX roll, pitch, yaw of a unit quaternion (inverse of :func:`from_rpy`).

    A numpy array of quaternion rows (N, 4) gives an (N, 3) array.
    """
    cas = _is_ca(q)
    if not cas and np.ndim(q) == 2:
        arr = np.asarray(q, dtype=float)
        if arr.shape[1] != 4:
            raise ValueError(f"expected quaternion rows of shape (N, 4), got {arr.shape}")
        q0, q1, q2, q3 = arr.T
    else:
        q0, q1, q2, q3 = _elems(q, 4)
    atan2 = ca.atan2 if cas else np.arctan2
    s = 2 * (q0 * q2 - q3 * q1)
    if cas:
        s = ca.fmin(ca.fmax(s, -1), 1)
        asin = ca.asin
    else:
        s = np.clip(s, -1.0, 1.0)
        asin = np.arcsin
    roll = atan2(2 * (q0 * q1 + q2 * q3), 1 - 2 * (q1**2 + q2**2))
    pitch = asin(s)
    yaw = atan2(2 * (q0 * q3 + q1 * q2), 1 - 2 * (q2**2 + q3**2))
    if not cas and np.ndim(q) == 2:
        return np.stack([roll, pitch, yaw], axis=1)
    return _col([roll, pitch, yaw], cas)

"""Input-output decoupling shared by the balance controllers (thesis 8.12-8.26).

Output ``y = vec(sigma q_e)``: the vector part of the shortest-path body-frame error
quaternion (thesis 7.4, §7.4).  Differentiating twice with the model's control-affine
split ``ddchi = f(x, p) + g(x, p) tau`` (thesis 8.1, 8.5, 8.6) gives (thesis 8.12)::
    ddy = D(x) + E(x) tau
    D   = sigma vec(ddq_ref* o q + 2 dq_ref* o dq + q_ref* o f_q)     (8.14, 8.20-8.22)
    E   = sigma [Phi(q_ref*) g_q]_{rows 1..3}                          (8.13, 8.24, 8.25)

where ``f_q = f[2:6]`` and ``g_q = g[2:6, :]`` are the quaternion rows.  For
``q_ref = 1`` this is exactly the thesis' ``D = [f4 f5 f6]``, ``E = g~_{6..8,:}``; for a
moving reference it is the exact form of the error dynamics that the thesis
approximates in (8.43, 8.44), so the closed loop obeys (8.45) without approximation.

Structure of E: the torques only act tangentially to the unit sphere, so
``E = sigma/2 (q_e0 I + [vec q_e]x) G`` with ``G = 2 vec(Phi(q)^T g_q)`` the torque ->
body angular acceleration map.  The kinematic factor has singular values
``(1, 1, |q_e0|)``: E is singular for a 180 deg error.  ``G`` is never singular for the
thesis robot but its tilt singular values fall ~10x at large tilt (reciprocal
Frobenius condition number ``rcond(G)`` from 0.05 upright to 0.005 at ~110 deg).

Inversion (thesis 8.26) is done as damped least squares,
``tau = (E^T E + lambda^2 I)^-1 E^T (v - D)``.  The conditioning margin
``m = min(|q_e0| / q_e0_min, rcond(G) / rcond_min)`` (defaults 0.05, i.e. an error
angle above 174 deg, and 0.01, a tilt beyond ~95 deg) is >= 1 in normal operation,
where ``lambda = 0`` and the inverse is exact; below 1, ``lambda^2 = mu^2 ||E||_F^2
(1 - m)`` rises continuously from zero, the torque stays finite and continuous (no
NaN even for an exactly singular E), and the flag ``singular = 1`` is reported.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

from ballbot_casadi.core.layout import GENERALISED, STATE
from ballbot_casadi.control.quaternion_error import (
    quaternion_error,
    quaternion_error_rate,
    shortest_path_sign,
)
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.errors import BallbotTypeError

__all__ = [
    "check_affine",
    "error_output_dynamics",
    "damped_solve",
    "DampedInverse",
    "solve3",
    "QE0_MIN",
    "RCOND_MIN",
    "DAMPING_MU",
]

#: Scalar part of the error quaternion below which E counts as near-singular (174 deg).
QE0_MIN = 0.05
#: Reciprocal Frobenius condition number of G below which E counts as near-singular.
#: Default robot: 0.05 upright, 0.012 at 90 deg, minimum 0.005 near 110 deg tilt.
RCOND_MIN = 0.01
#: Relative damping at the singularity: cond(E^T E + lambda^2 I) <= 1/mu^2 = 100.
DAMPING_MU = 0.1


def check_affine(affine: ca.Function) -> tuple[int, int]:
    """Validate the ``affine(x, p) -> (f, g)`` model Function; return ``(nx, np)``."""
    ok = (
        isinstance(affine, ca.Function)
        and affine.n_in() == 2
        and affine.n_out() == 2
        and affine.size1_in(0) == 12
        and affine.size_out(0) == (6, 1)
        and affine.size_out(1) == (6, 3)
    )
    if not ok:
        raise BallbotTypeError(
            "affine must be the model's CasADi Function affine(x[12], p) -> (f[6], g[6x3]) "
            "(e.g. make_model_functions()['affine'])"
        )
    return affine.size1_in(0), affine.size1_in(1)


def error_output_dynamics(
    x: ca.MX, q_ref: ca.MX, dq_ref: ca.MX, ddq_ref: ca.MX, f: ca.MX, g: ca.MX
) -> dict[str, ca.MX]:
    """Output ``y``, ``dy`` and the decoupling terms ``D``, ``E`` (see module docstring).

    Returns
    -------
    dict
        ``y`` (3), ``dy`` (3), ``D`` (3), ``E`` (3x3), ``sigma`` (scalar), ``qe0``
        (normalised scalar part of the sign-fixed error, >= 0) and ``G`` (3x3 torque
        -> body angular acceleration map).
    """
    q, dq = x[STATE["q"]], x[STATE["dq"]]
    qe = quaternion_error(q, q_ref)
    sigma = shortest_path_sign(qe)
    dqe = quaternion_error_rate(q, dq, q_ref, dq_ref)
    Pr = Q.Phi(Q.conj(q_ref))
    drift = (
        ca.mtimes(Q.Phi(Q.conj(ddq_ref)), q)
        + 2 * ca.mtimes(Q.Phi(Q.conj(dq_ref)), dq)
        + ca.mtimes(Pr, f[GENERALISED["q"]])
    )
    E = sigma * ca.mtimes(Pr, g[GENERALISED["q"], :])[1:4, :]
    G = 2 * ca.mtimes(Q.Phi(q).T, g[GENERALISED["q"], :])[1:4, :]
    return {
        "qe0": sigma * qe[0] / ca.sqrt(ca.sumsqr(qe)),
        "G": G,
        "y": sigma * qe[1:4],
        "dy": sigma * dqe[1:4],
        "D": sigma * drift[1:4],
        "E": E,
        "sigma": sigma,
    }


def _adj3(M: ca.MX) -> ca.MX:
    """Adjugate of a 3x3 matrix (closed form, no linear-solver plugin in generated C)."""
    a = [[M[i, j] for j in range(3)] for i in range(3)]
    cof = [[None] * 3 for _ in range(3)]
    for i in range(3):
        for j in range(3):
            r = [k for k in range(3) if k != i]
            c = [k for k in range(3) if k != j]
            minor = a[r[0]][c[0]] * a[r[1]][c[1]] - a[r[0]][c[1]] * a[r[1]][c[0]]
            cof[i][j] = minor if (i + j) % 2 == 0 else -minor
    # adj = cof^T
    return ca.vertcat(*[ca.horzcat(*[cof[j][i] for j in range(3)]) for i in range(3)])


def _det3(M: ca.MX) -> ca.MX:
    return (
        M[0, 0] * (M[1, 1] * M[2, 2] - M[1, 2] * M[2, 1])
        - M[0, 1] * (M[1, 0] * M[2, 2] - M[1, 2] * M[2, 0])
        + M[0, 2] * (M[1, 0] * M[2, 1] - M[1, 1] * M[2, 0])
    )


def _fro(M: ca.MX) -> ca.MX:
    return ca.sqrt(ca.sumsqr(M))


def rcond_fro(M: ca.MX) -> ca.MX:
    """Reciprocal Frobenius condition number ``|det M| / (||M||_F ||adj M||_F)`` of a 3x3."""
    return ca.fabs(_det3(M)) / (_fro(M) * _fro(_adj3(M)) + 1e-300)


def solve3(M: ca.MX, b: ca.MX) -> ca.MX:
    """``M^-1 b`` of a 3x3 ``M`` by the adjugate (closed form: no linear-solver plugin in the
    generated C); the caller ensures ``M`` is well conditioned (e.g. ``G``, see
    :func:`rcond_fro`)."""
    return ca.mtimes(_adj3(M), b) / _det3(M)


@dataclass(frozen=True)
class DampedInverse:
    """Singularity thresholds and relative damping of the regularised inverse (module docstring).

    Attributes
    ----------
    qe0_min
        Scalar part of the error quaternion below which E counts as near-singular.
    rcond_min
        Reciprocal Frobenius condition number of G below which E counts as near-singular.
    mu
        Relative damping ``lambda^2 = mu^2 ||E||_F^2 (1 - m)`` below the margin.
    """

    qe0_min: float = QE0_MIN
    rcond_min: float = RCOND_MIN
    mu: float = DAMPING_MU


def damped_solve(
    E: ca.MX, rhs: ca.MX, qe0: ca.MX, G: ca.MX, inverse: DampedInverse = DampedInverse()
) -> tuple[ca.MX, ca.MX, ca.MX]:
    """Regularised ``E^-1 rhs`` (thesis 8.26; damped least squares near singularity).

    ``inverse`` holds the thresholds and the damping (:class:`DampedInverse`).

    Returns
    -------
    tau, singular, margin
        The solution, the flag (1.0 when damping was active, else 0.0) and the
        conditioning margin ``m`` (see the module docstring; < 1 means damped).
    """
    qe0_min, rcond_min, mu = inverse.qe0_min, inverse.rcond_min, inverse.mu
    margin = ca.fmin(qe0 / qe0_min, rcond_fro(G) / rcond_min)
    w = ca.fmax(0, 1 - margin)
    lam2 = mu**2 * (ca.sumsqr(E) + 1e-12) * w
    M = ca.mtimes(E.T, E) + lam2 * ca.MX.eye(3)
    tau = ca.mtimes(_adj3(M), ca.mtimes(E.T, rhs)) / _det3(M)
    singular = ca.if_else(margin < 1, 1, 0)
    return tau, singular, margin

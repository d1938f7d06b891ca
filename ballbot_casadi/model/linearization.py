"""Operating points and the exact linearisation of the ballbot, full and reduced.

Operating point
---------------
An operating point is a state with the attitude at rest (``dq = 0``) and a trim torque
``tau0`` that makes every acceleration vanish (:func:`trim`).  The ball may roll at a
constant velocity (a relative equilibrium: the model does not depend on ``x, y``).  The
default is the balanced attitude at rest (:func:`balance_point`): upright when the centre
of mass lies on the body z axis, else tilted so that it lies straight above the ball
centre.

Reduced (minimal) model
-----------------------
The 12-state model carries the unit-quaternion constraint ``h = q^T q - 1 = 0`` with
Baumgarte stabilisation (thesis C.64-C.68), so the constraint manifold
``{h = 0, dh/dt = 0}`` is invariant and the 12-state Jacobian has, besides the 10
physical eigenvalues, the two constraint eigenvalues ``-beta, -beta``.  The physical
motions are parametrised by a left (ball-frame {K}) attitude perturbation,

``q = dq_K o q0``,  ``dq_K = [sqrt(1 - |v|^2), v]``,

so ``delta q = Gamma(q0)[:, 1:] v`` (thesis E.12) and, because ``dq0 = 0`` at the
operating point, ``delta dq = Gamma(q0)[:, 1:] dv``.  The 12x10 basis
``T = blkdiag(I2, Gamma(q0)[:, 1:], I2, Gamma(q0)[:, 1:])`` has orthonormal columns that
span the tangent space of the manifold (``q0^T delta q = 0``,
``dq0^T delta q + q0^T delta dq = 0``), which ``A`` leaves invariant, hence
``A_r = T^T A T`` (10x10) and ``B_r = T^T B`` with ``A T = T A_r`` exactly.  The reduced
state is ``[x, y, v1, v2, v3, dx, dy, dv1, dv2, dv3]``; ``v`` is the vector part of the
ball-frame attitude error quaternion (``v = (q1, q2, q3)`` when ``q0`` is the identity,
and ``2 v`` is the rotation vector to first order).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np
from scipy.optimize import least_squares

from ballbot_casadi.core.layout import STATE, STATE_DXY
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.params import Params
from ballbot_casadi.core.validation import as_vector, check_state
from ballbot_casadi.errors import StateError
from ballbot_casadi.model.dynamics import NP, NU, NX, make_model_functions

__all__ = [
    "NR",
    "REDUCED_STATE_NAMES",
    "TRIM_TOL",
    "OperatingPoint",
    "LinearModel",
    "parse_state_spec",
    "balance_point",
    "balance_tilt",
    "trim",
    "tangent_basis",
    "linearize",
    "sorted_eig",
]

NR = 10
REDUCED_STATE_NAMES = ("x", "y", "v1", "v2", "v3", "dx", "dy", "dv1", "dv2", "dv3")

#: Largest ball speed of an operating point (m/s): far beyond any ballbot, finite numbers.
MAX_SPEED = 10.0
#: Absolute tolerance on the trim accelerations (m/s^2 and quaternion units / s^2).
TRIM_TOL = 1e-8


@dataclass(frozen=True)
class OperatingPoint:
    """A trimmed operating point: 12-state ``x``, trim torques ``tau`` and the residual."""

    x: np.ndarray
    tau: np.ndarray
    residual: float

    def rpy_deg(self) -> np.ndarray:
        """Roll, pitch, yaw of the operating-point attitude in degrees (ZYX)."""
        return np.degrees(Q.to_rpy(self.x[STATE["q"]]))


@dataclass(frozen=True)
class LinearModel:
    """Linearisation at an operating point (full 12-state and reduced 10-state).

    Attributes
    ----------
    op
        The operating point.
    A, B
        12-state Jacobians ``df/dx`` (12x12) and ``df/dtau`` (12x3).
    T
        Tangent basis (12x10, orthonormal columns), see the module docstring.
    Ar, Br
        Reduced model ``T^T A T`` (10x10) and ``T^T B`` (10x3).
    invariance_error
        ``||A T - T Ar|| / ||A||``; zero up to rounding when the reduction is exact.
    beta
        Baumgarte gain (the constraint eigenvalues are ``-beta, -beta``).
    tau_max
        Torque limit used for input scaling.
    """

    op: OperatingPoint
    A: np.ndarray
    B: np.ndarray
    T: np.ndarray
    Ar: np.ndarray
    Br: np.ndarray
    invariance_error: float
    beta: float
    tau_max: float

    def eig_full(self) -> np.ndarray:
        """Eigenvalues of the 12-state Jacobian, sorted by decreasing real part."""
        return sorted_eig(self.A)

    def eig_reduced(self) -> np.ndarray:
        """Eigenvalues of the reduced 10-state model, sorted by decreasing real part."""
        return sorted_eig(self.Ar)


def sorted_eig(A: np.ndarray) -> np.ndarray:
    """Eigenvalues sorted by decreasing real part, then imaginary part."""
    e = np.linalg.eigvals(A)
    return e[np.lexsort((e.imag, -e.real))]


# --------------------------------------------------------------------------- operating point


_SPEC_KEYS = {
    "x": 1.0, "y": 1.0, "dx": 1.0, "dy": 1.0,
    "roll": np.pi / 180, "pitch": np.pi / 180, "yaw": np.pi / 180,
}


def parse_state_spec(text: str, params: Params) -> np.ndarray:
    """Operating-point state from the ``--at`` text of ``ballbot analyze``.

    Two formats:
    * ``key=value`` pairs separated by commas, keys ``x, y`` (m), ``dx, dy`` (m/s),
      ``roll, pitch, yaw`` (degrees, ZYX).  Omitted keys are 0, except that when both
      ``roll`` and ``pitch`` are omitted the attitude is the balanced tilt of
      :func:`balance_point` at heading ``yaw`` (upright for a centred COM).
      Example: ``yaw=30,dx=0.2``.
    * Exactly 12 comma-separated numbers, the full state
      ``x, y, q0, q1, q2, q3, dx, dy, dq0, dq1, dq2, dq3`` (SI, quaternion normalised
      to 1e-6).

    Raises
    ------
    StateError
        Malformed text, unknown key, non-finite number or non-unit quaternion.
    """
    items = [s.strip() for s in str(text).split(",") if s.strip()]
    if not items:
        raise StateError("empty operating point; use e.g. 'yaw=30' or 12 comma-separated numbers")
    if all("=" not in s for s in items):
        try:
            values = [float(s) for s in items]
        except ValueError:
            raise StateError(f"operating point {text!r}: expected 12 numbers") from None
        if len(values) != NX:
            raise StateError(
                f"operating point {text!r}: got {len(values)} numbers, expected {NX} "
                "(x, y, q0..q3, dx, dy, dq0..dq3) or key=value pairs"
            )
        return check_state(np.array(values), "operating point")
    vals: dict[str, float] = {}
    for item in items:
        key, sep, raw = item.partition("=")
        key = key.strip().lower()
        if not sep or key not in _SPEC_KEYS:
            raise StateError(
                f"operating point item {item!r}: expected key=value with key in "
                f"{', '.join(_SPEC_KEYS)} (angles in degrees)"
            )
        if key in vals:
            raise StateError(f"operating point: {key!r} given twice")
        try:
            v = float(raw)
        except ValueError:
            raise StateError(f"operating point item {item!r}: {raw.strip()!r} is not a number") from None
        if not np.isfinite(v):
            raise StateError(f"operating point item {item!r}: value must be finite")
        if key in ("dx", "dy") and abs(v) > MAX_SPEED:
            raise StateError(f"operating point item {item!r}: a ball speed above {MAX_SPEED:g} m/s "
                             "is outside what the model describes (no slip, small friction)")
        vals[key] = v * _SPEC_KEYS[key]
    x = np.concatenate(
        [[vals.get("x", 0.0), vals.get("y", 0.0)], np.array([1.0, 0, 0, 0]),
         [vals.get("dx", 0.0), vals.get("dy", 0.0)], np.zeros(4)]
    )
    if "roll" in vals or "pitch" in vals:
        x[STATE["q"]] = Q.from_rpy(vals.get("roll", 0.0), vals.get("pitch", 0.0), vals.get("yaw", 0.0))
        return x
    x[STATE["q"]] = balance_point(params, vals.get("yaw", 0.0))[STATE["q"]]
    return balance_tilt(params, x)


def balance_tilt(params: Params, x0: Any, functions: dict[str, ca.Function] | None = None) -> np.ndarray:
    """Refine the tilt of ``x0`` (heading, position and velocity kept) to an equilibrium.

    Solves ``f(x) + g(x) tau = 0`` for the tilt (a ball-frame rotation about x and y
    applied to ``q``) and ``tau`` by least squares; needed when the ball rolls against
    friction (the body leans into the motion).  Returns ``x0`` unchanged when it already
    trims (:data:`TRIM_TOL`) or when no tilt does.
    """

    x0 = check_state(x0, "operating point")
    funcs = functions if functions is not None else make_model_functions()
    pv = params.to_vector()

    def state(w: np.ndarray) -> np.ndarray:
        x = x0.copy()
        x[STATE["q"]] = Q.mul(Q.from_rotation_vector(np.array([w[0], w[1], 0.0])), x0[STATE["q"]])
        return x

    def resid(u: np.ndarray) -> np.ndarray:
        f, g = funcs["affine"](state(u[:2]), pv)
        return np.asarray(f).ravel() + np.asarray(g) @ u[2:]

    if np.max(np.abs(resid(np.zeros(5)))) <= TRIM_TOL:
        return x0
    sol = least_squares(resid, np.zeros(5), xtol=1e-15, ftol=1e-15, gtol=1e-15)
    return state(sol.x[:2]) if np.max(np.abs(sol.fun)) <= TRIM_TOL else x0


def balance_point(params: Params, yaw: float = 0.0) -> np.ndarray:
    """State at rest whose body centre of mass lies straight above the ball centre.

    ``q = q_z(yaw) o q_b`` where ``q_b`` is the smallest rotation taking the body COM
    direction ``(com_x, com_y, l)`` to the vertical, so ``R(q) p_com = |p_com| e_z``
    (thesis C.21: zero gravity torque).  Upright (``q = q_z(yaw)``) for a centred COM.
    """
    p = np.array([params.com_x, params.com_y, params.l])
    p = p / np.linalg.norm(p)
    axis = np.cross(p, [0.0, 0.0, 1.0])
    angle = float(np.arctan2(np.linalg.norm(axis), p[2]))
    rv = axis / np.linalg.norm(axis) * angle if np.linalg.norm(axis) > 1e-15 else np.zeros(3)
    q = Q.mul(Q.from_rpy(0.0, 0.0, yaw), Q.from_rotation_vector(rv))
    return np.concatenate([[0.0, 0.0], q, np.zeros(6)])


def trim(x0: Any, params: Params, functions: dict[str, ca.Function] | None = None) -> OperatingPoint:
    """Trim torques for an operating point: ``tau0 = argmin |f(x0) + g(x0) tau|``.

    Parameters
    ----------
    x0
        12-state with the attitude at rest (``dq0..dq3 = 0``).
    params
        Parameter set.
    functions
        Model Functions (default: :func:`~ballbot_casadi.model.dynamics.make_model_functions`);
        only ``affine`` is used (control-affine split, thesis C.10).

    Raises
    ------
    StateError
        The attitude is not at rest, or no torque makes the accelerations vanish to
        :data:`TRIM_TOL` (the state is not an equilibrium).
    """
    x0 = check_state(x0, "operating point")
    if np.max(np.abs(x0[STATE["dq"]])) > 1e-12:
        raise StateError(
            "operating point: the attitude must be at rest (dq0..dq3 = 0) for a linear "
            f"analysis, got dq = {x0[STATE['dq']].tolist()}"
        )
    x0 = x0.copy()
    x0[STATE["q"]] /= np.linalg.norm(x0[STATE["q"]])
    funcs = functions if functions is not None else make_model_functions()
    f, g = funcs["affine"](x0, params.to_vector())
    f, g = np.asarray(f).reshape(6), np.asarray(g)
    tau, *_ = np.linalg.lstsq(g, -f, rcond=None)
    res = float(np.max(np.abs(f + g @ tau)))
    if res > TRIM_TOL:
        rpy = np.degrees(Q.to_rpy(x0[STATE["q"]]))
        raise StateError(
            f"operating point (roll, pitch, yaw = {rpy.round(4).tolist()} deg, "
            f"dx, dy = {x0[STATE_DXY].tolist()} m/s) is not an equilibrium: the best trim torque "
            f"leaves an acceleration of {res:.3g}; omit roll/pitch to use the balanced tilt"
        )
    return OperatingPoint(x=x0, tau=tau, residual=res)


def tangent_basis(q0: Any) -> np.ndarray:
    """12x10 orthonormal basis of the constraint tangent space at attitude ``q0`` (at rest).

    ``T = blkdiag(I2, G, I2, G)`` with ``G = Gamma(q0)[:, 1:]`` (thesis E.12); see the
    module docstring.
    """
    q0 = as_vector(q0, 4, "q0")
    G = Q.Gamma(q0 / np.linalg.norm(q0))[:, 1:]
    T = np.zeros((NX, NR))
    T[0:2, 0:2] = np.eye(2)
    T[2:6, 2:5] = G
    T[6:8, 5:7] = np.eye(2)
    T[8:12, 7:10] = G
    return T


def linearize(
    params: Params,
    x0: Any | None = None,
    functions: dict[str, ca.Function] | None = None,
) -> LinearModel:
    """Linearise the model at an operating point and reduce it to the minimal 10 states.

    Parameters
    ----------
    params
        Parameter set.
    x0
        12-state operating point (attitude at rest); default :func:`balance_point`.
    functions
        Model Functions providing ``affine`` and ``jac`` (the exact Jacobians, e.g. the
        compiled ones of :func:`ballbot_casadi.codegen.load_model_library`).

    Returns
    -------
    LinearModel
    """
    funcs = functions if functions is not None else make_model_functions()
    op = trim(balance_point(params) if x0 is None else x0, params, funcs)
    A, B = funcs["jac"](op.x, op.tau, params.to_vector())
    A, B = np.asarray(A, dtype=float), np.asarray(B, dtype=float)
    T = tangent_basis(op.x[STATE["q"]])
    Ar, Br = T.T @ A @ T, T.T @ B
    inv_err = float(np.linalg.norm(A @ T - T @ Ar) / max(np.linalg.norm(A), 1.0))
    return LinearModel(op, A, B, T, Ar, Br, inv_err, params.beta, params.tau_max)


def model_summary(params: Params) -> str:
    """Sizes and equilibrium eigenvalues of the model as text.

    The equilibrium is the balanced attitude at rest (:func:`balance_point`, trimmed by
    :func:`trim`): upright for a centred COM, tilted over the ball otherwise.
    """
    op = trim(balance_point(params), params)
    funcs = make_model_functions()
    A = np.asarray(funcs["jac"](op.x, op.tau, params.to_vector())[0])
    eig = sorted_eig(A)
    rpy = np.degrees(Q.to_rpy(op.x[STATE["q"]]))
    where = ("upright" if np.max(np.abs(rpy[:2])) < 1e-12
             else f"balanced tilt roll {rpy[0]:+.4f} deg, pitch {rpy[1]:+.4f} deg")
    lines = [
        f"states: {NX}  inputs: {NU}  parameters: {NP}",
        f"equilibrium eigenvalues at rest, {where} (rad/s; 12-state model incl. the two "
        "Baumgarte constraint modes):",
        *[f"  {e.real:+.6f}{e.imag:+.6f}j" for e in eig],
    ]
    return "\n".join(lines)

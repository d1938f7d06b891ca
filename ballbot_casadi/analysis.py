"""Linear analysis of the ballbot: operating point, minimal model, controllability, zeros.

The thesis designs its controllers on the linearised model and reasons about bandwidth and
non-minimum-phase behaviour (thesis §2.5, §7.1, §9.1) without showing the analysis; this
module computes it.  Everything here is numpy/CasADi/python-control; plots and the report
live in :mod:`ballbot_casadi.studies.analyze`.

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

The closed loop (cascade bandwidths, 3x rule) is :mod:`ballbot_casadi.closed_loop_analysis`.

Scaling
-------
Controllability numbers depend on units, so they are computed in the scaled coordinates
of :data:`STATE_SCALE` (the design envelope of thesis §7.1: 1 m, 0.5 m/s, 5 deg tilt,
20 deg/s tilt rate, 1 rad heading, 1 rad/s heading rate) with the torques normalised by
``tau_max``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

import casadi as ca
import numpy as np
import scipy.linalg as sla

from . import quaternion as Q
from .errors import ShapeError, StateError
from .model import NU, NX, make_model_functions
from .params import Params
from .validation import as_vector, check_state

__all__ = [
    "NR",
    "REDUCED_STATE_NAMES",
    "STATE_SCALE",
    "CHANNELS",
    "OperatingPoint",
    "LinearModel",
    "parse_state_spec",
    "balance_point",
    "balance_tilt",
    "trim",
    "tangent_basis",
    "linearize",
    "state_scaling",
    "controllability",
    "mode_groups",
    "channel_system",
    "channel_poles_zeros",
    "singular_values",
    "finite_gramian",
    "planar_reduction",
    "analyze_plant",
]

NR = 10
REDUCED_STATE_NAMES = ("x", "y", "v1", "v2", "v3", "dx", "dy", "dv1", "dv2", "dv3")

#: Typical magnitude of each reduced state (thesis §7.1 envelope), used for scaling.
STATE_SCALE = np.array(
    [
        1.0, 1.0,  # position, m
        np.sin(np.radians(2.5)), np.sin(np.radians(2.5)),  # 5 deg tilt, quaternion units
        np.sin(0.5),  # 1 rad heading
        0.5, 0.5,  # 0.5 m/s
        0.5 * np.radians(20.0), 0.5 * np.radians(20.0),  # 20 deg/s tilt rate
        0.5,  # 1 rad/s heading rate
    ]
)

#: Output channels of the analysis: name -> (reduced-state indices, output names).
#: ``pose`` (x, y and heading) is the square 3x3 channel: at upright rest the summed
#: ("yaw") torque does not reach x, y, so the 2x3 ``position`` channel is effectively
#: square and has the RHP zeros; away from that symmetric point (tilted, rolling) the
#: yaw torque couples in weakly and a generic non-square system has no transmission
#: zeros, while the square ``pose`` channel keeps them.  ``rhp_zeros_position`` therefore
#: comes from ``pose``.
CHANNELS: dict[str, tuple[tuple[int, ...], tuple[str, ...]]] = {
    "position": ((0, 1), ("x", "y")),
    "tilt": ((2, 3), ("v1", "v2")),
    "heading": ((4,), ("v3",)),
    "pose": ((0, 1, 4), ("x", "y", "v3")),
}

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
        return np.degrees(Q.to_rpy(self.x[2:6]))


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
        return _sorted_eig(self.A)

    def eig_reduced(self) -> np.ndarray:
        """Eigenvalues of the reduced 10-state model, sorted by decreasing real part."""
        return _sorted_eig(self.Ar)


def _sorted_eig(A: np.ndarray) -> np.ndarray:
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
        vals[key] = v * _SPEC_KEYS[key]
    x = np.concatenate(
        [[vals.get("x", 0.0), vals.get("y", 0.0)], np.array([1.0, 0, 0, 0]),
         [vals.get("dx", 0.0), vals.get("dy", 0.0)], np.zeros(4)]
    )
    if "roll" in vals or "pitch" in vals:
        x[2:6] = Q.from_rpy(vals.get("roll", 0.0), vals.get("pitch", 0.0), vals.get("yaw", 0.0))
        return x
    x[2:6] = balance_point(params, vals.get("yaw", 0.0))[2:6]
    return balance_tilt(params, x)


def balance_tilt(params: Params, x0: Any, functions: dict[str, ca.Function] | None = None) -> np.ndarray:
    """Refine the tilt of ``x0`` (heading, position and velocity kept) to an equilibrium.

    Solves ``f(x) + g(x) tau = 0`` for the tilt (a ball-frame rotation about x and y
    applied to ``q``) and ``tau`` by least squares; needed when the ball rolls against
    friction (the body leans into the motion).  Returns ``x0`` unchanged when it already
    trims (:data:`TRIM_TOL`) or when no tilt does.
    """
    from scipy.optimize import least_squares

    x0 = check_state(x0, "operating point")
    funcs = functions if functions is not None else make_model_functions()
    pv = params.to_vector()

    def state(w: np.ndarray) -> np.ndarray:
        x = x0.copy()
        x[2:6] = Q.mul(Q.from_rotation_vector(np.array([w[0], w[1], 0.0])), x0[2:6])
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
        Model Functions (default: :func:`~ballbot_casadi.model.make_model_functions`);
        only ``affine`` is used (control-affine split, thesis C.10).

    Raises
    ------
    StateError
        The attitude is not at rest, or no torque makes the accelerations vanish to
        :data:`TRIM_TOL` (the state is not an equilibrium).
    """
    x0 = check_state(x0, "operating point")
    if np.max(np.abs(x0[8:12])) > 1e-12:
        raise StateError(
            "operating point: the attitude must be at rest (dq0..dq3 = 0) for a linear "
            f"analysis, got dq = {x0[8:12].tolist()}"
        )
    x0 = x0.copy()
    x0[2:6] /= np.linalg.norm(x0[2:6])
    funcs = functions if functions is not None else make_model_functions()
    f, g = funcs["affine"](x0, params.to_vector())
    f, g = np.asarray(f).reshape(6), np.asarray(g)
    tau, *_ = np.linalg.lstsq(g, -f, rcond=None)
    res = float(np.max(np.abs(f + g @ tau)))
    if res > TRIM_TOL:
        rpy = np.degrees(Q.to_rpy(x0[2:6]))
        raise StateError(
            f"operating point (roll, pitch, yaw = {rpy.round(4).tolist()} deg, "
            f"dx, dy = {x0[6:8].tolist()} m/s) is not an equilibrium: the best trim torque "
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
    T = tangent_basis(op.x[2:6])
    Ar, Br = T.T @ A @ T, T.T @ B
    inv_err = float(np.linalg.norm(A @ T - T @ Ar) / max(np.linalg.norm(A), 1.0))
    return LinearModel(op, A, B, T, Ar, Br, inv_err, params.beta, params.tau_max)


# --------------------------------------------------------------------------- controllability


def state_scaling(lin: LinearModel) -> tuple[np.ndarray, np.ndarray]:
    """Scaled reduced model ``(S^-1 Ar S, S^-1 Br tau_max)`` with ``S = diag(STATE_SCALE)``."""
    s = STATE_SCALE
    return lin.Ar * (1.0 / s)[:, None] * s[None, :], lin.Br * (lin.tau_max / s)[:, None]


def mode_groups(A: np.ndarray, tol: float = 1e-6) -> list[np.ndarray]:
    """Eigenvalues of ``A`` grouped into clusters (repeated eigenvalues and conjugate pairs).

    Each group is an array of eigenvalues; a complex pair forms one group with its
    conjugate, so every group spans a real invariant subspace.
    """
    e = _sorted_eig(A)
    groups: list[list[complex]] = []
    for lam in e:
        for g in groups:
            ref = g[0]
            if min(abs(lam - ref), abs(lam - np.conj(ref))) <= tol * max(1.0, abs(ref)):
                g.append(lam)
                break
        else:
            groups.append([lam])
    return [np.array(g) for g in groups]


def _left_invariant_subspace(A: np.ndarray, group: np.ndarray) -> np.ndarray:
    """Orthonormal basis (n x m) of the left invariant subspace of the eigenvalue group."""
    n, m = A.shape[0], group.size
    lam = group[np.argmax(group.imag)]
    if abs(lam.imag) > 0:
        N = A @ A - 2 * lam.real * A + abs(lam) ** 2 * np.eye(n)
        power = m // 2
    else:
        N = A - lam.real * np.eye(n)
        power = m
    U, _, _ = np.linalg.svd(np.linalg.matrix_power(N, power))
    return U[:, n - m :]


def finite_gramian(A: np.ndarray, B: np.ndarray, horizon: float) -> np.ndarray:
    """Controllability Gramian ``int_0^T e^{At} B B^T e^{A^T t} dt`` (Van Loan's method).

    Finite for unstable ``A``, so no stabilising loop is needed.
    """
    n = A.shape[0]
    M = np.zeros((2 * n, 2 * n))
    M[:n, :n], M[:n, n:], M[n:, n:] = -A, B @ B.T, A.T
    E = sla.expm(M * horizon)
    W = E[n:, n:].T @ E[:n, n:]
    return 0.5 * (W + W.T)


def controllability(lin: LinearModel, rtol: float = 1e-9, horizon: float = 1.0) -> dict[str, Any]:
    """Controllability of the reduced model in scaled coordinates (:func:`state_scaling`).

    * Kalman rank: singular values of ``[B, A B, ..., A^9 B]`` built from
      ``A / w0, B / |B|`` with ``w0 = |A|_2`` (time scaling keeps the blocks of equal size);
      rank = number of singular values above ``rtol * sigma_max``.
    * PBH per distinct eigenvalue: ``sigma_min([A - lambda I, B]) / |[A, B]|``
      (zero exactly when the eigenvalue is uncontrollable).
    * Gramian measure per mode group: the finite-horizon Gramian ``W(T)`` of the scaled
      plant restricted to the group's left invariant subspace ``U`` (the decoupled modal
      subsystem ``z = U^T x``); ``1 / lambda_min(U^T W U)`` is the least input energy
      (in ``tau_max^2 s``) that moves the group by one scale unit in its weakest
      direction within ``T`` seconds.  Larger energy = more weakly controllable.

    Returns
    -------
    dict
        ``rank``, ``n``, ``singular_values``, ``rtol``, ``pbh`` (list of dicts), ``modes``
        (list of dicts with ``eigenvalues``, ``energy``, ``dominant_states`` of the
        modes' right invariant subspace and the states of the ``weakest_direction``)
        and ``weakest_mode``.
    """
    A, B = state_scaling(lin)
    n = A.shape[0]
    w0 = np.linalg.norm(A, 2)
    As, Bs = A / w0, B / np.linalg.norm(B, 2)
    blocks, Mk = [], Bs
    for _ in range(n):
        blocks.append(Mk)
        Mk = As @ Mk
    sv = np.linalg.svd(np.hstack(blocks), compute_uv=False)
    rank = int(np.sum(sv > rtol * sv[0]))

    AB_norm = np.linalg.norm(np.hstack([A, B]), 2)
    pbh = []
    groups = mode_groups(A)
    for g in groups:
        for lam in dict.fromkeys(np.round(g, 12)):
            s = np.linalg.svd(np.hstack([A - lam * np.eye(n), B]), compute_uv=False)[-1] / AB_norm
            pbh.append({"eigenvalue": complex(lam), "sigma_min": float(s), "controllable": bool(s > rtol)})

    W = finite_gramian(A, B, horizon)
    modes = []
    for g in groups:
        U = _left_invariant_subspace(A, g)
        lam, vec = np.linalg.eigh(U.T @ W @ U)
        energy = 1.0 / lam[0] if lam[0] > 0 else float("inf")
        right = _right_invariant_subspace(A, g)
        modes.append(
            {
                "eigenvalues": [complex(v) for v in g],
                "energy": float(energy),
                "dominant_states": _dominant(np.sum(right**2, axis=1)),
                "weakest_direction": _dominant((U @ vec[:, 0]) ** 2),
            }
        )
    weakest = max(modes, key=lambda m: m["energy"])
    return {
        "n": n,
        "rank": rank,
        "rtol": rtol,
        "singular_values": sv.tolist(),
        "pbh": pbh,
        "horizon": horizon,
        "modes": modes,
        "weakest_mode": weakest,
    }


def _dominant(weight: np.ndarray, frac: float = 0.1) -> list[str]:
    """Reduced-state names whose weight exceeds ``frac`` of the largest, largest first."""
    return [REDUCED_STATE_NAMES[i] for i in np.argsort(-weight) if weight[i] > frac * weight.max()]


def _right_invariant_subspace(A: np.ndarray, group: np.ndarray) -> np.ndarray:
    """Orthonormal basis of the right invariant subspace of an eigenvalue group."""
    return _left_invariant_subspace(A.T, group)


# --------------------------------------------------------------------------- channels


def channel_system(lin: LinearModel, channel: str):
    """python-control state-space model wheel torques -> one output channel (reduced model).

    Channels (:data:`CHANNELS`): ``position`` (x, y in m), ``tilt`` (v1, v2: vector part
    of the ball-frame attitude error, about half the roll/pitch angle in rad) and
    ``heading`` (v3, about half the yaw angle).
    """
    import control

    if channel not in CHANNELS:
        raise ShapeError(f"unknown channel {channel!r}; known: {', '.join(CHANNELS)}")
    idx, names = CHANNELS[channel]
    C = np.zeros((len(idx), NR))
    C[np.arange(len(idx)), list(idx)] = 1.0
    return control.ss(lin.Ar, lin.Br, C, np.zeros((len(idx), NU)), outputs=list(names),
                      inputs=["tau0", "tau1", "tau2"])


def channel_poles_zeros(lin: LinearModel, channel: str, tol: float = 1e-9) -> dict[str, Any]:
    """Poles and transmission zeros of a channel's minimal realisation.

    Uncontrollable or unobservable modes (e.g. the ball position seen from the tilt
    output) would otherwise show up as decoupling zeros; ``control.minreal`` (SLICOT
    TB01PD) removes them first, then SLICOT AB08ND gives the invariant zeros of the
    (possibly non-square) minimal system, i.e. its transmission zeros.

    Returns
    -------
    dict
        ``order`` (minimal order), ``poles``, ``zeros`` (complex arrays) and ``rhp_zeros``
        (zeros with real part > ``1e-6 * max(1, |z|)``).
    """
    import control

    sys = channel_system(lin, channel)
    msys = control.minreal(sys, tol=tol, verbose=False)
    poles = _sort_c(np.linalg.eigvals(msys.A)) if msys.nstates else np.array([], complex)
    zeros = _sort_c(msys.zeros()) if msys.nstates else np.array([], complex)
    rhp = zeros[zeros.real > 1e-6 * np.maximum(1.0, np.abs(zeros))]
    return {"order": int(msys.nstates), "poles": poles, "zeros": zeros, "rhp_zeros": rhp}


def _sort_c(v: Sequence[complex]) -> np.ndarray:
    v = np.asarray(v, dtype=complex)
    return v[np.lexsort((v.imag, -v.real))]


def singular_values(lin_or_sys: Any, omega: np.ndarray, channel: str | None = None) -> np.ndarray:
    """Singular values of ``G(j omega)`` (rows: frequencies; columns: sigma_1 >= sigma_2 ...).

    ``lin_or_sys`` is a :class:`LinearModel` with a ``channel`` name or a python-control
    state-space system.  Evaluated directly as ``C (j w I - A)^-1 B + D``, which is
    defined for unstable plants as well.
    """
    sys = channel_system(lin_or_sys, channel) if isinstance(lin_or_sys, LinearModel) else lin_or_sys
    A, B, C, D = (np.asarray(M, dtype=float) for M in (sys.A, sys.B, sys.C, sys.D))
    n = A.shape[0]
    out = []
    for w in np.asarray(omega, dtype=float):
        G = C @ np.linalg.solve(1j * w * np.eye(n) - A, B) + D
        out.append(np.linalg.svd(G, compute_uv=False))
    return np.array(out)


# --------------------------------------------------------------------------- hand derivation


def planar_reduction(params: Params) -> dict[str, float]:
    """Unstable pole and position zero of the planar ball + inverted-pendulum reduction.

    Per tilt axis, with the ball angle ``phi`` (``x = rk phi``), the body tilt ``theta``
    and the energies of thesis (C.14, C.18, C.21, C.24) linearised at upright:
    ``a = (Mk + Mb) rk^2 + Jk``, ``b = Mb rk l``, ``c = Jb + Mb l^2``, ``G = Mb g l`` and
    the wheel inertia ``J = Jw (rk/rw)^2 cos^2(alpha) sum_i s_i^2`` acting on the relative
    rate ``dphi - dtheta`` (``s_i = sin(i gamma)`` for pitch, ``cos(i gamma)`` for roll,
    from the wheel map B.46).  The torque enters as ``(+u, -u)``, so

    * poles: ``s^2 [((a+J)(c+J) - (b-J)^2) s^2 - (a+J) G] = 0`` ->
      ``p = sqrt((a+J) G / ((a+J)(c+J) - (b-J)^2))``;
    * torque -> position numerator ``(b + c) s^2 - G`` (``J`` cancels) -> zeros
      ``+-sqrt(G / (b + c)) = +-sqrt(Mb g l / (Jb + Mb l (l + rk)))``, one in the right
      half-plane: the shape-accelerated, non-minimum-phase behaviour of thesis §2.5.

    Exact for the 3D model at upright without friction when the wheel layout does not
    couple the axes (``sum_i sin(i gamma) cos(i gamma) = 0``, true for gamma = 120 deg)
    and the COM is centred.

    Returns
    -------
    dict
        ``pole_pitch``, ``pole_roll``, ``zero_pitch``, ``zero_roll`` in rad/s (pitch moves
        the ball along x, roll along y).
    """
    P = params
    a = (P.Mk + P.Mb) * P.rk**2 + P.Jk
    b = P.Mb * P.rk * P.l
    G = P.Mb * P.g * P.l
    ig = np.arange(3) * P.gamma
    out = {}
    for axis, Jb, s in (("pitch", P.Jby, np.sin(ig)), ("roll", P.Jbx, np.cos(ig))):
        J = P.Jw * (P.rk / P.rw) ** 2 * np.cos(P.alpha) ** 2 * float(np.sum(s**2))
        c = Jb + P.Mb * P.l**2
        out[f"pole_{axis}"] = float(np.sqrt((a + J) * G / ((a + J) * (c + J) - (b - J) ** 2)))
        out[f"zero_{axis}"] = float(np.sqrt(G / (b + c)))
    return out


# --------------------------------------------------------------------------- full plant report


def _cplx(v: Sequence[complex]) -> list[list[float]]:
    return [[float(np.real(z)), float(np.imag(z))] for z in v]


def _real_list(v: Sequence[complex]) -> list[float]:
    """Real parts (rad/s), largest first; complex zeros appear once per member of the pair."""
    return sorted((float(np.real(z)) for z in v), reverse=True)


def analyze_plant(
    params: Params,
    x0: Any | None = None,
    functions: dict[str, ca.Function] | None = None,
    horizon: float = 1.0,
) -> tuple[LinearModel, dict[str, Any]]:
    """Open-loop analysis of the plant at an operating point, as a JSON-ready dict.

    Returns
    -------
    (LinearModel, dict)
        The linearisation and a dict with the operating point, eigenvalues of the full
        and reduced model, constraint eigenvalues, ``unstable_poles`` (rad/s),
        controllability (:func:`controllability`), per-channel poles/zeros
        (:func:`channel_poles_zeros`), ``rhp_zeros_<channel>`` (real parts, rad/s),
        ``rhp_zeros_position`` (from the square ``pose`` channel, see :data:`CHANNELS`)
        and the planar hand derivation (:func:`planar_reduction`).
    """
    lin = linearize(params, x0, functions)
    ef, er = lin.eig_full(), lin.eig_reduced()
    # constraint eigenvalues: those of the full model left after matching the reduced ones
    rest = list(ef)
    for lam in er:
        rest.pop(int(np.argmin(np.abs(np.array(rest) - lam))))
    unstable = sorted((float(z.real) for z in er if z.real > 1e-6), reverse=True)
    ctrb = controllability(lin, horizon=horizon)
    chans = {}
    for name in CHANNELS:
        r = channel_poles_zeros(lin, name)
        chans[name] = {
            "outputs": list(CHANNELS[name][1]),
            "minimal_order": r["order"],
            "poles": _cplx(r["poles"]),
            "zeros": _cplx(r["zeros"]),
            "rhp_zeros": _cplx(r["rhp_zeros"]),
        }
    weak = ctrb["weakest_mode"]
    result: dict[str, Any] = {
        "operating_point": {
            "state": lin.op.x.tolist(),
            "tau": lin.op.tau.tolist(),
            "rpy_deg": lin.op.rpy_deg().tolist(),
            "trim_residual": lin.op.residual,
        },
        "n_states_full": NX,
        "n_states_reduced": NR,
        "reduced_state_names": list(REDUCED_STATE_NAMES),
        "reduction_invariance_error": lin.invariance_error,
        "eigenvalues_full": _cplx(ef),
        "eigenvalues_reduced": _cplx(er),
        "constraint_eigenvalues": _cplx(rest),
        "unstable_poles": unstable,
        "controllability_rank": ctrb["rank"],
        "controllability": {
            "scaling": dict(zip(REDUCED_STATE_NAMES, STATE_SCALE.tolist())),
            "input_scale_tau_max": lin.tau_max,
            "rtol": ctrb["rtol"],
            "singular_values": ctrb["singular_values"],
            "pbh": [
                {"eigenvalue": [e["eigenvalue"].real, e["eigenvalue"].imag],
                 "sigma_min": e["sigma_min"], "controllable": e["controllable"]}
                for e in ctrb["pbh"]
            ],
            "gramian_horizon_s": ctrb["horizon"],
            "modes": [
                {**m, "eigenvalues": _cplx(m["eigenvalues"])} for m in ctrb["modes"]
            ],
            "weakest_mode": {**weak, "eigenvalues": _cplx(weak["eigenvalues"])},
        },
        "channels": chans,
        **{f"rhp_zeros_{n}": _real_list([complex(*z) for z in c["rhp_zeros"]]) for n, c in chans.items()},
        "rhp_zeros_position": _real_list([complex(*z) for z in chans["pose"]["rhp_zeros"]]),
        "rhp_zeros_position_2x3": _real_list([complex(*z) for z in chans["position"]["rhp_zeros"]]),
        "planar_reduction": planar_reduction(params),
    }
    return lin, result

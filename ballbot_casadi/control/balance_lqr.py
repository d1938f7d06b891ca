"""Balance LQR: the linear baseline balance controller (the predecessor's design, thesis §1.2).

``ballbot_lqr(x, q_ref, dq_ref, ddq_ref, p, k) -> (tau, diag)``, the interface of
:func:`~ballbot_casadi.control.flc.make_flc`.

Control law
-----------
On the error output of the other balance controllers, ``y = vec(sigma q_ref* o q)`` and
its rate ``dy`` (body frame, thesis 7.4, 7.5, :mod:`~ballbot_casadi.control.decoupling`)::
    tau = -K [y; dy]                                                (K: 3 x 6)

No model inversion: the gain is designed once on the linearised model at the upright
equilibrium and used at every attitude and heading (the wheels and the body inertia are
body-fixed, so the body-frame error dynamics do not depend on the heading).

Design (:func:`design_balance_lqr`)
-----------------------------------
The reduced linear model of :func:`~ballbot_casadi.model.linearization.linearize` at the
upright balance point has the attitude block ``[v, dv]`` (vector part of the attitude
perturbation and its rate) closed: the ball position and velocity do not enter it.  At
the upright point ``v`` equals the body-frame error ``y`` to first order.  That block
(6 states, 3 torques) is discretised exactly with the control period (ZOH, ``Ts``) and
closed by a discrete LQR (``control.dlqr``) with Bryson's weights (1 / acceptable
excursion^2): the thesis §7.1 limits 5 deg tilt and 20 deg/s tilt rate (in half-angle
units ``sin(2.5 deg)``, ``10 deg/s``), 10 deg and 60 deg/s for the heading, and the torque
limit ``tau_max`` per wheel.  The trim torque at the upright point is zero (the COM lies
on the body axis for the design parameters), so no feedforward term is needed.

``diag`` follows :data:`~ballbot_casadi.control.balance_frame.DIAG_NAMES`: ``singular = 0`` and
``cond_margin = 1`` (no inverse is taken), ``sigma``, ``y``, ``dy``, and as ``v`` the
error acceleration ``D + E tau`` that the torque produces in the internal model.

Gains ``k``: the 3 x 6 matrix ``K`` row-major (18 entries, :data:`LQR_GAIN_NAMES`).
"""

from __future__ import annotations

import math
from typing import Any

import casadi as ca
import numpy as np
import scipy.linalg

from ballbot_casadi.control.balance_frame import BalanceFrame, balance_controller, balance_diag
from ballbot_casadi.control.dlqr import stabilising_dlqr
from ballbot_casadi.core.constants import THESIS_LIMITS, TS_CONTROL
from ballbot_casadi.core.layout import REDUCED_STATE
from ballbot_casadi.errors import ScenarioError

__all__ = [
    "LQR_GAIN_NAMES",
    "ATTITUDE_STATES",
    "balance_design_model",
    "design_balance_lqr",
    "make_balance_lqr",
]

#: Gain vector layout: ``K`` (3 x 6) row-major, rows torques, columns ``[y1..3, dy1..3]``.
LQR_GAIN_NAMES = tuple(f"K{i}{j}" for i in range(3) for j in range(6))
#: Indices of the attitude block ``[v1, v2, v3, dv1, dv2, dv3]`` in the reduced linear state.
ATTITUDE_STATES = (*range(REDUCED_STATE["v"].start, REDUCED_STATE["v"].stop),
                   *range(REDUCED_STATE["dv"].start, REDUCED_STATE["dv"].stop))
_TILT = math.sin(THESIS_LIMITS["tilt_max"] / 2)
_TILT_RATE = THESIS_LIMITS["tilt_rate_max"] / 2
_YAW, _YAW_RATE = math.sin(math.radians(10.0) / 2), math.radians(60.0) / 2


def balance_design_model(linear: Any, Ts: float = TS_CONTROL
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Attitude block of the reduced linear model at the balance point and its ZOH form.

    ``linear`` is the :class:`~ballbot_casadi.model.linearization.LinearModel` of
    ``linearize(params)`` (controllers do not import the model: the caller linearises).

    Returns
    -------
    A, B, Ad, Bd
        Continuous (6 x 6, 6 x 3) and discrete (period ``Ts``) models of ``[v, dv]``.
    """
    i = list(ATTITUDE_STATES)
    A = np.asarray(linear.Ar, dtype=float)[np.ix_(i, i)]
    B = np.asarray(linear.Br, dtype=float)[i, :]
    M = np.zeros((9, 9))
    M[:6, :6], M[:6, 6:] = A, B
    Md = scipy.linalg.expm(M * Ts)
    return A, B, Md[:6, :6], Md[:6, 6:]


def design_balance_lqr(linear: Any, Ts: float = TS_CONTROL, Qw: Any = None,
                       Rw: Any = None) -> np.ndarray:
    """Discrete LQR gain ``K`` (3 x 6) of the balance loop (module docstring).

    Parameters
    ----------
    linear
        ``LinearModel`` of :func:`~ballbot_casadi.model.linearization.linearize` at the
        upright balance point (``Ar``, ``Br``, ``tau_max`` are used).
    Ts
        Control period (s).
    Qw, Rw
        Diagonal state (6) and input (3) weights; default Bryson's rule (module docstring).

    Raises
    ------
    ParameterError
        No stabilising gain exists for these parameters.
    """
    if not (isinstance(Ts, (int, float)) and math.isfinite(Ts) and Ts > 0):
        raise ScenarioError(f"Ts must be a finite number > 0, got {Ts!r}")
    exc_ = np.array([_TILT, _TILT, _YAW, _TILT_RATE, _TILT_RATE, _YAW_RATE])
    Qw = 1 / exc_**2 if Qw is None else np.asarray(Qw, dtype=float).ravel()
    Rw = np.full(3, 1 / float(linear.tau_max) ** 2) if Rw is None else np.asarray(Rw, dtype=float).ravel()
    if Qw.shape != (6,) or Rw.shape != (3,):
        raise ScenarioError(f"Qw needs 6 and Rw 3 diagonal entries, got {Qw.size} and {Rw.size}")
    _, _, Ad, Bd = balance_design_model(linear, Ts)
    return stabilising_dlqr(Ad, Bd, Qw, Rw,
                            "no stabilising balance LQR gain exists for these parameters")


def make_balance_lqr(affine: ca.Function) -> ca.Function:
    """Build ``ballbot_lqr``, the balance LQR (module docstring).

    ``affine`` (used only for ``diag``'s ``v``), the signature and ``diag``: as in
    :func:`~ballbot_casadi.control.balance_frame.balance_controller`; ``k`` as
    :data:`LQR_GAIN_NAMES`; ``tau`` unsaturated.
    """

    def lqr_law(b: BalanceFrame) -> tuple[ca.MX, ca.MX]:
        K = ca.reshape(b.k, 6, 3).T  # row-major 3 x 6
        tau = -ca.mtimes(K, ca.vertcat(b.o["y"], b.o["dy"]))
        v = b.o["D"] + ca.mtimes(b.o["E"], tau)
        return tau, balance_diag(b.o, 0, 1, v)

    return balance_controller("lqr", affine, len(LQR_GAIN_NAMES), lqr_law)

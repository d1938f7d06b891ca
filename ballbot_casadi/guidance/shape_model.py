"""Shape-accelerated prediction model of the balance-feed MPC (Kugle's arrangement).

The ballbot is *shape accelerated* (thesis §7.1): the body's tilt makes the ball
accelerate.  When the MPC feeds the balance controller directly (attitude, rate and
acceleration references, :mod:`ballbot_casadi.guidance.mpc_balance`), it chooses the
tilt acceleration ``u = ddtheta`` itself and predicts, per axis, position, velocity,
tilt and tilt rate:

``p' = v``,  ``v' = K_v v + K_th theta + K_dth dtheta + K_u u``,
``theta' = dtheta``,  ``dtheta' = u``

with ``theta = (theta_x, theta_y)`` the inertial tilts of the velocity loop
(:func:`~ballbot_casadi.control.velocity.measured_tilt`).  The 2x2 gains come from the
linearisation of our full model (thesis (C.68) at the upright equilibrium) when the
torque is chosen so that the tilt follows ``u`` exactly (:func:`shape_gains` in
:mod:`ballbot_casadi.sim.balance_feed`, which owns the model); Kugle's model kept only
``K_th`` (``ddx ~ 13.7 q_3``, ``ddy ~ -13.7 q_2`` for his robot, ``q_i ~ theta / 2``),
``kugle_only = True`` does the same here.

The model is laid out on the 14 states of the velocity loop's model
(:class:`~ballbot_casadi.guidance.prediction.LoopModel`: ``v`` at 0:2, ``theta`` at 2:4,
``dtheta`` at 4:6, position at 12:14; the reference-model and integrator states 6:12 are
unused and stay zero), so the shipped condensing (:mod:`ballbot_casadi.guidance.condensed`)
and MPC (:mod:`ballbot_casadi.guidance.mpc`) take it unchanged, with the tilt acceleration
in the place of the velocity reference.  Discretisation: exact zero-order hold of ``u``
over the MPC step (matrix exponential).  Outputs: ``v``, ``tilt``, ``tilt_rate``, ``acc``
(the ball acceleration ``v'``) and ``tilt_acc`` (``u`` itself: its bound stands in for
the torque limit, as in Kugle's MPC).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from ballbot_casadi.errors import ShapeError
from ballbot_casadi.guidance.prediction import NXL, LoopModel

__all__ = ["ShapeGains", "shape_model", "continuous_shape_model"]


@dataclass(frozen=True)
class ShapeGains:
    """The 2x2 gains of ``v' = K_v v + K_th theta + K_dth dtheta + K_u u`` (module docstring)."""

    K_v: np.ndarray
    K_th: np.ndarray
    K_dth: np.ndarray
    K_u: np.ndarray

    def __post_init__(self) -> None:
        for name in ("K_v", "K_th", "K_dth", "K_u"):
            arr = np.asarray(getattr(self, name), float)
            if arr.shape != (2, 2) or not np.all(np.isfinite(arr)):
                raise ShapeError(f"shape gain {name} must be a finite 2x2 matrix, got shape "
                                 f"{arr.shape}")
            object.__setattr__(self, name, arr)

    def kugle(self) -> "ShapeGains":
        """Only the tilt term ``K_th`` (Kugle's ``ddx ~ k q_3``)."""
        z = np.zeros((2, 2))
        return ShapeGains(z, self.K_th, z, z)


def continuous_shape_model(gains: ShapeGains) -> tuple[np.ndarray, np.ndarray]:
    """``(Ac, Bc)`` of the continuous model on the 14 loop-model states, input ``u`` (2)."""
    Ac = np.zeros((NXL, NXL))
    Bc = np.zeros((NXL, 2))
    Ac[0:2, 0:2], Ac[0:2, 2:4], Ac[0:2, 4:6] = gains.K_v, gains.K_th, gains.K_dth
    Bc[0:2] = gains.K_u
    Ac[2:4, 4:6] = np.eye(2)
    Bc[4:6] = np.eye(2)
    Ac[12:14, 0:2] = np.eye(2)
    return Ac, Bc


def shape_model(gains: ShapeGains, dt: float, kugle_only: bool = False) -> LoopModel:
    """The discrete shape-accelerated model at the MPC step ``dt`` (module docstring)."""
    if not (np.isfinite(dt) and dt > 0):
        raise ShapeError(f"dt must be > 0 s, got {dt!r}")
    g = gains.kugle() if kugle_only else gains
    Ac, Bc = continuous_shape_model(g)
    M = np.zeros((NXL + 2, NXL + 2))
    M[:NXL, :NXL], M[:NXL, NXL:] = Ac, Bc
    Md = scipy.linalg.expm(M * dt)
    A, B = Md[:NXL, :NXL], Md[:NXL, NXL:]
    eye = np.eye(NXL)
    C = {"v": eye[0:2], "tilt": eye[2:4], "tilt_rate": eye[4:6], "acc": Ac[0:2],
         "tilt_acc": np.zeros((2, NXL))}
    D = {"v": np.zeros((2, 2)), "tilt": np.zeros((2, 2)), "tilt_rate": np.zeros((2, 2)),
         "acc": Bc[0:2].copy(), "tilt_acc": np.eye(2)}
    return LoopModel(A, B, C, D, float(dt))

"""Online adaptation of the velocity filter's acceleration random walk (issue 22).

The velocity filter's process model (thesis 5.9-5.10) lets the ball acceleration walk,
``a_k = a_{k-1} + w_k``, ``w_k ~ N(0, Q_a)``; the thesis gives no value for ``Q_a``
(§5.3) and the right one depends on what the robot does: measured from the truth in the
closed loop, the moving robot's ball acceleration changes by ~1e-2 (m/s^2)^2 per period,
the standing robot's (COM offset, position hold) by 0.08-0.12.  One constant is
overconfident on one and underconfident on the other.  This module estimates ``Q_a`` per
axis while the filter runs, from its own corrections, with no truth.

Derivation (covariance matching, Mehra 1972 [1]; Mohamed and Schwarz 1999 [2]).  For a
consistent Kalman filter the correction ``dx = K nu`` has covariance
``E[dx dx^T] = K S K^T = P^- - P^+`` (thesis 5.25).  The acceleration rows of the process
model are ``a_k = a_{k-1}`` (the velocity does not feed back into them), so the
acceleration block of the prediction is ``P^-_aa = P^+_aa(k-1) + Q_a`` (also with the
matched model's ``G Q G^T``, whose ``aa`` block is ``Q_a``).  At a stationary covariance
``P^+_aa(k) = P^+_aa(k-1)``, hence

    ``E[dx_a dx_a^T] = P^-_aa - P^+_aa = Q_a``,

the expected square of the acceleration correction *is* the random walk.  Conversely, a
filter run with a wrong ``Q`` has corrections whose mean square differs from it: when the
accelerometer is precise (``Sigma_acc`` ~ 4e-4 against ``Q_a`` ~ 1e-2), the gain on the
acceleration is near one, ``dx_a`` is about the period's true change of acceleration
whatever ``Q`` the filter assumed, and the fixed point ``Q_a`` of the matching is reached in
a few time constants.  The estimate is a Sage-Husa exponentially weighted mean with
forgetting factor ``1 - lambda`` (Sage and Husa 1969 [3]; a state of the filter):

    ``q_{k} = clip((1 - lambda) q_{k-1} + lambda min(dx_{a,k}^2, q_max), q_min, q_max)``

per horizontal axis of the inertial frame (``dx[2]``, ``dx[3]``: the COM offset and the
profiles make the motion anisotropic).  Its time constant is ``Ts / lambda``; the relative
spread of the estimate of a stationary walk is about ``sqrt(lambda)`` (the mean of
``2 / lambda`` squared Gaussians).  It is updated only in periods where every measurement
component was used (``n_valid`` = all): a missing or gated reading's zero correction
would drag it down.  Bounded by construction: each sample is clipped to the ceiling
before it enters, so one glitch that passes the innovation gate moves ``q`` by at most
``lambda q_max`` and decays with ``(1 - lambda)^k``; ``q`` stays in ``[q_min, q_max]``
whatever the readings (a non-finite correction leaves it unchanged).

The filter uses ``diag(q)`` as the acceleration block of its ``Q`` (the other blocks are
the configured ``Q``'s).  A state of ``0`` (the power-on value) means "not yet
adapted": the configured ``Q``'s acceleration block is used as the prior for that period.

[1] R. K. Mehra, "Approaches to adaptive filtering", IEEE Trans. Autom. Control 17(5),
    1972.  [2] A. H. Mohamed, K. P. Schwarz, "Adaptive Kalman filtering for INS/GPS",
    J. Geodesy 73, 1999 (``Q = K C_nu K^T``).  [3] A. P. Sage, G. W. Husa, "Adaptive
    filtering with unknown prior statistics", JACC 1969.  Jaulin, Mobile Robotics (2019),
    ch. 7, gives the Kalman filter whose covariances these are.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca

from ballbot_casadi.errors import ShapeError
from ballbot_casadi.estimation.linalg import FINITE_MAX
from ballbot_casadi.estimation.tuning import (
    ADAPTIVE_WALK_CEILING,
    ADAPTIVE_WALK_FLOOR,
    ADAPTIVE_WALK_FORGETTING,
)

__all__ = ["ACC_AXES", "WalkAdaptation", "adapt_walk", "prior_walk", "with_walk"]

#: The acceleration entries of the velocity filter's state (and tangent): ``ddx, ddy``.
ACC_AXES = slice(2, 4)


@dataclass(frozen=True)
class WalkAdaptation:
    """Constants of the random-walk adaptation (module docstring), generated into the
    filter's C.

    Attributes
    ----------
    forgetting
        ``lambda`` in (0, 1): the weight of the newest squared correction (time constant
        ``Ts / lambda``).
    floor, ceiling
        Bounds of the estimate, (m/s^2)^2 per period, ``0 < floor < ceiling``.
    """

    forgetting: float = ADAPTIVE_WALK_FORGETTING
    floor: float = ADAPTIVE_WALK_FLOOR
    ceiling: float = ADAPTIVE_WALK_CEILING

    def __post_init__(self) -> None:
        vals = (self.forgetting, self.floor, self.ceiling)
        if not all(isinstance(v, (int, float)) and math.isfinite(v) for v in vals):
            raise ShapeError(f"walk adaptation constants must be finite numbers, got {vals!r}")
        if not 0.0 < self.forgetting < 1.0:
            raise ShapeError(f"walk adaptation forgetting must be in (0, 1), got {self.forgetting!r}")
        if not 0.0 < self.floor < self.ceiling:
            raise ShapeError("walk adaptation bounds must satisfy 0 < floor < ceiling, got "
                             f"floor {self.floor!r}, ceiling {self.ceiling!r}")


def prior_walk(q_state, Q):
    """The random walk a period uses (2): the state where it is positive, else (power-on,
    ``q_state = 0``) the diagonal of ``Q``'s acceleration block."""
    return ca.vertcat(*(ca.if_else(q_state[i] > 0, q_state[i], Q[2 + i, 2 + i]) for i in range(2)))


def with_walk(Q, q):
    """``Q`` with its acceleration block replaced by ``diag(q)``."""
    n = Q.size1()
    keep = ca.DM.ones(n, n)  # the entries outside the acceleration rows and columns
    keep[2:4, :] = 0
    keep[:, 2:4] = 0
    E = ca.DM.zeros(n, 2)
    E[2, 0] = E[3, 1] = 1.0
    return Q * keep + ca.mtimes([E, ca.diag(q), E.T])


def adapt_walk(q, dx_acc, all_valid, a: WalkAdaptation):
    """One Sage-Husa step of the estimate (module docstring): ``q`` (2) the walk used this
    period, ``dx_acc`` (2) the period's acceleration correction, ``all_valid`` true when
    every measurement component was used.  Returns the next period's ``q``."""
    ok = ca.logic_and(all_valid, ca.logic_and(ca.fabs(dx_acc[0]) <= FINITE_MAX,
                                              ca.fabs(dx_acc[1]) <= FINITE_MAX))
    d = ca.if_else(ok, dx_acc, ca.DM.zeros(2), True)
    sample = ca.fmin(d * d, a.ceiling)
    q_new = ca.fmin(ca.fmax((1 - a.forgetting) * q + a.forgetting * sample, a.floor), a.ceiling)
    return ca.if_else(ok, q_new, ca.fmin(ca.fmax(q, a.floor), a.ceiling), True)

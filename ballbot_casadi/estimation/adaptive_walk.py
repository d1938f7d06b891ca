"""Online adaptation of the velocity filter's acceleration random walk (issue 22).

The velocity filter's process model (thesis 5.9-5.10) lets the ball acceleration walk,
``a_k = a_{k-1} + w_k``, ``w_k ~ N(0, Q_a)``; the thesis gives no value for ``Q_a``
(§5.3) and the right one depends on what the robot does: measured from the truth in the
closed loop, the moving robot's ball acceleration changes by ~1e-2 (m/s^2)^2 per period,
the standing robot's (COM offset, position hold) by 0.08-0.12.  One constant is
overconfident on one and underconfident on the other.  This module estimates ``Q_a`` per
axis while the filter runs, from its own accelerometer innovations, with no truth.

Derivation (innovation covariance matching, Mehra 1970/1972 [1]; Myers and Tapley 1976
[2]).  The accelerometer prediction (thesis 5.18) is ``R(q)^T [a, g] + b``: rotated to the
inertial frame, its horizontal part is ``a + (R(q) b)_xy``, so in that frame the
horizontal accelerometer innovation ``nu_I = (R(q) nu_acc)_xy`` has the predicted
covariance ``S_I = (R(q) S_acc R(q)^T)_xy`` (``S_acc`` the accelerometer block of the
innovation covariance ``P_zz``, thesis 5.21 + 5.28) whose diagonal depends on the walk
with unit slope: the acceleration rows of the process model are ``a_k = a_{k-1}`` (also
with the matched model's ``G Q G^T``, whose ``aa`` block is ``Q_a``), so
``P^-_aa = P^+_aa + Q_a`` and ``dS_I,ii / dq_i = 1``.  The filter is consistent on the
axis when ``E[nu_I,i^2] = S_I,ii``, i.e. when

    ``q_i = E[s_i]``,   ``s_i = nu_I,i^2 - (S_I,ii - q_i)``,

the squared innovation less the part of its predicted variance that is not the walk
(prior acceleration error, accelerometer noise, offset, body rate): an unbiased sample of
the walk for a filter of the true model.  A filter run with a wrong ``q`` has
``E[nu^2] - S`` of the sign of the error, so the matching drives ``q`` to the value that
makes the accelerometer's innovations consistent.  The estimate is a Sage-Husa
exponentially weighted mean with forgetting factor ``1 - lambda`` (Sage and Husa 1969
[3]; a state of the filter):

    ``q_{k} = clip((1 - w_k) q_{k-1} + w_k clip(s_{i,k}, 0, s_max), q_min, q_max)``,
    ``w_k = max(lambda, 1 / (n_0 + k))``

per horizontal axis of the inertial frame (the COM offset and the profiles make the
motion anisotropic).  Its time constant is ``Ts / lambda``; the relative spread of the
estimate of a stationary walk is about ``sqrt(lambda)`` (the mean of ``2 / lambda``
squared Gaussians).  The weight ``w_k`` is Sage and Husa's growing memory at the start:
the prior (``Q``'s acceleration block) counts as ``n_0`` samples and the estimate is the
plain mean of the prior and the samples so far until ``n_0 + k`` reaches ``1 / lambda``
(a prior a decade off is forgotten in a fraction of a second, not in several time
constants); the count ``k`` is the third entry of the state.  It is updated only in
periods where every measurement component was used (``n_valid`` = all): a missing or
gated reading has no innovation.  Bounded by construction: each sample is clipped to
``[0, s_max]`` before it enters, so one glitch that passes the innovation gate moves ``q``
by at most ``lambda s_max`` (after the start) and decays with ``(1 - lambda)^k``; ``q``
stays in ``[q_min, q_max]`` whatever the readings (a non-finite sample leaves it unchanged).
``s_max`` is ten times ``q_max``: the loop's innovations have heavier tails than a Gaussian
(clipping the samples at ``q_max`` = 1 lowered the com_observer estimate enough to move its
mean NIS from 6.07 to 6.09, the band's edge).

Why the innovations and not the corrections: the covariance-matching estimate from the
corrections, ``E[dx_a dx_a^T] = P^-_aa - P^+_aa = Q_a`` at a stationary covariance
(Mohamed and Schwarz 1999 [4], ``Q = K C_nu K^T``), converges to the walk as well on
matched data, but in the closed loop (where the ball's acceleration is not exactly a
random walk) it settled 5 % below the walk that makes the innovations consistent
(com_observer: mean NIS 6.10, above the band; the same walk held constant: 6.11).

The filter uses ``diag(q)`` as the acceleration block of its ``Q`` (the other blocks are
the configured ``Q``'s).  A state of ``0`` (the power-on value) means "not yet
adapted": the configured ``Q``'s acceleration block is used as the prior for that period.

[1] R. K. Mehra, "On the identification of variances and adaptive Kalman filtering",
    IEEE Trans. Autom. Control 15(2), 1970; "Approaches to adaptive filtering", ibid.
    17(5), 1972.  [2] K. A. Myers, B. D. Tapley, "Adaptive sequential estimation with
    unknown noise statistics", IEEE Trans. Autom. Control 21(4), 1976.  [3] A. P. Sage,
    G. W. Husa, "Adaptive filtering with unknown prior statistics", JACC 1969.
    [4] A. H. Mohamed, K. P. Schwarz, "Adaptive Kalman filtering for INS/GPS",
    J. Geodesy 73, 1999.  Jaulin, Mobile Robotics (2019),
    ch. 7, gives the Kalman filter whose covariances these are.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca

from ballbot_casadi.errors import ShapeError
from ballbot_casadi.estimation.linalg import FINITE_MAX, make_cholesky, solve_lower
from ballbot_casadi.estimation.tuning import (
    ADAPTIVE_WALK_CEILING,
    ADAPTIVE_WALK_FLOOR,
    ADAPTIVE_WALK_FORGETTING,
    ADAPTIVE_WALK_PRIOR_SAMPLES,
    ADAPTIVE_WALK_SAMPLE_MAX,
)

__all__ = ["ACC_STATE", "WALK_SIZE", "WalkAdaptation", "adapt_walk", "prior_walk",
           "make_walk_sample", "with_walk"]

#: The acceleration entries of the velocity filter's state ``[v, a, b_acc]``.
ACC_STATE = slice(2, 4)
#: Smallest ``b_i`` of a sample (an innovation insensitive to the walk gives none).
FINITE_MIN = 1e-300
#: Size of the adaptation's state ``[q_x, q_y, n]``: the walk per axis and the number of
#: samples in it (saturating at ``1 / lambda``).
WALK_SIZE = 3


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
    sample_max
        Each sample is clipped to ``[0, sample_max]`` (>= ``ceiling``) before it enters.
    prior_samples
        ``n0 >= 0``: the number of squared corrections the prior (``Q``'s acceleration
        block at power-on) counts for.
    """

    forgetting: float = ADAPTIVE_WALK_FORGETTING
    floor: float = ADAPTIVE_WALK_FLOOR
    ceiling: float = ADAPTIVE_WALK_CEILING
    prior_samples: float = ADAPTIVE_WALK_PRIOR_SAMPLES
    sample_max: float = ADAPTIVE_WALK_SAMPLE_MAX

    def __post_init__(self) -> None:
        vals = (self.forgetting, self.floor, self.ceiling, self.prior_samples, self.sample_max)
        if not all(isinstance(v, (int, float)) and math.isfinite(v) for v in vals):
            raise ShapeError(f"walk adaptation constants must be finite numbers, got {vals!r}")
        if not 0.0 < self.forgetting < 1.0:
            raise ShapeError(f"walk adaptation forgetting must be in (0, 1), got {self.forgetting!r}")
        if not 0.0 < self.floor < self.ceiling:
            raise ShapeError("walk adaptation bounds must satisfy 0 < floor < ceiling, got "
                             f"floor {self.floor!r}, ceiling {self.ceiling!r}")
        if self.sample_max < self.ceiling:
            raise ShapeError(f"walk adaptation sample_max must be >= ceiling {self.ceiling!r}, "
                             f"got {self.sample_max!r}")
        if self.prior_samples < 0:
            raise ShapeError(f"walk adaptation prior_samples must be >= 0, got {self.prior_samples!r}")


def prior_walk(walk, Q):
    """The random walk a period uses (2): the state's ``q`` where it is positive, else
    (power-on, ``walk = 0``) the diagonal of ``Q``'s acceleration block."""
    return ca.vertcat(*(ca.if_else(walk[i] > 0, walk[i], Q[2 + i, 2 + i]) for i in range(2)))


def with_walk(Q, q):
    """``Q`` with its acceleration block replaced by ``diag(q)``."""
    n = Q.size1()
    keep = ca.DM.ones(n, n)  # the entries outside the acceleration rows and columns
    keep[2:4, :] = 0
    keep[:, 2:4] = 0
    E = ca.DM.zeros(n, 2)
    E[2, 0] = E[3, 1] = 1.0
    return Q * keep + ca.mtimes([E, ca.diag(q), E.T])


def make_walk_sample(nz: int) -> ca.Function:
    """``walk_sample{nz}(nu, S, Hg, q) -> (s, ok)``: the period's samples of the walk per
    axis (module docstring), ``s_i = q_i + (a_i^2 - b_i) / b_i^2`` with
    ``a_i = h_i^T S^-1 nu``, ``b_i = h_i^T S^-1 h_i``; ``nu`` (nz) the innovation, ``S`` its
    predicted covariance, ``Hg`` (nz x 2) the columns ``h_i = H G e_i``, ``q`` (2) the walk
    used.  ``ok`` is 0 when ``S`` is not positive definite (no sample)."""
    nu, S = ca.SX.sym("nu", nz), ca.SX.sym("S", nz, nz)
    Hg, q = ca.SX.sym("Hg", nz, 2), ca.SX.sym("q", 2)
    L, pd = make_cholesky(nz)(0.5 * (S + S.T))
    W = solve_lower(L, ca.horzcat(nu, Hg))  # whitened: L^-1 [nu, h_x, h_y]
    a = ca.mtimes(W[:, 1:].T, W[:, 0])
    b = ca.sum1(W[:, 1:] * W[:, 1:]).T
    b = ca.fmax(b, FINITE_MIN)
    return ca.Function(f"walk_sample{nz}", [nu, S, Hg, q], [q + (a * a - b) / (b * b), pd],
                       ["nu", "S", "Hg", "q"], ["s", "ok"], {"cse": True})


def adapt_walk(walk, q, sample, all_valid, a: WalkAdaptation):
    """One Sage-Husa step (module docstring).  ``walk`` the filter's state ``[q_x, q_y, n]``
    (:data:`WALK_SIZE`), ``q`` (2) the walk used this period (:func:`prior_walk`),
    ``sample`` (2) the period's samples (:func:`make_walk_sample`), ``all_valid`` true when every
    measurement component was used.  Returns the next period's state."""
    ok = ca.logic_and(all_valid, ca.logic_and(ca.fabs(sample[0]) <= FINITE_MAX,
                                              ca.fabs(sample[1]) <= FINITE_MAX))
    s = ca.if_else(ok, sample, ca.DM.zeros(2))
    n = ca.fmin(ca.fmax(walk[2], 0), 1.0 / a.forgetting)
    w = ca.fmax(a.forgetting, 1.0 / (a.prior_samples + n + 1))
    s = ca.fmin(ca.fmax(s, 0), a.sample_max)
    q_new = ca.fmin(ca.fmax((1 - w) * q + w * s, a.floor), a.ceiling)
    q_held = ca.fmin(ca.fmax(q, a.floor), a.ceiling)
    return ca.vertcat(ca.if_else(ok, q_new, q_held),
                      ca.if_else(ok, ca.fmin(n + 1, 1.0 / a.forgetting), n))

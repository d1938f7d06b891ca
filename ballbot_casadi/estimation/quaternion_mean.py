"""Weighted means of unit quaternions: the filter's code-generatable mean and references.

The QUKF needs the mean of its propagated sigma-point quaternions (thesis 4.19-4.20).
The thesis computes it by an exhaustive *sweep*: candidate rotations on a grid are tried
and the one minimising ``sum_i ||R(q) - R(q_i)||_F^2`` is kept (4.20).  That is accurate
only to the grid step and cannot be code-generated at a useful resolution.

:func:`make_karcher_mean` replaces it with the intrinsic (Karcher, geodesic) mean,
computed by a fixed number of Gauss-Newton steps on the unit sphere::

    mu <- mu o exp( sum_i w_i log(mu* o q_i) )

(``exp``/``log`` of :mod:`ballbot_casadi.core.quaternion`; ``log`` takes the shortest
branch, so ``q`` and ``-q`` are the same rotation).  Every step multiplies unit
quaternions, so the mean is unit by construction - nothing is renormalised.  Near the
solution each step multiplies the error by O(spread^2); for sigma-point spreads of a few
milliradians three steps reach machine precision from the propagated centre point, and
ten steps do so for spreads of 0.3 rad (see the tests).  At the converged mean the
weighted tangent deviations sum to zero, which is what the covariance (4.21)-(4.26)
assumes.

:func:`sweep_mean` (the thesis' method, numpy) and :func:`chordal_mean` (the exact
minimiser of the same Frobenius objective: the principal eigenvector of
``sum_i w_i q_i q_i^T``, because ``||R(p) - R(q)||_F^2 = 8 (1 - (p.q)^2)``) are
numerical references for tests and studies; they are not used by the filters.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.errors import ShapeError

__all__ = [
    "MEAN_ITERATIONS",
    "chordal_mean",
    "karcher_mean",
    "make_karcher_mean",
    "mul_rows",
    "sweep_mean",
]

#: Default number of Karcher steps of the filters' quaternion mean.
MEAN_ITERATIONS = 3


def make_karcher_mean(n_points: int, iterations: int = MEAN_ITERATIONS) -> ca.Function:
    """``quat_mean{n}(Qs, w, q_init) -> q_mean``: weighted Karcher mean (replaces thesis 4.20).

    Parameters
    ----------
    n_points
        Number of quaternions (columns of ``Qs``).
    iterations
        Fixed number of Karcher steps (code generation needs a fixed count).

    Returns
    -------
    casadi.Function
        Inputs ``Qs`` (4 x n unit quaternions), ``w`` (n weights summing to 1; may be
        zero or negative), ``q_init`` (unit starting point, e.g. the propagated centre
        sigma point); output ``q_mean`` (4).
    """
    if n_points < 1 or iterations < 1:
        raise ShapeError(f"need n_points >= 1 and iterations >= 1, got {n_points}, {iterations}")
    Qs = ca.SX.sym("Qs", 4, n_points)
    w = ca.SX.sym("w", n_points)
    mu = ca.SX.sym("q_init", 4)
    m = mu
    for _ in range(iterations):
        e = ca.SX.zeros(3)
        for i in range(n_points):
            e += w[i] * Q.log(Q.mul(Q.conj(m), Qs[:, i]))
        m = Q.mul(m, Q.exp(e))
    return ca.Function(
        f"quat_mean{n_points}", [Qs, w, mu], [m], ["Qs", "w", "q_init"], ["q_mean"], {"cse": True}
    )


def _rows(quats: np.ndarray, weights: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    qs = np.asarray(quats)
    if qs.ndim != 2 or qs.shape[1] != 4:
        raise ShapeError(f"quaternions must be rows of shape (N, 4), got {qs.shape}")
    n = qs.shape[0]
    w = np.full(n, 1.0 / n) if weights is None else np.asarray(weights, dtype=qs.dtype)
    if w.shape != (n,):
        raise ShapeError(f"weights must have shape ({n},), got {w.shape}")
    return qs, w


def mul_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise Hamilton product ``a o b`` of quaternion rows (..., 4) in their own dtype.

    Unlike :func:`ballbot_casadi.core.quaternion.mul` (one quaternion, float64) it keeps
    ``np.longdouble`` and broadcasts over rows.
    """
    a0, a1, a2, a3 = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    b0, b1, b2, b3 = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    return np.stack([a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
                     a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
                     a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1,
                     a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0], axis=-1)


def karcher_mean(quats: np.ndarray, weights: np.ndarray | None = None,
                 iterations: int = 50) -> np.ndarray:
    """Weighted Karcher mean of quaternion rows in the rows' own precision (numpy).

    Used as a high-precision reference with ``np.longdouble`` input; the iteration is
    the one of :func:`make_karcher_mean`, started from the normalised, sign-aligned
    weighted sum.
    """
    qs, w = _rows(quats, weights)
    qs = qs * np.where(qs @ qs[0] < 0, -1, 1)[:, None]
    m = (w[:, None] * qs).sum(axis=0)
    m = m / np.sqrt((m * m).sum())
    for _ in range(iterations):
        d = mul_rows(np.broadcast_to(m * np.array([1, -1, -1, -1], dtype=m.dtype), qs.shape), qs)
        d = d * np.where(d[:, 0] < 0, -1, 1)[:, None]
        nv = np.sqrt((d[:, 1:] ** 2).sum(axis=1))
        ang = np.arctan2(nv, d[:, 0])
        k = np.where(nv > 0, ang / np.where(nv > 0, nv, 1), 1)
        e = (w[:, None] * k[:, None] * d[:, 1:]).sum(axis=0)
        ne = np.sqrt((e * e).sum())
        s = np.sin(ne) / ne if ne > 0 else m.dtype.type(1)
        m = mul_rows(m, np.concatenate([[np.cos(ne)], s * e]))
    return m


def chordal_mean(quats: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """Exact minimiser of the thesis' objective (4.20): principal eigenvector of sum w q q^T."""
    qs, w = _rows(np.asarray(quats, dtype=float), weights)
    M = (w[:, None, None] * qs[:, :, None] * qs[:, None, :]).sum(axis=0)
    v = np.linalg.eigh(M)[1][:, -1]
    return v if v[0] >= 0 else -v


def sweep_mean(quats: np.ndarray, weights: np.ndarray | None = None, step_deg: float = 0.1,
               span_deg: float = 5.0, chunk: int = 200_000) -> np.ndarray:
    """The thesis' sweep mean (4.20): best grid rotation under the Frobenius objective.

    The thesis sweeps "rotations from 0 to 180 degrees about each axis" without giving
    the grid; here the grid is roll, pitch, yaw (ZYX, :func:`quaternion.from_rpy`) each
    in ``[-span, span]`` with spacing ``step_deg`` (both signs, so negative angles are
    reachable).  The objective ``sum_i w_i ||R(q) - R(q_i)||_F^2`` is evaluated through
    its quaternion form ``8 (1 - q^T M q)`` with ``M = sum_i w_i q_i q_i^T``.
    """
    qs, w = _rows(np.asarray(quats, dtype=float), weights)
    M = (w[:, None, None] * qs[:, :, None] * qs[:, None, :]).sum(axis=0)
    ang = np.radians(np.arange(-span_deg, span_deg + 0.5 * step_deg, step_deg))
    r, p, y = (a.ravel() for a in np.meshgrid(ang, ang, ang, indexing="ij"))
    best, best_val = None, -np.inf
    for s in range(0, r.size, chunk):
        cand = Q.from_rpy(r[s:s + chunk], p[s:s + chunk], y[s:s + chunk]).T
        val = np.einsum("ni,ij,nj->n", cand, M, cand)
        i = int(np.argmax(val))
        if val[i] > best_val:
            best, best_val = cand[i], val[i]
    return best

"""Small dense linear algebra of the filters as code-generatable SX Functions.

Every routine is unrolled for a fixed size (n <= ~10), so the generated C has no loops
over dynamic sizes, no malloc and no LAPACK.  Three Functions are built here and called
by the filter core (thesis §3.4, eqs 3.20, 3.29-3.31):

* :func:`make_cholesky` - lower Cholesky factor ``L L^T = A`` (thesis 3.20, 4.5, 5.5).
* :func:`make_spd_repair` - symmetrise a covariance and, if it is not positive definite,
  add the smallest jitter of a short ladder that makes it so; reports whether it had to.
* :func:`make_masked_update` - the Kalman gain and correction (thesis 3.29-3.31) for a
  measurement vector whose non-finite components are masked out *inside* the Function.
* :func:`make_innovation_gate` - the chi-square test of each measurement group's
  normalised innovation; a rejected group's components are replaced by NaN, so the
  masked update skips them.

Positive definiteness test
--------------------------
A symmetric ``A`` counts as positive definite when every pivot ``d_j`` of its Cholesky
factorisation (the Schur complements, ``L_jj = sqrt(d_j)``) satisfies
``d_j > PIVOT_TOL * A_jj``: a pivot that lost all but ``1e-13`` of its diagonal is
numerically singular and would give an unreliable square root in the next sigma-point
set.  Non-finite pivots fail the test.

Repair ladder
-------------
``A_s = (A + A^T) / 2``; if it passes, it is returned unchanged.  Otherwise
``A_s + delta_1 I`` with ``delta_1 = max(0, -min_j d_j) + JITTER * mean(diag)``; if that
still fails, ``A_s + delta_2 I`` with the Gershgorin bound
``delta_2 = max(0, -min_i (A_ii - sum_{j != i} |A_ij|)) + JITTER * mean(diag)``, which is
positive definite by Gershgorin's circle theorem.  All candidates are evaluated and the
first that passes is selected with ``if_else`` (no branch leaks a NaN into the result).
"""

from __future__ import annotations

import sys
from typing import Sequence

import casadi as ca

__all__ = [
    "FINITE_MAX",
    "JITTER",
    "PIVOT_TOL",
    "make_cholesky",
    "make_innovation_gate",
    "make_masked_update",
    "make_spd_repair",
    "solve_lower",
]

#: Relative pivot threshold of the positive-definiteness test (see module docstring).
PIVOT_TOL = 1e-13
#: Relative diagonal jitter of a repair (times the mean diagonal entry).
JITTER = 1e-9
#: A measurement component counts as valid when ``|z_i| <= FINITE_MAX`` (false for NaN, inf).
FINITE_MAX = sys.float_info.max
#: Absolute floor of the jitter scale, so an all-zero covariance is still repaired.
_JITTER_FLOOR = 1e-30


def _chol_pivots(A: ca.SX) -> tuple[ca.SX, list]:
    """Unrolled Cholesky of symmetric ``A``: guarded factor ``L`` and the raw pivots ``d_j``.

    A failing pivot is replaced by ``max(|A_jj|, floor)`` in ``L`` so the factorisation
    always finishes with finite numbers; callers use the raw pivots to decide.
    """
    n = A.size1()
    L = ca.SX.zeros(n, n)
    pivots = []
    for j in range(n):
        d = A[j, j]
        for k in range(j):
            d -= L[j, k] ** 2
        pivots.append(d)
        ok = d > PIVOT_TOL * A[j, j]
        safe = ca.if_else(ok, d, ca.fmax(ca.fabs(A[j, j]), _JITTER_FLOOR))
        ljj = ca.sqrt(safe)
        L[j, j] = ljj
        for i in range(j + 1, n):
            s = A[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            L[i, j] = s / ljj
    return L, pivots


def _is_pd(A: ca.SX, pivots: list) -> ca.SX:
    ok = ca.SX(1)
    for j, d in enumerate(pivots):
        ok = ca.logic_and(ok, d > PIVOT_TOL * A[j, j])
    return ok


def make_cholesky(n: int) -> ca.Function:
    """``chol{n}(A) -> (L, pd)``: lower Cholesky factor (thesis 3.20) and the PD flag.

    ``pd`` is 1 when ``A`` passes the positive-definiteness test of the module docstring.
    ``L`` is always finite; it is the exact factor when ``pd`` is 1.
    """
    A = ca.SX.sym("A", n, n)
    L, piv = _chol_pivots(A)
    return ca.Function(f"chol{n}", [A], [L, _is_pd(A, piv)], ["A"], ["L", "pd"], {"cse": True})


def make_spd_repair(n: int) -> ca.Function:
    """``spd_repair{n}(P) -> (P_spd, repaired)``: symmetrise, and repair if not PD.

    See the module docstring for the ladder.  ``repaired`` is 1 when a jitter was added.
    """
    P = ca.SX.sym("P", n, n)
    Ps = 0.5 * (P + P.T)
    _, piv = _chol_pivots(Ps)
    ok0 = _is_pd(Ps, piv)
    scale = ca.fmax(ca.fabs(ca.trace(Ps)) / n, _JITTER_FLOOR)
    jit = JITTER * scale
    dmin = piv[0]
    for d in piv[1:]:
        dmin = ca.fmin(dmin, d)
    P1 = Ps + (ca.fmax(0, -dmin) + jit) * ca.SX.eye(n)
    _, piv1 = _chol_pivots(P1)
    ok1 = _is_pd(P1, piv1)
    gersh = []
    for i in range(n):
        off = 0
        for j in range(n):
            if j != i:
                off += ca.fabs(Ps[i, j])
        gersh.append(Ps[i, i] - off)
    gmin = gersh[0]
    for g in gersh[1:]:
        gmin = ca.fmin(gmin, g)
    P2 = Ps + (ca.fmax(0, -gmin) + jit) * ca.SX.eye(n)
    out = ca.if_else(ok0, Ps, ca.if_else(ok1, P1, P2))
    return ca.Function(
        f"spd_repair{n}", [P], [out, 1 - ok0], ["P"], ["P_spd", "repaired"], {"cse": True}
    )


def solve_lower(L: ca.SX, B: ca.SX) -> ca.SX:
    """``L^-1 B`` for a lower-triangular SX ``L`` (unrolled forward substitution)."""
    return _tri_solve_lower(L, B)


def _tri_solve_lower(L: ca.SX, B: ca.SX) -> ca.SX:
    """Solve ``L X = B`` by forward substitution (L lower triangular, unrolled)."""
    n, m = B.shape
    X = ca.SX.zeros(n, m)
    for c in range(m):
        for i in range(n):
            s = B[i, c]
            for k in range(i):
                s -= L[i, k] * X[k, c]
            X[i, c] = s / L[i, i]
    return X


def make_masked_update(n: int, m: int) -> ca.Function:
    """``kf_update{n}x{m}(P_pred, P_xz, P_zz, z, z_pred) -> (dx, P_post, nu, nis, n_valid)``.

    The correction step of thesis (3.29)-(3.31) / (4.34)-(4.36) / (5.23)-(5.25) with the
    measurement validity mask computed inside:

    * ``valid_i = |z_i| <= FINITE_MAX`` (0 for NaN and +-inf);
    * the raw ``z`` is replaced by 0 where invalid *before* it is used, so a NaN never
      reaches an arithmetic operation, then ``nu = valid * (z - z_pred)``;
    * with ``M = diag(valid)``: ``S = M P_zz M + (I - M)``, ``C = P_xz M``,
      ``K = C S^-1`` (its columns of invalid components are exactly zero),
      ``dx = K nu``, ``P_post = P_pred - K S K^T = P_pred - C S^-1 C^T``;
    * ``nis = nu^T S^-1 nu`` (normalised innovation squared over the valid components)
      and ``n_valid = sum(valid)``.

    With every component invalid this is exactly a predict-only step.  ``P_zz`` must
    already contain the measurement noise ``R``; ``S`` is factorised by an unrolled
    Cholesky decomposition.  ``dx`` lives in the filter's tangent (error) space.
    """
    P = ca.SX.sym("P_pred", n, n)
    Pxz = ca.SX.sym("P_xz", n, m)
    Pzz = ca.SX.sym("P_zz", m, m)
    z = ca.SX.sym("z", m)
    zp = ca.SX.sym("z_pred", m)
    valid = ca.fabs(z) <= FINITE_MAX
    z_safe = ca.if_else(valid, z, 0)
    nu = valid * (z_safe - zp)
    M = ca.diag(valid)
    S = ca.mtimes([M, 0.5 * (Pzz + Pzz.T), M]) + ca.diag(1 - valid)
    C = ca.mtimes(Pxz, M)
    L, _ = _chol_pivots(S)
    Ci = _tri_solve_lower(L, C.T)  # L^-1 C^T  (m x n)
    ni = _tri_solve_lower(L, nu)  # L^-1 nu
    dx = ca.mtimes(Ci.T, ni)  # C S^-1 nu = K nu
    P_post = P - ca.mtimes(Ci.T, Ci)
    nis = ca.sumsqr(ni)
    return ca.Function(
        f"kf_update{n}x{m}",
        [P, Pxz, Pzz, z, zp],
        [dx, P_post, nu, nis, ca.sum1(valid)],
        ["P_pred", "P_xz", "P_zz", "z", "z_pred"],
        ["dx", "P_post", "nu", "nis", "n_valid"],
        {"cse": True},
    )


def make_innovation_gate(m: int, groups: Sequence[Sequence[int]],
                         thresholds: Sequence[Sequence[float]],
                         max_rejections: int, name: str = "gate") -> ca.Function:
    """``{name}(P_zz, z, z_pred, n_rej) -> (z_gated, rejected, n_rej_next)``: chi-square
    gating of the measurement groups (``g = len(groups)``).

    For group ``G`` (indices into ``z``) with valid components ``M`` (``|z_i| <=
    FINITE_MAX``, as in :func:`make_masked_update`): ``nu_G = M (z_G - z_pred_G)``,
    ``S_G = M P_zz[G, G] M + (I - M)`` and ``d_G = nu_G^T S_G^-1 nu_G``, the normalised
    innovation squared of the group alone.  The group *fails* when it has ``k > 0``
    valid components and ``d_G`` is not ``<= thresholds[G][k - 1]`` (a NaN or infinite
    ``d_G`` fails too).  A failing group is *rejected* unless ``n_rej_G >=
    max_rejections``: after that many consecutive rejections the gate is open and stays
    open (the group is used whatever its innovation) until an innovation passes again -
    the guard against lock-out after a real manoeuvre or a long dropout that the filter's
    model did not foresee.  A rejected group's components of ``z_gated`` are NaN (the
    masked update then skips them: a predict-only step for that group); the others are
    ``z``.  ``rejected`` (g) is 1 for a rejected group; the counters of the next period
    are ``n_rej_next = fails min(n_rej + 1, max_rejections)`` (0 once a group passes).
    """
    if len(groups) != len(thresholds) or not all(len(t) == len(g)
                                                   for g, t in zip(groups, thresholds)):
        raise ValueError("one threshold per possible number of valid components of each group")
    Pzz = ca.SX.sym("P_zz", m, m)
    z = ca.SX.sym("z", m)
    zp = ca.SX.sym("z_pred", m)
    n_rej = ca.SX.sym("n_rej", len(groups))
    z_out = [z[i] for i in range(m)]
    rejected, counts = [], []
    for j, (idx, thr) in enumerate(zip(groups, thresholds)):
        idx = list(idx)
        zg, zpg = z[idx], zp[idx]
        valid = ca.fabs(zg) <= FINITE_MAX
        nu = valid * (ca.if_else(valid, zg, 0) - zpg)
        M = ca.diag(valid)
        S = ca.mtimes([M, 0.5 * (Pzz[idx, idx] + Pzz[idx, idx].T), M]) + ca.diag(1 - valid)
        L, _ = _chol_pivots(S)
        d = ca.sumsqr(_tri_solve_lower(L, nu))
        k = ca.sum1(valid)
        limit = ca.SX(thr[-1])
        for n_valid in range(len(thr) - 1, 0, -1):
            limit = ca.if_else(k == n_valid, thr[n_valid - 1], limit)
        fails = ca.logic_and(k > 0, ca.logic_not(d <= limit))
        rej = ca.logic_and(fails, n_rej[j] < max_rejections)
        rejected.append(rej)
        counts.append(fails * ca.fmin(n_rej[j] + 1, max_rejections))
        for i in idx:
            z_out[i] = ca.if_else(rej, ca.DM.nan(1), z[i])
    rejected = ca.vertcat(*rejected)
    return ca.Function(
        name,
        [Pzz, z, zp, n_rej],
        [ca.vertcat(*z_out), rejected, ca.vertcat(*counts)],
        ["P_zz", "z", "z_pred", "n_rej"],
        ["z_gated", "rejected", "n_rej_next"],
        {"cse": True},
    )

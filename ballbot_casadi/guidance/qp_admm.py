"""A fixed-iteration ADMM solver for the MPC's small dense QP, as CasADi expressions.

``ballbot_mpc_admm(P, q, l, h, nobs, u0, z0, y0) -> (u_opt, z, y, r_prim)`` (:func:`make_admm`;
the MPC forms ``K`` itself and calls :func:`admm_iterate`) solves

``min 1/2 u'P u + q'u + sum_i c_i dist(a_i u, [l_i, u_i])``

with the rows ``A = [A_c; N(nobs) G]``: constant rows ``A_c`` (built into the code as
constants) and rows ``N G`` whose left factor ``N`` (a fixed sparsity, nonzeros
``nobs``) is a parameter (the obstacle normals acting on the predicted positions
``G u``).  Rows with a finite penalty ``c_i`` are soft (an exact L1 penalty, no slack
variables); rows with ``c_i = inf`` are hard.

Algorithm: the ADMM iteration of OSQP (Stellato et al., "OSQP: an operator splitting
solver for quadratic programs", 2020; with relaxation ``alpha``), where the soft rows change only the ``z``-update: the proximal map of
``(c_i / rho) dist(., [l_i, u_i])`` instead of the projection onto ``[l_i, u_i]``, so
their multipliers stay within ``[-c_i, c_i]`` (bounded, no divergence on infeasible
rows).  ``K = P + sigma I + rho A'A`` is factorised once per call (sparse LDL', CasADi's
``ldl`` linear solver, which generates plain C; its inverse is formed by ``n`` solves),
then ``iterations`` fixed steps follow: a deterministic operation count and a static
workspace (no data-dependent branching, no allocation).  Warm start: ``u0, z0, y0``.
Generated C and static workspace: the ``iterations`` steps are one flat MX graph in
the caller's Function (:func:`admm_iterate`), so CasADi's live-variable analysis gives
all steps the same few work vectors (a work vector is only reused by one of equal size;
a called step Function would hold copies of all its inputs).  The products with the
constant factors, ``A v`` and ``A' w``, and ``K^-1 r`` are small called Functions: their
constants and temporaries share the callees' workspace region.  Scalar constants are single nodes
(CasADi orders constant nodes, with no dependencies, before the first iteration, so a
literal per use would be a work element each).  The multiplier update is written
``y+ = rho (w - z+)`` with ``w = v + y / rho`` (equal to ``y + rho (v - z+)``), so ``v``
and ``y`` die early.  The C multiplies by the sparse factors and the dense ``K^-1`` in
loops (an SX body wrote one scalar line per product: several times the C and the
compile time).
``r_prim = ||A u - z||_inf`` tells how far from feasibility (of the rows' split) the
fixed iteration count left the solution (the dual residual is not formed: it would keep
``P`` in the workspace).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from ballbot_casadi.errors import ShapeError

__all__ = ["make_admm", "admm_graph", "admm_iterate", "kkt_constant"]

#: Stand-in for an infinite penalty in the generated code (a hard row).
_HARD = 1e20


def make_admm(n: int, A_c: np.ndarray, G: np.ndarray, N_sp: ca.Sparsity, penalty: np.ndarray,
              rho: float, sigma: float, alpha: float, iterations: int) -> ca.Function:
    """Build ``ballbot_mpc_admm`` (see the module docstring; arguments: :func:`admm_graph`)."""
    m = np.asarray(A_c).shape[0] + N_sp.size1()
    Pm = ca.MX.sym("P", ca.Sparsity.dense(n, n))
    qm, lm, hm = ca.MX.sym("q", n), ca.MX.sym("l", m), ca.MX.sym("u", m)
    nm = ca.MX.sym("nobs", N_sp.nnz())
    u0, z0, y0 = ca.MX.sym("u0", n), ca.MX.sym("z0", m), ca.MX.sym("y0", m)
    out = admm_graph(n, (np.eye(m - N_sp.size1()), A_c), G, N_sp, penalty, rho, sigma, alpha, iterations,
                     Pm, qm, lm, hm, nm, u0, z0, y0)
    return ca.Function("ballbot_mpc_admm", [Pm, qm, lm, hm, nm, u0, z0, y0], list(out),
                       ["P", "q", "l", "h", "nobs", "u0", "z0", "y0"],
                       ["u_opt", "z", "y", "r_prim"])


def admm_graph(n: int, A_c: tuple[np.ndarray, np.ndarray], G: np.ndarray, N_sp: ca.Sparsity, penalty: np.ndarray,
               rho: float, sigma: float, alpha: float, iterations: int, Pm: ca.MX, qm: ca.MX,
               lm: ca.MX, hm: ca.MX, nm: ca.MX, u0: ca.MX, z0: ca.MX, y0: ca.MX
               ) -> tuple[ca.MX, ca.MX, ca.MX, ca.MX]:
    """The ADMM as MX expressions of the QP data ``Pm, qm, lm, hm, nm`` and the warm
    start ``u0, z0, y0`` (one flat graph: the caller's data share its workspace).

    Parameters
    ----------
    n
        Unknowns.
    A_c
        Constant rows as a product ``(D, Y)``, ``A_c = D Y`` (m_c x k, k x n): a thin ``Y``
        and a sparse ``D`` take fewer operations than their product.
    G
        Constant map to the quantities the parametric rows act on (m_g, n).
    N_sp
        Sparsity (m_o, m_g) of the parametric left factor ``N``.
    penalty
        L1 penalty ``c_i`` per row (m_c + m_o), ``inf`` for a hard row.
    rho, sigma, alpha
        ADMM step, proximal regularisation, relaxation (OSQP's defaults: 0.1, 1e-6, 1.6).
    iterations
        Fixed number of ADMM iterations.
    """
    N_m = ca.MX(N_sp, nm)
    Gd = ca.MX(ca.sparsify(ca.DM(np.asarray(G, float))))
    NG = ca.mtimes(N_m, Gd)
    C0 = kkt_constant(A_c, rho, sigma)
    K = ca.densify(Pm + ca.MX(ca.DM(C0)) + rho * ca.mtimes(NG.T, NG))
    return admm_iterate(A_c, G, N_sp, penalty, rho, sigma, alpha, iterations, K, qm, lm, hm, nm,
                        u0, z0, y0)


def kkt_constant(A_c: tuple[np.ndarray, np.ndarray], rho: float, sigma: float) -> np.ndarray:
    """The constant part ``sigma I + rho A_c' A_c`` of the ADMM's KKT matrix (dense, n x n)."""
    A = np.asarray(A_c[0], float) @ np.asarray(A_c[1], float)
    return sigma * np.eye(A.shape[1]) + rho * (A.T @ A)


def admm_iterate(A_c: tuple[np.ndarray, np.ndarray], G: np.ndarray, N_sp: ca.Sparsity,
                 penalty: np.ndarray, rho: float, sigma: float, alpha: float, iterations: int,
                 K: ca.MX, qm: ca.MX, lm: ca.MX, hm: ca.MX, nm: ca.MX, u0: ca.MX, z0: ca.MX,
                 y0: ca.MX) -> tuple[ca.MX, ca.MX, ca.MX, ca.MX]:
    """The ADMM on the KKT matrix ``K = P + sigma I + rho A'A`` (dense MX, formed by the
    caller), the linear term ``qm``, the row bounds and the warm start: ``(u, z, y, r_prim)``.

    ``K^-1`` is formed once (``ldl``, ``n`` solves in place of the identity); the
    ``iterations`` steps are one flat graph in the caller's Function, so CasADi's
    live-variable analysis gives every step the same few work vectors; ``A v``, ``A' w``
    and ``K^-1 r`` are called Functions (see the module docstring).
    """
    Dn, Yn = (np.asarray(M, float) for M in A_c)
    G = np.asarray(G, float)
    m_c, m_o, n = Dn.shape[0], N_sp.size1(), Yn.shape[1]
    penalty = np.asarray(penalty, float).ravel()
    if Dn.shape[1] != Yn.shape[0] or G.shape[1] != n or N_sp.size2() != G.shape[0] or \
            penalty.size != m_c + m_o:
        raise ShapeError(f"ADMM: D {Dn.shape}, Y {Yn.shape}, G {G.shape}, N {N_sp.shape}, "
                         f"penalty {penalty.shape} do not fit")
    Dm, Ym, Gm = (ca.MX(ca.sparsify(ca.DM(M))) for M in (Dn, Yn, G))
    crv = np.where(np.isfinite(penalty), penalty / rho, _HARD)
    cr = ca.MX(float(crv[0])) if np.all(crv == crv[0]) else ca.MX(ca.DM(crv))
    # A v and A' w as two called Functions: their constant factors and temporaries live in
    # the callees' shared workspace, not beside the iteration's vectors
    v_s, w_s, n_s = ca.MX.sym("v", n), ca.MX.sym("w", m_c + m_o), ca.MX.sym("nobs", N_sp.nnz())
    N_s = ca.MX(N_sp, n_s)
    A_f = ca.Function("ballbot_mpc_admm_rows", [v_s, n_s],
                      [ca.vertcat(ca.mtimes(Dm, ca.mtimes(Ym, v_s)), ca.mtimes(N_s, ca.mtimes(Gm, v_s)))],
                      ["v", "nobs"], ["Av"])
    # A'w by the transposed constant factors (in this callee's own workspace, which the
    # callees share; row vectors times D, Y instead take a loop per nonzero in the C)
    DTm, YTm, GTm = (ca.MX(ca.sparsify(ca.DM(M.T))) for M in (Dn, Yn, G))
    At_f = ca.Function("ballbot_mpc_admm_rows_t", [w_s, n_s],
                       [ca.mtimes(YTm, ca.mtimes(DTm, w_s[:m_c]))
                        + ca.mtimes(GTm, ca.mtimes(N_s.T, w_s[m_c:]))], ["w", "nobs"], ["Atw"])

    def A_mul(v: ca.MX) -> ca.MX:
        return A_f(v, nm)

    def At_mul(w: ca.MX) -> ca.MX:
        return At_f(w, nm)

    Kinv = ca.solve(K, ca.DM.eye(n), "ldl")
    # K^-1 r in a called Function too (an inline product's zero accumulator is a constant
    # that CasADi's depth-first ordering places, for all iterations, before the first one)
    Ki_s, r_s = ca.MX.sym("Kinv", ca.Sparsity.dense(n, n)), ca.MX.sym("r", n)
    Ki_f = ca.Function("ballbot_mpc_admm_kinv", [Ki_s, r_s], [ca.mtimes(Ki_s, r_s)],
                       ["Kinv", "r"], ["x"])
    # the scalar constants once (a literal per use would be one work element each, all
    # ordered before the first iteration)
    c_sig, c_rho, c_al, c_1al, c_0 = (ca.MX(v) for v in (sigma, rho, alpha, 1.0 - alpha, 0.0))
    uk, zk, yk = u0, z0, y0
    for _ in range(iterations):
        ut = Ki_f(Kinv, c_sig * uk - qm + At_mul(c_rho * zk - yk))
        zt = A_mul(ut)
        un = c_al * ut + c_1al * uk
        v = c_al * zt + c_1al * zk
        wv = v + yk / c_rho
        zn = wv - ca.fmin(ca.fmax(wv - hm, c_0), cr) + ca.fmin(ca.fmax(lm - wv, c_0), cr)
        # y + rho (v - zn) = rho (wv - zn): v and y are dead once wv is formed (one
        # row-sized work vector less)
        yn = c_rho * (wv - zn)
        uk, zk, yk = un, zn, yn
    return uk, zk, yk, ca.norm_inf(A_mul(uk) - zk)


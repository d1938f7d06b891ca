"""A fixed-iteration ADMM solver for the MPC's small dense QP, as CasADi expressions.

``ballbot_mpc_admm(P, q, l, h, nobs, u0, z0, y0) -> (u_opt, z, y, r_prim)`` solves

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
Generated C: the iteration is one Function called ``iterations`` times, and it, the
KKT matrix and the residual are MX matrix operations, so the C multiplies by the
constant sparse factors and the dense ``K^-1`` in loops (an SX body wrote one scalar
line per product: several times the C and the compile time).
``r_prim = ||A u - z||_inf`` tells how far from feasibility (of the rows' split) the
fixed iteration count left the solution (the dual residual is not formed: it would keep
``P`` in the workspace).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from ballbot_casadi.errors import ShapeError

__all__ = ["make_admm", "admm_graph"]

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
    Dn, Yn = (np.asarray(M, float) for M in A_c)
    A_c, G = Dn @ Yn, np.asarray(G, float)
    m_c, m_o = A_c.shape[0], N_sp.size1()
    m = m_c + m_o
    penalty = np.asarray(penalty, float).reshape(-1)
    if A_c.shape[1] != n or G.shape[1] != n or N_sp.size2() != G.shape[0] or penalty.size != m:
        raise ShapeError(f"ADMM: A_c {A_c.shape}, G {G.shape}, N {N_sp.shape}, penalty "
                         f"{penalty.shape} do not fit n = {n}")
    Dd, Yd = ca.sparsify(ca.DM(Dn)), ca.sparsify(ca.DM(Yn))
    Gd = ca.sparsify(ca.DM(G))
    cr = ca.DM(np.where(np.isfinite(penalty), penalty / rho, _HARD))

    # matrix operations on MX: the generated C multiplies by the constant sparse D, Y, G
    # and the dense K^-1 in loops (casadi_mtimes) instead of one scalar line per product
    # (the SX form took ~70k lines of C and minutes of -O3 per library)
    P = ca.MX.sym("P", ca.Sparsity.dense(n, n))
    q = ca.MX.sym("q", n)
    lo = ca.MX.sym("l", m)
    hi = ca.MX.sym("u", m)
    nobs = ca.MX.sym("nobs", N_sp.nnz())
    Nm = ca.MX(N_sp, nobs)
    Kinv = ca.MX.sym("Kinv", ca.Sparsity.dense(n, n))

    def A_mul(v: ca.MX) -> ca.MX:
        return ca.vertcat(ca.mtimes(Dd, ca.mtimes(Yd, v)), ca.mtimes(Nm, ca.mtimes(Gd, v)))

    def At_mul(w: ca.MX) -> ca.MX:
        return (ca.mtimes(Yd.T, ca.mtimes(Dd.T, w[:m_c]))
                + ca.mtimes(Gd.T, ca.mtimes(Nm.T, w[m_c:])))

    # factorisation, once per call
    NG = ca.mtimes(Nm, Gd)
    K = P + sigma * ca.DM.eye(n) + rho * (ca.DM(A_c.T @ A_c) + ca.mtimes(NG.T, NG))
    K = ca.densify(0.5 * (K + K.T))
    kkt = ca.Function("ballbot_mpc_admm_kkt", [P, nobs], [K], ["P", "nobs"], ["K"])

    # one iteration: the state (u, z, y) is accumulated, the data are the same each time
    st = ca.MX.sym("st", n + 2 * m)
    uk, zk, yk = st[:n], st[n:n + m], st[n + m:]
    ut = ca.mtimes(Kinv, sigma * uk - q + At_mul(rho * zk - yk))
    zt = A_mul(ut)
    un = alpha * ut + (1 - alpha) * uk
    v = alpha * zt + (1 - alpha) * zk
    wv = v + yk / rho
    zn = wv - ca.fmin(ca.fmax(wv - hi, 0), cr) + ca.fmin(ca.fmax(lo - wv, 0), cr)
    yn = yk + rho * (v - zn)
    step = ca.Function("ballbot_mpc_admm_step", [st, Kinv, q, lo, hi, nobs],
                       [ca.vertcat(un, zn, yn)])

    # primal residual of the final iterate
    ur = ca.MX.sym("u", n)
    zr = ca.MX.sym("z", m)
    resid = ca.Function("ballbot_mpc_admm_residual", [ur, zr, nobs],
                        [ca.norm_inf(A_mul(ur) - zr)])

    # K^-1 by one sparse LDL' factorisation (CasADi's codegen-able ``ldl``), n solves
    Ki = ca.solve(kkt(Pm, nm), ca.DM.eye(n), "ldl")
    s = ca.vertcat(u0, z0, y0)
    for _ in range(iterations):
        s = step(s, Ki, qm, lm, hm, nm)
    uo, zo, yo = s[:n], s[n:n + m], s[n + m:]
    return uo, zo, yo, resid(uo, zo, nm)

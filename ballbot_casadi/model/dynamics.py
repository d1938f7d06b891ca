"""Symbolic 3D quaternion Euler-Lagrange model of the ballbot (thesis App. C).

Generalised coordinates ``chi = [x, y, q0, q1, q2, q3]`` (thesis 2.3), state
``x = [chi; dchi]`` (thesis 2.4), input ``tau`` = the three wheel torques in the thesis
wheel order, parameter vector ``p`` in :data:`~ballbot_casadi.core.params.PARAM_NAMES` order.
Parameters are inputs of every Function, never constants baked into the graph.

Derivation
----------
* Energies: ball (C.14), body translation + rotation (C.18) with the centre of mass at
  ``(com_x, com_y, l)`` in {B}, wheels (C.24) with the wheel speeds of (B.47), body
  potential (C.21).  The body rotational energy uses the vector part of
  ``2 Phi(q)^T dq`` only; the thesis' extra scalar entry in (C.16) multiplies
  ``q^T dq``, which vanishes on the constraint manifold, so the constrained motion
  is identical either way.
* Euler-Lagrange (C.7, C.26) by CasADi automatic differentiation:
  ``M = d2T/d dchi2``, ``C dchi = (d/dchi dT/d dchi) dchi - dT/dchi``, ``G = dV/dchi``.
* Viscous friction (C.40-C.42) as the gradient of the Rayleigh function
  ``R = Bvk/2 (dx^2+dy^2) + Bvb/2 |omega_b|^2 + Bvm/2 |dphi|^2``, so
  ``D = Bvk [dx,dy,0..] + 4 Bvb Phi diag(0,1,1,1) Phi^T dq + J_m^T Bvm dphi``.
* Input map ``Q = J_m^T tau`` with ``J_m = d dphi / d dchi`` (C.36-C.38).
* Unit-norm constraint: the Lagrange multiplier is eliminated with
  ``H~ = blkdiag(I2, [0 I3] Phi(q)^T)`` (C.49-C.52), and the sixth row is the
  Baumgarte-stabilised second derivative of ``h = q^T q - 1`` (C.64-C.66):
  ``q^T ddq + dq^T dq + 2 beta q^T dq + beta^2/2 (q^T q - 1) = 0`` (C.67, C.68).
* The resulting 6x6 system (C.68) is solved through its tangent/normal split
  (:func:`projected_terms`): a closed-form normal component and a 5x5 symmetric positive
  definite LDL^T solve; the Jacobians use implicit differentiation of the same equations.
  :func:`constrained_terms` keeps the thesis' M~, C~, G~, D~, Q~ form for verification.
"""

from __future__ import annotations

import casadi as ca

from ballbot_casadi.core.layout import GENERALISED, STATE
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.params import PARAM_NAMES, ParamView
from ballbot_casadi.model import kinematics as K

__all__ = [
    "NX",
    "NU",
    "NP",
    "STATE_NAMES",
    "INPUT_NAMES",
    "symbols",
    "lagrangian_terms",
    "constrained_terms",
    "projected_terms",
    "make_el_terms",
    "make_ode",
    "make_jacobians",
    "make_affine",
    "make_energy",
    "make_wheel_speeds",
    "make_forward_kinematics",
    "make_model_functions",
]

NX = 12
NU = 3
NP = len(PARAM_NAMES)
STATE_NAMES = ("x", "y", "q0", "q1", "q2", "q3", "dx", "dy", "dq0", "dq1", "dq2", "dq3")
INPUT_NAMES = ("tau0", "tau1", "tau2")

#: Function options: common-subexpression elimination (a smaller generated C).
_FUNC_OPTS = {"cse": True}


def symbols() -> tuple[ca.SX, ca.SX, ca.SX]:
    """Fresh SX symbols ``(x, tau, p)`` of sizes (12, 3, NP)."""
    return ca.SX.sym("x", NX), ca.SX.sym("tau", NU), ca.SX.sym("p", NP)


def lagrangian_terms(x: ca.SX, p: ca.SX) -> dict[str, ca.SX]:
    """Unconstrained Euler-Lagrange terms (thesis C.12-C.44).

    Returns
    -------
    dict
        ``T``, ``V`` (energies), ``M`` (6x6), ``Cdq`` (C(chi,dchi) dchi, 6),
        ``G`` (6), ``D`` (6), ``Q`` (6x3 input map), ``dphi`` (wheel speeds, 3).
    """
    P = ParamView(p)
    chi, dchi = x[:6], x[6:]
    dx, dy = dchi[0], dchi[1]
    q, dq = chi[GENERALISED["q"]], dchi[GENERALISED["q"]]

    # Ball (C.14): translation plus rolling, Jkx = Jky = Jk.
    T_k = 0.5 * (P.Mk + P.Jk / P.rk**2) * (dx**2 + dy**2)

    # Body (C.15-C.18): COM velocity (B.15) and body angular velocity (B.16).
    p_com = ca.vertcat(P.com_x, P.com_y, P.l)
    r_com = Q.rotate(q, p_com)  # (B.11), COM position in {K}
    v_com = ca.vertcat(dx, dy, 0) + ca.mtimes(ca.jacobian(r_com, q), dq)  # (B.15)
    w_b = K.body_angular_velocity(q, dq)  # (B.16)
    J_b = ca.diag(ca.vertcat(P.Jbx, P.Jby, P.Jbz))
    T_b = 0.5 * P.Mb * ca.dot(v_com, v_com) + 0.5 * ca.mtimes([w_b.T, J_b, w_b])

    # Wheels (C.22-C.24): motor-shaft speeds from inverse kinematics (B.47).
    dphi = K.wheel_speeds(q, dq, dx, dy, P)
    T_w = 0.5 * P.Jw * ca.dot(dphi, dphi)

    T = T_k + T_b + T_w
    V = P.Mb * P.g * r_com[2]  # (C.21)

    # Euler-Lagrange by AD (C.7, C.26).
    dT_ddchi = ca.gradient(T, dchi)
    M = ca.jacobian(dT_ddchi, dchi)
    # (d/dchi dT/d dchi) dchi as a forward-mode directional derivative (cheaper than J dchi).
    Cdq = ca.jtimes(dT_ddchi, chi, dchi) - ca.gradient(T, chi)
    G = ca.gradient(V, chi)

    # Input map (C.37, C.38) and viscous friction (C.40-C.43) via a Rayleigh function.
    J_m = ca.jacobian(dphi, dchi)
    Rayleigh = (
        0.5 * P.Bvk * (dx**2 + dy**2)
        + 0.5 * P.Bvb * ca.dot(w_b, w_b)
        + 0.5 * P.Bvm * ca.dot(dphi, dphi)
    )
    D = ca.gradient(Rayleigh, dchi)
    return {"T": T, "V": V, "M": M, "Cdq": Cdq, "G": G, "D": D, "Q": J_m.T, "dphi": dphi}


def constrained_terms(x: ca.SX, p: ca.SX) -> dict[str, ca.SX]:
    """Constrained model ``M~ ddchi = b~ + Q~ tau`` (thesis C.49-C.68).

    Returns
    -------
    dict
        ``Mt`` (6x6), ``bt`` (6, all torque-free terms moved to the right-hand side,
        Baumgarte row included) and ``Qt`` (6x3), plus the entries of
        :func:`lagrangian_terms`.
    """
    P = ParamView(p)
    terms = lagrangian_terms(x, p)
    q, dq = x[STATE["q"]], x[STATE["dq"]]
    # H~ (C.52): keep the x, y rows and the vector part of Phi(q)^T on the quaternion rows.
    Ht = ca.SX.zeros(5, 6)
    Ht[0, 0] = 1
    Ht[1, 1] = 1
    Ht[2:5, 2:6] = Q.Phi(q).T[1:4, :]
    rhs = -(terms["Cdq"] + terms["G"] + terms["D"])
    h = ca.dot(q, q) - 1  # (C.46)
    Mt = ca.vertcat(ca.mtimes(Ht, terms["M"]), ca.horzcat(0, 0, q.T))
    bt = ca.vertcat(
        ca.mtimes(Ht, rhs),
        -ca.dot(dq, dq) - 2 * P.beta * ca.dot(q, dq) - 0.5 * P.beta**2 * h,  # (C.66)
    )
    Qt = ca.vertcat(ca.mtimes(Ht, terms["Q"]), ca.SX.zeros(1, 3))
    return {**terms, "Mt": Mt, "bt": bt, "Qt": Qt}


def make_el_terms() -> ca.Function:
    """``ballbot_el_terms(x, p) -> (M, Cdq, G, D, Q)``: unconstrained EL terms (C.26-C.44)."""
    x, _, p = symbols()
    t = lagrangian_terms(x, p)
    return ca.Function(
        "ballbot_el_terms",
        [x, p],
        [t["M"], t["Cdq"], t["G"], t["D"], t["Q"]],
        ["x", "p"],
        ["M", "Cdq", "G", "D", "Q"],
        _FUNC_OPTS,
    )


def _ldl(A: ca.SX) -> tuple[list, list]:
    """Symbolic LDL^T factorisation (no pivoting) of a small symmetric positive definite matrix."""
    n = A.shape[0]
    L = [[None] * n for _ in range(n)]
    D = [None] * n
    for j in range(n):
        d = A[j, j]
        for k in range(j):
            d = d - L[j][k] ** 2 * D[k]
        D[j] = d
        for i in range(j + 1, n):
            s = A[i, j]
            for k in range(j):
                s = s - L[i][k] * L[j][k] * D[k]
            L[i][j] = s / d
    return L, D


def _ldl_solve(L: list, D: list, B: ca.SX) -> ca.SX:
    """Solve ``L D L^T X = B`` column by column with the factors of :func:`_ldl`."""
    n = len(D)
    cols = []
    for c in range(B.shape[1]):
        y = []
        for i in range(n):
            s = B[i, c]
            for k in range(i):
                s = s - L[i][k] * y[k]
            y.append(s)
        xs = [None] * n
        for i in reversed(range(n)):
            s = y[i] / D[i]
            for k in range(i + 1, n):
                s = s - L[k][i] * xs[k]
            xs[i] = s
        cols.append(ca.vertcat(*xs))
    return ca.horzcat(*cols)


def projected_terms(x: ca.SX, p: ca.SX) -> dict[str, ca.SX]:
    """The constrained equations (C.68) solved through their tangent/normal split.

    ``H~ = blkdiag(I2, Xi(q)^T)`` with ``Xi(q) = Phi(q)[:, 1:]`` (C.52), and every
    ``ddq`` splits uniquely as ``ddq = q b + Xi(q) a`` because ``Phi(q) = [q, Xi(q)]`` is a
    scaled orthogonal matrix.  The Baumgarte row (C.66) fixes ``b = c / q^T q`` with
    ``c = -dq^T dq - 2 beta q^T dq - beta^2/2 (q^T q - 1)``; the five rows
    ``H~ M ddchi = H~ (Q tau - C dchi - G - D)`` become the symmetric positive definite
    system ``(S^T M S) u = S^T (r - M s0)`` for ``u = [ddx, ddy, a]`` with ``S = H~^T``,
    ``s0 = [0, 0, q b]``.  Mathematically identical to solving (C.68) directly, but a 5x5
    LDL^T solve instead of a general 6x6 one.

    Returns
    -------
    dict
        ``S`` (6x5), ``s0`` (6), ``L``/``D`` (LDL^T factors of ``S^T M S``), ``r0`` (torque-free
        generalised forces ``-(C dchi + G + D)``), plus :func:`lagrangian_terms` entries.
    """
    P = ParamView(p)
    t = lagrangian_terms(x, p)
    q, dq = x[STATE["q"]], x[STATE["dq"]]
    S = ca.diagcat(ca.SX.eye(2), Q.Phi(q)[:, 1:])
    qq = ca.dot(q, q)
    c = -ca.dot(dq, dq) - 2 * P.beta * ca.dot(q, dq) - 0.5 * P.beta**2 * (qq - 1)
    s0 = ca.vertcat(0, 0, q * (c / qq))
    L, D = _ldl(ca.mtimes([S.T, t["M"], S]))
    r0 = -(t["Cdq"] + t["G"] + t["D"])
    return {**t, "S": S, "s0": s0, "L": L, "D": D, "r0": r0}


def _ddchi(t: dict, tau: ca.SX) -> ca.SX:
    r = t["r0"] + ca.mtimes(t["Q"], tau)
    u = _ldl_solve(t["L"], t["D"], ca.mtimes(t["S"].T, r - ca.mtimes(t["M"], t["s0"])))
    return t["s0"] + ca.mtimes(t["S"], u)


def make_ode() -> ca.Function:
    """``ballbot_ode(x, tau, p) -> xdot``: the state equation (thesis C.10, C.68).

    Solved as in :func:`projected_terms`.
    """
    x, tau, p = symbols()
    ddchi = _ddchi(projected_terms(x, p), tau)
    return ca.Function(
        "ballbot_ode", [x, tau, p], [ca.vertcat(x[6:], ddchi)], ["x", "tau", "p"], ["xdot"],
        _FUNC_OPTS,
    )


def make_jacobians() -> ca.Function:
    """``ballbot_jac(x, tau, p) -> (A, B)``: ``A = d xdot/dx`` (12x12), ``B = d xdot/d tau``.

    By implicit differentiation of the projected equations of :func:`projected_terms`:
    with ``ddchi = s0 + S u`` and ``F(x, tau, u) = S^T (M (s0 + S u) - r) = 0``,
    ``d ddchi/d(x, tau) = d(s0 + S u)/d(x, tau) - S (S^T M S)^-1 dF/d(x, tau)`` at fixed
    ``u``, which reuses the LDL^T factors of the ODE instead of differentiating the solve.
    """
    x, tau, p = symbols()
    t = projected_terms(x, p)
    u = ca.SX.sym("u", 5)
    r = t["r0"] + ca.mtimes(t["Q"], tau)
    e = t["s0"] + ca.mtimes(t["S"], u)
    F = ca.mtimes(t["S"].T, ca.mtimes(t["M"], e) - r)
    xt = ca.vertcat(x, tau)
    # Forward-mode columns: fewer operations than CasADi's default mode choice here.
    seeds = ca.DM.eye(xt.numel())
    JF = ca.horzcat(*[ca.jtimes(F, xt, seeds[:, i]) for i in range(xt.numel())])
    J = ca.jacobian(e, xt) - ca.mtimes(t["S"], _ldl_solve(t["L"], t["D"], JF))
    u_val = _ldl_solve(t["L"], t["D"], ca.mtimes(t["S"].T, r - ca.mtimes(t["M"], t["s0"])))
    J = ca.substitute(J, u, u_val)
    top = ca.horzcat(ca.SX.zeros(6, 6), ca.SX.eye(6), ca.SX.zeros(6, 3))
    full = ca.vertcat(top, J)
    return ca.Function(
        "ballbot_jac", [x, tau, p], [full[:, :12], full[:, 12:]], ["x", "tau", "p"], ["A", "B"],
        _FUNC_OPTS,
    )


def make_affine() -> ca.Function:
    """``ballbot_affine(x, p) -> (f, g)`` with ``ddchi = f(x, p) + g(x, p) tau`` (6, 6x3).

    The control-affine split that feedback linearisation needs (thesis C.10, 8.12).
    """
    x, _, p = symbols()
    t = projected_terms(x, p)
    rhs = ca.mtimes(t["S"].T, ca.horzcat(t["r0"] - ca.mtimes(t["M"], t["s0"]), t["Q"]))
    sol = ca.mtimes(t["S"], _ldl_solve(t["L"], t["D"], rhs))
    f = t["s0"] + sol[:, 0]
    return ca.Function(
        "ballbot_affine", [x, p], [f, sol[:, 1:]], ["x", "p"], ["f", "g"], _FUNC_OPTS
    )


def make_energy() -> ca.Function:
    """``ballbot_energy(x, p) -> (T, V, E)``: kinetic, potential and total energy (C.14-C.24)."""
    x, _, p = symbols()
    t = lagrangian_terms(x, p)
    return ca.Function(
        "ballbot_energy", [x, p], [t["T"], t["V"], t["T"] + t["V"]], ["x", "p"], ["T", "V", "E"],
        _FUNC_OPTS,
    )


def make_wheel_speeds() -> ca.Function:
    """``ballbot_wheel_speeds(x, p) -> dphi``: motor-shaft speeds (inverse kinematics, B.47)."""
    x, _, p = symbols()
    P = ParamView(p)
    dphi = K.wheel_speeds(x[STATE["q"]], x[STATE["dq"]], x[STATE.index("dx")], x[STATE.index("dy")], P)
    return ca.Function(
        "ballbot_wheel_speeds", [x, p], [dphi], ["x", "p"], ["dphi"], _FUNC_OPTS
    )


def make_forward_kinematics() -> ca.Function:
    """``ballbot_forward_kinematics(q, dq, dphi, p) -> dxy``: ball velocity (B.51-B.55)."""
    q, dq, dphi = ca.SX.sym("q", 4), ca.SX.sym("dq", 4), ca.SX.sym("dphi", 3)
    p = ca.SX.sym("p", NP)
    dxy = K.forward_kinematics(q, dq, dphi, ParamView(p))
    return ca.Function(
        "ballbot_forward_kinematics",
        [q, dq, dphi, p],
        [dxy],
        ["q", "dq", "dphi", "p"],
        ["dxy"],
        _FUNC_OPTS,
    )


def make_model_functions() -> dict[str, ca.Function]:
    """All model Functions, keyed by their name without the ``ballbot_`` prefix."""
    funcs = [
        make_ode(),
        make_jacobians(),
        make_affine(),
        make_energy(),
        make_wheel_speeds(),
        make_forward_kinematics(),
        make_el_terms(),
    ]
    return {f.name().removeprefix("ballbot_"): f for f in funcs}

"""Symbolic 3D quaternion Euler-Lagrange model of the ballbot (thesis App. C).

Generalised coordinates ``chi = [x, y, q0, q1, q2, q3]`` (thesis 2.3), state
``x = [chi; dchi]`` (thesis 2.4), input ``tau`` = the three wheel torques in the thesis
wheel order, parameter vector ``p`` in :data:`~ballbot_casadi.params.PARAM_NAMES` order.
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
"""

from __future__ import annotations

import casadi as ca

from . import kinematics as K
from . import quaternion as Q
from .params import PARAM_NAMES, ParamView

__all__ = [
    "NX",
    "NU",
    "NP",
    "STATE_NAMES",
    "INPUT_NAMES",
    "symbols",
    "lagrangian_terms",
    "constrained_terms",
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
    q, dq = chi[2:6], dchi[2:6]

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
    Cdq = ca.mtimes(ca.jacobian(dT_ddchi, chi), dchi) - ca.gradient(T, chi)
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
    q, dq = x[2:6], x[8:12]
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
    )


def make_ode() -> ca.Function:
    """``ballbot_ode(x, tau, p) -> xdot``: the state equation (thesis C.10, C.68)."""
    x, tau, p = symbols()
    t = constrained_terms(x, p)
    ddchi = ca.solve(t["Mt"], t["bt"] + ca.mtimes(t["Qt"], tau))
    return ca.Function(
        "ballbot_ode", [x, tau, p], [ca.vertcat(x[6:], ddchi)], ["x", "tau", "p"], ["xdot"]
    )


def make_jacobians(ode: ca.Function | None = None) -> ca.Function:
    """``ballbot_jac(x, tau, p) -> (A, B)``: ``A = d xdot/dx`` (12x12), ``B = d xdot/d tau``."""
    ode = make_ode() if ode is None else ode
    x, tau, p = symbols()
    xdot = ode(x, tau, p)
    return ca.Function(
        "ballbot_jac",
        [x, tau, p],
        [ca.jacobian(xdot, x), ca.jacobian(xdot, tau)],
        ["x", "tau", "p"],
        ["A", "B"],
    )


def make_affine() -> ca.Function:
    """``ballbot_affine(x, p) -> (f, g)`` with ``ddchi = f(x, p) + g(x, p) tau`` (6, 6x3).

    The control-affine split that feedback linearisation needs (thesis C.10, 8.12).
    """
    x, _, p = symbols()
    t = constrained_terms(x, p)
    fg = ca.solve(t["Mt"], ca.horzcat(t["bt"], t["Qt"]))
    return ca.Function("ballbot_affine", [x, p], [fg[:, 0], fg[:, 1:]], ["x", "p"], ["f", "g"])


def make_energy() -> ca.Function:
    """``ballbot_energy(x, p) -> (T, V, E)``: kinetic, potential and total energy (C.14-C.24)."""
    x, _, p = symbols()
    t = lagrangian_terms(x, p)
    return ca.Function(
        "ballbot_energy", [x, p], [t["T"], t["V"], t["T"] + t["V"]], ["x", "p"], ["T", "V", "E"]
    )


def make_wheel_speeds() -> ca.Function:
    """``ballbot_wheel_speeds(x, p) -> dphi``: motor-shaft speeds (inverse kinematics, B.47)."""
    x, _, p = symbols()
    P = ParamView(p)
    dphi = K.wheel_speeds(x[2:6], x[8:12], x[6], x[7], P)
    return ca.Function("ballbot_wheel_speeds", [x, p], [dphi], ["x", "p"], ["dphi"])


def make_forward_kinematics() -> ca.Function:
    """``ballbot_forward_kinematics(q, dq, dphi, p) -> dxy``: ball velocity (B.51-B.55)."""
    q, dq, dphi = ca.SX.sym("q", 4), ca.SX.sym("dq", 4), ca.SX.sym("dphi", 3)
    p = ca.SX.sym("p", NP)
    dxy = K.forward_kinematics(q, dq, dphi, ParamView(p))
    return ca.Function(
        "ballbot_forward_kinematics", [q, dq, dphi, p], [dxy], ["q", "dq", "dphi", "p"], ["dxy"]
    )


def make_model_functions() -> dict[str, ca.Function]:
    """All model Functions, keyed by their name without the ``ballbot_`` prefix."""
    ode = make_ode()
    funcs = [
        ode,
        make_jacobians(ode),
        make_affine(),
        make_energy(),
        make_wheel_speeds(),
        make_forward_kinematics(),
        make_el_terms(),
    ]
    return {f.name().removeprefix("ballbot_"): f for f in funcs}

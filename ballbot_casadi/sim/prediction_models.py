"""Builders of the MPC's alternative prediction models from the closed loop as it runs.

The guidance layer takes numbers and Functions only; this module ties them to the model
and the controllers (issue 18, "which prediction model serves best"):

* :func:`full_loop_model`: the exact linearisation of the closed loop at upright (the
  full 3D model, the FLC and the velocity LQR at the control period, RK4 plant, torque
  held) as a :class:`~ballbot_casadi.guidance.prediction.LoopModel`
  (:func:`ballbot_casadi.guidance.prediction_full.sampled_loop_model`);
* :func:`reduced_nonlinear_loop`: the same closed loop, *nonlinear*, reduced to the
  heading-free motions (the 14 loop coordinates; heading, heading rate and the heading
  reference held at zero): one MPC step ``F(X, v_ref) -> X+`` (``dt / Ts`` periods of the
  real period Function) and the outputs ``Y(X, v_ref) -> [acc, tilt_acc]`` for the
  real-time-iteration NMPC of :mod:`ballbot_casadi.guidance.nmpc`;
* :func:`loop_step`: the period Function both are made of (plant and velocity-controller
  state ``w = [x (12), z (8)]``; the COM observer is off in the path runs).
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any, Mapping

import casadi as ca
import numpy as np

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.constants import N_SUB
from ballbot_casadi.core.layout import STATE, STATE_DXY, STATE_XY
from ballbot_casadi.core.layout import VELOCITY_CONTROLLER_STATE as Z
from ballbot_casadi.control.velocity import design_model
from ballbot_casadi.guidance.prediction import (
    NXL,
    LoopModel,
    closed_velocity_loop,
    open_loop_period,
)
from ballbot_casadi.guidance.prediction_full import reduction_residual, sampled_loop_model
from ballbot_casadi.model.dynamics import make_jacobians, make_ode
from ballbot_casadi.sim.embedded import controller_blocks
from ballbot_casadi.sim.path_following import make_loop_state
from ballbot_casadi.sim.ports import PERIOD_CONSTANTS
from ballbot_casadi.sim.steps import make_closed_loop_step

__all__ = ["loop_step", "full_loop_model", "upright_state", "reduced_nonlinear_loop",
           "lift_function", "ClippedLoop", "NW"]

#: Size of the closed loop's state ``w = [x (12), z (8)]``.
NW = STATE.size + Z.size
#: The constant inputs of the period the builders read from a scenario's inputs.
#: |v_ref| (m/s, per axis) at which the closed loop is linearised (see full_loop_model).
_V_LIN = 1e-9
_CONSTANTS = PERIOD_CONSTANTS


@lru_cache(maxsize=None)
def loop_step(n_sub: int = N_SUB) -> ca.Function:
    """``ballbot_loop_step(w_loop[20], v_ref[2], constants) -> (w_next, acc, tilt_acc)``: one
    control period of the FLC cascade (no COM observer), ``constants`` those of
    :data:`_CONSTANTS` stacked; ``acc`` the ball acceleration at the period's start (the
    ODE on the torque that acts), ``tilt_acc`` the velocity LQR's tilt-reference
    acceleration (the reference model is a double integrator per axis)."""
    blocks = controller_blocks("flc", observer=False)
    ode = make_ode()
    step = make_closed_loop_step(blocks.balance, blocks.velocity, ode, n_sub)
    w, v = ca.MX.sym("w", NW), ca.MX.sym("v_ref", 2)
    sizes = [step.numel_in(k) for k in _CONSTANTS]
    c = ca.MX.sym("c", sum(sizes))
    parts, o = {}, 0
    for k, n in zip(_CONSTANTS, sizes):
        parts[k] = c[o:o + n]
        o += n
    out = step.call({"xz": w, "v_ref": ca.vertcat(v, 0.0), "q_ref": ca.DM.zeros(4),
                     "dq_ref": ca.DM.zeros(4), "ddq_ref": ca.DM.zeros(4), "w": ca.DM.zeros(6),
                     **parts})
    x = w[:STATE.size]
    acc = ode(x, out["tau"], parts["p_plant"])[STATE_DXY]
    zs, zn = w[STATE.size:], out["xz_next"][STATE.size:]
    tilt_acc = (zn[Z["dtheta_r"]] - zs[Z["dtheta_r"]]) / parts["Ts"]
    return ca.Function("ballbot_loop_step", [w, v, c], [out["xz_next"], acc, tilt_acc],
                       ["w_loop", "v_ref", "constants"], ["w_next", "acc", "tilt_acc"])


def constants(inp: Mapping[str, Any]) -> np.ndarray:
    """The stacked constants ``c`` of :func:`loop_step` from a scenario's inputs."""
    return np.concatenate([np.atleast_1d(np.asarray(inp[k], float)).ravel() for k in _CONSTANTS])


def upright_state(inp: Mapping[str, Any]) -> np.ndarray:
    """``w`` at the upright equilibrium at the origin (zero heading), the velocity
    controller's initial state of the scenario."""
    x = np.zeros(STATE.size)
    x[STATE["q"].start] = 1.0
    return np.concatenate([x, np.asarray(inp["z0"], float).ravel()])


def _loop_map() -> ca.Function:
    w = ca.SX.sym("w", NW)
    X = make_loop_state()(w[:STATE.size], w[STATE.size:])
    return ca.Function("T", [w], [X, ca.jacobian(X, w)])


def full_loop_model(inp: Mapping[str, Any], dt: float, n_sub: int = N_SUB
                    ) -> tuple[LoopModel, dict[str, float]]:
    """The "full" prediction model at the MPC step ``dt`` (module docstring) for the
    robot and gains of a scenario's inputs ``inp`` (:meth:`Scenario.inputs`); also
    ``{"equilibrium_residual": max |w+ - w| at upright, "reduction_residual": ...}``."""
    f = loop_step(n_sub)
    c = constants(inp)
    # the velocity controller's speed limit divides by |v_ref|: its derivative at exactly
    # v_ref = 0 is 0 * inf; linearise at |v_ref| = 1e-9 m/s instead (the limit inactive:
    # the Jacobians differ from the limit v_ref -> 0 by O(1e-9))
    w0, v0 = upright_state(inp), np.full(2, _V_LIN)
    Ts = float(inp["Ts"])
    wv, vv = ca.MX.sym("w", NW), ca.MX.sym("v", 2)
    o = f(wv, vv, c)
    jac = ca.Function("J", [wv, vv], [ca.jacobian(o[0], wv), ca.jacobian(o[0], vv),
                                      ca.jacobian(o[1], wv), ca.jacobian(o[1], vv),
                                      ca.jacobian(o[2], wv), ca.jacobian(o[2], vv), o[0]])
    A1, B1, Ca, Da, Ct, Dt, wn = (np.asarray(M, float) for M in jac(w0, v0))
    X0, T = (np.asarray(M, float) for M in _loop_map()(w0))
    L = np.linalg.pinv(T)
    L[np.abs(L) < 1e-14] = 0.0
    model = sampled_loop_model(A1, B1, T, L, {"acc": Ca, "tilt_acc": Ct},
                               {"acc": Da, "tilt_acc": Dt}, Ts, dt)
    wn = wn.ravel()
    wn[STATE.size + Z["p_e"].start:STATE.size + Z["p_e"].stop] += Ts * v0  # p_e integrates v_ref
    return model, {"equilibrium_residual": float(np.max(np.abs(wn - w0))),
                   "reduction_residual": reduction_residual(A1, T, L),
                   "loop_state_at_upright": float(np.max(np.abs(X0)))}


def lift_function() -> ca.Function:
    """``ballbot_loop_lift(X[14], w_ref[20]) -> w``: a plant and controller state with the
    loop coordinates ``X`` and zero heading (nonlinear: ``q = q_x(theta_x) o q_y(theta_y)``,
    its rate from the tilt rates), the other controller entries of ``w_ref``; the inverse
    of :func:`~ballbot_casadi.sim.path_following.make_loop_state` on that set."""
    X, wr = ca.SX.sym("X", NXL), ca.SX.sym("w_ref", NW)
    th, dth = X[2:4], X[4:6]
    qx = ca.vertcat(ca.cos(th[0] / 2), ca.sin(th[0] / 2), 0, 0)
    qy = ca.vertcat(ca.cos(th[1] / 2), 0, ca.sin(th[1] / 2), 0)
    q = Q.mul(qx, qy)
    dq = ca.jtimes(q, th, dth)
    x = ca.SX.zeros(STATE.size)
    x[STATE["q"]] = q
    x[STATE["dq"]] = dq
    x[STATE_XY] = X[12:14]
    x[STATE_DXY] = X[0:2]
    z = wr[STATE.size:]
    z[Z["theta_r"]] = X[6:8]
    z[Z["dtheta_r"]] = X[8:10]
    z[Z["p_e"]] = X[10:12]
    return ca.Function("ballbot_loop_lift", [X, wr], [ca.vertcat(x, z)], ["X", "w_ref"], ["w"])


def reduced_nonlinear_loop(inp: Mapping[str, Any], dt: float, n_sub: int = N_SUB
                           ) -> tuple[ca.Function, ca.Function]:
    """``(F, Y)``: the nonlinear closed loop on the heading-free motions, one MPC step
    ``F(X[14], v_ref[2]) -> X+`` (``dt / Ts`` real periods, ``v_ref`` held) and the
    outputs at the step's start ``Y(X, v_ref) -> [acc (2); tilt_acc (2)]``."""
    f = loop_step(n_sub)
    c = ca.DM(constants(inp))
    w_ref = ca.DM(upright_state(inp))
    m = int(round(dt / float(inp["Ts"])))
    lift = lift_function()
    loop_state = make_loop_state()
    X, v = ca.MX.sym("X", NXL), ca.MX.sym("v_ref", 2)
    wv = ca.MX.sym("w", NW)
    per_w = ca.Function("per_w", [wv, v], [f(wv, v, c)[0]])
    w = _w(lift, X, w_ref)
    for _ in range(m):
        w = per_w(w, v)
    Xn = loop_state(w[:STATE.size], w[STATE.size:])
    F = ca.Function("ballbot_loop_reduced_step", [X, v], [Xn], ["X", "v_ref"], ["X_next"])
    o = f(_w(lift, X, w_ref), v, c)
    Y = ca.Function("ballbot_loop_reduced_outputs", [X, v], [ca.vertcat(o[1], o[2])],
                    ["X", "v_ref"], ["y"])
    return F, Y


def _w(lift: ca.Function, X: Any, w_ref: Any) -> Any:
    return lift(X, w_ref)


class ClippedLoop:
    """The NMPC's reduced nonlinear model: the shipped closed-velocity-loop model with the
    velocity controller's own limits.

    Per control period ``X+ = Phi X + Ga a(X, v_ref) + Gv v_ref`` (the design model of
    the velocity loop with the position, :func:`~ballbot_casadi.guidance.prediction.open_loop_period`),
    where ``a`` is the tilt-reference acceleration the *actual* velocity controller
    (``ballbot_velocity``) computes on the lifted state (:func:`lift_function`): the LQR
    law with its clips (tilt-acceleration bound, tilt-rate and braking limits, the speed
    limit of ``v_ref``).  Without a clip active it equals the shipped linear model; the
    plant's trigonometric nonlinearity (sin 5 deg vs 5 deg: 0.13 %) is left out.

    Calling it with ``(X[14 x N], v_ref[2 x N])`` returns the MPC step ``dt`` (``m``
    periods, ``v_ref`` held) and its outputs with Jacobians, the ``linearise`` protocol of
    :class:`~ballbot_casadi.guidance.nmpc.NonlinearPathMPC`: ``(X_next, A, B, y, C, D)``,
    ``y = [acc (2); tilt_acc (2)]`` at the step's start: the accelerations the LQR
    *demands* (linear, as in the shipped model), so the soft rows keep the demand inside
    the clip's bound while the dynamics predict what the clip does.
    """

    def __init__(self, inp: Mapping[str, Any], dt: float) -> None:
        Ac, Bc, _, _ = design_model(make_jacobians(), inp["p_ctrl"], float(inp["Ts"]))
        Ts = float(inp["Ts"])
        self.m = int(round(dt / Ts))
        self.Phi, self.Ga, self.Gv, Acont, Bcont = open_loop_period(Ac, Bc, Ts)
        # the constrained outputs: the LQR's *demanded* accelerations, linear as in the
        # shipped model (a clipped output has no gradient where it clips, so a
        # Gauss-Newton step could not pull it back inside its bound)
        lin = closed_velocity_loop(Ac, Bc, np.asarray(inp["k_vel"], float)[:24].reshape(2, 12),
                                   Ts, dt)
        self.Cy = np.vstack([lin.C["acc"], lin.C["tilt_acc"]])
        self.Dy = np.vstack([lin.D["acc"], lin.D["tilt_acc"]])
        blocks = controller_blocks("flc", observer=False)
        X, v = ca.SX.sym("X", NXL), ca.SX.sym("v_ref", 2)
        w = lift_function()(X, ca.DM(upright_state(inp)))
        x, z = w[:STATE.size], w[STATE.size:]
        out = blocks.velocity(x, ca.vertcat(v, 0.0), z, inp["p_ctrl"], inp["k_vel"], Ts)
        a = (out[3][Z["dtheta_r"]] - z[Z["dtheta_r"]]) / Ts
        self._a = ca.Function("ballbot_clipped_loop_a", [X, v],
                              [a, ca.jacobian(a, X), ca.jacobian(a, v)])
        self.dt = float(dt)

    def step(self, X: np.ndarray, v: np.ndarray) -> np.ndarray:
        """One MPC step of the model from ``X`` (14) with ``v_ref`` (2) held."""
        X, v = np.asarray(X, float).copy(), np.asarray(v, float)
        for _ in range(self.m):
            a = np.asarray(self._a(X, v)[0], float).ravel()
            X = self.Phi @ X + self.Ga @ a + self.Gv @ v
        return X

    def __call__(self, Xs: np.ndarray, vs: np.ndarray) -> tuple[np.ndarray, ...]:
        Xs, vs = np.asarray(Xs, float), np.asarray(vs, float)
        N = Xs.shape[1]
        fa = self._a.map(N)
        X = Xs.copy()
        JX = np.tile(np.eye(NXL)[:, :, None], (1, 1, N))  # dX/dX0 per node (14, 14, N)
        Jv = np.zeros((NXL, 2, N))
        y = None
        # the speed limit divides by |v_ref|: at exactly 0 its derivative is 0 * inf, so
        # the controller is evaluated at |v_ref| >= 1e-9 m/s per axis (see full_loop_model)
        v_eval = np.where(np.abs(vs) < _V_LIN, _V_LIN, vs)
        for i in range(self.m):
            a, da_X, da_v = (np.asarray(o, float) for o in fa(X, v_eval))
            da_X = np.stack([da_X[:, NXL * k:NXL * (k + 1)] for k in range(N)], axis=2)
            da_v = np.stack([da_v[:, 2 * k:2 * (k + 1)] for k in range(N)], axis=2)
            # per node: A_per = Phi + Ga da/dX, B_per = Ga da/dv + Gv
            A_per = self.Phi[:, :, None] + np.einsum("ij,jkn->ikn", self.Ga, da_X)
            B_per = np.einsum("ij,jkn->ikn", self.Ga, da_v) + self.Gv[:, :, None]
            JX = np.einsum("ijn,jkn->ikn", A_per, JX)
            Jv = np.einsum("ijn,jkn->ikn", A_per, Jv) + B_per
            X = self.Phi @ X + self.Ga @ a + self.Gv @ vs
        A = np.concatenate([JX[:, :, k] for k in range(N)], axis=1)
        B = np.concatenate([Jv[:, :, k] for k in range(N)], axis=1)
        y = self.Cy @ Xs + self.Dy @ vs
        return X, A, B, y, np.tile(self.Cy, (1, N)), np.tile(self.Dy, (1, N))

"""The balance-feed guidance block: the MPC gives the balance controller its references.

Kugle's arrangement (issue 18), an option beside the shipped velocity feed
(:mod:`ballbot_casadi.sim.guided`, guidance ``mpc``): the MPC predicts with the
shape-accelerated model (:mod:`ballbot_casadi.guidance.shape_model`), chooses the tilt
acceleration ``a`` (held over its 0.1 s step) and the period's references come from the
MPC's plan, bypassing the velocity LQR:

``ballbot_guidance_mpc_balance(x, v_ref, g, z, p, k_guid, Ts) ->
(v_ref_out, g_next, q_ref, dq_ref, ddq_ref)``

with the state ``g = [count, theta_r (2), dtheta_r (2), MPC sample state]``
(:func:`balance_state_layout`).  Every ``every``-th period (``count = 0``) the MPC
sample (:func:`~ballbot_casadi.guidance.blocks.make_mpc_sample`, the same real-time
iteration as the velocity feed's, on the shape model) runs from the shape state
``[v (measured), theta_r - theta_eq, dtheta_r, 0 (6), p (measured)]`` and returns the new
``a``; the other periods hold it.  Each period the tilt reference follows the plan
exactly (a double integrator of ``a``: ``theta_r += Ts dtheta_r + Ts^2 a / 2``,
``dtheta_r += Ts a``; the MPC's own model between its nodes, so the plan and the
references agree) and the references are the quaternion
``q_x(theta_r) o q_y(theta_r) o q_z(psi_r)`` and its first two derivatives along
``(dtheta_r, r_r)`` and ``(a, 0)`` (:func:`~ballbot_casadi.control.velocity.tilt_heading_quaternion`,
the velocity controller's own construction; the heading ``psi_r, r_r`` from its
heading model in ``z``, the heading acceleration taken as zero).  The tilt states start
from the reference, not the measured tilt, so the references are continuous (C1 in
tilt) across samples; position and velocity are measured (the feedback).
``theta_eq`` is the balance point of the controller model's COM
(:func:`~ballbot_casadi.control.velocity.equilibrium_tilt`, +0 for a centred COM).

``v_ref_out`` is the measured ball velocity with the period's yaw-rate reference: the
velocity LQR still runs below (its state is unused here), following the robot.

:func:`run_balance_path` is the block's independent reference: :class:`PathMPC
<ballbot_casadi.guidance.mpc.PathMPC>` on the shape model called from Python every
0.1 s, the tilt-reference integration and quaternion references in numpy, and the
compiled balance loop alone (``cascade = 0``, the references as input sequences).

:func:`shape_gains` derives the shape model's gains from our model's linearisation.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from ballbot_casadi.control.velocity import equilibrium_tilt, tilt_heading_reference
from ballbot_casadi.core.constants import TS_CONTROL
from ballbot_casadi.core.layout import VELOCITY_CONTROLLER_STATE as Z
from ballbot_casadi.core.layout import Layout, planar_maps
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.guidance.blocks import mpc_state_layout
from ballbot_casadi.guidance.mpc import MpcConfig, MpcLayout, PathMPC
from ballbot_casadi.guidance.paths import Path
from ballbot_casadi.guidance.prediction import NXL
from ballbot_casadi.guidance.shape_model import ShapeGains
from ballbot_casadi.model.dynamics import NP, make_jacobians
from ballbot_casadi.sim.closed_loop import ClosedLoop
from ballbot_casadi.sim.path_following import (
    PathRun,
    chunks_log,
    make_loop_state,
    path_scenario,
    simulate_chunk,
)
from ballbot_casadi.sim.ports import PERIOD_SEQUENCES, REFERENCE_SEQUENCES

__all__ = ["shape_gains", "balance_state_layout", "make_balance_guidance",
           "balance_initial_function", "BALANCE_FEED_CONFIG", "run_balance_path"]

#: The balance feed's MPC configuration: the shipped one (horizon, nodes, weights, limits,
#: solver), so the two feeds differ only in the prediction model and the feed point; its
#: ``w_dv`` then weights the change of the tilt acceleration (rad/s^2).  (A sweep of
#: ``w_dv`` over 0.5 / 5 / 20 / 50 on the figure-eight: 0.5 lets the plan's tilt
#: acceleration chatter, several times the lateral error; 5 to 50 are alike.)
BALANCE_FEED_CONFIG = MpcConfig()


def shape_gains(p: np.ndarray) -> ShapeGains:
    """The gains of the shape-accelerated model from our model's linearisation.

    The model (thesis (C.68)) linearised at the upright equilibrium (the ``jac`` Function,
    as the velocity loop's design, thesis §7.3), ``x' = A x + B tau``; the torque that makes
    the tilts follow ``u`` with no yaw acceleration, ``tau = E^-1 ([u/2; 0] - A_q s)``
    (``E``, ``A_q``: the quaternion-vector acceleration rows, ``q_{1,2} = theta_{x,y} / 2``),
    put into the ball's acceleration rows gives ``v' = K_v v + K_th theta + K_dth dtheta
    + K_u u``.
    """
    p = np.asarray(p, float).ravel()
    if p.size != NP or not np.all(np.isfinite(p)):
        raise ScenarioError(f"p must be a finite parameter vector of {NP} entries, got {p.size}")
    x0 = np.zeros(12)
    x0[2] = 1.0
    A, B = (np.asarray(M, float) for M in make_jacobians()(x0, np.zeros(3), p))
    T, _ = planar_maps()  # reduced state s = [dx, dy, th_x, th_y, dth_x, dth_y]
    Einv = np.linalg.inv(B[9:12])
    Ks = (A[6:8] - B[6:8] @ Einv @ A[9:12]) @ T
    Ku = B[6:8] @ Einv @ np.vstack([0.5 * np.eye(2), np.zeros((1, 2))])
    return ShapeGains(Ks[:, 0:2], Ks[:, 2:4], Ks[:, 4:6], Ku)


def balance_state_layout(L: MpcLayout) -> Layout:
    """State of the balance-feed block after its period counter: the tilt reference
    ``theta_r``, its rate ``dtheta_r``, then the MPC sample's state
    (:func:`~ballbot_casadi.guidance.blocks.mpc_state_layout`; its ``v`` is the held
    tilt acceleration)."""
    S = mpc_state_layout(L)
    return Layout("balance-feed guidance state",
                  [("theta_r", 2), ("dtheta_r", 2)] + [(f, S.size_of(f)) for f in S.fields])


def _references() -> ca.Function:
    """``(s, ds, dds) -> (q, dq, ddq)`` for ``s = [theta_x, theta_y, psi]`` (the velocity
    controller's :func:`~ballbot_casadi.control.velocity.tilt_heading_reference`)."""
    return tilt_heading_reference("ballbot_guidance_mpc_balance_reference")


def make_balance_guidance(sample: ca.Function, L: MpcLayout, every: int) -> ca.Function:
    """``ballbot_guidance_mpc_balance`` (module docstring) around the MPC sample
    ``(X, g, k) -> (a, g_next)`` of layout ``L``, sampled every ``every`` periods."""
    if not (isinstance(every, int) and every >= 1):
        raise ScenarioError(f"guidance every must be an int >= 1 periods, got {every!r}")
    S = balance_state_layout(L)
    nm = sample.numel_in(1)
    Xs, gs, k = (ca.MX.sym(n, sample.numel_in(i)) for i, n in enumerate(("X", "gs", "k")))
    hold = ca.Function("ballbot_guidance_mpc_balance_hold", [Xs, gs, k], [gs[0:2], gs],
                       ["X", "g", "k"], ["v", "g_next"])
    branch = ca.Function.conditional("ballbot_guidance_mpc_balance_branch", [sample], hold)
    loop_state = make_loop_state()
    x, v_ref, g, z = (ca.MX.sym(n, m) for n, m in (("x", 12), ("v_ref", 3), ("g", S.size + 1),
                                                    ("z", loop_state.numel_in(1))))
    p, kg, Ts = ca.MX.sym("p", NP), ca.MX.sym("k_guid", k.numel()), ca.MX.sym("Ts")
    count, gb = g[0], g[1:]
    th_r, dth_r = gb[S["theta_r"]], gb[S["dtheta_r"]]
    psi_r, r_r = z[Z.index("psi_r")], z[Z.index("r_r")]
    th_eq = equilibrium_tilt(p, psi_r)
    X = loop_state(x, z)
    Xs_now = ca.vertcat(X[0:2], th_r - th_eq, dth_r, ca.DM.zeros(6), X[12:14])
    a, gm_next = branch(count, Xs_now, gb[S.offset("v"):S.offset("v") + nm], kg)
    q_ref, dq_ref, ddq_ref = _references()(ca.vertcat(th_r, psi_r), ca.vertcat(dth_r, r_r),
                                           ca.vertcat(a, 0.0))
    th_n = th_r + Ts * dth_r + 0.5 * Ts ** 2 * a
    dth_n = dth_r + Ts * a
    count_next = ca.if_else(count + 1 >= every, 0.0, count + 1)
    return ca.Function("ballbot_guidance_mpc_balance", [x, v_ref, g, z, p, kg, Ts],
                       [ca.vertcat(X[0:2], v_ref[2]), ca.vertcat(count_next, th_n, dth_n, gm_next),
                        q_ref, dq_ref, ddq_ref],
                       ["x", "v_ref", "g", "z", "p", "k_guid", "Ts"],
                       ["v_ref_out", "g_next", "q_ref", "dq_ref", "ddq_ref"])


def balance_initial_function(state: Layout) -> ca.Function:
    """``ballbot_guidance_mpc_balance_initial(x0[12], z0, s0) -> g0``: counter 0, the tilt
    reference and its rate from the velocity controller's power-on state ``z0`` (the
    measured tilt, :func:`~ballbot_casadi.control.velocity.velocity_initial_state`),
    ``first = 1`` and the MPC state at the shape state of ``x0`` with progress ``s0``."""
    x0, s0 = ca.SX.sym("x0", 12), ca.SX.sym("s0")
    loop_state = make_loop_state()
    z0 = ca.SX.sym("z0", loop_state.numel_in(1))
    X0 = loop_state(x0, z0)
    th_r, dth_r = z0[Z["theta_r"]], z0[Z["dtheta_r"]]
    Xs = ca.vertcat(X0[0:2], th_r, dth_r, ca.DM.zeros(6), X0[12:14])
    parts = {"theta_r": th_r, "dtheta_r": dth_r, "first": ca.DM(1.0),
             "x0": ca.vertcat(Xs, s0, 0.0)}
    if Xs.numel() != NXL:  # pragma: no cover - a layout change
        raise ScenarioError("balance feed: the shape state must have the loop model's size")
    g = ca.vertcat(*(parts.get(f, ca.DM.zeros(state.size_of(f))) for f in state.fields))
    return ca.Function("ballbot_guidance_mpc_balance_initial", [x0, z0, s0],
                       [ca.vertcat(0.0, g)], ["x0", "z0", "s0"], ["g0"])


def run_balance_path(path: Path, mpc: PathMPC, duration: float, sim: ClosedLoop | None = None,
                     every: int = 20) -> PathRun:
    """The balance feed driven from Python (module docstring): ``mpc`` (a :class:`PathMPC`
    on the shape model) every ``every`` periods, the references of each period computed
    here, the compiled balance loop alone between samples (true state)."""
    sim = ClosedLoop() if sim is None else sim
    inp = path_scenario(path, every * TS_CONTROL).inputs()
    for key in ("com_observer", "k_obs", "estimator"):
        inp.pop(key, None)
    inp["cascade"] = False
    Ts = float(inp["Ts"])
    loop_state, ref = make_loop_state(), _references()
    x, z, xz = inp["x0"], inp["z0"], None
    th_r, dth_r = z[Z["theta_r"]].copy(), z[Z["dtheta_r"]].copy()
    psi, r = float(z[Z.index("psi_r")]), float(z[Z.index("r_r")])
    th_eq = np.asarray(equilibrium_tilt(inp["p_ctrl"], psi), float).reshape(2)
    parts: dict[str, list[np.ndarray]] = {}
    t_g, a_log, prog, preds = [], [], [], []
    for i in range(int(round(duration / (every * Ts)))):
        X = np.asarray(loop_state(x, z), float).ravel()
        Xs = np.concatenate([X[0:2], th_r - th_eq, dth_r, np.zeros(6), X[12:14]])
        a = np.asarray(mpc.step(Xs), float).reshape(2)
        t_g.append(i * every * Ts)
        a_log.append(a)
        prog.append(mpc.progress())
        preds.append(mpc.prediction())
        seq = {key: inp[key][:every] for key in PERIOD_SEQUENCES}
        qs = []
        for _ in range(every):
            qs.append([np.asarray(v, float).ravel() for v in
                       ref(np.r_[th_r, psi], np.r_[dth_r, r], np.r_[a, 0.0])])
            th_r, dth_r = th_r + Ts * dth_r + 0.5 * Ts ** 2 * a, dth_r + Ts * a
        fed = [key for key in REFERENCE_SEQUENCES if key != "v_ref"]  # q_ref, dq_ref, ddq_ref
        for j, key in enumerate(fed):
            seq[key] = np.array([q[j] for q in qs])
        xz, x, z = simulate_chunk(sim, "flc", {**inp, **seq}, xz, parts)
    log = chunks_log(parts, x, z, Ts)
    return PathRun(log, np.array(t_g), np.array(a_log), np.array(mpc.solve_s), np.array(prog),
                   preds)

"""The guidance laws as CasADi Functions of one guidance sample (the MPC and pure pursuit).

What :class:`~ballbot_casadi.guidance.mpc.PathMPC` and
:class:`~ballbot_casadi.guidance.pure_pursuit.PurePursuit` do in Python once per guidance
sample, written on symbols, so the sample runs inside the compiled control period
(:mod:`ballbot_casadi.sim.guided` wraps it into the period's guidance slot):

``ballbot_guidance_<law>_sample(X[14], g, k) -> (v[2], g_next)``

``X`` is the loop-model state (:mod:`ballbot_casadi.guidance.prediction`), ``g`` the
law's state (:func:`mpc_state_layout`, :func:`pursuit_state_layout`: the velocity
reference held since the last sample first), ``k`` the law's parameters (the path
table of :mod:`ballbot_casadi.guidance.path_table`; pure pursuit: its two gains first).

MPC sample (the real-time iteration of ``PathMPC.step``): the previous plan ``w``
shifted one step (its last node advanced by the prediction model; on the first sample
the initial guess of :func:`mpc_initial_state` as it is), the current loop state as node
0, the solver parameters from the guessed progress and positions
(:func:`mpc_parameters`: path window, progress-speed reference, obstacle half-planes),
one call of ``ballbot_mpc`` (:func:`~ballbot_casadi.guidance.mpc.make_mpc`, used through
its public signature only, so another QP solver drops in).  Its duals are warm-started
(shifted) when the configuration asks for it, else cold.  A QP that fails in the
generated C makes the call return an error (the mission stops with it); this block has
no fallback plan.

Pure-pursuit sample: the projection onto the path by five Gauss-Newton steps
``s <- s + T(s) . (p - P(s))`` from the previous projection (the Python class searches a
+-0.5 m window densely; on a path the robot follows both agree to ~1e-4 m), then the
law of :class:`~ballbot_casadi.guidance.pure_pursuit.PurePursuit`.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from ballbot_casadi.core.layout import Layout
from ballbot_casadi.errors import BuildError, ScenarioError
from ballbot_casadi.guidance.mpc import NX_MPC, MpcConfig, MpcLayout
from ballbot_casadi.guidance.path_table import (
    PATH_SAMPLES,
    PathSymbols,
    pack_path,
    path_eval,
    path_table_layout,
)
from ballbot_casadi.guidance.paths import Path
from ballbot_casadi.guidance.prediction import NXL, LoopModel

__all__ = ["mpc_state_layout", "pursuit_state_layout", "pursuit_parameters_layout",
           "mpc_parameters", "make_mpc_sample", "make_pursuit_sample", "mpc_initial_state",
           "pursuit_initial_state", "pursuit_parameters", "stage_shift_index"]

_PARAMS = ("v_prev", "path_p", "path_t", "s_bar", "v_s", "obs_n", "obs_b", "s_max")


def mpc_state_layout(layout: MpcLayout, n_g: int, warm_dual: bool) -> Layout:
    """State of the MPC sample: held ``v``, ``first`` (1 before the first solve), the plan
    ``w`` and (``warm_dual``) its duals ``lam_x``, ``lam_a`` (``n_g`` constraint rows)."""
    return Layout("MPC guidance state", [("v", 2), ("first", 1), ("w", layout.n_w),
                                         *((("lam_x", layout.n_w), ("lam_a", n_g))
                                           if warm_dual else ())])


def pursuit_state_layout() -> Layout:
    """State of the pure-pursuit sample: held ``v`` and the last projection ``s``."""
    return Layout("pure-pursuit guidance state", [("v", 2), ("s", 1)])


def pursuit_parameters_layout(n_samples: int = PATH_SAMPLES) -> Layout:
    """Parameters of pure pursuit: ``lookahead`` (m), ``k_lat`` (1/s), the path table."""
    return Layout("pure-pursuit parameters", [("lookahead", 1), ("k_lat", 1),
                                              ("path", path_table_layout(0, n_samples))])


def stage_shift_index(L: MpcLayout) -> np.ndarray:
    """Indices moving a vector laid out like ``w`` one stage ahead, its last stage
    repeated (``PathMPC._shift_stages``)."""
    idx = np.arange(L.n_w)
    for k in range(L.N):
        idx[L.x(k)] = np.arange(L.n_w)[L.x(k + 1)]
        if k < L.N - 1:
            idx[L.u(k)] = np.arange(L.n_w)[L.u(k + 1)]
            idx[L.slack(k + 1)] = np.arange(L.n_w)[L.slack(k + 2)]
    return idx


def _check_params(L: MpcLayout) -> None:
    if tuple(L.params) != _PARAMS:
        raise BuildError(f"ballbot_mpc parameters {', '.join(L.params)} differ from the ones "
                         f"this guidance block packs ({', '.join(_PARAMS)})")


def mpc_parameters(L: MpcLayout, config: MpcConfig, P: PathSymbols, guess: Any, v_prev: Any) -> Any:
    """The ``ballbot_mpc`` parameter vector from the guessed plan ``guess`` (symbols):
    ``PathMPC.parameters`` with the path from the table."""
    _check_params(L)
    N, M = L.N, L.M
    n1 = N + 1
    s_bar = ca.vertcat(*(guess[L.x(k).start + NXL] for k in range(n1))).T
    pos = ca.horzcat(*(guess[L.x(k).start + 12:L.x(k).start + 14] for k in range(n1)))
    ev = path_eval(P, s_bar)
    pp, pt = ev["point"], ev["tangent"]
    lat = ca.vertcat(-pt[1, :], pt[0, :])
    obs_n, obs_b = [], []
    for j in range(M):
        if j < P.n_obstacles:
            c, r = P.obstacles[0:2, j], P.obstacles[2, j]
            cc = ca.repmat(c, 1, n1)
            d = pos - cc
            side = ca.if_else(ca.sum1(lat * (cc - pp)) > 0, -1.0, 1.0)
            along = ca.sum1(pt * d)
            off = ca.fmax(side * ca.sum1(lat * d), r + config.clearance)
            d2 = pt * ca.repmat(along, 2, 1) + lat * ca.repmat(side * off, 2, 1)
            n = d2 / ca.repmat(ca.fmax(ca.sqrt(ca.sum1(d2 ** 2)), 1e-9), 2, 1)
            b = r + config.clearance + ca.mtimes(c.T, n)
            on = r > 0
            obs_n.append(ca.vec(ca.if_else(on, n, ca.DM.zeros(2, n1))))
            obs_b.append(ca.if_else(on, b, -ca.DM.ones(1, n1)).T)
        else:
            obs_n.append(ca.DM.zeros(2 * n1))
            obs_b.append(-ca.DM.ones(n1))
    return ca.vertcat(v_prev, ca.vec(pp), ca.vec(pt), s_bar.T, ev["speed"].T, *obs_n, *obs_b,
                      ev["s_max"])


def make_mpc_sample(mpc: ca.Function, L: MpcLayout, model: LoopModel, config: MpcConfig,
                    n_samples: int = PATH_SAMPLES) -> ca.Function:
    """``ballbot_guidance_mpc_sample(X, g, k) -> (v, g_next)`` (module docstring) around the
    ``ballbot_mpc`` Function ``mpc`` of layout ``L``; ``k`` is the path table with
    ``config.n_obstacles`` slots."""
    n_g = mpc.size1_in(4)
    G = mpc_state_layout(L, n_g, config.warm_dual)
    K = path_table_layout(config.n_obstacles, n_samples)
    X, g, k = ca.MX.sym("X", NXL), ca.MX.sym("g", G.size), ca.MX.sym("k", K.size)
    P = PathSymbols(k, config.n_obstacles, n_samples)
    idx = stage_shift_index(L)
    w = g[G["w"]]
    shifted = w[list(idx)]
    xN = w[L.x(L.N)]
    uN = w[L.u(L.N - 1)]
    last = ca.vertcat(ca.mtimes(ca.DM(model.A), xN[:NXL]) + ca.mtimes(ca.DM(model.B), uN[0:2]),
                      xN[NXL] + config.dt * xN[NXL + 1], xN[NXL + 1])
    shifted = ca.vertcat(shifted[:L.x(L.N).start], last, shifted[L.x(L.N).stop:])
    guess = ca.if_else(g[G["first"]] > 0.5, w, shifted)
    x0 = ca.vertcat(X, guess[NXL:NX_MPC])
    guess = ca.vertcat(x0, guess[NX_MPC:])
    p = mpc_parameters(L, config, P, guess, g[G["v"]])
    if config.warm_dual:
        lam_x = ca.if_else(g[G["first"]] > 0.5, 0.0, g[G["lam_x"]][list(idx)])
        rows = n_g // L.N
        la = g[G["lam_a"]]
        lam_a = ca.if_else(g[G["first"]] > 0.5, 0.0, ca.vertcat(la[rows:], la[n_g - rows:]))
    else:
        lam_x, lam_a = ca.DM.zeros(L.n_w), ca.DM.zeros(n_g)
    res = mpc.call({"x0": x0, "p": p, "w0": guess, "lam_x0": lam_x, "lam_a0": lam_a})
    v = res["v_ref"]
    g_next = ca.vertcat(v, 0.0, res["w"], *((res["lam_x"], res["lam_a"]) if config.warm_dual else ()))
    return ca.Function("ballbot_guidance_mpc_sample", [X, g, k], [v, g_next],
                       ["X", "g", "k"], ["v", "g_next"])


def make_pursuit_sample(n_samples: int = PATH_SAMPLES, newton_steps: int = 5) -> ca.Function:
    """``ballbot_guidance_pursuit_sample(X, g, k) -> (v, g_next)`` (module docstring)."""
    G, K = pursuit_state_layout(), pursuit_parameters_layout(n_samples)
    X, g, k = ca.MX.sym("X", NXL), ca.MX.sym("g", G.size), ca.MX.sym("k", K.size)
    P = PathSymbols(k[K["path"]], 0, n_samples)
    pos = X[12:14]
    s = g[G["s"]]
    for _ in range(newton_steps):
        ev = path_eval(P, s)
        s = s + ca.dot(ev["tangent"], pos - ev["point"])
        s = ca.if_else(P.closed > 0.5, s, ca.fmin(ca.fmax(s, 0.0), P.length))
    here = path_eval(P, s)
    ahead = path_eval(P, s + k[K["lookahead"]])
    d = ahead["point"] - pos
    nd = ca.norm_2(d)
    v = ca.if_else(nd > 1e-9, here["speed"] * d / ca.fmax(nd, 1e-9), ca.DM.zeros(2))
    v = v + k[K["k_lat"]] * (here["point"] - pos)
    nv = ca.norm_2(v)
    v = ca.if_else(nv > 0, v * ca.fmin(1.0, P.speed / ca.fmax(nv, 1e-12)), v)
    return ca.Function("ballbot_guidance_pursuit_sample", [X, g, k], [v, ca.vertcat(v, s)],
                       ["X", "g", "k"], ["v", "g_next"])


def mpc_initial_state(L: MpcLayout, n_g: int, config: MpcConfig, path: Path,
                      X0: np.ndarray) -> np.ndarray:
    """The MPC sample's state before the first sample: no velocity, ``first = 1`` and the
    guess of ``PathMPC`` (every node at the loop state ``X0`` and the projection of its
    position onto ``path``, progress rate 0)."""
    X0 = np.asarray(X0, float).reshape(NXL)
    s0 = path.project(X0[12:14])
    w = np.zeros(L.n_w)
    for kk in range(L.N + 1):
        w[L.x(kk)] = np.r_[X0, s0, 0.0]
    G = mpc_state_layout(L, n_g, config.warm_dual)
    parts = {"v": np.zeros(2), "first": 1.0, "w": w}
    if config.warm_dual:
        parts.update(lam_x=np.zeros(L.n_w), lam_a=np.zeros(n_g))
    return G.pack(parts)


def pursuit_initial_state(path: Path, X0: np.ndarray) -> np.ndarray:
    """The pure-pursuit state before the first sample: no velocity, the projection of the
    position onto ``path``."""
    X0 = np.asarray(X0, float).reshape(NXL)
    return pursuit_state_layout().pack({"v": np.zeros(2), "s": path.project(X0[12:14])})


def pursuit_parameters(path: Path, lookahead: float = 0.3, k_lat: float = 1.0,
                       n_samples: int = PATH_SAMPLES) -> np.ndarray:
    """The pure-pursuit parameter vector (:func:`pursuit_parameters_layout`)."""
    if not (np.isfinite(lookahead) and lookahead > 0):
        raise ScenarioError(f"lookahead must be > 0 m, got {lookahead!r}")
    return pursuit_parameters_layout(n_samples).pack(
        {"lookahead": lookahead, "k_lat": k_lat, "path": pack_path(path, 0, n_samples, obstacles=False)})

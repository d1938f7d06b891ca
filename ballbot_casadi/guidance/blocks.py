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

MPC sample (the real-time iteration of ``PathMPC.step``, same numbers): the state
carries what ``PathMPC`` carries between samples (:func:`mpc_state_layout`: the held
``v``, ``first``, the last MPC state ``x0``, the blocked inputs ``u`` and the ADMM's
``z, y``).  Node 0 is the current loop state with the progress continued from the last
prediction (clipped monotone); the guess is ``u`` shifted one step
(:func:`~ballbot_casadi.guidance.mpc.input_shift_matrix`), the multipliers ``y``
shifted (:func:`~ballbot_casadi.guidance.mpc.dual_shift_index`), ``z0 = A u0``; the
parameters come from the guessed trajectory (:func:`mpc_parameters`: path window,
progress-speed reference, lateral weight, obstacle half-planes).  The first sample
starts cold and re-linearises :data:`~ballbot_casadi.guidance.mpc.FIRST_SAMPLE_QPS`
times (a separate branch, ``Function.conditional``).  A non-finite solution keeps the
shifted plan with cold multipliers; the primal residual ``r_prim`` is kept in the state.

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
from ballbot_casadi.guidance.mpc import (
    FIRST_SAMPLE_QPS,
    NX_MPC,
    MpcConfig,
    MpcLayout,
    dual_shift_index,
    input_shift_matrix,
)
from ballbot_casadi.guidance.path_table import (
    PATH_SAMPLES,
    PathSymbols,
    pack_path,
    path_eval,
    path_table_layout,
)
from ballbot_casadi.guidance.paths import Path
from ballbot_casadi.guidance.prediction import NXL

__all__ = ["mpc_state_layout", "pursuit_state_layout", "pursuit_parameters_layout",
           "mpc_parameters", "make_mpc_sample", "make_pursuit_sample", "mpc_initial_state",
           "pursuit_initial_state", "pursuit_parameters", "MPC_SAMPLE_BRANCHES"]

#: The MPC sample's two branches (called Functions of ``ballbot_guidance_mpc_sample``, chosen
#: by its state's ``first``): a later (warm) sample, the cold first sample.
MPC_SAMPLE_BRANCHES = ("ballbot_guidance_mpc_sample_next", "ballbot_guidance_mpc_sample_first")


def mpc_state_layout(L: MpcLayout) -> Layout:
    """State of the MPC sample: held ``v``, ``first`` (1 before the first solve), the MPC
    state ``x0`` of the last sample (16), its blocked inputs ``u``, the ADMM's split
    ``z`` and multipliers ``y`` (one per row) and its primal residual ``r_prim``."""
    return Layout("MPC guidance state", [("v", 2), ("first", 1), ("x0", NX_MPC), ("u", L.n_u),
                                         ("z", L.n_rows), ("y", L.n_rows), ("r_prim", 1)])


def pursuit_state_layout() -> Layout:
    """State of the pure-pursuit sample: held ``v`` and the last projection ``s``."""
    return Layout("pure-pursuit guidance state", [("v", 2), ("s", 1)])


def pursuit_parameters_layout(n_samples: int = PATH_SAMPLES) -> Layout:
    """Parameters of pure pursuit: ``lookahead`` (m), ``k_lat`` (1/s), the path table."""
    return Layout("pure-pursuit parameters", [("lookahead", 1), ("k_lat", 1),
                                              ("path", path_table_layout(0, n_samples))])


def _states(cond: Any, x0: Any, u: Any) -> list[Any]:
    """Predicted MPC states ``X_k = Phi_k x0 + Gamma_k u`` (symbols), k = 0..N."""
    return [ca.mtimes(ca.DM(cond.Phi[k]), x0) + ca.mtimes(ca.DM(cond.Gamma[k]), u)
            for k in range(cond.N + 1)]


def mpc_parameters(L: MpcLayout, config: MpcConfig, cond: Any, P: PathSymbols, x0: Any,
                   guess: Any, v_prev: Any) -> Any:
    """The ``ballbot_mpc`` parameter vector from the guessed trajectory (symbols):
    ``PathMPC.parameters`` with the path from the table (packed in ``L.params`` order)."""
    N, M = L.N, L.M
    n1 = N + 1
    X = _states(cond, x0, guess)
    s_bar = ca.horzcat(*(x[NXL] for x in X))
    pos = ca.horzcat(*(x[12:14] for x in X))
    ev = path_eval(P, s_bar)
    pp, pt = ev["point"], ev["tangent"]
    lat = ca.vertcat(-pt[1, :], pt[0, :])
    w_lat = ca.DM.ones(1, n1)
    obs_n, obs_b = [], []
    for j in range(M):
        c, r = P.obstacles[0:2, j], P.obstacles[2, j]
        on = r > 0
        cc = ca.repmat(c, 1, n1)
        r_safe = r + config.clearance
        side = ca.if_else(ca.sum1(lat * (cc - pp)) > 0, -1.0, 1.0)
        along = ca.sum1(pt * (pos - cc))
        beside = ca.logic_and(on, ca.fabs(along) < r_safe)
        n = lat * ca.repmat(side, 2, 1)
        b = ca.sum1(n * cc) + ca.sqrt(ca.fmax(r_safe ** 2 - along ** 2, 0.0))
        obs_n.append(ca.vec(ca.if_else(ca.repmat(beside, 2, 1), n, 0.0)))
        obs_b.append(ca.if_else(beside, b, -1.0).T)
        near = ca.logic_and(on, ca.sqrt(ca.sum1((pp - cc) ** 2)) < r_safe + 0.3)
        w_lat = ca.if_else(near, ca.fmin(w_lat, config.obstacle_relax), w_lat)
    blocks = {"v_prev": v_prev, "path_p": ca.vec(pp), "path_t": ca.vec(pt), "s_bar": s_bar.T,
              "v_s": ev["speed"].T, "w_lat": w_lat.T, "obs_n": ca.vertcat(*obs_n),
              "obs_b": ca.vertcat(*obs_b), "s_max": ev["s_max"]}
    if set(blocks) != set(L.params):
        raise BuildError(f"ballbot_mpc parameters {', '.join(L.params)} differ from the ones "
                         f"this guidance block packs ({', '.join(blocks)})")
    return ca.vertcat(*(blocks[name] for name in L.params))


def _rows(L: MpcLayout, config: MpcConfig, A_c: np.ndarray, G: np.ndarray, u: Any, p: Any) -> Any:
    """``A u`` with the parameters ``p`` (``PathMPC.rows``, symbols)."""
    Pp = L.unpack(p)
    pos = ca.mtimes(ca.DM(G), u)
    ob = []
    for j in range(L.M):
        for i, k in enumerate(L.nodes):
            o = (j * (L.N + 1) + k) * 2
            ob.append(config.obstacle_scale * ca.dot(Pp["obs_n"][o:o + 2], pos[2 * i:2 * i + 2]))
    return ca.vertcat(ca.mtimes(ca.DM(A_c), u), *ob)


def make_mpc_sample(mpc: ca.Function, L: MpcLayout, parts: dict[str, Any], config: MpcConfig,
                    n_samples: int = PATH_SAMPLES) -> ca.Function:
    """``ballbot_guidance_mpc_sample(X, g, k) -> (v, g_next)`` (module docstring) around the
    ``ballbot_mpc`` Function ``mpc`` of layout ``L``; ``parts`` as
    :func:`~ballbot_casadi.guidance.mpc.make_mpc_parts` returns them; ``k`` is the path
    table with ``config.n_obstacles`` slots."""
    cond, A_c, G = parts["cond"], parts["A_c"], parts["G"]
    S = mpc_state_layout(L)
    K = path_table_layout(config.n_obstacles, n_samples)
    T0 = ca.DM(cond.T[0][0:2])
    zero_u, zero_y = ca.DM.zeros(L.n_u), ca.DM.zeros(L.n_rows)

    def solve(x0: Any, guess: Any, y0: Any, v_prev: Any, P: PathSymbols) -> tuple:
        p = mpc_parameters(L, config, cond, P, x0, guess, v_prev)
        z0 = _rows(L, config, A_c, G, guess, p)
        res = mpc.call({"x0": x0, "p": p, "u0": guess, "z0": z0, "y0": y0})
        u = res["u"]
        ok = ca.sum1(ca.fabs(u)) < ca.inf  # false for inf / nan (u - u == 0 simplifies to 1)
        return ok, u, res, z0

    def branch(first: bool) -> ca.Function:
        X, g, k = ca.MX.sym("X", NXL), ca.MX.sym("g", S.size), ca.MX.sym("k", K.size)
        P = PathSymbols(k, config.n_obstacles, n_samples)
        x_prev, u_prev, v_prev = g[S["x0"]], g[S["u"]], g[S["v"]]
        if first:
            x0 = ca.vertcat(X, x_prev[NXL], 0.0)
            guess, y0 = zero_u, zero_y
        else:
            x1 = ca.mtimes(ca.DM(cond.Phi[1][NXL:]), x_prev) + ca.mtimes(ca.DM(cond.Gamma[1][NXL:]), u_prev)
            x0 = ca.vertcat(X, ca.fmax(x1[0], x_prev[NXL]), ca.fmax(x1[1], 0.0))
            guess = ca.mtimes(ca.DM(input_shift_matrix(cond)), u_prev)
            y0 = g[S["y"]][list(dual_shift_index(L))]
        for _ in range(FIRST_SAMPLE_QPS if first else 1):
            ok, u, res, z0 = solve(x0, guess, y0, v_prev, P)
            guess = ca.if_else(ok, u, guess)
            y0 = ca.if_else(ok, res["y"], y0)
        u_new = ca.if_else(ok, u, guess)
        z_new = ca.if_else(ok, res["z"], z0)
        y_new = ca.if_else(ok, y0, zero_y)
        v = ca.mtimes(T0, u_new)
        g_next = ca.vertcat(v, 0.0, x0, u_new, z_new, y_new, res["r_prim"])
        return ca.Function(MPC_SAMPLE_BRANCHES[int(first)],
                           [X, g, k], [v, g_next], ["X", "g", "k"], ["v", "g_next"])

    X, g, k = ca.MX.sym("X", NXL), ca.MX.sym("g", S.size), ca.MX.sym("k", K.size)
    # index 0: a later sample; otherwise (first = 1) the default, the first sample
    cond_f = ca.Function.conditional("ballbot_guidance_mpc_branch", [branch(False)], branch(True))
    v, g_next = cond_f(g[S["first"]] > 0.5, X, g, k)
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


def mpc_initial_state(L: MpcLayout, path: Path, X0: np.ndarray) -> np.ndarray:
    """The MPC sample's state before the first sample: no velocity, ``first = 1``, the
    MPC state at the loop state ``X0`` with the projection of its position onto ``path``
    (what ``PathMPC.step`` starts from), everything else zero."""
    X0 = np.asarray(X0, float).reshape(NXL)
    S = mpc_state_layout(L)
    return S.pack({"v": np.zeros(2), "first": 1.0,
                   "x0": np.r_[X0, path.project(X0[12:14]), 0.0], "u": np.zeros(L.n_u),
                   "z": np.zeros(L.n_rows), "y": np.zeros(L.n_rows), "r_prim": 0.0})


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

"""Path-following MPC above the velocity LQR: real-time iteration, one condensed QP per sample.

``ballbot_mpc(x0, p, u0, z0, y0) -> (v_ref, u, z, y, r_prim)``

Decision
--------
The MPC gives *velocity references* ``v_ref = (vx, vy)`` (heading rate 0) to the
existing velocity LQR (:mod:`ballbot_casadi.control.velocity`), and predicts with the
linear model of that closed loop (:mod:`ballbot_casadi.guidance.prediction`): the loop's
tilt, tilt rate and accelerations are outputs of the model, so the §7.1 limits are
linear rows, and the balance and velocity loops below stay exactly as validated.

Feed point (issue 18): the alternative, Kugle's arrangement, is built as the option
``guidance = "mpc_balance"`` (:mod:`ballbot_casadi.sim.balance_feed`): this same MPC on
the shape-accelerated model (:mod:`ballbot_casadi.guidance.shape_model`) feeding the
balance controller its attitude, rate and acceleration references.  Measured on the same
courses and seeds (``ballbot study path``, report section "Feed point"): alike with the
true state (figure-eight, obstacle course: lateral error, clearance, completion); with
noise and the UKFs the balance feed tracked worse on the study's seed (and on average
over two further seeds, measured once), while its torque and tilt-rate peaks were
lower; the same solver, workspace and time per sample.  The velocity LQR closes the
velocity loop every period with integral action, the balance feed only through the
10 Hz replanning on the estimate.  So the velocity feed stays the default; the balance
feed is kept as an option (two small modules, the same solver).

Problem (``N`` steps of ``dt``; default N = 20, dt = 0.1 s: a 2 s horizon)
---------------------------------------------------------------------------
State ``[loop state (14), s, ds]`` with the progress ``s`` along the path, input
``[v_ref (2), dds]`` per step, held over the move blocks ``blocks``.  The model is LTI,
so the states are eliminated (:mod:`ballbot_casadi.guidance.condensed`): the unknowns are
the ``3 * len(blocks)`` blocked inputs only.  Least squares on

* lateral and longitudinal errors ``e = p - P(s)`` in the path frame, with the path
  linearised at the guessed progress ``s_k`` (the path window of parameters:
  ``P(s) ~ P_k + T_k (s - s_k)``, i.e. one Gauss-Newton step of the nonlinear problem);
* the progress-speed error ``ds - v_s(s_k)`` (so the robot slows where the limits need
  it, instead of cutting the corner), ``dds`` and the change of ``v_ref``.

Rows at the constraint nodes ``nodes`` (inner octagons of the norm balls, so each norm
bound holds; each row normalised by its bound and scaled by ``margin``, the acceleration
by ``acc_margin``: it is sampled at the steps' starts and peaks between them): inclination
``|theta| <= tilt_max``, inclination rate, speed ``|v| <= v_max`` at node k; the ball
acceleration ``|a| <= a_max`` (thesis §7.1) and the tilt-reference acceleration
``|a_r| <= tilt_acc_max`` per axis (the torque budget of the balance loop, standing in
for the torque limit) at the start of step k - 1.  All are soft with an exact L1
penalty ``soft_penalty`` (no slack variables, see :mod:`ballbot_casadi.guidance.qp_admm`);
``ds >= 0`` (progress never decreases) and ``s <= s_max`` (end of an open path) are hard.
Circular obstacles: soft half-planes ``n_jk . p_k >= b_jk`` parallel to the path where
the guessed position is beside the inflated circle (radius + ``clearance``), on the side
of the path away from the centre (:meth:`PathMPC.parameters`); the lateral-error weight
is relaxed near an obstacle (``obstacle_relax``) so the cost does not pull the robot
back into it.

Solver: ``admm`` (default), a fixed-iteration ADMM written as CasADi expressions and
generated into the same C function (:mod:`ballbot_casadi.guidance.qp_admm`:
deterministic operation count, static workspace, no malloc, self-contained C99).  Why
not ``qrqp``: its KKT system carries every row, and the condensed rows are dense, so
each active-set iteration refactorises a large matrix; ``hpipm``/``daqp`` generate code
that links their shared libraries (host only, not embeddable).  Any CasADi ``conic``
plugin (``qrqp``, ``osqp``, ...) solves the same condensed QP with one slack per soft
row instead (``solver``), as the independent reference of the tests.

Real-time iteration: one QP per sample, warm-started with the previous solution
shifted by one step (primal ``u`` and the ADMM's ``z, y``), whose predicted progress
and positions also give the path window and the obstacle normals.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from ballbot_casadi.core.constants import THESIS_LIMITS
from ballbot_casadi.core.toolchain import Library, build_library, load_library
from ballbot_casadi.errors import ScenarioError, ShapeError
from ballbot_casadi.guidance.condensed import NU_MPC, NX_MPC, Condensed, condense
from ballbot_casadi.guidance.paths import Path
from ballbot_casadi.guidance.prediction import LOOP_OUTPUTS, NXL, LoopModel
from ballbot_casadi.guidance.qp_admm import admm_iterate, kkt_constant

__all__ = ["MpcConfig", "MpcLayout", "PathMPC", "make_mpc", "make_mpc_parts", "mpc_library",
           "workspace_bytes", "dual_shift_index", "FIRST_SAMPLE_QPS", "input_shift_matrix",
           "NX_MPC", "NU_MPC",
           "polygon", "path_window"]

#: Rows per node k = 1..N: speed octagon (4, soft), ds >= 0 and s <= s_max (hard).
_N_STEP_ROWS = 6
#: QPs of the first sample (RTI starts cold: the path window is re-linearised this often).
FIRST_SAMPLE_QPS = 5
#: Soft rows per constraint node: tilt, tilt rate, acceleration octagons (4 each) and
#: the tilt-reference acceleration per axis (2).
_N_NODE_ROWS = 14


@dataclass(frozen=True)
class MpcConfig:
    """Horizon, weights, limits and solver of the MPC (defaults: N = 20, dt = 0.1 s, §7.1).

    The default weights, the shipped tuning (this table is their documentation; a test
    pins the fields and reads the table back).  The cost sums squared residuals in SI
    units, so a weight ``w`` prices an error ``1 / sqrt(w)`` as much as 1 (Bryson's
    reading, last column); the soft rows are normalised by their bounds.

    ==============  =======  ================================================  =========
    field           default  acts on                                           1/sqrt(w)
    ==============  =======  ================================================  =========
    w_lat           400      lateral error from the path (m)                   0.05 m
    w_lon           100      longitudinal error along the path (m)             0.1 m
    w_speed         20       progress-speed error ds - v_s (m/s)               0.224 m/s
    w_dds           1        progress acceleration dds (m/s^2)                 1 m/s^2
    w_dv            20       change of v_ref from one step to the next (m/s)   0.224 m/s
    w_terminal      2        factor on the last node's path errors             -
    soft_penalty    30       exact L1 price of a soft row's violation          -
    obstacle_scale  10       scale of the obstacle rows (1/m)                  -
    obstacle_relax  0.1      cap on the lateral weight's factor near obstacles -
    ==============  =======  ================================================  =========
    """

    N: int = 20
    dt: float = 0.1
    n_obstacles: int = 5
    w_lat: float = 400.0
    w_lon: float = 100.0
    w_speed: float = 20.0
    w_dds: float = 1.0
    w_dv: float = 20.0
    w_terminal: float = 2.0
    clearance: float = 0.15
    margin: float = 0.9
    acc_margin: float = 0.8
    tilt_acc_max: float = 2.0
    limits: dict = field(default_factory=lambda: dict(THESIS_LIMITS))
    blocks: tuple = (1, 1, 1, 1, 2, 2, 2, 2, 4, 4)
    nodes: tuple = (1, 2, 3, 4, 6, 8, 10, 12, 16, 20)
    soft_penalty: float = 30.0
    obstacle_scale: float = 10.0
    obstacle_relax: float = 0.1
    solver: str = "admm"
    iterations: int = 60
    rho: float = 0.1
    sigma: float = 1e-6
    alpha: float = 1.6
    solver_options: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not (isinstance(self.N, int) and self.N >= 2):
            raise ScenarioError(f"N must be an int >= 2, got {self.N!r}")
        if not (math.isfinite(self.dt) and self.dt > 0):
            raise ScenarioError(f"dt must be > 0 s, got {self.dt!r}")
        for key in ("margin", "acc_margin"):
            if not (0 < getattr(self, key) <= 1):
                raise ScenarioError(f"{key} must be in (0, 1], got {getattr(self, key)!r}")
        if sum(self.blocks) != self.N or min(self.blocks) < 1:
            raise ScenarioError(f"blocks must be positive and sum to N = {self.N}, got "
                                f"{tuple(self.blocks)!r}")
        if not self.nodes or sorted(set(self.nodes)) != list(self.nodes) or \
                self.nodes[0] < 1 or self.nodes[-1] > self.N:
            raise ScenarioError(f"nodes must be increasing node numbers in 1..{self.N}, got "
                                f"{tuple(self.nodes)!r}")
        if not (isinstance(self.iterations, int) and self.iterations >= 1):
            raise ScenarioError(f"iterations must be an int >= 1, got {self.iterations!r}")


def polygon(n: int) -> tuple[np.ndarray, float]:
    """Directions (n/2 rows for two-sided use) and apothem factor of the inner regular n-gon."""
    ang = np.pi * np.arange(n // 2) / (n // 2)
    return np.column_stack([np.cos(ang), np.sin(ang)]), math.cos(math.pi / n)


@dataclass(frozen=True)
class MpcLayout:
    """Sizes of the QP and the layout of the parameter vector ``p``."""

    N: int
    M: int
    n_u: int
    nodes: tuple

    @property
    def n_c(self) -> int:
        """Constant rows: speed and hard rows node by node, then the limits at ``nodes``."""
        return self.N * _N_STEP_ROWS + len(self.nodes) * _N_NODE_ROWS

    @property
    def n_rows(self) -> int:
        """All rows: constant rows, then obstacle rows (obstacle-major, node-minor)."""
        return self.n_c + self.M * len(self.nodes)

    @property
    def params(self) -> dict[str, tuple[int, ...]]:
        """Parameter blocks in order with their shapes (row-major)."""
        n1 = self.N + 1
        return {"v_prev": (2,), "path_p": (n1, 2), "path_t": (n1, 2), "s_bar": (n1,),
                "v_s": (n1,), "w_lat": (n1,), "obs_n": (self.M, n1, 2), "obs_b": (self.M, n1),
                "s_max": (1,)}

    @property
    def n_p(self) -> int:
        return sum(int(np.prod(s)) for s in self.params.values())

    def pack(self, **blocks: Any) -> np.ndarray:
        out = []
        for name, shape in self.params.items():
            arr = np.asarray(blocks[name], float)
            if arr.shape != shape:
                raise ShapeError(f"MPC parameter {name} must have shape {shape}, got {arr.shape}")
            out.append(arr.ravel())
        return np.concatenate(out)

    def unpack(self, p: Any) -> dict[str, Any]:
        out, o = {}, 0
        for name, shape in self.params.items():
            n = int(np.prod(shape))
            out[name] = p[o:o + n]
            o += n
        return out


def _qp(model: LoopModel, cond: Condensed, config: MpcConfig, L: MpcLayout) -> dict[str, Any]:
    """The condensed QP in symbols ``x0, p``: cost, constant rows, obstacle rows."""
    N, M, nodes = config.N, config.n_obstacles, config.nodes
    lim, mg = config.limits, config.margin
    x0 = ca.SX.sym("x0", NX_MPC)
    p = ca.SX.sym("p", L.n_p)
    ub = ca.SX.sym("ub", L.n_u)
    P = L.unpack(p)
    X = [ca.mtimes(ca.DM(cond.Phi[k]), x0) + ca.mtimes(ca.DM(cond.Gamma[k]), ub)
         for k in range(N + 1)]
    U = [ca.mtimes(ca.DM(cond.T[k]), ub) for k in range(N)]
    model_C, model_D = _outputs(model)
    # J = sum_i w_i r_i^2, written on the cost quantities c = Yq ub (the inputs, then the
    # position, progress and its rate at the nodes 1..N; their x0 parts are added back), so
    # the Hessian P = Yq' Hq Yq has a small sparse middle factor Hq (3x3 blocks per node)
    qsel = [12, 13, NXL, NXL + 1]
    Yq = np.vstack([np.eye(L.n_u)] + [cond.Gamma[k][qsel] for k in range(1, N + 1)])
    cq = ca.SX.sym("c", Yq.shape[0])
    Uq = [ca.mtimes(ca.DM(cond.T[k]), cq[:L.n_u]) for k in range(N)]
    res, wts = [], []
    v_before = P["v_prev"]
    for k in range(N):
        vr, dds = Uq[k][0:2], Uq[k][2]
        res += [vr - v_before, dds]
        wts += [ca.DM([config.w_dv] * 2), config.w_dds]
        v_before = vr
        k1 = k + 1
        xn = ca.mtimes(ca.DM(cond.Phi[k1][qsel]), x0) + cq[L.n_u + 4 * k:L.n_u + 4 * k1]
        pos, s1, ds1 = xn[0:2], xn[2], xn[3]
        pk, tk = P["path_p"][2 * k1:2 * k1 + 2], P["path_t"][2 * k1:2 * k1 + 2]
        nk = ca.vertcat(-tk[1], tk[0])
        e = pos - pk - tk * (s1 - P["s_bar"][k1])
        wt = config.w_terminal if k1 == N else 1.0
        res += [ca.dot(nk, e), ca.dot(tk, e), ds1 - P["v_s"][k1]]
        wts += [wt * P["w_lat"][k1] * config.w_lat, wt * config.w_lon, config.w_speed]
    r, w = ca.vertcat(*res), ca.vertcat(*wts)
    Jq = ca.dot(w, r ** 2)
    J = ca.substitute(Jq, cq, ca.mtimes(ca.DM(Yq), ub))
    dirs, f8 = polygon(8)
    D8 = ca.DM(dirs)
    # rows = D y(ub): the distinct outputs y (tilt, rates, speeds, ... linear in ub) and the
    # octagon directions D, so the solver multiplies by the thin Y = dy/dub, then by D
    outs, Ds, lo, hi = [], [], [], []
    oct_rows = {}
    for name, bound in (("v", lim["v_max"] * mg), ("tilt", lim["tilt_max"] * mg),
                        ("tilt_rate", lim["tilt_rate_max"] * mg),
                        ("acc", lim["a_max"] * config.acc_margin)):
        oct_rows[name] = D8 / (bound * f8)
    # every node: speed (the limit active whenever the path speed is v_max) and hard rows
    for k in range(1, N + 1):
        xk = X[k]
        outs += [ca.mtimes(model_C["v"], xk), xk[NXL + 1], xk[NXL] - P["s_max"]]
        Ds += [oct_rows["v"], ca.DM(1), ca.DM(1)]
        lo += [-1.0] * 4 + [0.0, -ca.inf]
        hi += [1.0] * 4 + [ca.inf, 0.0]
    # the constraint nodes: tilt, tilt rate at node k, accelerations at the start of step k-1
    for k in nodes:
        xk, xp, up = X[k], X[k - 1], U[k - 1][0:2]
        outs += [ca.mtimes(model_C["tilt"], xk), ca.mtimes(model_C["tilt_rate"], xk),
                 ca.mtimes(model_C["acc"], xp) + ca.mtimes(model_D["acc"], up),
                 ca.mtimes(model_C["tilt_acc"], xp) + ca.mtimes(model_D["tilt_acc"], up)]
        Ds += [oct_rows["tilt"], oct_rows["tilt_rate"], oct_rows["acc"],
               ca.DM.eye(2) / (config.tilt_acc_max * mg)]
        lo += [-1.0] * _N_NODE_ROWS
        hi += [1.0] * _N_NODE_ROWS
    y_out = ca.vertcat(*outs)
    D = ca.diagcat(*Ds)
    g = ca.mtimes(D, y_out)
    # obstacle rows: s_o n_jk . (G_k ub + pos0_k) >= s_o b_jk
    so = config.obstacle_scale
    G = np.vstack([cond.Gamma[k][12:14] for k in nodes])
    Nm = ca.SX(M * len(nodes), 2 * len(nodes))
    ob_lo = []
    for j in range(M):
        for i, k in enumerate(nodes):
            o = (j * (N + 1) + k) * 2
            n_ob = P["obs_n"][o:o + 2]
            Nm[j * len(nodes) + i, 2 * i] = so * n_ob[0]
            Nm[j * len(nodes) + i, 2 * i + 1] = so * n_ob[1]
            pos0 = ca.mtimes(ca.DM(cond.Phi[k][12:14]), x0)
            ob_lo.append(so * (P["obs_b"][j * (N + 1) + k] - ca.dot(n_ob, pos0)))
    zero = ca.DM.zeros(L.n_u)
    Hq = ca.hessian(Jq, cq)[0]
    gq = ca.substitute(ca.gradient(Jq, cq), cq, ca.DM.zeros(cq.numel()))
    Y = ca.jacobian(y_out, ub)
    if ca.depends_on(Y, ca.vertcat(x0, p)):
        raise ShapeError("MPC: the constant rows depend on the parameters")  # pragma: no cover
    Y, D = np.array(ca.evalf(Y)), np.array(D)
    A_c = D @ Y
    g0 = ca.substitute(g, ub, zero)
    # the node positions G u among the cost quantities (the obstacle rows' A'A = G'N'NG)
    i_pos = [L.n_u + 4 * (k - 1) + j for k in nodes for j in (0, 1)]
    return {"x0": x0, "p": p, "ub": ub, "J": J, "Hq": Hq, "gq": gq, "Yq": Yq, "i_pos": i_pos,
            "A_c": A_c, "D": D, "Y": Y,
            "G": G,
            "N": Nm, "l": ca.vertcat(ca.DM(lo) - g0, *ob_lo),
            "u": ca.vertcat(ca.DM(hi) - g0, ca.DM.inf(len(ob_lo))),
            "penalty": np.concatenate([np.tile([config.soft_penalty] * 4 + [np.inf] * 2, N),
                                       np.full(_N_NODE_ROWS * len(nodes) + len(ob_lo),
                                               config.soft_penalty)])}


def _outputs(model: LoopModel) -> tuple[dict, dict]:
    """Output maps of the loop model on the 16-state MPC state (C) and on v_ref (D)."""
    out_C, out_D = {}, {}
    for name in LOOP_OUTPUTS:
        Cp = np.zeros((2, NX_MPC))
        Cp[:, :NXL] = model.C[name]
        out_C[name], out_D[name] = ca.DM(Cp), ca.DM(model.D[name])
    return out_C, out_D


def make_mpc(model: LoopModel, config: MpcConfig = MpcConfig()) -> tuple[ca.Function, MpcLayout]:
    """Build ``ballbot_mpc`` (see the module docstring) and the layout of its vectors."""
    if abs(model.dt - config.dt) > 1e-12:
        raise ScenarioError(f"prediction model step {model.dt} s differs from the MPC dt {config.dt} s")
    cond = condense(model, config.blocks)
    return _make(model, cond, config)[:2]


def make_mpc_parts(model: LoopModel, config: MpcConfig = MpcConfig()
                   ) -> tuple[ca.Function, MpcLayout, dict[str, Any]]:
    """``ballbot_mpc``, its layout and what a caller needs to warm-start and parametrise
    it: ``cond`` (:class:`Condensed`), ``A_c`` (constant rows), ``G`` (node positions
    from ``u``), ``cost`` (``ballbot_mpc_cost``), ``scale``; and the QP it solves, formed
    directly (for checks): ``qp_data(x0, p) -> (P, q, l, u, nobs)`` (the scaled Hessian
    and gradient of ``cost``, the row bounds and the obstacle factor's nonzeros of
    sparsity ``N_sp``), the rows' ``penalty``."""
    if abs(model.dt - config.dt) > 1e-12:
        raise ScenarioError(f"prediction model step {model.dt} s differs from the MPC dt {config.dt} s")
    return _make(model, condense(model, config.blocks), config)


def dual_shift_index(L: MpcLayout) -> np.ndarray:
    """Warm start of the row multipliers one sample on: the indices into the previous
    ``y`` (speed/hard rows of node k from node k + 1, the last repeated; the constraint
    nodes' rows from the old node nearest to k_i + 1)."""
    nodes = np.asarray(L.nodes)
    src = np.array([int(np.argmin(np.abs(nodes - min(k + 1, L.N)))) for k in nodes])
    rs, rn = _N_STEP_ROWS, _N_NODE_ROWS
    idx = [min(k + 1, L.N - 1) * rs + r for k in range(L.N) for r in range(rs)]
    idx += [L.N * rs + src[i] * rn + r for i in range(len(nodes)) for r in range(rn)]
    idx += [L.n_c + j * len(nodes) + src[i] for j in range(L.M) for i in range(len(nodes))]
    return np.array(idx, int)


def input_shift_matrix(cond: Condensed) -> np.ndarray:
    """``S`` with ``S u`` = :meth:`PathMPC.shift` ``(u)`` (the map is linear)."""
    n = cond.n_u
    eye = np.eye(n)
    return np.column_stack([cond.block(np.vstack([cond.inputs(eye[:, i])[1:],
                                                  cond.inputs(eye[:, i])[-1:]]))
                            for i in range(n)])


def _make(model: LoopModel, cond: Condensed, config: MpcConfig
          ) -> tuple[ca.Function, MpcLayout, dict[str, Any]]:
    """``ballbot_mpc``, its layout and the numbers :class:`PathMPC` needs (A_c, G, scales)."""
    L = MpcLayout(config.N, config.n_obstacles, cond.n_u, tuple(config.nodes))
    Q = _qp(model, cond, config, L)
    x0, p = Q["x0"], Q["p"]
    # cost scale: the Hessian's mean diagonal at a nominal window (tangent +x) -> 1
    nominal = L.pack(v_prev=np.zeros(2), path_p=np.zeros((L.N + 1, 2)),
                     path_t=np.tile([1.0, 0.0], (L.N + 1, 1)), s_bar=np.zeros(L.N + 1),
                     v_s=np.zeros(L.N + 1), w_lat=np.ones(L.N + 1),
                     obs_n=np.zeros((L.M, L.N + 1, 2)), obs_b=np.zeros((L.M, L.N + 1)),
                     s_max=[1.0])
    Yq = Q["Yq"]
    Hq_nom = np.array(ca.Function("Hq", [p], [ca.densify(Q["Hq"])])(nominal))
    scale = float(np.mean(np.diag(Yq.T @ Hq_nom @ Yq)))
    Nm = Q["N"]
    nobs = ca.vertcat(*Nm.nonzeros()) if Nm.nnz() else ca.SX(0, 1)
    # the Hessian's parametric part acts on a few cost quantities S (the positions and
    # progress at the nodes): K = C0 + Yq[S]' H_S Yq[S] with the constant C0 = sigma I +
    # rho A_c'A_c + (constant Hessian part) and H_S = the Hessian's S block + rho N'N on the
    # node positions (the obstacle rows' A'A = G'N'NG)
    Hq = Q["Hq"]
    hr, hc = Hq.sparsity().get_triplet()
    par = [bool(ca.depends_on(e, ca.vertcat(x0, p))) for e in Hq.nonzeros()]
    S = sorted({r for r, d in zip(hr, par) if d} | {c for c, d in zip(hc, par) if d}
               | set(Q["i_pos"]))
    Hc = Hq_nom.copy()
    Hc[np.ix_(S, S)] = 0.0
    E = ca.DM(ca.Sparsity.triplet(len(Q["i_pos"]), len(S), list(range(len(Q["i_pos"]))),
                                  [S.index(i) for i in Q["i_pos"]]), 1.0)
    HS = Hq[S, S] / scale + config.rho * ca.mtimes(E.T, ca.mtimes(ca.mtimes(Nm.T, Nm), E))
    # the parametric data as scalar code (small), split in two Functions (each one's
    # scalar work is smaller than both together's)
    # (the whole scaled Hessian H only for a conic solver, which takes P = Yq' H Yq)
    H_out = [Hq / scale] if config.solver != "admm" else []
    setup_cost = ca.Function("ballbot_mpc_setup_cost", [x0, p], [HS, Q["gq"] / scale, *H_out],
                             ["x0", "p"], ["H_S", "g", "H"][:2 + len(H_out)])
    setup_rows = ca.Function("ballbot_mpc_setup_rows", [x0, p], [Q["l"], Q["u"], nobs],
                             ["x0", "p"], ["l", "u", "nobs"])
    n, m = L.n_u, L.n_rows
    X0 = ca.MX.sym("x0", NX_MPC)
    Pm = ca.MX.sym("p", L.n_p)
    u0, z0, y0 = ca.MX.sym("u0", n), ca.MX.sym("z0", m), ca.MX.sym("y0", m)
    HSh, gh, *Hh = setup_cost(X0, Pm)
    lh, hh, nh = setup_rows(X0, Pm)
    # q = Yq' g, a called Function (its constant in the callees' shared workspace)
    g_s = ca.MX.sym("g", Yq.shape[0])
    grad = ca.Function("ballbot_mpc_grad", [g_s], [ca.mtimes(g_s.T, ca.MX(ca.sparsify(ca.DM(Yq)))).T],
                       ["g"], ["q"])
    qh = grad(gh)
    if config.solver == "admm":
        # K = C0 + Yq[S]' H_S Yq[S], accumulated in one dense n x n vector
        C0 = kkt_constant((Q["D"], Q["Y"]), config.rho, config.sigma) + Yq.T @ Hc @ Yq / scale
        YS = ca.sparsify(ca.DM(Yq[S]))
        H_s = ca.MX.sym("H_S", HS.sparsity())
        kkt = ca.Function("ballbot_mpc_kkt", [H_s],
                          [ca.mac(ca.MX(YS.T), ca.mtimes(H_s, ca.MX(YS)), ca.MX(ca.DM(C0)))],
                          ["H_S"], ["K"])
        K = kkt(HSh)
        uo, zo, yo, rp = admm_iterate((Q["D"], Q["Y"]), Q["G"], Nm.sparsity(), Q["penalty"],
                                      config.rho, config.sigma, config.alpha, config.iterations,
                                      K, qh, lh, hh, nh, u0, z0, y0)
    else:
        Yqm = ca.MX(ca.sparsify(ca.DM(Yq)))
        Ph = ca.densify(ca.mtimes(ca.MX(ca.sparsify(ca.DM(Yq.T))), ca.mtimes(Hh[0], Yqm)))
        uo, zo, yo = _conic(Q, Nm.sparsity(), config, Ph, qh, lh, hh, nh, u0, y0)
        rp = ca.MX(0)
    # T[0] selects the first block's v_ref from u (an index, not a product with a constant)
    v_ref = uo[[int(np.argmax(row)) for row in cond.T[0][0:2]]]
    f = ca.Function("ballbot_mpc", [X0, Pm, u0, z0, y0], [v_ref, uo, zo, yo, rp],
                    ["x0", "p", "u0", "z0", "y0"], ["v_ref", "u", "z", "y", "r_prim"])
    cost = ca.Function("ballbot_mpc_cost", [Q["ub"], x0, p], [Q["J"]], ["u", "x0", "p"], ["J"])
    ub = Q["ub"]
    zero = ca.DM.zeros(L.n_u)
    qp_data = ca.Function("ballbot_mpc_qp_data", [x0, p],
                          [ca.densify(ca.hessian(Q["J"], ub)[0]) / scale,
                           ca.substitute(ca.gradient(Q["J"], ub), ub, zero) / scale,
                           Q["l"], Q["u"], nobs], ["x0", "p"], ["P", "q", "l", "u", "nobs"])
    return f, L, {"A_c": Q["A_c"], "G": Q["G"], "scale": scale, "cond": cond, "cost": cost,
                  "qp_data": qp_data, "N_sp": Nm.sparsity(), "penalty": Q["penalty"]}


def _conic(Q: dict, N_sp: ca.Sparsity, config: MpcConfig, Ph: ca.MX, qh: ca.MX, lh: ca.MX,
           hh: ca.MX, nh: ca.MX, u0: ca.MX, y0: ca.MX) -> tuple[ca.MX, ca.MX, ca.MX]:
    """The same QP through a CasADi ``conic`` plugin, one slack ``e_i >= 0`` per soft row
    (``a_i u - e_i <= u_i``, ``a_i u + e_i >= l_i``, cost ``c_i e_i``): an independent
    formulation of the L1 penalty."""
    n, A_c, G = Q["ub"].numel(), Q["A_c"], Q["G"]
    pen = Q["penalty"]
    soft = np.flatnonzero(np.isfinite(pen))
    ns, m = soft.size, pen.size
    nobs = ca.SX.sym("nobs", N_sp.nnz())
    A = ca.vertcat(ca.DM(A_c), ca.mtimes(ca.SX(N_sp, nobs), ca.DM(G)))
    E = np.zeros((m, ns))
    E[soft, np.arange(ns)] = 1.0
    Afull = ca.vertcat(ca.horzcat(A, -ca.DM(E)), ca.horzcat(A[soft.tolist(), :], ca.DM(E[soft])))
    Afun = ca.Function("A", [nobs], [Afull])
    H = ca.diagcat(ca.MX(Ph), ca.MX(ns, ns))
    g = ca.vertcat(qh, ca.DM(pen[soft]))
    inf = ca.DM.inf(ns)
    hard = np.flatnonzero(~np.isfinite(pen))
    lba1 = ca.MX(ca.DM.inf(m) * -1.0)
    lba1[hard.tolist()] = lh[hard.tolist()]
    lba = ca.vertcat(lba1, lh[soft.tolist()])
    uba = ca.vertcat(hh, inf)
    opts = {"error_on_fail": False}
    if config.solver == "qrqp":
        opts.update({"print_iter": False, "print_header": False, "print_info": False,
                     "max_iter": 1000})
    opts.update(config.solver_options)
    Hs = ca.Sparsity.dense(n + ns, n + ns)
    qp = ca.conic("ballbot_mpc_qp", config.solver, {"h": Hs, "a": Afull.sparsity()}, opts)
    lbx = ca.vertcat(-ca.DM.inf(n), ca.DM.zeros(ns))
    sol = qp(h=ca.densify(H), g=g, a=Afun(nh), lba=lba, uba=uba, lbx=lbx, ubx=ca.DM.inf(n + ns),
             x0=ca.vertcat(u0, ca.DM.zeros(ns)))
    uo = sol["x"][:n]
    lam = sol["lam_a"]
    y = lam[:m] + ca.mtimes(ca.DM(E), lam[m:])
    A_u = ca.Function("Au", [nobs], [A])(nh)
    return uo, ca.mtimes(A_u, uo), y


def workspace_bytes(f: ca.Function) -> int:
    """Static memory of a generated Function's call: real and integer work, argument pointers.

    ``sz_w`` doubles, ``sz_iw`` integers (``long long``, the package's ``casadi_int``) and
    ``sz_arg + sz_res`` pointers: what a caller allocates once (statically) for the solve.
    """
    return 8 * (f.sz_w() + f.sz_iw() + f.sz_arg() + f.sz_res())


def mpc_library(f: ca.Function, root: Any = None) -> tuple[Library, ca.Function]:
    """Generate ``f`` (``ballbot_mpc``) to C99, compile it (strict flags, cached by hash), load it."""
    lib = build_library("ballbot_mpc", [f], root)
    return lib, load_library(lib, [f.name()])[f.name()]


def path_window(path: Path, config: MpcConfig, s_bar: np.ndarray, pos: np.ndarray
                ) -> dict[str, np.ndarray]:
    """The path-dependent parameters at a guessed trajectory (progress ``s_bar`` and
    positions ``pos`` at the nodes 0..N): ``path_p``, ``path_t`` (window), ``s_bar``,
    ``v_s`` (progress-speed reference), ``w_lat`` (lateral weight, relaxed near an
    obstacle), ``obs_n``, ``obs_b`` (the obstacle half-planes, module docstring) and
    ``s_max`` (end of an open path)."""
    N, M = config.N, config.n_obstacles
    pp, pt = path.window(s_bar)
    obs_n = np.zeros((M, N + 1, 2))
    obs_b = -1.0 * np.ones((M, N + 1))
    w_lat = np.ones(N + 1)
    lat = np.column_stack([-pt[:, 1], pt[:, 0]])
    for j, ob in enumerate(path.obstacles):
        c = np.asarray(ob.center)
        r_safe = ob.radius + config.clearance
        # pass on the side of the path away from the centre (left if on the path);
        # where the guessed position is beside the circle (|along| < r_safe, along the
        # path tangent), keep it at least sqrt(r_safe^2 - along^2) to that side of the
        # centre: a half-plane parallel to the path, so it bounds the lateral offset
        # and never blocks the progress (the circle's boundary at that abscissa)
        side = -np.sign(np.sum(lat * (c - pp), axis=1))
        side[side == 0] = 1.0
        along = np.sum(pt * (pos - c), axis=1)
        beside = np.abs(along) < r_safe
        n = lat * side[:, None]
        obs_n[j, beside] = n[beside]
        obs_b[j, beside] = (np.sum(n * c, axis=1)
                            + np.sqrt(np.maximum(r_safe**2 - along**2, 0.0)))[beside]
        # relax the lateral weight where the path point is near the obstacle
        near = np.linalg.norm(pp - c, axis=1) < r_safe + 0.3
        w_lat[near] = np.minimum(w_lat[near], config.obstacle_relax)
    s_max = np.inf if path.closed else path.length
    return {"path_p": pp, "path_t": pt, "s_bar": np.asarray(s_bar, float),
            "v_s": path.reference_speed(s_bar), "w_lat": w_lat, "obs_n": obs_n, "obs_b": obs_b,
            "s_max": np.array([min(s_max, 1e9)])}


class PathMPC:
    """The MPC with its warm start: parameters from a :class:`Path`, shift, one QP per call.

    ``function`` may be replaced by a compiled copy (same signature, e.g. loaded from
    the generated C library); :meth:`step` only calls it.
    """

    #: a solution whose primal residual ``||A u - z||_inf`` exceeds this (rows are
    #: normalised by their bounds: 5 % of a limit) counts as a failed QP
    residual_tol = 0.05

    def __init__(self, model: LoopModel, path: Path, config: MpcConfig = MpcConfig()) -> None:
        if len(path.obstacles) > config.n_obstacles:
            raise ScenarioError(f"obstacles: at most {config.n_obstacles} allowed by this MPC, "
                                f"got {len(path.obstacles)}")
        if abs(model.dt - config.dt) > 1e-12:
            raise ScenarioError(f"prediction model step {model.dt} s differs from the MPC dt "
                                f"{config.dt} s")
        self.config, self.path, self.model = config, path, model
        self.function, self.layout, info = _make(model, condense(model, config.blocks), config)
        self.cond: Condensed = info["cond"]
        self._A_c, self._G = info["A_c"], info["G"]
        #: ``ballbot_mpc_cost(u, x0, p) -> J``: the QP's objective (up to a constant)
        self.cost = info["cost"]
        L = self.layout
        self.u = np.zeros(L.n_u)
        self.z = np.zeros(L.n_rows)
        self.y = np.zeros(L.n_rows)
        self.x0: np.ndarray | None = None
        self.v_prev = np.zeros(2)
        self.last: dict[str, Any] = {}
        #: samples whose QP failed: non-finite result (the shifted previous plan is kept)
        #: or a primal residual above :attr:`residual_tol`
        self.failures = 0
        #: wall-clock seconds of each call of ``function`` (the QP solve; for benchmarks)
        self.solve_s: list[float] = []
        #: CPU seconds of the calling thread in each call (excludes preemption by other
        #: processes on a loaded machine; for benchmarks)
        self.solve_cpu_s: list[float] = []
        #: primal residual of each solve
        self.residuals: list[float] = []
        # warm start of the multipliers: new node i takes the old node nearest to k_i + 1
        self._y_shift = dual_shift_index(L)

    def shift(self, u: np.ndarray) -> np.ndarray:
        """Warm start: the blocked inputs moved one step ahead, the last step repeated."""
        steps = self.cond.inputs(u)
        return self.cond.block(np.vstack([steps[1:], steps[-1:]]))

    def parameters(self, x0: np.ndarray, u_guess: np.ndarray) -> np.ndarray:
        """Parameter vector from the guessed trajectory: path window, speeds, obstacle normals."""
        X = self.cond.states(x0, u_guess)
        w = path_window(self.path, self.config, X[:, NXL], X[:, 12:14])
        return self.layout.pack(v_prev=self.v_prev, **w)

    def rows(self, u: np.ndarray, p: np.ndarray) -> np.ndarray:
        """``A u`` of the QP with parameters ``p`` (the ADMM's ``z`` of a warm start)."""
        L, so = self.layout, self.config.obstacle_scale
        P = L.unpack(p)
        n = P["obs_n"].reshape(L.M, L.N + 1, 2)[:, list(L.nodes)]
        pos = (self._G @ u).reshape(len(L.nodes), 2)
        return np.concatenate([self._A_c @ u, (so * np.sum(n * pos[None], axis=2)).ravel()])

    def step(self, x_loop: np.ndarray, s: float | None = None) -> np.ndarray:
        """One real-time iteration from the loop-model state ``x_loop`` (14); returns ``v_ref``.

        The progress state continues from the previous prediction (``s`` only seeds the
        first call, default: the projection of the position onto the path).
        """
        x_loop = np.asarray(x_loop, float).reshape(NXL)
        first = self.x0 is None
        if first:
            s0 = self.path.project(x_loop[12:14]) if s is None else float(s)
            x0 = np.concatenate([x_loop, [s0, 0.0]])
            guess = np.zeros(self.layout.n_u)
            y0 = np.zeros(self.layout.n_rows)
        else:
            x1 = self.cond.states(self.x0, self.u)[1]
            x0 = np.concatenate([x_loop, x1[NXL:]])
            # ds >= 0 holds to the ADMM's residual: clip, so that s never decreases
            x0[NXL] = max(x0[NXL], self.x0[NXL])
            x0[NXL + 1] = max(x0[NXL + 1], 0.0)
            guess = self.shift(self.u)
            y0 = self.y[self._y_shift]
        # the first sample re-linearises the path a few times (RTI starts cold)
        for _ in range(FIRST_SAMPLE_QPS if first else 1):
            p = self.parameters(x0, guess)
            z0 = self.rows(guess, p)
            t0, c0 = time.perf_counter(), time.thread_time()
            out = self.function(x0, p, guess, z0, y0)
            self.solve_s.append(time.perf_counter() - t0)
            self.solve_cpu_s.append(time.thread_time() - c0)
            u = np.asarray(out[1], float).ravel()
            ok = bool(np.all(np.isfinite(u)))
            if ok:
                guess, y0 = u, np.asarray(out[3], float).ravel()
        r_prim = float(out[4])
        self.residuals.append(r_prim)
        if not ok or not r_prim <= self.residual_tol:
            self.failures += 1
        if ok:
            self.u, self.z, self.y = u, np.asarray(out[2], float).ravel(), y0
        else:  # keep the shifted plan, cold multipliers
            self.u, self.z, self.y = guess, z0, np.zeros(self.layout.n_rows)
        self.x0 = x0
        v = self.cond.inputs(self.u)[0, 0:2].copy()
        self.v_prev = v
        self.last = {"x0": x0, "p": p, "u0": guess, "r_prim": r_prim}
        return v

    def prediction(self) -> np.ndarray:
        """Predicted positions (N+1, 2) of the last solution."""
        return self.cond.states(self.x0, self.u)[:, 12:14]

    def progress(self) -> float:
        """Progress ``s`` at the current sample of the last solution."""
        return float(self.x0[NXL])

"""Path-following MPC above the velocity LQR: real-time iteration, one QP per sample.

``ballbot_mpc(x0, p, w0, lam_x0, lam_a0) -> (v_ref, w, lam_x, lam_a, cost)``

Decision
--------
The MPC gives *velocity references* ``v_ref = (vx, vy)`` (heading rate 0) to the
existing velocity LQR (:mod:`ballbot_casadi.control.velocity`), and predicts with the
linear model of that closed loop (:mod:`ballbot_casadi.guidance.prediction`): the loop's
tilt, tilt rate and tilt-reference acceleration are states/outputs of the model, so the
§7.1 limits are linear constraints, and the balance and velocity loops below stay exactly
as validated.

Problem (multiple shooting, ``N`` steps of ``dt``; default N = 20, dt = 0.1 s: 2 s)
-------------------------------------------------------------------------------
State ``x = [loop state (14), s, ds]`` with the progress ``s`` along the path, input
``u = [v_ref (2), dds]``; ``s`` is a double integrator of ``dds``, ``ds >= 0`` (progress
never decreases) and ``s <= s_max`` (end of an open path).  Least squares on

* lateral and longitudinal errors ``e = p - P(s)`` in the path frame, with the path
  linearised at the guessed progress ``s_k`` (the path window of parameters:
  ``P(s) ~ P_k + T_k (s - s_k)``, i.e. one Gauss-Newton step of the nonlinear problem);
* the progress-speed error ``ds - v_s(s_k)`` (so the robot slows where the limits need it,
  instead of cutting the corner), ``dds`` and the change of ``v_ref``;
* a quadratic penalty (``slack_l2``) on the free slacks of the soft rows.

Constraints at every node (inner polygons of the norm balls, so each norm bound holds):
inclination ``|theta| <= tilt_max``, inclination rate ``<= tilt_rate_max`` (thesis §7.1;
the acceleration ``a_max`` is *not* a row: as an octagon or a square its rows made qrqp
cycle, nearly dependent on the tilt and tilt-acceleration rows), tilt-reference
acceleration ``|a| <= tilt_acc_max`` per axis (the
torque budget of the balance loop, the velocity LQR's limit), all scaled by
``margin``; a soft speed limit ``|v| <= v_max`` and soft circular obstacle constraints
``n_jk . (p_k - c_j) >= r_j + clearance`` linearised at the guessed positions (normals
``n_jk`` are parameters), with slacks.  The heading rate reference is 0 (within its limit).

Real-time iteration: the QP is solved once per sample, warm-started with the previous
solution shifted by one step (primal and dual, :meth:`PathMPC.shift`), whose predicted
progress and positions also give the path window and the obstacle normals.

A sample whose QP does not converge within ``max_iter`` (the generated solver then
returns an error) keeps the shifted previous plan, with cold duals
(:attr:`PathMPC.failures` counts them).

QP solver: ``qrqp`` (CasADi's sparse active-set QP, code-generated into plain C with a
static work vector; no malloc in the solve).
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
from ballbot_casadi.guidance.paths import Path
from ballbot_casadi.guidance.prediction import NXL, LoopModel

__all__ = ["MpcConfig", "MpcLayout", "PathMPC", "make_mpc", "mpc_library", "workspace_bytes",
           "NX_MPC", "NU_MPC", "polygon"]

#: MPC state: loop model (14), progress s and its rate.
NX_MPC = NXL + 2
#: MPC input: velocity reference (2), progress acceleration.
NU_MPC = 3
_NS_LIMITS = 14  # soft rows per node: tilt acc 2, tilt/tilt rate/speed octagons 4 each


@dataclass(frozen=True)
class MpcConfig:
    """Horizon, weights and limits of the MPC (defaults: N = 20, dt = 0.1 s, thesis §7.1)."""

    N: int = 20
    dt: float = 0.1
    n_obstacles: int = 5
    w_lat: float = 400.0
    w_lon: float = 100.0
    w_speed: float = 20.0
    w_dds: float = 1.0
    w_dv: float = 20.0
    w_terminal: float = 2.0
    slack_l2: float = 1e5
    clearance: float = 0.15
    margin: float = 0.9
    tilt_acc_max: float = 2.0
    limits: dict = field(default_factory=lambda: dict(THESIS_LIMITS))
    warm_dual: bool = False
    solver: str = "qrqp"
    solver_options: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not (isinstance(self.N, int) and self.N >= 2):
            raise ScenarioError(f"N must be an int >= 2, got {self.N!r}")
        if not (math.isfinite(self.dt) and self.dt > 0):
            raise ScenarioError(f"dt must be > 0 s, got {self.dt!r}")
        if not (0 < self.margin <= 1):
            raise ScenarioError(f"margin must be in (0, 1], got {self.margin!r}")


def polygon(n: int) -> tuple[np.ndarray, float]:
    """Directions (n/2 rows for two-sided use) and apothem factor of the inner regular n-gon."""
    ang = np.pi * np.arange(n // 2) / (n // 2)
    return np.column_stack([np.cos(ang), np.sin(ang)]), math.cos(math.pi / n)


@dataclass(frozen=True)
class MpcLayout:
    """Index layout of the decision vector ``w`` and the parameter vector ``p``."""

    N: int
    M: int

    @property
    def n_w(self) -> int:
        return (self.N + 1) * NX_MPC + self.N * NU_MPC + self.N * self.n_slack

    def x(self, k: int) -> slice:
        o = k * (NX_MPC + NU_MPC)
        return slice(o, o + NX_MPC)

    def u(self, k: int) -> slice:
        o = k * (NX_MPC + NU_MPC) + NX_MPC
        return slice(o, o + NU_MPC)

    def slack(self, k: int) -> slice:
        """Slacks of node k = 1..N."""
        o = (self.N + 1) * NX_MPC + self.N * NU_MPC + (k - 1) * self.n_slack
        return slice(o, o + self.n_slack)

    @property
    def n_slack(self) -> int:
        """Slacks per node: one per soft row (limits, then obstacles)."""
        return _NS_LIMITS + self.M

    @property
    def params(self) -> dict[str, tuple[int, ...]]:
        """Parameter blocks in order with their shapes (row-major)."""
        n1 = self.N + 1
        return {"v_prev": (2,), "path_p": (n1, 2), "path_t": (n1, 2), "s_bar": (n1,),
                "v_s": (n1,), "obs_n": (self.M, n1, 2), "obs_b": (self.M, n1), "s_max": (1,)}

    @property
    def n_p(self) -> int:
        return sum(int(np.prod(s)) for s in self.params.values())

    def pack(self, **blocks: Any) -> np.ndarray:
        out = []
        for name, shape in self.params.items():
            arr = np.asarray(blocks[name], float)
            if arr.shape != shape:
                raise ShapeError(f"MPC parameter {name} must have shape {shape}, got {arr.shape}")
            out.append(arr.reshape(-1))
        return np.concatenate(out)

    def unpack_sym(self, p: ca.SX) -> dict[str, Any]:
        out, o = {}, 0
        for name, shape in self.params.items():
            n = int(np.prod(shape))
            out[name] = p[o:o + n]
            o += n
        return out


def _sparse(M: np.ndarray, rtol: float = 1e-12) -> ca.DM:
    """``M`` with entries below ``rtol * max|M|`` dropped (rounding noise of the matrix
    exponential, e.g. the x-y cross terms of the decoupled loop): a sparser QP, smaller
    KKT factors, a smaller solver workspace."""
    M = np.asarray(M, float)
    scale = float(np.abs(M).max()) if M.size else 0.0
    return ca.sparsify(ca.DM(M), rtol * scale) if scale > 0 else ca.DM(M.shape[0], M.shape[1])


def make_mpc(model: LoopModel, config: MpcConfig = MpcConfig()) -> tuple[ca.Function, MpcLayout]:
    """Build ``ballbot_mpc`` (see the module docstring) and the layout of its vectors."""
    if abs(model.dt - config.dt) > 1e-12:
        raise ScenarioError(f"prediction model step {model.dt} s differs from the MPC dt {config.dt} s")
    N, M, dt = config.N, config.n_obstacles, config.dt
    L = MpcLayout(N, M)
    lim = config.limits
    x0 = ca.SX.sym("x0", NX_MPC)
    p = ca.SX.sym("p", L.n_p)
    w = ca.SX.sym("w", L.n_w)
    P = L.unpack_sym(p)
    A, B = _sparse(model.A), _sparse(model.B)
    Cs = {k: _sparse(v) for k, v in model.C.items()}
    Ds = {k: _sparse(v) for k, v in model.D.items()}
    dirs, f8 = polygon(8)
    D8 = ca.DM(dirs)
    J = 0
    g, lbg, ubg = [], [], []

    def row(expr: Any, lo: Any, hi: Any) -> None:
        g.append(expr)
        lbg.append(lo)
        ubg.append(hi)

    def soft(y: Any, bound: float, sl: Any) -> None:
        """``|d_i . y| <= bound`` on the inner octagon, normalised, one free slack per row."""
        row(ca.mtimes(D8, y) / (bound * f8) - sl, -ca.DM.ones(4), ca.DM.ones(4))

    v_before = P["v_prev"]
    for k in range(N):
        xk, uk, xn = w[L.x(k)], w[L.u(k)], w[L.x(k + 1)]
        vr = uk[0:2]
        xl, s, ds = xk[:NXL], xk[NXL], xk[NXL + 1]
        dds = uk[2]
        pred = ca.vertcat(ca.mtimes(A, xl) + ca.mtimes(B, vr), s + dt * ds + 0.5 * dt**2 * dds,
                          ds + dt * dds)
        row(xn - pred, ca.DM.zeros(NX_MPC), ca.DM.zeros(NX_MPC))
        J += config.w_dv * ca.sumsqr(vr - v_before) + config.w_dds * dds**2
        v_before = vr
        # node k + 1
        k1 = k + 1
        xl1, s1, ds1 = xn[:NXL], xn[NXL], xn[NXL + 1]
        pos = xl1[12:14]
        pk, tk = P["path_p"][2 * k1:2 * k1 + 2], P["path_t"][2 * k1:2 * k1 + 2]
        nk = ca.vertcat(-tk[1], tk[0])
        e = pos - pk - tk * (s1 - P["s_bar"][k1])
        wt = config.w_terminal if k1 == N else 1.0
        J += wt * (config.w_lat * ca.dot(nk, e) ** 2 + config.w_lon * ca.dot(tk, e) ** 2)
        J += config.w_speed * (ds1 - P["v_s"][k1]) ** 2
        sl = w[L.slack(k1)]
        J += config.slack_l2 * ca.sumsqr(sl)
        m = config.margin
        ta = ca.mtimes(Cs["tilt_acc"], xl) + ca.mtimes(Ds["tilt_acc"], vr)
        b = config.tilt_acc_max * m
        row(ta / b - sl[0:2], -ca.DM.ones(2), ca.DM.ones(2))
        soft(ca.mtimes(Cs["tilt"], xl1), lim["tilt_max"] * m, sl[2:6])
        soft(ca.mtimes(Cs["tilt_rate"], xl1), lim["tilt_rate_max"] * m, sl[6:10])
        # no acceleration rows (a_max): as an octagon or a square they made qrqp cycle
        # between the bounds of one row (nearly dependent on the tilt and tilt-acceleration
        # rows) on most samples in curves; measured instead (see the report)
        soft(ca.mtimes(Cs["v"], xl1), lim["v_max"] * m, sl[10:14])
        for j in range(M):
            o = (j * (N + 1) + k1) * 2
            n_ob = P["obs_n"][o:o + 2]
            row(ca.dot(n_ob, pos) + sl[_NS_LIMITS + j], P["obs_b"][j * (N + 1) + k1], ca.inf)
    g_all = ca.vertcat(*g)
    lbg_all, ubg_all = ca.vertcat(*lbg), ca.vertcat(*ubg)
    # variable bounds: x_0 fixed, ds >= 0, s <= s_max; slacks free (quadratic penalty)
    lbx = -ca.inf * ca.DM.ones(L.n_w)
    ubx = ca.inf * ca.DM.ones(L.n_w)
    lbx, ubx = ca.SX(lbx), ca.SX(ubx)
    lbx[L.x(0)] = x0
    ubx[L.x(0)] = x0
    for k in range(1, N + 1):
        lbx[L.x(k).start + NXL + 1] = 0.0
        ubx[L.x(k).start + NXL] = P["s_max"]
    H = ca.hessian(J, w)[0]
    grad = ca.substitute(ca.gradient(J, w), w, ca.DM.zeros(L.n_w))
    Amat = ca.jacobian(g_all, w)
    g0 = ca.substitute(g_all, w, ca.DM.zeros(L.n_w))
    H = ca.substitute(H, w, ca.DM.zeros(L.n_w))
    Amat = ca.substitute(Amat, w, ca.DM.zeros(L.n_w))
    opts = {"error_on_fail": False}
    if config.solver == "qrqp":
        opts.update({"print_iter": False, "print_header": False, "print_info": False,
                     "max_iter": 200})
    opts.update(config.solver_options)
    qp = ca.conic("ballbot_mpc_qp", config.solver, {"h": H.sparsity(), "a": Amat.sparsity()}, opts)
    w0 = ca.SX.sym("w0", L.n_w)
    lam_x0 = ca.SX.sym("lam_x0", L.n_w)
    lam_a0 = ca.SX.sym("lam_a0", g_all.numel())
    # lower bounds -inf stay -inf after the shift by g0 (g0 is finite)
    sol = qp(h=H, g=grad, a=Amat, lba=lbg_all - g0, uba=ubg_all - g0, lbx=lbx, ubx=ubx,
             x0=w0, lam_x0=lam_x0, lam_a0=lam_a0)
    wopt = sol["x"]
    v_ref = wopt[L.u(0)][0:2]
    f = ca.Function("ballbot_mpc", [x0, p, w0, lam_x0, lam_a0],
                    [v_ref, wopt, sol["lam_x"], sol["lam_a"], sol["cost"]],
                    ["x0", "p", "w0", "lam_x0", "lam_a0"],
                    ["v_ref", "w", "lam_x", "lam_a", "cost"])
    return f, L


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


class PathMPC:
    """The MPC with its warm start: parameters from a :class:`Path`, shift, one QP per call.

    ``function`` may be replaced by a compiled copy (same signature, e.g. loaded from
    the generated C library); :meth:`step` only calls it.
    """

    def __init__(self, model: LoopModel, path: Path, config: MpcConfig = MpcConfig()) -> None:
        if len(path.obstacles) > config.n_obstacles:
            raise ScenarioError(f"obstacles: at most {config.n_obstacles} allowed by this MPC, "
                                f"got {len(path.obstacles)}")
        self.config, self.path, self.model = config, path, model
        self.function, self.layout = make_mpc(model, config)
        self.n_g = self.function.size1_in(4)
        self.w: np.ndarray | None = None
        self.lam_x = np.zeros(self.layout.n_w)
        self.lam_a = np.zeros(self.n_g)
        self.v_prev = np.zeros(2)
        self.last: dict[str, np.ndarray] = {}
        #: samples whose QP failed (the generated solver returns an error at ``max_iter``);
        #: the robot then follows the shifted previous plan (its first input)
        self.failures = 0
        #: wall-clock seconds of each call of ``function`` (the QP solve; for benchmarks)
        self.solve_s: list[float] = []

    def _guess(self, x_loop: np.ndarray, s: float, ds: float) -> np.ndarray:
        """Initial guess when there is no previous solution: progress at the reference speed."""
        L, N, dt = self.layout, self.config.N, self.config.dt
        w = np.zeros(L.n_w)
        for k in range(N + 1):
            xk = np.zeros(NX_MPC)
            xk[:NXL] = x_loop
            xk[NXL] = s + k * dt * max(ds, 0.0)
            xk[NXL + 1] = max(ds, 0.0)
            w[L.x(k)] = xk
        return w

    def shift(self, w: np.ndarray) -> np.ndarray:
        """Warm start: the solution moved one step ahead, its last step repeated."""
        L, N = self.layout, self.config.N
        out = self._shift_stages(w)
        xl = w[L.x(N)]
        xn = xl.copy()
        xn[:NXL] = self.model.A @ xl[:NXL] + self.model.B @ w[L.u(N - 1)][:2]
        xn[NXL] = xl[NXL] + self.config.dt * xl[NXL + 1]
        out[L.x(N)] = xn
        return out

    def parameters(self, w_guess: np.ndarray) -> np.ndarray:
        """Parameter vector from the guessed trajectory: path window, speeds, obstacle normals."""
        L, N, M = self.layout, self.config.N, self.config.n_obstacles
        s_bar = np.array([w_guess[L.x(k)][NXL] for k in range(N + 1)])
        pos = np.array([w_guess[L.x(k)][12:14] for k in range(N + 1)])
        pp, pt = self.path.window(s_bar)
        obs_n = np.zeros((M, N + 1, 2))
        obs_b = -1.0 * np.ones((M, N + 1))
        lat = np.column_stack([-pt[:, 1], pt[:, 0]])
        for j, ob in enumerate(self.path.obstacles):
            c = np.asarray(ob.center)
            d = pos - c
            # pass on the side of the path away from the centre: the guessed point is moved
            # sideways to at least the inflated radius, so a head-on guess gives a tilted
            # half-plane (a funnel around the circle) instead of a wall across the path
            side = -np.sign(np.sum(lat * (c - pp), axis=1))
            side[side == 0] = 1.0
            along = np.sum(pt * d, axis=1)
            off = np.maximum(side * np.sum(lat * d, axis=1), ob.radius + self.config.clearance)
            d = pt * along[:, None] + lat * (side * off)[:, None]
            n = d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-9)
            obs_n[j] = n
            obs_b[j] = ob.radius + self.config.clearance + n @ c
        s_max = np.inf if self.path.closed else self.path.length
        return L.pack(v_prev=self.v_prev, path_p=pp, path_t=pt, s_bar=s_bar,
                      v_s=self.path.reference_speed(s_bar), obs_n=obs_n, obs_b=obs_b,
                      s_max=[min(s_max, 1e9)])

    def step(self, x_loop: np.ndarray, s: float | None = None) -> np.ndarray:
        """One real-time iteration from the loop-model state ``x_loop`` (14); returns ``v_ref``.

        The progress state continues from the previous prediction (``s`` only seeds the
        first call, default: the projection of the position onto the path).
        """
        x_loop = np.asarray(x_loop, float).reshape(NXL)
        L = self.layout
        if self.w is None:
            s0 = self.path.project(x_loop[12:14]) if s is None else float(s)
            guess = self._guess(x_loop, s0, 0.0)
        else:
            guess = self.shift(self.w)
            self.lam_x = self._shift_stages(self.lam_x)
            rows = self.n_g // self.config.N  # every stage adds the same constraint rows
            self.lam_a = np.concatenate([self.lam_a[rows:], self.lam_a[-rows:]])
            if not self.config.warm_dual:
                self.lam_x[:], self.lam_a[:] = 0.0, 0.0
        x0 = guess[L.x(0)].copy()
        x0[:NXL] = x_loop
        guess[L.x(0)] = x0
        p = self.parameters(guess)
        t0 = time.perf_counter()
        try:
            v_ref, w, lam_x, lam_a, cost = self.function(x0, p, guess, self.lam_x, self.lam_a)
        except RuntimeError:
            # failed QP (compiled solver at max_iter): keep the shifted plan, cold duals
            self.failures += 1
            v_ref, w, cost = guess[L.u(0)][:2], guess, math.nan
            lam_x, lam_a = np.zeros(L.n_w), np.zeros(self.n_g)
        self.solve_s.append(time.perf_counter() - t0)
        self.w = np.asarray(w, float).reshape(-1)
        self.lam_x = np.asarray(lam_x, float).reshape(-1)
        self.lam_a = np.asarray(lam_a, float).reshape(-1)
        v = np.asarray(v_ref, float).reshape(2)
        self.v_prev = v
        self.last = {"x0": x0, "p": p, "w0": guess, "cost": float(cost)}
        return v

    def _shift_stages(self, v: np.ndarray) -> np.ndarray:
        """A vector laid out like ``w`` moved one stage ahead, its last stage repeated."""
        L, N = self.layout, self.config.N
        out = v.copy()
        for k in range(N):
            out[L.x(k)] = v[L.x(k + 1)]
            if k < N - 1:
                out[L.u(k)] = v[L.u(k + 1)]
                out[L.slack(k + 1)] = v[L.slack(k + 2)]
        return out

    def prediction(self) -> np.ndarray:
        """Predicted positions (N+1, 2) of the last solution."""
        L = self.layout
        return np.array([self.w[L.x(k)][12:14] for k in range(self.config.N + 1)])

    def progress(self) -> float:
        """Progress ``s`` at the current sample of the last solution."""
        return float(self.w[self.layout.x(0)][NXL])

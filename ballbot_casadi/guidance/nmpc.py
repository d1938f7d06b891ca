"""Nonlinear path-following MPC: real-time iteration on a nonlinear prediction model (Python).

The same problem as :mod:`ballbot_casadi.guidance.mpc` (velocity references to the
velocity LQR; the same cost, limits, obstacle half-planes, progress variable, move
blocks, constraint nodes and exact L1 penalty of the soft rows), but the prediction is
*nonlinear*: a step ``F(X, v_ref) -> X+`` of the closed loop on the loop coordinates and
its outputs ``y(X, v_ref) = [acc (2), tilt_acc (2)]`` with their Jacobians (e.g. the
velocity loop with the velocity controller's own limits,
:class:`ballbot_casadi.sim.prediction_models.ClippedLoop`).

Real-time iteration (Gauss-Newton, one QP per sample): the model is linearised along
the previous solution shifted by one step (LTV, the gaps of the multiple-shooting
trajectory kept as the constant terms ``c_k``),

``X_{k+1} = A_k X_k + B_k v_k + c_k``,  ``y_k = C_k X_k + D_k v_k + d_k``,

condensed onto the blocked inputs each sample (``X_k = Mx_k ub + rx_k``).  The QP in the
blocked inputs and one slack per soft row (QP size: ``qp_size``) is solved through
:func:`casadi.qpsol` by a CasADi ``conic`` plugin: ``highs`` by default (active set:
exact, and faster here than OSQP, which also stops at its iteration limit on some
samples; the study's report has the times); ``osqp`` (ADMM) is the independent check of
the tests; ``daqp`` and ``qrqp`` are accepted but failed on this QP.

This controller is a Python-only option: the linearisation is a Python callable
(numpy and the CasADi interpreter), the QP solver a plugin library; nothing of it is
generated into the mission's C.  The comparison of issue 18 (``ballbot study
mpc_models``) says whether that would be worth doing.
"""

from __future__ import annotations

import time
from typing import Any, Callable

import casadi as ca
import numpy as np

from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.guidance.condensed import NU_MPC, NX_MPC
from ballbot_casadi.guidance.mpc import FIRST_SAMPLE_QPS, MpcConfig, MpcLayout, path_window, polygon
from ballbot_casadi.guidance.paths import Path
from ballbot_casadi.guidance.prediction import NXL

__all__ = ["NonlinearPathMPC", "NMPC_SOLVERS"]

#: The conic plugins the NMPC's QP may use.
NMPC_SOLVERS = ("osqp", "daqp", "highs", "qrqp")
#: Rows of the linearised outputs y: ball acceleration (2), tilt-reference acceleration (2).
NY = 4


class NonlinearPathMPC:
    """The real-time-iteration NMPC (module docstring) with its warm start.

    Parameters
    ----------
    linearise
        ``(X[14 x N], v_ref[2 x N]) -> (X_next, A, B, y, C, D)``: the model's step and
        outputs with their Jacobians at ``N`` points, blocks side by side (``A`` 14 x 14N,
        ``B`` 14 x 2N, ``y`` 4 x N, ``C`` 4 x 14N, ``D`` 4 x 2N), e.g.
        :class:`ballbot_casadi.sim.prediction_models.ClippedLoop`.
    path, config
        As for :class:`~ballbot_casadi.guidance.mpc.PathMPC` (``config.solver`` is
        ignored: ``solver`` chooses the plugin).
    solver
        One of :data:`NMPC_SOLVERS`.
    """

    def __init__(self, linearise: Callable[..., tuple], path: Path, config: MpcConfig = MpcConfig(),
                 solver: str = "highs", solver_options: dict | None = None) -> None:
        if solver not in NMPC_SOLVERS:
            raise ScenarioError(f"NMPC solver {solver!r} not allowed; allowed: "
                                f"{', '.join(NMPC_SOLVERS)}")
        if len(path.obstacles) > config.n_obstacles:
            raise ScenarioError(f"obstacles: at most {config.n_obstacles} allowed by this MPC, "
                                f"got {len(path.obstacles)}")
        self.linearise, self.path, self.config, self.solver = linearise, path, config, solver
        blocks = tuple(config.blocks)
        self.block_of = np.repeat(np.arange(len(blocks)), blocks)
        self.starts = np.concatenate([[0], np.cumsum(blocks)[:-1]]).astype(int)
        self.n_u = NU_MPC * len(blocks)
        self.layout = MpcLayout(config.N, config.n_obstacles, self.n_u, tuple(config.nodes))
        self.linearise_s: list[float] = []
        self._build(solver_options or {})
        self.ub = np.zeros(self.n_u)
        self.X: np.ndarray | None = None
        self.x0: np.ndarray | None = None
        self.v_prev = np.zeros(2)
        self.failures = 0
        #: wall-clock seconds per sample: the linearisation and the QP
        self.linearise_s: list[float] = []
        self.solve_s: list[float] = []
        #: CPU seconds of the calling thread per QP (less sensitive to a loaded machine)
        self.solve_cpu_s: list[float] = []
        #: the largest slack of each sample's solution (normalised rows: 0.05 = 5 % over)
        self.max_slack: list[float] = []

    # ------------------------------------------------------------------ the QP
    def _build(self, solver_options: dict) -> None:
        c, N, L = self.config, self.config.N, self.layout
        nodes, M = tuple(c.nodes), c.n_obstacles
        lim, mg = c.limits, c.margin
        nx = NX_MPC
        ub = ca.SX.sym("ub", self.n_u)
        # the condensed LTV prediction X_k = Mx_k ub + rx_k (k = 1..N) and the linearised
        # outputs of the step k - 1 at the constraint nodes, as parameters
        lin = {"Mx": ca.SX.sym("Mx", nx * N, self.n_u), "rx": ca.SX.sym("rx", nx * N),
               "x0": ca.SX.sym("x0", nx), "C": ca.SX.sym("C", NY, NXL * N),
               "D": ca.SX.sym("D", NY, 2 * N), "d": ca.SX.sym("d", NY, N)}
        pw = ca.SX.sym("p", L.n_p)
        P = L.unpack(pw)
        X = [lin["x0"]] + [ca.mtimes(lin["Mx"][nx * k:nx * (k + 1), :], ub)
                           + lin["rx"][nx * k:nx * (k + 1)] for k in range(N)]
        U = [ub[NU_MPC * int(b):NU_MPC * (int(b) + 1)] for b in self.block_of]
        res, wts = [], []
        v_before = P["v_prev"]
        for k in range(N):
            uk, xn = U[k], X[k + 1]
            # the cost of guidance/mpc.py, term by term
            res += [uk[0:2] - v_before, uk[2]]
            wts += [ca.DM([c.w_dv] * 2), c.w_dds]
            v_before = uk[0:2]
            k1 = k + 1
            pk, tk = P["path_p"][2 * k1:2 * k1 + 2], P["path_t"][2 * k1:2 * k1 + 2]
            nk = ca.vertcat(-tk[1], tk[0])
            e = xn[12:14] - pk - tk * (xn[NXL] - P["s_bar"][k1])
            wt = c.w_terminal if k1 == N else 1.0
            res += [ca.dot(nk, e), ca.dot(tk, e), xn[NXL + 1] - P["v_s"][k1]]
            wts += [wt * P["w_lat"][k1] * c.w_lat, wt * c.w_lon, c.w_speed]
        r, wv = ca.vertcat(*res), ca.vertcat(*wts)
        J = ca.dot(wv, r ** 2)
        # rows (normalised as in guidance/mpc.py): soft (one slack each) and hard
        dirs, f8 = polygon(8)
        D8 = ca.DM(dirs)

        def octagon(y: Any, bound: float) -> Any:
            return ca.mtimes(D8, y) / (bound * f8)

        soft, hard_lo, hard_hi, hard = [], [], [], []
        for k in range(1, N + 1):
            soft.append(octagon(X[k][0:2], lim["v_max"] * mg))
            hard += [X[k][NXL + 1], X[k][NXL] - P["s_max"]]
            hard_lo += [0.0, -ca.inf]
            hard_hi += [ca.inf, 0.0]
        for k in nodes:
            xk, xp, up = X[k], X[k - 1], U[k - 1][0:2]
            y = (ca.mtimes(lin["C"][:, NXL * (k - 1):NXL * k], xp[:NXL])
                 + ca.mtimes(lin["D"][:, 2 * (k - 1):2 * k], up) + lin["d"][:, k - 1])
            soft += [octagon(xk[2:4], lim["tilt_max"] * mg),
                     octagon(xk[4:6], lim["tilt_rate_max"] * mg),
                     octagon(y[0:2], lim["a_max"] * c.acc_margin),
                     y[2:4] / (c.tilt_acc_max * mg)]
        s_two = ca.vertcat(*soft)
        n_two = s_two.numel()
        so = c.obstacle_scale
        obs = []
        for j in range(M):
            for k in nodes:
                o = (j * (N + 1) + k) * 2
                n_ob = P["obs_n"][o:o + 2]
                obs.append(so * (ca.dot(n_ob, X[k][12:14]) - P["obs_b"][j * (N + 1) + k]))
        s_obs = ca.vertcat(*obs)
        ns = n_two + s_obs.numel()
        e = ca.SX.sym("e", ns)
        g = ca.vertcat(ca.vertcat(*hard), s_two + e[:n_two], s_two - e[:n_two], s_obs + e[n_two:])
        self._lbg = np.concatenate([hard_lo, -np.ones(n_two), np.full(n_two, -np.inf),
                                    np.zeros(s_obs.numel())])
        self._ubg = np.concatenate([hard_hi, np.full(n_two, np.inf), np.ones(n_two),
                                    np.full(s_obs.numel(), np.inf)])
        w = ca.vertcat(ub, e)
        self.n_w, self.n_s, self.n_g = w.numel(), ns, g.numel()
        self._lbx = np.concatenate([np.full(self.n_u, -np.inf), np.zeros(ns)])
        self._lin_keys = ("Mx", "rx", "x0", "C", "D", "d")
        par = ca.vertcat(*(ca.vec(lin[k]) for k in self._lin_keys), pw)
        # the cost scale of guidance/mpc.py: the Hessian's mean diagonal in the blocked
        # inputs, at the model's linearisation at rest and a nominal window
        hess = ca.Function("H", [par], [ca.hessian(J, ub)[0]])
        Xs, Vs = np.zeros((NXL, N)), np.zeros((2, N))
        nominal = L.pack(v_prev=np.zeros(2), path_p=np.zeros((N + 1, 2)),
                         path_t=np.tile([1.0, 0.0], (N + 1, 1)), s_bar=np.zeros(N + 1),
                         v_s=np.zeros(N + 1), w_lat=np.ones(N + 1),
                         obs_n=np.zeros((L.M, N + 1, 2)), obs_b=np.zeros((L.M, N + 1)),
                         s_max=[1.0])
        lin0 = self._condense(np.zeros(nx), Xs.T, Vs.T, self.linearise(Xs, Vs))
        H0 = np.asarray(hess(np.concatenate([*(lin0[k] for k in self._lin_keys), nominal])), float)
        self.scale = float(np.mean(np.diag(H0)))
        f = J / self.scale + c.soft_penalty * ca.sum1(e)
        opts: dict[str, Any] = {"error_on_fail": False}
        if self.solver == "osqp":
            # rows are normalised by their bounds: 1e-4 of a limit is ample
            opts["osqp"] = {"verbose": False, "eps_abs": 1e-4, "eps_rel": 1e-4,
                            "max_iter": 10000, "polish": True}
        elif self.solver == "highs":
            opts["highs"] = {"output_flag": False}
        elif self.solver == "qrqp":
            opts.update({"print_iter": False, "print_header": False, "print_info": False,
                         "max_iter": 2000})
        opts.update(solver_options)
        self.qp = ca.qpsol("ballbot_nmpc_qp", self.solver, {"x": w, "p": par, "f": f, "g": g}, opts)
        self.qp_size = {"variables": int(self.n_w), "rows": int(self.n_g), "slacks": int(ns)}

    def _condense(self, x0: np.ndarray, Xbar: np.ndarray, Vbar: np.ndarray,
                  lin: tuple) -> dict[str, np.ndarray]:
        """The QP's parameters from the linearisation ``lin`` along ``Xbar`` (N(+1) x 16),
        ``Vbar`` (N x 2): the LTV model condensed onto the blocked inputs."""
        N, nx, dt = self.config.N, NX_MPC, self.config.dt
        Xn, A, B, y, C, D = (np.asarray(v, float) for v in lin)
        Mx = np.zeros((nx * N, self.n_u))
        rx = np.zeros(nx * N)
        Mk, rk = np.zeros((nx, self.n_u)), np.asarray(x0, float).copy()
        Ap = np.array([[1.0, dt], [0.0, 1.0]])
        Bp = np.array([0.5 * dt**2, dt])
        for k in range(N):
            Ak, Bk = A[:, NXL * k:NXL * (k + 1)], B[:, 2 * k:2 * (k + 1)]
            ck = Xn[:, k] - Ak @ Xbar[k, :NXL] - Bk @ Vbar[k]
            cols = slice(NU_MPC * int(self.block_of[k]), NU_MPC * (int(self.block_of[k]) + 1))
            Mn, rn = np.zeros_like(Mk), np.zeros_like(rk)
            Mn[:NXL] = Ak @ Mk[:NXL]
            Mn[:NXL, cols.start:cols.start + 2] += Bk
            rn[:NXL] = Ak @ rk[:NXL] + ck
            Mn[NXL:] = Ap @ Mk[NXL:]
            Mn[NXL:, cols.start + 2] += Bp
            rn[NXL:] = Ap @ rk[NXL:]
            Mk, rk = Mn, rn
            Mx[nx * k:nx * (k + 1)], rx[nx * k:nx * (k + 1)] = Mk, rk
        d = np.column_stack([y[:, k] - C[:, NXL * k:NXL * (k + 1)] @ Xbar[k, :NXL]
                             - D[:, 2 * k:2 * (k + 1)] @ Vbar[k] for k in range(N)])
        return {"Mx": Mx.ravel(order="F"), "rx": rx, "x0": np.asarray(x0, float),
                "C": C.ravel(order="F"), "D": D.ravel(order="F"), "d": d.ravel(order="F")}

    # ------------------------------------------------------------------ one sample
    def inputs(self, ub: np.ndarray) -> np.ndarray:
        """Per-step inputs (N, 3) of blocked inputs ``ub``."""
        return np.asarray(ub, float).reshape(-1, NU_MPC)[self.block_of]

    def shift(self, ub: np.ndarray) -> np.ndarray:
        steps = self.inputs(ub)
        return np.vstack([steps[1:], steps[-1:]])[self.starts].ravel()

    def states(self, ub: np.ndarray) -> np.ndarray:
        """Predicted states (N+1, 16) of the last QP's condensed model at ``ub``."""
        q = self._lin
        Mx = q["Mx"].reshape(NX_MPC * self.config.N, self.n_u, order="F")
        return np.vstack([q["x0"], (Mx @ ub + q["rx"]).reshape(self.config.N, NX_MPC)])

    def qp_parameters(self, x0: np.ndarray, Xbar: np.ndarray, ubar: np.ndarray) -> np.ndarray:
        """The QP's parameter vector linearised along ``Xbar`` (N+1, 16), ``ubar``."""
        N = self.config.N
        Vbar = self.inputs(ubar)[:, 0:2]
        t0 = time.perf_counter()
        lin = self.linearise(Xbar[:N, :NXL].T, Vbar.T)
        self._lin = self._condense(x0, Xbar, Vbar, lin)
        self.linearise_s.append(time.perf_counter() - t0)
        win = path_window(self.path, self.config, Xbar[:, NXL], Xbar[:, 12:14])
        p = self.layout.pack(v_prev=self.v_prev, **win)
        return np.concatenate([*(self._lin[k] for k in self._lin_keys), p])

    def _solve(self, par: np.ndarray, w0: np.ndarray | None) -> tuple[np.ndarray, bool]:
        args = {"p": par, "lbg": self._lbg, "ubg": self._ubg, "lbx": self._lbx}
        if w0 is not None:
            args["x0"] = w0
        t0, c0 = time.perf_counter(), time.thread_time()
        sol = self.qp(**args)
        self.solve_s.append(time.perf_counter() - t0)
        self.solve_cpu_s.append(time.thread_time() - c0)
        return np.asarray(sol["x"], float).ravel(), bool(self.qp.stats()["success"])

    def step(self, x_loop: np.ndarray, s: float | None = None) -> np.ndarray:
        """One real-time iteration from the loop state ``x_loop`` (14); returns ``v_ref``."""
        x_loop = np.asarray(x_loop, float).reshape(NXL)
        N = self.config.N
        first = self.x0 is None
        if first:
            s0 = self.path.project(x_loop[12:14]) if s is None else float(s)
            x0 = np.concatenate([x_loop, [s0, 0.0]])
            Xbar, ubar = np.tile(x0, (N + 1, 1)), np.zeros(self.n_u)
        else:
            X_prev = self.X
            x0 = np.concatenate([x_loop, X_prev[1, NXL:]])
            x0[NXL] = max(x0[NXL], self.x0[NXL])
            x0[NXL + 1] = max(x0[NXL + 1], 0.0)
            Xbar = np.vstack([x0, X_prev[2:], X_prev[-1:]])
            ubar = self.shift(self.ub)
        w0 = np.concatenate([ubar, np.zeros(self.n_s)])
        for _ in range(FIRST_SAMPLE_QPS if first else 1):
            par = self.qp_parameters(x0, Xbar, ubar)
            w, ok = self._solve(par, w0)
            ok = ok and bool(np.all(np.isfinite(w)))
            if ok:
                ubar, w0 = w[:self.n_u], w
                Xbar = self.states(ubar)
        if not ok:
            self.failures += 1
            w = np.concatenate([ubar, np.zeros(self.n_s)])
        self.x0, self.ub, self.X = x0, w[:self.n_u], self.states(w[:self.n_u])
        self.max_slack.append(float(np.max(w[self.n_u:], initial=0.0)))
        self.last = {"par": par, "w": w, "ok": ok}
        v = self.inputs(self.ub)[0, 0:2].copy()
        self.v_prev = v
        return v

    def prediction(self) -> np.ndarray:
        """Predicted positions (N+1, 2) of the last solution."""
        return self.X[:, 12:14]

    def progress(self) -> float:
        return float(self.x0[NXL])

"""The NMPC's condensing of a time-varying linearisation (every step's matrices distinct,
so a wrong step index shows) against a hand recursion, and its QP against the shipped
linear MPC's QP (built independently in guidance/mpc.py) where the two models coincide."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.guidance.condensed import NU_MPC
from ballbot_casadi.guidance.mpc import MpcConfig, make_mpc
from ballbot_casadi.guidance.nmpc import NY, NonlinearPathMPC
from ballbot_casadi.guidance.paths import line_path
from ballbot_casadi.guidance.prediction import NXL
from ballbot_casadi.sim.path_following import path_scenario, velocity_loop_model
from ballbot_casadi.sim.prediction_models import ClippedLoop

#: blocks of different lengths and nodes with gaps: block and node indices separate
CFG = MpcConfig(N=4, blocks=(2, 1, 1), nodes=(1, 3, 4), n_obstacles=1)


class FakeLTV:
    """A nonlinear "model" with per-step distinct Jacobians: step k of a call uses
    matrices seeded by k (the linearisation protocol of NonlinearPathMPC)."""

    def __init__(self) -> None:
        rng = np.random.default_rng(23)
        self.A = [np.eye(NXL) * 0.9 + 0.05 * rng.standard_normal((NXL, NXL)) for _ in range(8)]
        self.B = [rng.standard_normal((NXL, 2)) for _ in range(8)]
        self.C = [rng.standard_normal((NY, NXL)) for _ in range(8)]
        self.D = [rng.standard_normal((NY, 2)) for _ in range(8)]

    def __call__(self, Xs, vs):
        Xs, vs = np.asarray(Xs, float), np.asarray(vs, float)
        N = Xs.shape[1]
        Xn = np.column_stack([self.A[k] @ Xs[:, k] + self.B[k] @ vs[:, k] + 0.01 * np.sin(Xs[:, k])
                              + 0.003 * (k + 1) for k in range(N)])
        y = np.column_stack([self.C[k] @ Xs[:, k] + self.D[k] @ vs[:, k] + 0.1 * np.cos(Xs[:4, k])
                             for k in range(N)])
        return (Xn, np.hstack(self.A[:N]), np.hstack(self.B[:N]), y,
                np.hstack(self.C[:N]), np.hstack(self.D[:N]))


def _hand_states(lin, x0, Xbar, Vbar, U, dt):
    """X_{k+1} = A_k X_k + B_k v_k + c_k, c_k = F(Xbar_k, Vbar_k) - A_k Xbar_k - B_k Vbar_k;
    the progress a double integrator of the third input."""
    Xn, _, _, _, _, _ = lin(Xbar[:-1, :NXL].T, Vbar.T)
    X = [np.asarray(x0, float)]
    for k in range(U.shape[0]):
        A, B = lin.A[k], lin.B[k]
        c = Xn[:, k] - A @ Xbar[k, :NXL] - B @ Vbar[k]
        s, ds = X[-1][NXL:]
        nxt = np.concatenate([A @ X[-1][:NXL] + B @ U[k, :2] + c,
                              [s + dt * ds + 0.5 * dt ** 2 * U[k, 2], ds + dt * U[k, 2]]])
        X.append(nxt)
    return np.array(X)


@pytest.fixture(scope="module")
def line():
    return line_path((0.0, 0.0), (3.0, 0.0), 0.5, obstacles=[(0.6, 0.05, 0.1)])


def test_ltv_condensing_equals_a_hand_recursion(line) -> None:
    lin = FakeLTV()
    nm = NonlinearPathMPC(lin, line, CFG, solver="osqp")
    rng = np.random.default_rng(5)
    x0 = rng.standard_normal(NXL + 2)
    Xbar = rng.standard_normal((CFG.N + 1, NXL + 2))
    ubar, ub = rng.standard_normal(nm.n_u), rng.standard_normal(nm.n_u)
    nm.qp_parameters(x0, Xbar, ubar)
    # blocked inputs -> steps by hand: blocks (2, 1, 1)
    steps = ub.reshape(-1, NU_MPC)[[0, 0, 1, 2]]
    np.testing.assert_array_equal(nm.inputs(ub), steps)
    Vbar = ubar.reshape(-1, NU_MPC)[[0, 0, 1, 2], 0:2]
    want = _hand_states(lin, x0, Xbar, Vbar, steps, CFG.dt)
    np.testing.assert_allclose(nm.states(ub), want, rtol=1e-12, atol=1e-12)
    # the output offsets d_k = y(Xbar_k, Vbar_k) - C_k Xbar_k - D_k Vbar_k
    _, _, _, y, _, _ = lin(Xbar[:-1, :NXL].T, Vbar.T)
    d = np.column_stack([y[:, k] - lin.C[k] @ Xbar[k, :NXL] - lin.D[k] @ Vbar[k]
                         for k in range(CFG.N)])
    np.testing.assert_allclose(nm._lin["d"].reshape(NY, CFG.N, order="F"), d, atol=1e-12)
    np.testing.assert_allclose(nm._lin["C"].reshape(NY, NXL * CFG.N, order="F"),
                               np.hstack(lin.C[:CFG.N]), atol=0)
    np.testing.assert_allclose(nm._lin["x0"], x0, atol=0)


def test_shift_moves_steps_one_ahead_per_block(line) -> None:
    nm = NonlinearPathMPC(FakeLTV(), line, CFG, solver="osqp")
    ub = np.arange(nm.n_u, dtype=float)  # blocks (2, 1, 1): steps 0, 0, 1, 2
    # shifted steps: 0, 1, 2, 2 -> blocks start at steps 0, 2, 3: blocks 0, 2, 2
    np.testing.assert_array_equal(nm.shift(ub), np.concatenate([ub[0:3], ub[6:9], ub[6:9]]))


#: the lateral weights of the path window near the obstacle (all 0.1, relaxed; the obstacle
#: row then sets the lateral offset), and, on the line without the obstacle, a set that
#: differs node by node (a weight applied to the wrong node, or divided, shows)
W_LAT = (None, (1.0, 0.1, 2.0, 0.3, 0.05))


@pytest.mark.parametrize("w_lat", W_LAT)
def test_qp_solution_equals_the_linear_mpc_where_the_models_coincide(line, w_lat) -> None:
    """At small signals the NMPC's model is the shipped linear loop model, so its QP (cost
    term by term, soft rows with one slack each, obstacle rows, progress rows) has the
    linear MPC's solution: HiGHS on the NMPC's QP against OSQP on guidance/mpc.py's."""
    if w_lat is not None:
        line = line_path((0.0, 0.0), (3.0, 0.0), 0.5)
    inp = path_scenario(line, 0.1).inputs()
    nm = NonlinearPathMPC(ClippedLoop(inp, 0.1), line, CFG, solver="highs")
    x0 = np.zeros(NXL + 2)
    x0[0:2] = [0.004, -0.003]          # moving slowly: every clip inactive
    x0[12:14] = [0.42, 0.02]           # 2 cm off the line, the obstacle ahead
    x0[NXL:] = [0.42, 0.05]
    par = nm.qp_parameters(x0, np.tile(x0, (CFG.N + 1, 1)), np.zeros(nm.n_u))
    if w_lat is not None:
        at = par.size - nm.layout.n_p  # the MPC's parameters close the NMPC's vector
        for name, shape in nm.layout.params.items():
            if name == "w_lat":
                par[at:at + len(w_lat)] = w_lat
            at += int(np.prod(shape))
    w, ok = nm._solve(par, None)
    assert ok
    model = velocity_loop_model(inp["p_ctrl"], inp["k_vel"], 0.1)
    ref, L = make_mpc(model, MpcConfig(**{**CFG.__dict__, "solver": "osqp", "solver_options": {
        "osqp": {"verbose": False, "eps_abs": 1e-10, "eps_rel": 1e-10, "max_iter": 200000,
                 "polishing": True}}}))
    p = par[-L.n_p:]
    out = ref(x0, p, np.zeros(L.n_u), np.zeros(L.n_rows), np.zeros(L.n_rows))
    u_lin = np.asarray(out[1], float).ravel()
    assert np.max(np.abs(u_lin)) > 1e-2  # a non-trivial plan
    np.testing.assert_allclose(w[:nm.n_u], u_lin, rtol=0, atol=2e-5)


def test_solve_times_are_per_solve_and_cpu_within_wall(line) -> None:
    """The bookkeeping of a step: one linearisation and one QP time per solve (the cold
    first sample: FIRST_SAMPLE_QPS of them), the calling thread's CPU seconds of a solve
    never above its wall-clock seconds (a differenced clock, not a running total)."""
    from ballbot_casadi.guidance.mpc import FIRST_SAMPLE_QPS

    nm = NonlinearPathMPC(FakeLTV(), line, CFG, solver="osqp")
    x = np.zeros(NXL)
    x[12:14] = [0.1, 0.02]
    nm.step(x)
    nm.step(x)
    n = FIRST_SAMPLE_QPS + 1
    assert len(nm.solve_s) == len(nm.solve_cpu_s) == len(nm.linearise_s) == n
    assert len(nm.max_slack) == 2
    cpu, wall = np.array(nm.solve_cpu_s), np.array(nm.solve_s)
    assert np.all(cpu >= 0.0) and np.all(cpu <= wall + 1e-3)


def test_the_next_sample_starts_from_the_previous_prediction_clipped(line) -> None:
    """The progress state of a sample continues from the previous prediction's step 1,
    never below the previous progress, its rate never negative."""
    nm = NonlinearPathMPC(FakeLTV(), line, CFG, solver="osqp")
    x = np.zeros(NXL)
    x[12:14] = [0.1, 0.02]
    nm.step(x)
    x_prev, X1 = nm.x0.copy(), nm.X[1].copy()
    nm.step(x)
    want = [max(X1[NXL], x_prev[NXL]), max(X1[NXL + 1], 0.0)]
    np.testing.assert_array_equal(nm.x0[NXL:], want)
    np.testing.assert_array_equal(nm.x0[:NXL], x)
    # a plan whose step-1 progress went backwards at a negative rate: both clipped
    nm.X = nm.X.copy()
    nm.X[1, NXL:] = [nm.x0[NXL] - 0.3, -0.2]
    s_before = nm.x0[NXL]
    nm.step(x)
    np.testing.assert_array_equal(nm.x0[NXL:], [s_before, 0.0])


def test_a_qp_that_stops_early_is_a_failure_and_keeps_the_shifted_plan(line) -> None:
    """OSQP stopped after one iteration: the solver reports no success although its
    iterate is finite; the sample counts as failed and the shifted plan is applied."""
    nm = NonlinearPathMPC(FakeLTV(), line, CFG, solver="osqp",
                          solver_options={"osqp": {"max_iter": 1, "verbose": False}})
    x = np.zeros(NXL)
    x[12:14] = [0.1, 0.02]
    v = nm.step(x)
    assert not nm.last["ok"] and np.all(np.isfinite(nm.last["w"]))
    assert nm.failures == 1
    np.testing.assert_array_equal(v, [0.0, 0.0])  # the cold start's plan: zeros
    np.testing.assert_array_equal(nm.ub, np.zeros(nm.n_u))

"""The NMPC's sizes, options and per-sample bookkeeping read back by hand: the QP's
variable, row and slack counts of a small configuration, each plugin built with its own
quiet options (a solver that prints, or an option handed to the wrong plugin, shows),
the obstacle-count refusal, and what a step leaves behind (largest slack, previous
reference, progress, predicted positions)."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.guidance.mpc import MpcConfig
from ballbot_casadi.guidance.nmpc import NMPC_SOLVERS, NY, NonlinearPathMPC
from ballbot_casadi.guidance.paths import line_path
from ballbot_casadi.guidance.prediction import NXL

#: blocks of different lengths, nodes with a gap, one obstacle
CFG = MpcConfig(N=4, blocks=(2, 1, 1), nodes=(1, 3, 4), n_obstacles=1)


class DecayLTV:
    """A small stable LTV "model" (distinct matrices per step) in the NMPC's protocol."""

    def __init__(self) -> None:
        rng = np.random.default_rng(31)
        self.A = [np.eye(NXL) * 0.8 + 0.02 * rng.standard_normal((NXL, NXL)) for _ in range(8)]
        self.B = [0.1 * rng.standard_normal((NXL, 2)) for _ in range(8)]
        for B in self.B:
            B[12:14] += 0.1 * np.eye(2)            # the references move the ball
        self.C = [0.1 * rng.standard_normal((NY, NXL)) for _ in range(8)]
        self.D = [0.1 * rng.standard_normal((NY, 2)) for _ in range(8)]
        # an affine output part of its own per step, so the offset of the wrong step shows
        self.y0 = [0.02 * rng.standard_normal(NY) for _ in range(8)]

    def __call__(self, Xs, vs):
        Xs, vs = np.asarray(Xs, float), np.asarray(vs, float)
        N = Xs.shape[1]
        Xn = np.column_stack([self.A[k] @ Xs[:, k] + self.B[k] @ vs[:, k] for k in range(N)])
        y = np.column_stack([self.C[k] @ Xs[:, k] + self.D[k] @ vs[:, k] + self.y0[k]
                             for k in range(N)])
        return (Xn, np.hstack(self.A[:N]), np.hstack(self.B[:N]), y,
                np.hstack(self.C[:N]), np.hstack(self.D[:N]))


@pytest.fixture(scope="module")
def line():
    return line_path((0.0, 0.0), (3.0, 0.0), 0.5, obstacles=[(0.6, 0.05, 0.1)])


def test_qp_sizes_by_hand(line):
    nm = NonlinearPathMPC(DecayLTV(), line, CFG, solver="osqp")
    n_u = 3 * 3                                   # 3 blocks of (vx, vy, dds)
    soft = 4 * CFG.N + (4 + 4 + 4 + 2) * 3        # speed octagon per step; 14 rows per node
    obstacles = 1 * 3                             # one obstacle at 3 nodes
    slacks = soft + obstacles
    rows = 2 * CFG.N + 2 * soft + obstacles       # hard, soft both sides, obstacle rows
    assert nm.n_u == n_u and nm.n_s == slacks
    assert nm.qp_size == {"variables": n_u + slacks, "rows": rows, "slacks": slacks}
    np.testing.assert_array_equal(nm.block_of, [0, 0, 1, 2])
    np.testing.assert_array_equal(nm.starts, [0, 2, 3])
    assert nm.layout.N == CFG.N and nm.layout.nodes == CFG.nodes and nm.layout.n_u == n_u
    # the bounds of the decision variables: free inputs, non-negative slacks
    np.testing.assert_array_equal(nm._lbx, np.r_[np.full(n_u, -np.inf), np.zeros(slacks)])
    # rows: hard (ds >= 0, s - s_max <= 0 per step), soft lower, soft upper, obstacles >= 0
    np.testing.assert_array_equal(nm._lbg[:2 * CFG.N], np.tile([0.0, -np.inf], CFG.N))
    np.testing.assert_array_equal(nm._ubg[:2 * CFG.N], np.tile([np.inf, 0.0], CFG.N))
    np.testing.assert_array_equal(nm._lbg[2 * CFG.N:], np.r_[-np.ones(soft), np.full(soft, -np.inf),
                                                            np.zeros(obstacles)])
    np.testing.assert_array_equal(nm._ubg[2 * CFG.N:], np.r_[np.full(soft, np.inf), np.ones(soft),
                                                            np.full(obstacles, np.inf)])


def test_more_obstacles_than_the_mpc_holds_are_refused(line):
    two = line_path((0.0, 0.0), (3.0, 0.0), 0.5, obstacles=[(0.6, 0.05, 0.1), (1.6, -0.05, 0.1)])
    with pytest.raises(ScenarioError, match=r"^obstacles: at most 1 allowed by this MPC, got 2$"):
        NonlinearPathMPC(DecayLTV(), two, CFG)
    NonlinearPathMPC(DecayLTV(), two, MpcConfig(**{**CFG.__dict__, "n_obstacles": 2}), solver="osqp")


@pytest.mark.parametrize("solver", ["highs", "qrqp", "osqp", "daqp"])
def test_every_plugin_builds_with_its_own_options_and_solves_quietly(line, solver, capfd):
    assert solver in NMPC_SOLVERS
    nm = NonlinearPathMPC(DecayLTV(), line, CFG, solver=solver)
    capfd.readouterr()
    x0 = np.zeros(NXL + 2)
    x0[12:14] = [0.2, 0.01]
    x0[NXL] = 0.2
    par = nm.qp_parameters(x0, np.tile(x0, (CFG.N + 1, 1)), np.zeros(nm.n_u))
    w, _ = nm._solve(par, None)
    out = capfd.readouterr()
    assert out.out.strip() == "" and w.shape == (nm.n_w,)


def test_a_step_leaves_its_slack_reference_progress_and_prediction(line):
    nm = NonlinearPathMPC(DecayLTV(), line, CFG, solver="highs")
    x = np.zeros(NXL)
    x[12:14] = [0.3, 0.04]
    v = nm.step(x)
    w = nm.last["w"]
    assert nm.last["ok"] and nm.failures == 0
    assert nm.max_slack == [float(np.max(w[nm.n_u:]))]
    np.testing.assert_array_equal(nm.ub, w[:nm.n_u])
    np.testing.assert_array_equal(v, w[0:2])             # the first block's (vx, vy)
    np.testing.assert_array_equal(nm.v_prev, v)
    assert nm.progress() == nm.x0[NXL] == pytest.approx(line.project(x[12:14]), abs=1e-12)
    np.testing.assert_array_equal(nm.prediction(), nm.X[:, 12:14])
    np.testing.assert_array_equal(nm.prediction()[0], x[12:14])
    np.testing.assert_allclose(nm.X, nm.states(nm.ub), rtol=0, atol=0)
    # an explicit start progress replaces the projection
    nm2 = NonlinearPathMPC(DecayLTV(), line, CFG, solver="highs")
    nm2.step(x, s=0.75)
    assert nm2.progress() == 0.75


TIGHT = MpcConfig(N=4, blocks=(2, 1, 1), nodes=(1, 3, 4), n_obstacles=1, tilt_acc_max=0.05,
                  limits={"v_max": 0.05, "a_max": 0.05, "yaw_rate_max": 1.0, "yaw_acc_max": 10.0,
                          "tilt_max": 0.002, "tilt_rate_max": 0.01})


def test_each_soft_rows_slack_is_its_violation_of_the_bound_recomputed_here(line):
    """Tight limits and a start beyond them: at HiGHS's optimum every slack is the violation
    ``max(0, |row| - 1)`` of its row written here from the module docstring (bounds, margins,
    octagon directions, the node of each row, the outputs of the step before the node), and
    the obstacle row's slack ``max(0, -row)``."""
    c = TIGHT
    nm = NonlinearPathMPC(DecayLTV(), line, c, solver="highs")
    x0 = np.zeros(NXL + 2)
    x0[0:6] = [0.2, -0.15, 0.01, -0.008, 0.05, 0.03]   # speed, tilt, tilt rate beyond their bounds
    x0[12:14] = [0.45, 0.03]
    x0[NXL] = 0.45
    par = nm.qp_parameters(x0, np.tile(x0, (c.N + 1, 1)), np.zeros(nm.n_u))
    w, ok = nm._solve(par, None)
    assert ok
    ub, e = w[:nm.n_u], w[nm.n_u:]
    X, U = nm.states(ub), nm.inputs(ub)
    lin, N = nm._lin, c.N
    C = lin["C"].reshape(NY, NXL * N, order="F")
    D = lin["D"].reshape(NY, 2 * N, order="F")
    d = lin["d"].reshape(NY, N, order="F")
    ang = np.pi * np.arange(4) / 4
    D8 = np.column_stack([np.cos(ang), np.sin(ang)])
    f8 = np.cos(np.pi / 8)
    lim, mg = c.limits, c.margin
    rows = [D8 @ X[k, 0:2] / (lim["v_max"] * mg * f8) for k in range(1, N + 1)]
    groups = {"v": np.concatenate(rows)}
    per = {"tilt": [], "tilt_rate": [], "acc": [], "tilt_acc": []}
    for k in c.nodes:
        y = C[:, NXL * (k - 1):NXL * k] @ X[k - 1, :NXL] + D[:, 2 * (k - 1):2 * k] @ U[k - 1, 0:2] \
            + d[:, k - 1]
        per["tilt"].append(D8 @ X[k, 2:4] / (lim["tilt_max"] * mg * f8))
        per["tilt_rate"].append(D8 @ X[k, 4:6] / (lim["tilt_rate_max"] * mg * f8))
        per["acc"].append(D8 @ y[0:2] / (lim["a_max"] * c.acc_margin * f8))
        per["tilt_acc"].append(y[2:4] / (c.tilt_acc_max * mg))
        rows += [per["tilt"][-1], per["tilt_rate"][-1], per["acc"][-1], per["tilt_acc"][-1]]
    soft = np.concatenate(rows)
    n_two = soft.size
    np.testing.assert_allclose(e[:n_two], np.maximum(0.0, np.abs(soft) - 1.0), rtol=1e-6, atol=1e-7)
    # every group of rows is violated somewhere (so a bound's scale cannot hide)
    assert np.max(np.abs(groups["v"])) > 1.5
    for name, r in per.items():
        assert np.max(np.abs(np.concatenate(r))) > 1.05, name
    # the obstacle rows: s_o (n . p_k - b) >= -e, at the nodes
    P = nm.layout.unpack(par[-nm.layout.n_p:])
    obs_n = np.asarray(P["obs_n"]).reshape(1, N + 1, 2)
    obs_b = np.asarray(P["obs_b"]).reshape(1, N + 1)
    ob = np.array([c.obstacle_scale * (obs_n[0, k] @ X[k, 12:14] - obs_b[0, k]) for k in c.nodes])
    np.testing.assert_allclose(e[n_two:], np.maximum(0.0, -ob), rtol=1e-6, atol=1e-7)
    # the hard rows hold: progress rate >= 0, progress <= s_max
    assert np.min(X[1:, NXL + 1]) >= -1e-9
    assert np.max(X[1:, NXL] - float(P["s_max"][0])) <= 1e-9

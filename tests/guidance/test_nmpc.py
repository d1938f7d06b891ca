"""The RTI NMPC: its condensed LTV prediction, its QP against another solver, a run."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.core.constants import THESIS_LIMITS
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.guidance.condensed import condense
from ballbot_casadi.guidance.mpc import MpcConfig
from ballbot_casadi.guidance.nmpc import NonlinearPathMPC
from ballbot_casadi.guidance.paths import line_path
from ballbot_casadi.sim.path_following import path_scenario, run_path, velocity_loop_model
from ballbot_casadi.sim.prediction_models import ClippedLoop

SMALL = MpcConfig(N=4, blocks=(1, 1, 1, 1), nodes=(1, 2, 3, 4), n_obstacles=1)


@pytest.fixture(scope="module")
def setup():
    path = line_path((0.0, 0.0), (3.0, 0.0), 0.5, obstacles=[(0.6, 0.05, 0.1)])
    inp = path_scenario(path, 0.1).inputs()
    return path, inp, ClippedLoop(inp, 0.1)


def test_condensed_prediction_is_the_shipped_model_at_small_signals(setup) -> None:
    """Without a clip active the NMPC's model is the shipped loop model: the condensed LTV
    prediction equals the shipped MPC's condensing (built independently) to rounding."""
    path, inp, model = setup
    nm = NonlinearPathMPC(model, path, MpcConfig())
    rng = np.random.default_rng(18)
    x0 = np.concatenate([1e-3 * rng.standard_normal(14), [0.1, 0.2]])
    ub = 1e-3 * rng.standard_normal(nm.n_u)
    nm.qp_parameters(x0, np.tile(x0, (21, 1)), ub)
    cond = condense(velocity_loop_model(inp["p_ctrl"], inp["k_vel"], 0.1), MpcConfig().blocks)
    np.testing.assert_allclose(nm.states(ub), cond.states(x0, ub), rtol=0, atol=1e-12)


def test_qp_equals_an_independent_solver_on_a_small_case(setup) -> None:
    """The same QP (N = 4, an obstacle beside the start, the robot 5 cm off the path and
    moving) through OSQP (ADMM) and through HiGHS (simplex-type active set for QPs)."""
    path, inp, model = setup
    x0 = np.zeros(16)
    x0[0:2] = [0.3, 0.1]  # moving
    x0[12:14] = [0.4, -0.05]
    x0[14] = 0.4
    sols = {}
    for solver, opts in (("osqp", {"osqp": {"verbose": False, "eps_abs": 1e-10,
                                             "eps_rel": 1e-10, "max_iter": 100000,
                                             "polish": True}}),
                         ("highs", {"highs": {"output_flag": False}})):
        nm = NonlinearPathMPC(model, path, SMALL, solver=solver, solver_options=opts)
        par = nm.qp_parameters(x0, np.tile(x0, (5, 1)), np.zeros(nm.n_u))
        w, ok = nm._solve(par, None)
        assert ok, solver
        sols[solver] = w
    # the solution against rows recomputed here: slacks >= 0, progress rate >= 0, and the
    # speed octagon at every node (|v| <= margin v_max, inner octagon) within its slack
    ub, e = sols["highs"][:nm.n_u], sols["highs"][nm.n_u:]
    assert np.min(e) >= -1e-9
    X = nm.states(ub)
    assert np.min(X[1:, 15]) >= -1e-9
    ang = np.pi * np.arange(4) / 4
    D8 = np.column_stack([np.cos(ang), np.sin(ang)])
    bound = SMALL.margin * THESIS_LIMITS["v_max"] * np.cos(np.pi / 8)
    speed_rows = np.abs(X[1:, 0:2] @ D8.T) / bound
    np.testing.assert_array_less(speed_rows, 1 + e[:16].reshape(4, 4) + 1e-7)
    assert np.max(sols["highs"][nm.n_u:]) > 1e-3  # some soft row is active: not a trivial QP
    # the progress acceleration (weight w_dds = 1) is the least determined entry: 1e-5
    np.testing.assert_allclose(sols["osqp"], sols["highs"], rtol=0, atol=1e-5)


def test_unknown_solver_refused(setup) -> None:
    path, _, model = setup
    with pytest.raises(ScenarioError, match="allowed: osqp, daqp, highs, qrqp"):
        NonlinearPathMPC(model, path, SMALL, solver="ipopt")


@pytest.mark.slow
def test_a_run_keeps_the_limits_and_progress(setup) -> None:
    """2.5 s along the line past the obstacle: tilt and tilt rate inside the §7.1 limits on
    every period, progress never decreasing, the obstacle not touched; OSQP may stop at
    its iteration limit on a sample (the shifted plan is kept): at most 10 % of them."""
    path, _, model = setup
    nm = NonlinearPathMPC(model, path, MpcConfig())
    run = run_path(path, nm, 2.5)
    from ballbot_casadi.analysis.metrics import tilt_deg, tilt_rate_deg_s
    from ballbot_casadi.core.layout import STATE, STATE_XY
    x = run.log["state"]
    assert np.max(tilt_deg(x[:, STATE["q"]])) <= np.degrees(THESIS_LIMITS["tilt_max"])
    assert np.max(tilt_rate_deg_s(x)) <= np.degrees(THESIS_LIMITS["tilt_rate_max"])
    assert np.all(np.diff(run.progress) >= 0) and run.progress[-1] > 0.5
    assert np.min(path.clearance(x[:, STATE_XY])) > 0.0
    assert nm.failures <= 0.1 * len(run.v_ref)

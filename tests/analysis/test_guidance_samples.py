"""Per-sample figures of a path run's guidance block: the sample periods, the ADMM residual
read from the logged state, timing summaries by hand, the predicted horizon of a known
plan against stepping the prediction model, and the timed re-evaluation reproducing the
logged guidance state."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.analysis.guidance_samples import (
    sample_inputs,
    sample_periods,
    sample_residuals,
    time_samples,
    timing_summary,
)
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.sim.guided import GUIDANCE_EVERY, predictions, pursuit_law, run_guided
from ballbot_casadi.sim.path_following import velocity_loop_model


def test_sample_periods_every_20th_from_0():
    np.testing.assert_array_equal(sample_periods(45, 20), [0, 20, 40])
    np.testing.assert_array_equal(sample_periods(40, 20), [0, 20])  # period 40 not run
    np.testing.assert_array_equal(sample_periods(1, 20), [0])
    with pytest.raises(ScenarioError, match="every"):
        sample_periods(10, 0)


def test_timing_summary_by_hand():
    s = np.arange(1, 101) * 1e-6  # 1 .. 100 us
    got = timing_summary(s)
    # median of 1..100 = 50.5; p99 at rank 0.99 * 99 = 98.01: 99 + 0.01 * (100 - 99)
    assert got == pytest.approx({"median_us": 50.5, "p99_us": 99.01, "max_us": 100.0}, rel=1e-12)
    assert timing_summary([3e-6]) == pytest.approx({"median_us": 3.0, "p99_us": 3.0, "max_us": 3.0})
    with pytest.raises(ScenarioError, match="no samples"):
        timing_summary([])


def test_residual_is_read_after_each_sample_period(guided_law):
    S = guided_law.state
    guide = np.full((2 * GUIDANCE_EVERY + 6, 1 + S.size), 9.0)  # 46 periods: samples at 0, 20, 40
    col = 1 + S["r_prim"].start
    for row, r in ((1, 0.1), (GUIDANCE_EVERY + 1, 0.2), (2 * GUIDANCE_EVERY + 1, 0.3)):
        guide[row, col] = r
    np.testing.assert_array_equal(sample_residuals(guided_law, guide), [0.1, 0.2, 0.3])
    with pytest.raises(ScenarioError, match="only the MPC"):
        sample_residuals(pursuit_law(), guide)


def test_predicted_horizon_of_a_known_plan_equals_stepping_the_model(guided_law,
                                                                     guided_inputs):
    """The plan in the logged state (MPC state x0, blocked inputs u) predicts the positions
    of the closed velocity loop stepped with each step's held reference."""
    S, cond = guided_law.state, guided_law.cond
    rng = np.random.default_rng(4)
    guide = np.zeros((GUIDANCE_EVERY + 2, 1 + S.size))
    plans = []
    for row in (1, GUIDANCE_EVERY + 1):
        x0 = rng.normal(0, 0.1, S["x0"].stop - S["x0"].start)
        ub = rng.normal(0, 0.3, cond.n_u)
        guide[row, 1 + S["x0"].start:1 + S["x0"].stop] = x0
        guide[row, 1 + S["u"].start:1 + S["u"].stop] = ub
        plans.append((x0, ub))
    periods, pos = predictions(guided_law, {"guide": guide})
    np.testing.assert_array_equal(periods, [0, GUIDANCE_EVERY])
    model = velocity_loop_model(guided_inputs["p_ctrl"], guided_inputs["k_vel"],
                                guided_law.config.dt)
    for (x0, ub), p in zip(plans, pos):
        steps = np.repeat(ub.reshape(-1, 3), cond.blocks, axis=0)  # block j held blocks[j] steps
        assert steps.shape == (cond.N, 3)
        ref = model.simulate(x0[:14], steps[:, :2])[:, 12:14]
        np.testing.assert_allclose(p, ref, rtol=1e-9, atol=1e-12)


def test_sample_inputs_read_what_the_controllers_read():
    log = {"state": np.zeros((3, 12)), "v_ref": np.ones((3, 3)), "guide": 2 * np.ones((3, 4)),
           "z": 3 * np.ones((3, 8))}
    x, v, g, z = sample_inputs(log, 1)
    assert np.all(x == 0) and np.all(v == 1) and np.all(g == 2) and np.all(z == 3)
    log["x_hat"] = 5 * np.ones((3, 12))
    assert np.all(sample_inputs(log, 1)[0] == 5)


def test_timed_calls_reproduce_the_logged_guidance_state(guided_path, guided_inputs):
    law = pursuit_law()
    log = run_guided(guided_path, law, 1.0)
    t = time_samples(law.function, log, guided_inputs["p_ctrl"], law.parameters(guided_path),
                     guided_inputs["Ts"])
    np.testing.assert_array_equal(t.periods, np.arange(0, 200, GUIDANCE_EVERY))
    np.testing.assert_allclose(t.g_next, log["guide"][t.periods + 1], rtol=0, atol=1e-12)
    assert np.all(t.wall_s > 0) and np.all(t.cpu_s >= 0) and t.wall_s.shape == (10,)

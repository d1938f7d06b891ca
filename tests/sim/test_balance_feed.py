"""The balance feed (guidance ``mpc_balance``): the scenario key, the block's contract in
the period, and the compiled mission against the Python reference driver, with the
constraint rows on every sample."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.core.constants import THESIS_LIMITS
from ballbot_casadi.errors import ScenarioError, ScenarioFileError
from ballbot_casadi.guidance.mpc import PathMPC, make_mpc_parts
from ballbot_casadi.guidance.shape_model import shape_model
from ballbot_casadi.sim.balance_feed import (
    BALANCE_FEED_CONFIG,
    run_balance_path,
    shape_gains,
)
from ballbot_casadi.sim.guided import (
    GUIDANCE_EVERY,
    mpc_balance_law,
    predictions,
    run_guided,
    scenario_law,
)
from ballbot_casadi.sim.ports import PeriodBlocks, check_blocks
from ballbot_casadi.sim.scenario.file import parse_scenario
from ballbot_casadi.sim.scenario.path_section import GUIDANCE_CHOICES

DURATION = 3.0
BASE = {"duration_s": 2.0, "cascade": True,
        "path": {"type": "figure_eight", "length": 4.0, "width": 2.0, "speed": 0.5}}


@pytest.fixture(scope="module")
def balance_law(guided_inputs):
    return mpc_balance_law(guided_inputs["p_ctrl"])


def test_the_scenario_key_round_trips_and_builds_the_balance_feed(balance_law):
    sc = parse_scenario({**BASE, "guidance": "mpc_balance"}).scenario
    assert sc.guidance == "mpc_balance" and "mpc_balance" in GUIDANCE_CHOICES
    assert sc.to_file()["guidance"] == "mpc_balance"
    assert parse_scenario(sc.to_file()).scenario == sc
    law = scenario_law(sc)
    assert law.name == "mpc_balance"
    assert law.function.name() == "ballbot_guidance_mpc_balance"
    assert law.function.name_out() == ["v_ref_out", "g_next", "q_ref", "dq_ref", "ddq_ref"]
    # the shipped velocity feed stays the default
    assert parse_scenario(BASE).scenario.guidance == "mpc" == GUIDANCE_CHOICES[0]


def test_a_bad_guidance_value_is_refused_naming_the_key():
    with pytest.raises(ScenarioFileError) as exc:
        parse_scenario({**BASE, "guidance": "mpc_ballance"})
    msg = str(exc.value)
    assert "key 'guidance'" in msg and "mpc_balance" in msg and "\n" not in msg


def test_the_period_refuses_a_feed_with_wrong_reference_sizes(balance_law, guided_inputs):
    """A guidance block may add (q_ref, dq_ref, ddq_ref), 4 entries each, nothing else."""
    from ballbot_casadi.sim.embedded import controller_blocks

    blocks = controller_blocks("flc")
    f = balance_law.function
    ok = PeriodBlocks(blocks.balance, blocks.velocity, None, f)
    assert check_blocks(ok, guided_inputs["p_ctrl"].size)["ng"] == f.numel_in(2)
    ins = [ca.MX.sym(n, f.sparsity_in(i)) for i, n in enumerate(f.name_in())]
    outs = f(*ins)
    bad = ca.Function("bad", ins, [*outs[:4], outs[4][0:3]], f.name_in(), f.name_out())
    with pytest.raises(ScenarioError, match="ddq_ref"):
        check_blocks(PeriodBlocks(blocks.balance, blocks.velocity, None, bad),
                     guided_inputs["p_ctrl"].size)


class _Recording(PathMPC):
    """PathMPC recording each sample's state, parameters and solution (for the rows)."""

    def step(self, x_loop, s=None):
        v = super().step(x_loop, s)
        self.record = getattr(self, "record", []) + [
            (self.last["x0"].copy(), self.last["p"].copy(), self.u.copy())]
        return v


@pytest.fixture(scope="module")
def balance_runs(guided_path, guided_inputs, balance_law):
    mission = run_guided(guided_path, balance_law, DURATION)
    model = shape_model(shape_gains(guided_inputs["p_ctrl"]), BALANCE_FEED_CONFIG.dt)
    mpc = _Recording(model, guided_path, BALANCE_FEED_CONFIG)
    return mission, run_balance_path(guided_path, mpc, DURATION), mpc


@pytest.mark.slow
def test_the_compiled_balance_feed_equals_the_python_reference(balance_runs, balance_law):
    """The compiled mission with ``mpc_balance`` in the period == PathMPC on the shape
    model called from Python every 0.1 s, the references computed in numpy and the
    compiled balance loop alone (path table vs spline: ~1e-7 m)."""
    mission, ref, _ = balance_runs
    assert mission["state"].shape == ref.log["state"].shape
    np.testing.assert_allclose(mission["state"], ref.log["state"], rtol=0, atol=1e-6)
    for key in ("q_ref", "dq_ref", "ddq_ref"):
        np.testing.assert_allclose(mission[key], ref.log[key], rtol=0, atol=1e-6)
    _, pos = predictions(balance_law, mission)
    np.testing.assert_allclose(pos, np.array(ref.predictions), rtol=0, atol=1e-6)
    assert np.linalg.norm(mission["state"][-1, :2] - mission["state"][0, :2]) > 0.8
    # the tilt acceleration changes only at the samples
    dd = mission["ddq_ref"]
    assert np.any(np.abs(dd[GUIDANCE_EVERY] - dd[0]) > 1e-4)


@pytest.mark.slow
def test_constraint_rows_hold_on_every_sample(balance_runs):
    """Every sample's plan keeps the §7.1 limits (the rows are scaled by ``margin``: the
    limit itself is 1 / margin), the tilt-acceleration budget and ds >= 0 (to the ADMM's
    residual); the references fed to the balance controller keep the tilt limits."""
    _, ref, mpc = balance_runs
    L = mpc.layout
    qp_data = make_mpc_parts(mpc.model, mpc.config)[2]["qp_data"]
    assert mpc.failures == 0
    worst = 0.0
    for x0, p, u in mpc.record:
        _, _, lo, hi, _ = (np.asarray(v, float).ravel() for v in qp_data(x0, p))
        rows = mpc.rows(u, p)[:L.n_c]
        # bounds are 1 at margin * limit: a row of 1 / margin is at the limit itself
        excess = np.maximum(rows - hi[:L.n_c], lo[:L.n_c] - rows)
        hard = np.zeros(L.n_c, bool)
        hard[:L.N * 6].reshape(L.N, 6)[:, 4:] = True
        assert np.all(excess[hard] <= mpc.residual_tol)  # ds >= 0, s <= s_max
        worst = max(worst, float(np.max(excess[~hard])))
    assert worst <= 1.0 / mpc.config.margin - 1.0, worst
    assert np.all(np.diff(ref.progress) >= 0)
    q = ref.log["q_ref"]
    tilt = np.arccos(np.clip(q[:, 0] ** 2 - q[:, 1] ** 2 - q[:, 2] ** 2 + q[:, 3] ** 2, -1, 1))
    assert np.max(tilt) <= THESIS_LIMITS["tilt_max"]

"""The guidance block's state before the first period (sim.guided.GuidanceLaw.initial_state)
by hand: the counter 0, pure pursuit's projection of the start onto the path, the MPC's
``first`` flag and its state at the loop state of the start with that progress, the
latency tail zero, and the block sizes of each variant (issue 23: a field from the wrong
input, a sample state one entry short, a tail of the wrong size must show)."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.guidance.prediction import NXL
from ballbot_casadi.sim.guided import (
    GUIDANCE_EVERY,
    first_sample_latency,
    latency_layout,
    mpc_law,
    path_metadata,
    pursuit_law,
)
from ballbot_casadi.sim.path_following import make_loop_state


def _start(guided_inputs):
    x0 = np.array(guided_inputs["x0"], float)
    x0[0:2] = [0.4, 0.5]         # off the path
    x0[6:8] = [0.2, -0.1]        # moving
    return x0, np.asarray(guided_inputs["z0"], float)


def test_pursuit_starts_at_the_projection(guided_path, guided_inputs):
    law = pursuit_law()
    x0, z0 = _start(guided_inputs)
    g0 = law.initial_state(guided_path, x0, z0)
    s0 = guided_path.project(np.array([0.4, 0.5]))
    assert law.state.fields == ("v", "s") and law.block_size == 4 and g0.size == 4
    np.testing.assert_allclose(g0, [0.0, 0.0, 0.0, float(s0)], rtol=1e-15, atol=0)
    assert 0.3 < float(s0) < 0.7  # near the first segment's (0.4, 0.5) . (1, 0.3) / |(1, 0.3)| = 0.53
    assert dict(law.options) == {"lookahead": 0.6, "k_lat": 1.0}


def test_mpc_starts_first_at_the_loop_state_of_the_start(guided_law, guided_path, guided_inputs):
    law = guided_law
    x0, z0 = _start(guided_inputs)
    g0 = law.initial_state(guided_path, x0, z0)
    S = law.state
    assert g0.size == law.block_size == 1 + S.size and law.tail.size == 0 and g0[0] == 0.0
    gs = g0[1:]
    X0 = np.asarray(make_loop_state()(x0, z0), float).ravel()
    s0 = float(guided_path.project(X0[12:14]))
    assert gs[S["first"]] == 1.0
    np.testing.assert_allclose(gs[S["x0"]], np.r_[X0, s0, 0.0], rtol=1e-14, atol=1e-15)
    np.testing.assert_array_equal(gs[S["v"]], 0.0)
    others = [f for f in S.fields if f not in ("first", "x0")]
    assert all(not np.any(gs[S[f]]) for f in others)
    np.testing.assert_allclose(X0[0:2], [0.2, -0.1], rtol=0, atol=1e-15)   # velocity first
    np.testing.assert_allclose(X0[12:14], [0.4, 0.5], rtol=0, atol=1e-15)  # position last


def test_latency_variants_and_their_tails(guided_inputs, guided_path):
    law = mpc_law(guided_inputs["p_ctrl"], guided_inputs["k_vel"], latency=3)
    assert (law.latency, law.first_latency, law.split) == (3, GUIDANCE_EVERY - 1, False)
    assert law.tail.fields == ("v_prev", "due") and law.block_size == 1 + law.state.size + 3
    x0, z0 = _start(guided_inputs)
    g0 = law.initial_state(guided_path, x0, z0)
    assert g0.size == law.block_size and not np.any(g0[-3:])
    assert law.function.name() == "ballbot_guidance_mpc_l3" and law.relink is not None
    split = mpc_law(guided_inputs["p_ctrl"], guided_inputs["k_vel"], latency=2, split=True)
    assert split.block_size == 1 + split.state.size + 3 + NXL and split.relink is None
    assert split.function.name() == "ballbot_guidance_mpc_l2_split"
    assert first_sample_latency() == 19 and first_sample_latency(5) == 4
    assert latency_layout(0).size == 0 and latency_layout(0, True).fields == ("snap",)
    assert mpc_law(guided_inputs["p_ctrl"], guided_inputs["k_vel"]).function.name() == "ballbot_guidance_mpc"


def test_mpc_dt_must_be_a_multiple_of_the_period(guided_inputs):
    from ballbot_casadi.guidance.mpc import MpcConfig
    with pytest.raises(ScenarioError, match="multiple of 0.005 s"):
        mpc_law(guided_inputs["p_ctrl"], guided_inputs["k_vel"], MpcConfig(dt=0.0125))


def test_path_metadata_spacing_and_ends(guided_path):
    meta = path_metadata(guided_path, spacing=0.5)
    n = int(np.ceil(guided_path.length / 0.5)) + 1
    xy = np.array(meta["xy"])
    assert xy.shape == (n, 2) and meta["obstacles"] == []
    np.testing.assert_allclose(xy[0], [0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(xy[-1], [2.0, 0.0], atol=1e-12)
    assert len(path_metadata(guided_path, spacing=100.0)["xy"]) == 2

"""The guidance block's latency switch (issue 18): a sample's reference takes effect exactly
L periods later (the cold first sample's latency for the first), latency 0 is the block
without latency, and the split block of the firmware's interrupt step, driven by the
background protocol of csrc/ballbot_fw.c (snapshot after the counter-0 period, result
written into the state before the due period), gives the mission block's references.

A synthetic sample (cheap, no MPC): its reference depends on the loop state it reads and
on its own state, so a wrong snapshot or a wrong application period shows."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.guidance.prediction import NXL
from ballbot_casadi.sim.guided import latency_layout, make_guidance, mpc_law
from ballbot_casadi.sim.path_following import make_loop_state

EVERY = 20
N = 5 * EVERY + 7
NS = 3  # sample state: v (2), first


def _sample() -> ca.Function:
    X, g, k = ca.SX.sym("X", NXL), ca.SX.sym("g", NS), ca.SX.sym("k", 1)
    v = ca.vertcat(0.5 * g[0] + X[12] + k, g[1] - X[13] + 1.0)  # reads the snapshot and the state
    return ca.Function("toy_sample", [X, g, k], [v, ca.vertcat(v, 0.0)], ["X", "g", "k"],
                       ["v", "g_next"])


def _inputs(seed: int = 3):
    rng = np.random.default_rng(seed)
    nz = make_loop_state().numel_in(1)
    return rng.normal(size=(N, 12)), rng.normal(size=(N, nz))


def _run(block: ca.Function, ntail: int, apply=None):
    """Step ``block`` N periods (``apply(k, g) -> g``: the background protocol)."""
    xs, zs = _inputs()
    g = np.concatenate([[0.0, 0.0, 0.0, 1.0], np.zeros(ntail)])  # count, v, first = 1
    v_out = []
    for k in range(N):
        if apply is not None:
            g = apply(k, g)
        v, g_next = block(xs[k], np.array([0.0, 0.0, 0.25]), g, zs[k], np.zeros(block.numel_in(4)),
                          np.array([0.1]), 0.005)
        v_out.append(np.asarray(v, float).ravel())
        g_prev, g = g, np.asarray(g_next, float).ravel()
        if apply is not None:
            apply.after(k, g_prev, g)
    return np.array(v_out)


def _changes(v: np.ndarray) -> np.ndarray:
    """Periods whose reference differs from the period before (before period 0: none, 0)."""
    v = np.vstack([np.zeros((1, v.shape[1])), v])
    return np.flatnonzero(np.abs(np.diff(v[:, :2], axis=0)).max(axis=1) > 0)


@pytest.mark.parametrize("latency", [1, 5, 19])
def test_reference_changes_exactly_latency_periods_after_the_sample(latency):
    first = EVERY - 1
    v0 = _run(make_guidance("toy", _sample(), EVERY), 0)
    vL = _run(make_guidance("toy", _sample(), EVERY, latency, first, 2), latency_layout(latency).size)
    samples = np.arange(0, N, EVERY)
    assert list(_changes(v0)) == list(samples)  # latency 0: in the sample's own period
    due = np.array([first, *(samples[1:] + latency)])
    assert list(_changes(vL)) == [d for d in due if d < N]
    # the reference is the same sequence, shifted to its due periods
    for s, d in zip(samples, due):
        if d < N:
            np.testing.assert_array_equal(vL[d], v0[s])
    np.testing.assert_array_equal(vL[:first], np.tile([0.0, 0.0, 0.25], (first, 1)))


class _Background:
    """The C protocol of csrc/ballbot_fw.c in Python: snapshot after a counter-0 period,
    the sample on it, its state written into the block's state before the due period."""

    def __init__(self, sample: ca.Function, latency: int) -> None:
        self.sample, self.tail = sample, latency_layout(latency, split=True)
        self.due, self.result = -1, None

    def __call__(self, k: int, g: np.ndarray) -> np.ndarray:
        if k == self.due:
            g = g.copy()
            g[1:1 + NS] = self.result
        return g

    def after(self, k: int, g_prev: np.ndarray, g_next: np.ndarray) -> None:
        if g_prev[0] == 0:
            snap = g_next[1 + NS + self.tail.offset("snap"):][:NXL]
            self.result = np.asarray(self.sample(snap, g_next[1:1 + NS], 0.1)[1], float).ravel()
            self.due = k + int(g_next[1 + NS + self.tail.offset("due")])


@pytest.mark.parametrize("latency", [1, 5])
def test_split_block_with_background_equals_the_mission_block(latency):
    mission = make_guidance("toy", _sample(), EVERY, latency, EVERY - 1, 2)
    split = make_guidance("toy", _sample(), EVERY, latency, EVERY - 1, 2, split=True)
    v_mission = _run(mission, latency_layout(latency).size)
    v_split = _run(split, latency_layout(latency, True).size, _Background(_sample(), latency))
    np.testing.assert_allclose(v_split, v_mission, rtol=0, atol=1e-15)
    assert len(_changes(v_mission)) >= 4
    # the split block never calls the sample (the mission's does)
    mission.find_function("toy_sample")
    with pytest.raises(RuntimeError):
        split.find_function("toy_sample")


def test_latency_zero_is_the_block_without_latency(guided_inputs):
    law = mpc_law(guided_inputs["p_ctrl"], guided_inputs["k_vel"])
    assert law is mpc_law(guided_inputs["p_ctrl"], guided_inputs["k_vel"], latency=0)
    assert law.latency == 0 and law.tail.size == 0 and law.block_size == 1 + law.state.size
    assert law.function.name() == "ballbot_guidance_mpc"
    assert law.function.numel_in(2) == 1 + law.state.size


def test_bad_latency_refused():
    with pytest.raises(ScenarioError, match=r"latency must be an int in 0\.\.19"):
        make_guidance("toy", _sample(), EVERY, 20)
    with pytest.raises(ScenarioError, match="first_latency"):
        make_guidance("toy", _sample(), EVERY, 3, -1)
    with pytest.raises(ScenarioError, match="needs latency >= 1"):
        make_guidance("toy", _sample(), EVERY, 0, split=True)


def test_a_sample_every_period_is_allowed_and_changes_the_reference_every_period():
    """``every = 1`` (the smallest interval) is a block whose sample runs in each period;
    ``every = 0`` is refused."""
    v = _run(make_guidance("toy", _sample(), 1), 0)
    assert _changes(v).tolist() == list(range(N))
    with pytest.raises(ScenarioError, match="every must be an int >= 1 periods, got 0"):
        make_guidance("toy", _sample(), 0)

"""The period's guidance block (sim.guided.make_guidance) around a toy sample whose output
is known by hand: the sample runs at count 0 on the loop state and the parameter, the
other periods hold the last velocity reference and the sample's state, the counter wraps
after ``every`` periods, and the period's own yaw-rate reference passes through."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.model.dynamics import NP
from ballbot_casadi.sim.guided import make_guidance
from ballbot_casadi.sim.path_following import make_loop_state

EVERY = 4


@pytest.fixture(scope="module")
def block():
    # toy sample: v = [X_last + k0, X_second_last - k1] (the loop state ends with the
    # position), state [v, n_samples + 1]
    X, g, k = ca.MX.sym("X", 14), ca.MX.sym("g", 3), ca.MX.sym("k", 2)
    v = ca.vertcat(X[12] + k[0], X[13] - k[1])
    sample = ca.Function("toy", [X, g, k], [v, ca.vertcat(v, g[2] + 1)], ["X", "g", "k"],
                         ["v", "g_next"])
    return make_guidance("toy", sample, EVERY)


def _x(px, py):
    x = np.zeros(12)
    x[0:2] = px, py
    x[2:6] = Q.from_rpy(0.0, 0.0, 0.3)
    return x


def test_loop_state_ends_with_the_position():
    X = np.asarray(make_loop_state()(_x(1.25, -0.5), np.zeros(8))).ravel()
    np.testing.assert_array_equal(X[12:14], [1.25, -0.5])


def test_sample_at_count_zero_hold_between_and_yaw_rate_passes(block):
    kg, p = np.array([0.1, 0.2]), np.zeros(NP)
    g = np.array([0.0, 9.0, 9.0, 5.0])  # count 0, held v (9, 9), 5 samples so far
    v_ref = np.array([7.0, 7.0, 0.35])  # the period's own reference: only its yaw rate is used
    outs, counts = [], []
    for k in range(2 * EVERY + 1):
        v, g = (np.asarray(a).ravel() for a in block(_x(1.0 + k, -2.0 * k), v_ref, g,
                                                        np.zeros(8), p, kg, 0.005))
        outs.append(v)
        counts.append(g[0])
    # samples at periods 0, EVERY, 2 EVERY on that period's position; held in between
    for k, v in enumerate(outs):
        ks = EVERY * (k // EVERY)
        np.testing.assert_allclose(v, [1.0 + ks + 0.1, -2.0 * ks - 0.2, 0.35], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(counts, [1, 2, 3, 0, 1, 2, 3, 0, 1])
    assert g[3] == 5.0 + 3  # three samples ran
    with pytest.raises(ScenarioError, match="every"):
        make_guidance("toy", ca.Function("s", [ca.MX.sym("X", 14), ca.MX.sym("g", 3),
                                               ca.MX.sym("k", 2)], [ca.MX.zeros(2), ca.MX.zeros(3)]), 0)

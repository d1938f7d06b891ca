"""The balance-feed guidance block (sim/balance_feed.py) period by period around a fake
MPC sample whose output is a known linear map of the shape state it is given: the shape
state's composition, the sample / hold schedule, the double integration of the tilt
reference, the quaternion references and the initial state, all by hand."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.control.velocity import equilibrium_tilt, tilt_heading_reference
from ballbot_casadi.core.layout import VELOCITY_CONTROLLER_STATE as Z
from ballbot_casadi.core.params import PARAM_NAMES
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.guidance.blocks import mpc_state_layout
from ballbot_casadi.guidance.mpc import MpcLayout
from ballbot_casadi.guidance.prediction import NXL
from ballbot_casadi.sim.balance_feed import (
    balance_initial_function,
    balance_state_layout,
    make_balance_guidance,
)
from ballbot_casadi.sim.path_following import make_loop_state

L = MpcLayout(2, 1, 6, (1, 2))
EVERY = 3
TS = 0.005
#: the fake sample's output a = W @ Xs (every entry of Xs with its own weight)
W = np.array([[1.0, 0, 2, 0, 3, 0, 0, 0, 0, 0, 0, 0, 5, 0],
              [0, 1.0, 0, -1, 0, 7, 0, 0, 0, 0, 0, 0, 0, 11]])


def _fake_sample() -> ca.Function:
    nm = mpc_state_layout(L).size
    X, g, k = ca.MX.sym("X", NXL), ca.MX.sym("g", nm), ca.MX.sym("k", 3)
    a = ca.mtimes(ca.DM(W), X) + k[0]
    return ca.Function("fake_sample", [X, g, k], [a, g + 1.0], ["X", "g", "k"], ["v", "g_next"])


@pytest.fixture(scope="module")
def block(guided_inputs):
    p = np.asarray(guided_inputs["p_ctrl"], float).copy()
    p[PARAM_NAMES.index("com_x")], p[PARAM_NAMES.index("com_y")] = 0.01, -0.02  # off centre
    return make_balance_guidance(_fake_sample(), L, EVERY), p


def _inputs(rng):
    x = np.zeros(12)
    x[3] = 1.0
    x[6:8] = [0.3, -0.2]      # ball velocity
    x[0:2] = [1.5, -0.7]      # position
    z = 0.01 * rng.standard_normal(Z.size)
    z[Z.index("psi_r")], z[Z.index("r_r")] = 0.4, 0.2
    return x, z


@pytest.mark.parametrize("bad", [0, -2, 1.5])
def test_every_below_one_period_is_refused(bad):
    with pytest.raises(ScenarioError, match="every must be an int >= 1"):
        make_balance_guidance(_fake_sample(), L, bad)


def test_a_sample_period_by_hand(block):
    f, p = block
    S = balance_state_layout(L)
    rng = np.random.default_rng(4)
    x, z = _inputs(rng)
    X = np.asarray(make_loop_state()(x, z), float).ravel()
    g = rng.standard_normal(S.size + 1)
    g[0] = 0.0  # sample period
    th_r, dth_r = g[1 + S.offset("theta_r"):][:2], g[1 + S.offset("dtheta_r"):][:2]
    psi, r = z[Z.index("psi_r")], z[Z.index("r_r")]
    th_eq = np.asarray(equilibrium_tilt(p, psi), float).ravel()
    assert np.max(np.abs(th_eq)) > 1e-6  # the COM offset tilts the equilibrium: it shows
    Xs = np.concatenate([X[0:2], th_r - th_eq, dth_r, np.zeros(6), X[12:14]])
    kg = np.array([0.25, 0.0, 0.0])
    a = W @ Xs + 0.25
    out = [np.asarray(o, float).ravel() for o in f(x, [0.1, 0.2, 0.3], g, z, p, kg, TS)]
    np.testing.assert_allclose(out[0], [X[0], X[1], 0.3], rtol=1e-14, atol=1e-15)
    gn = out[1]
    assert gn[0] == 1.0
    np.testing.assert_allclose(gn[1 + S.offset("theta_r"):][:2],
                               th_r + TS * dth_r + 0.5 * TS ** 2 * a, rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(gn[1 + S.offset("dtheta_r"):][:2], dth_r + TS * a,
                               rtol=1e-13, atol=1e-15)
    o = 1 + S.offset("v")
    np.testing.assert_allclose(gn[o:], g[o:] + 1.0, rtol=1e-14)  # the sample's state
    want = tilt_heading_reference()(np.r_[th_r, psi], np.r_[dth_r, r], np.r_[a, 0.0])
    for got, w in zip(out[2:], want):
        np.testing.assert_allclose(got, np.asarray(w, float).ravel(), rtol=1e-12, atol=1e-14)


def test_hold_periods_and_the_counter_cycle(block):
    f, p = block
    S = balance_state_layout(L)
    rng = np.random.default_rng(9)
    x, z = _inputs(rng)
    g = rng.standard_normal(S.size + 1)
    o = 1 + S.offset("v")
    counts = []
    for count in (1.0, 2.0):
        g[0] = count
        gn = np.asarray(f(x, [0, 0, 0], g, z, p, [0.0, 0, 0], TS)[1], float).ravel()
        counts.append(gn[0])
        a = g[o:o + 2]  # held: the last sample's tilt acceleration
        dth = g[1 + S.offset("dtheta_r"):][:2]
        np.testing.assert_allclose(gn[1 + S.offset("dtheta_r"):][:2], dth + TS * a, rtol=1e-13)
        np.testing.assert_array_equal(gn[o:], g[o:])  # no sample
    assert counts == [2.0, 0.0]


def test_initial_state_from_the_power_on_state(guided_inputs):
    S = balance_state_layout(L)
    rng = np.random.default_rng(2)
    x, z = _inputs(rng)
    X = np.asarray(make_loop_state()(x, z), float).ravel()
    g0 = np.asarray(balance_initial_function(S)(x, z, 0.7), float).ravel()
    assert g0.size == S.size + 1 and g0[0] == 0.0
    np.testing.assert_array_equal(g0[1 + S.offset("theta_r"):][:2], z[Z["theta_r"]])
    np.testing.assert_array_equal(g0[1 + S.offset("dtheta_r"):][:2], z[Z["dtheta_r"]])
    M = mpc_state_layout(L)
    m = g0[1 + S.offset("v"):]
    assert m[M.offset("first")] == 1.0 and np.all(m[M["v"]] == 0.0)
    x0 = m[M["x0"]]
    np.testing.assert_allclose(x0, np.concatenate([X[0:2], z[Z["theta_r"]], z[Z["dtheta_r"]],
                                                   np.zeros(6), X[12:14], [0.7, 0.0]]), atol=0)
    assert np.all(m[M.offset("u"):] == 0.0)

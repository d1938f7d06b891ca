"""One control period (sim.period) on toy blocks whose outputs name their inputs: which
reference reaches the balance controller (cascade on/off, feed-forward scaling only the
acceleration, the balance feed replacing the velocity controller's), which parameters the
controllers get (observer switch), the order of the next controller state, the two torque
limits (the controller's direction-preserving one at ``p_ctrl``'s ``tau_max``, the plant's
per-wheel one at ``p_plant``'s, the disturbance added after it) and the push, numerically
and symbolically alike (issue 23: a swapped branch, a dropped factor, the wrong tau_max or
the state parts out of order must show)."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.params import PARAM_NAMES
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.sim.period import (
    TORQUE_LIMIT_MODES,
    actuate,
    apply_push,
    control_period,
    controller_part,
    controller_torque_limit,
    require_finite_controller_limit,
)
from ballbot_casadi.sim.ports import PeriodBlocks

NP = len(PARAM_NAMES)
TAU = PARAM_NAMES.index("tau_max")
S = ca.MX.sym


def _velocity():
    x, v, z, p, k, Ts = S("x", 12), S("v_ref", 3), S("z", 8), S("p", NP), S("k", 26), S("Ts")
    q = ca.vertcat(v[0], v[1], v[2], p[0])
    return ca.Function("ballbot_velocity", [x, v, z, p, k, Ts], [q, 2 * q, 3 * q, z + Ts * k[0]])


def _balance(stateful=False):
    x, q, dq, ddq, p, k = S("x", 12), S("q", 4), S("dq", 4), S("ddq", 4), S("p", NP), S("k", 7)
    tau = ca.vertcat(q[0] + 10 * dq[1] + 100 * ddq[2], x[0] + k[0], p[1])
    diag = ca.vertcat(q[3], dq[3], ddq[3])
    if not stateful:
        return ca.Function("ballbot_toy", [x, q, dq, ddq, p, k], [tau, diag])
    zb = S("zb", 2)
    return ca.Function("ballbot_toy", [x, q, dq, ddq, p, k, zb], [tau + zb[0], diag, 2 * zb + 1])


def _observer():
    x, v, o, p, k, Ts = S("x", 12), S("v_ref", 3), S("o", 3), S("p", NP), S("k_obs", 4), S("Ts")
    p_hat = ca.vertcat(p[0] + 5.0, p[1:])
    return ca.Function("ballbot_obs", [x, v, o, p, k, Ts], [o + 1, p_hat, o[0:2], v[0:2]])


def _guidance(feed=False):
    x, v, g, z, p, k, Ts = S("x", 12), S("v_ref", 3), S("g", 2), S("z", 8), S("p", NP), S("k_guid", 1), S("Ts")
    outs = [k[0] * v + z[0], g + 1]
    if feed:
        outs += [ca.DM([7.0, 0, 0, 0]), ca.DM([0, 8.0, 0, 0]), ca.DM([0, 0, 9.0, 0])]
    return ca.Function("ballbot_guide", [x, v, g, z, p, k, Ts], outs)


def _inputs(cascade=1.0, feedforward=1.0, tau_max=50.0):
    p = np.arange(1.0, NP + 1.0)
    p[TAU] = tau_max
    seq = {"q_ref": np.array([0.5, 0.6, 0.7, 0.8]), "dq_ref": np.array([1.5, 1.6, 1.7, 1.8]),
           "ddq_ref": np.array([2.5, 2.6, 2.7, 2.8]), "v_ref": np.array([0.3, -0.2, 0.1]),
           "w": np.zeros(6)}
    const = {"p_plant": p.copy(), "p_ctrl": p, "k_bal": np.arange(7.0) + 0.25, "k_vel": np.full(26, 2.0),
             "Ts": 0.01, "cascade": cascade, "feedforward": feedforward, "com_observer": 0.0,
             "k_obs": np.zeros(4), "k_guid": np.array([2.0])}
    x = np.arange(12.0) / 10
    return x, seq, const


def test_balance_only_reads_the_sequence_references_and_feedforward_scales_the_acceleration():
    x, seq, const = _inputs(cascade=0.0, feedforward=0.0)
    z = np.arange(8.0)
    out = controller_part(PeriodBlocks(_balance(), _velocity()), x, z, seq, const)
    np.testing.assert_array_equal(out["q_ref_used"], seq["q_ref"])
    np.testing.assert_array_equal(out["dq_ref_used"], seq["dq_ref"])
    np.testing.assert_array_equal(out["ddq_ref_used"], 0.0)
    np.testing.assert_allclose(out["tau_cmd"], [0.5 + 16.0, 0.0 + 0.25, 2.0], rtol=1e-15)
    np.testing.assert_array_equal(out["z_next"], z)  # the velocity state held in balance-only mode
    np.testing.assert_allclose(out["diag"], [0.8, 1.8, 0.0], rtol=1e-15)


def test_cascade_reads_the_velocity_controller_and_advances_its_state():
    x, seq, const = _inputs()
    z = np.arange(8.0)
    out = controller_part(PeriodBlocks(_balance(), _velocity()), x, z, seq, const)
    q = np.array([0.3, -0.2, 0.1, 1.0])
    np.testing.assert_allclose(out["q_ref_used"], q, rtol=1e-15)
    np.testing.assert_allclose(out["ddq_ref_used"], 3 * q, rtol=1e-15)
    np.testing.assert_allclose(out["tau_cmd"], [0.3 + 10 * 2 * -0.2 + 100 * 3 * 0.1, 0.25, 2.0], rtol=1e-14)
    np.testing.assert_allclose(out["z_next"], z + 0.02, rtol=1e-15)
    assert "v_ref_used" not in out and "com_hat" not in out


def test_direction_preserving_limit_at_the_controllers_tau_max():
    x, seq, const = _inputs(tau_max=3.0)  # tau_cmd = [26.3, 0.25, 2.0] scaled to max 3
    out = controller_part(PeriodBlocks(_balance(), _velocity()), x, np.zeros(8), seq, const)
    cmd = np.asarray(out["tau_cmd"])
    np.testing.assert_allclose(out["tau_lim"], cmd * 3.0 / np.max(np.abs(cmd)), rtol=1e-14)
    const["p_plant"] = const["p_plant"].copy()
    const["p_plant"][TAU] = 100.0  # only the controller's value limits here
    out2 = controller_part(PeriodBlocks(_balance(), _velocity()), x, np.zeros(8), seq, const)
    np.testing.assert_allclose(out2["tau_lim"], out["tau_lim"], rtol=0)


def test_observer_switch_guidance_and_state_order():
    x, seq, const = _inputs()
    blocks = PeriodBlocks(_balance(stateful=True), _velocity(), _observer(), _guidance())
    z = np.r_[np.zeros(8), [10.0, 20.0, 30.0], [4.0, 5.0], [0.5, -1.0]]  # z, obs, guide, bal
    out = controller_part(blocks, x, z, seq, const)
    v_used = 2.0 * seq["v_ref"] + 0.0
    np.testing.assert_allclose(out["v_ref_used"], v_used, rtol=1e-15)
    np.testing.assert_allclose(out["com_meas"], v_used[0:2], rtol=1e-15)  # the observer follows it too
    np.testing.assert_allclose(out["com_hat"], [10.0, 20.0], rtol=0)
    np.testing.assert_allclose(out["q_ref_used"], [*v_used, 1.0], rtol=1e-15)  # p_ctrl[0] = 1: switch off
    np.testing.assert_allclose(out["z_next"], np.r_[0.02 * np.ones(8), [11.0, 21.0, 31.0], [5.0, 6.0],
                                                    [2.0, -1.0]], rtol=1e-15)
    np.testing.assert_allclose(out["tau_cmd"][1], 0.0 + 0.25 + 0.5, rtol=1e-15)  # + zb[0]
    const["com_observer"] = 1.0
    on = controller_part(blocks, x, z, seq, const)
    np.testing.assert_allclose(on["q_ref_used"], [*v_used, 6.0], rtol=1e-15)  # p_hat[0] = 1 + 5
    np.testing.assert_allclose(on["tau_cmd"][2], 2.0 + 0.5, rtol=0)  # p_hat[1] = p_ctrl[1], + zb[0]


def test_a_balance_feed_replaces_the_velocity_controllers_references():
    x, seq, const = _inputs()
    blocks = PeriodBlocks(_balance(), _velocity(), guidance=_guidance(feed=True))
    z = np.r_[np.ones(8), [0.0, 0.0]]
    out = controller_part(blocks, x, z, seq, const)
    np.testing.assert_array_equal(out["q_ref_used"], [7.0, 0, 0, 0])
    np.testing.assert_array_equal(out["dq_ref_used"], [0, 8.0, 0, 0])
    np.testing.assert_array_equal(out["ddq_ref_used"], [0, 0, 9.0, 0])
    np.testing.assert_allclose(out["z_next"], np.r_[1.02 * np.ones(8), [1.0, 1.0]], rtol=1e-15)


def test_symbolic_period_equals_the_numeric_one():
    x, seq, const = _inputs(tau_max=3.0)
    blocks = PeriodBlocks(_balance(stateful=True), _velocity(), _observer(), _guidance())
    z = np.r_[np.zeros(8), [10.0, 20.0, 30.0], [4.0, 5.0], [0.5, -1.0]]
    const["com_observer"] = 1.0
    xs, zs = S("x", 12), S("z", z.size)
    ss = {k: S(k, np.size(v)) for k, v in seq.items()}
    cs = {k: S(k, np.size(v)) for k, v in const.items()}
    sym = controller_part(blocks, xs, zs, ss, cs)
    keys = sorted(sym)
    f = ca.Function("f", [xs, zs, *ss.values(), *cs.values()], [sym[k] for k in keys])
    got = f(x, z, *seq.values(), *const.values())
    num = controller_part(blocks, x, z, seq, const)
    for k, v in zip(keys, got):
        np.testing.assert_allclose(np.asarray(v).ravel(), np.ravel(num[k]), rtol=1e-14, err_msg=k)


def test_control_period_push_plant_saturation_and_disturbance():
    x, seq, const = _inputs(tau_max=50.0)
    const["p_plant"] = const["p_plant"].copy()
    const["p_plant"][TAU] = 2.0
    x = np.zeros(12)
    x[2], x[9] = 1.0, 0.3  # upright, a roll rate
    seq["w"] = np.array([0.1, 0.0, 0.0, 0.05, -0.05, 0.5])
    seen = {}

    def plant(xk, tau, tau_lim, tau_dist):
        seen.update(xk=xk, tau=tau, tau_lim=tau_lim, tau_dist=tau_dist)
        return xk + 1.0

    out = control_period(PeriodBlocks(_balance(), _velocity()), x, np.zeros(8), seq, const, plant)
    r = np.asarray(Q.from_rotation_vector(np.array([0.1, 0.0, 0.0])), float).ravel()
    np.testing.assert_allclose(out["x"][2:6], r, rtol=1e-14)
    np.testing.assert_allclose(out["x"][8:12], np.asarray(Q.mul(r, x[8:12]), float).ravel(), rtol=1e-14)
    tl = np.asarray(out["tau_lim"])  # [26.3, x[0] + 0.25 after the push = 0.25, 2]: under 50
    np.testing.assert_allclose(out["tau"], np.clip(tl, -2.0, 2.0) + [0.05, -0.05, 0.5], rtol=1e-15)
    np.testing.assert_allclose(out["tau"], [2.05, 0.2, 2.5], rtol=1e-14)
    np.testing.assert_array_equal(seen["tau_dist"], [0.05, -0.05, 0.5])
    np.testing.assert_array_equal(out["x_next"], out["x"] + 1.0)
    ctl = control_period(PeriodBlocks(_balance(), _velocity()), x, np.zeros(8), seq, const, plant,
                         controller=lambda xk, z, s, c: {"tau_lim": np.array([-3.0, 1.0, 0.0]), "mine": 1})
    np.testing.assert_allclose(ctl["tau"], [-1.95, 0.95, 0.5], rtol=1e-15)
    assert ctl["mine"] == 1


def test_push_keeps_wheel_angles_and_is_identity_at_zero():
    x = np.r_[0.1, 0.2, 1.0, 0.0, 0.0, 0.0, 0.3, 0.4, 0.0, 0.5, 0.0, 0.0, 7.0, 8.0, 9.0]
    np.testing.assert_array_equal(apply_push(x, np.zeros(3)), x)
    y = apply_push(x, np.array([0.0, 0.2, 0.0]))
    np.testing.assert_array_equal(y[[0, 1, 6, 7, 12, 13, 14]], x[[0, 1, 6, 7, 12, 13, 14]])
    np.testing.assert_allclose(y[2:6], [math.cos(0.1), 0.0, math.sin(0.1), 0.0], rtol=1e-15, atol=1e-17)


def test_actuate_and_the_torque_limit_modes():
    np.testing.assert_allclose(actuate(np.array([3.0, -3.0, 1.0]), np.array([0.5, 0.5, 0.5]), 2.0),
                               [2.5, -1.5, 1.5], rtol=1e-15)
    assert TORQUE_LIMIT_MODES == ("direction", "per-wheel")
    assert controller_torque_limit(1.5, "direction") == 1.5
    assert controller_torque_limit(1.5, "per-wheel") == math.inf
    with pytest.raises(ScenarioError) as info:
        controller_torque_limit(1.5, "wheel")
    assert info.value.key == "torque_limit"
    require_finite_controller_limit("direction", "s", "the FMU")
    with pytest.raises(ScenarioError) as info:
        require_finite_controller_limit("per-wheel", "s", "the FMU")
    assert info.value.key == "torque_limit" and "scenario 's': the FMU" in str(info.value)

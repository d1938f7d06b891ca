"""COM-offset observer: the moment balance against the model, the observable part at rest,
the filters' exact discrete response, freezing during commanded motion, the gain checks."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import STATE
from ballbot_casadi.core.params import PARAM_NAMES, load_params
from ballbot_casadi.errors import ArgumentError, ShapeError
from ballbot_casadi.estimation.com_observer import (
    COM_OBSERVER_DEFAULT_GAINS,
    COM_OBSERVER_STATE as O,
    check_com_observer_gains,
    com_moment_coefficients,
    com_observer_initial_state,
    make_com_observer,
    observable_offset,
)
from ballbot_casadi.model.dynamics import make_affine
from ballbot_casadi.model.linearization import balance_point

TS = 0.005
#: The thesis §8.4.2 offset: (-2, -3) cm horizontally, 3 cm higher.
TRUE = load_params().replace(com_x=-0.02, com_y=-0.03, l=0.4213 + 0.03)


@pytest.fixture(scope="module")
def observer():
    return make_com_observer()


@pytest.fixture(scope="module")
def affine():
    return make_affine()


def _rest(q):
    return np.concatenate([[0.0, 0.0], q, np.zeros(6)])


def _omega_dot(ddq, q):
    """Angular acceleration in {K} at rest (dq = 0): 2 vec(ddq o q*)."""
    return 2 * Q.vee(Q.mul(ddq, Q.conj(q)))


def _run(observer, x, o, p, k=COM_OBSERVER_DEFAULT_GAINS, v_ref=None):
    v_ref = np.zeros(3) if v_ref is None else v_ref
    o_next, p_hat, com_hat, meas = observer(x, v_ref, o, p, k, TS)
    return (np.ravel(np.asarray(o_next)), np.ravel(np.asarray(p_hat)), np.ravel(np.asarray(com_hat)),
            np.ravel(np.asarray(meas)))


@pytest.mark.parametrize("rpy", [(0.02, 0.03, 0.4), (-0.06, 0.01, 1.0), (0.0, 0.0, 0.0)])
def test_kappa_is_the_models_quasi_static_ball_acceleration(affine, rpy):
    # torques that leave the body without angular acceleration: the model's ball
    # acceleration a must satisfy d = kappa a (moment balance (1) with dw = 0)
    q = Q.from_rpy(*rpy)
    f, g = (np.asarray(v) for v in affine(_rest(q), TRUE.to_vector()))
    f = f.ravel()
    W = np.column_stack([_omega_dot(g[2:6, i], q) for i in range(3)])
    tau = np.linalg.solve(W, -_omega_dot(f[2:6], q))
    a = (f + g @ tau)[0:2]
    d = (Q.rotation_matrix(q) @ [TRUE.com_x, TRUE.com_y, TRUE.l])[:2]
    kappa, _ = com_moment_coefficients(TRUE.to_vector())
    np.testing.assert_allclose(d, kappa * a, rtol=3e-3, atol=0)


@pytest.mark.parametrize("rpy", [(0.02, 0.03, 0.4), (0.0, 0.0, 0.0)])
def test_lambda_is_the_models_body_acceleration_without_ball_acceleration(affine, rpy):
    # torques that hold the ball (a = 0, no yaw acceleration): d = -lambda e_z x dw
    q = Q.from_rpy(*rpy)
    f, g = (np.asarray(v) for v in affine(_rest(q), TRUE.to_vector()))
    f = f.ravel()
    W = np.column_stack([_omega_dot(g[2:6, i], q) for i in range(3)])
    A = np.vstack([g[0:2], W[2:3]])
    tau = np.linalg.solve(A, -np.concatenate([f[0:2], [_omega_dot(f[2:6], q)[2]]]))
    dd = f + g @ tau
    dw = _omega_dot(dd[2:6], q)
    d = (Q.rotation_matrix(q) @ [TRUE.com_x, TRUE.com_y, TRUE.l])[:2]
    _, lam = com_moment_coefficients(TRUE.to_vector())
    np.testing.assert_allclose(np.abs(dd[0:2]).max(), 0.0, atol=1e-12)
    np.testing.assert_allclose(d, -lam * np.array([-dw[1], dw[0]]), rtol=5e-3, atol=0)


def test_at_the_balance_point_the_measurement_is_the_observable_part(observer):
    # robot at rest on its true balance point; the observer's model has the nominal
    # height: it sees the true direction scaled to its own l (height not observable)
    model = load_params().to_vector()
    x = balance_point(TRUE, yaw=0.7)
    o = com_observer_initial_state(x, model)
    _, _, _, meas = _run(observer, x, o, model, k=[0.3, 2.0, 0.0, 0.1])
    expected = observable_offset([TRUE.com_x, TRUE.com_y], TRUE.l, load_params().l)
    np.testing.assert_allclose(meas, expected, rtol=0, atol=1e-12)
    # and with the true height in the model it is the true offset
    o = com_observer_initial_state(x, TRUE)
    _, _, _, meas = _run(observer, x, o, TRUE.to_vector(), k=[0.3, 2.0, 0.0, 0.1])
    np.testing.assert_allclose(meas, [TRUE.com_x, TRUE.com_y], rtol=0, atol=1e-12)


def test_an_accelerating_robot_is_measured_through_the_moment_balance(observer, affine):
    # tilted off its balance point, accelerating without body angular acceleration:
    # the static condition alone is off by centimetres, the moment balance is not
    q = Q.from_rpy(0.03, -0.02, 0.3)
    p = TRUE.to_vector()
    f, g = (np.asarray(v) for v in affine(_rest(q), p))
    f = f.ravel()
    W = np.column_stack([_omega_dot(g[2:6, i], q) for i in range(3)])
    a = (f + g @ np.linalg.solve(W, -_omega_dot(f[2:6], q)))[0:2]
    v = np.array([0.1, -0.05])
    x = _rest(q)
    x[STATE["dx"]], x[STATE["dy"]] = v
    o = com_observer_initial_state(x, p)
    o[O["v_f"]] = v - TS * a  # the previous period's velocity
    _, _, _, meas = _run(observer, x, o, p, k=[0.3, 2.0, 0.0, 0.1])
    static = o[O["s_f"]]
    assert np.linalg.norm(static - [TRUE.com_x, TRUE.com_y]) > 0.01
    np.testing.assert_allclose(meas, [TRUE.com_x, TRUE.com_y], rtol=0, atol=2e-4)


def test_filters_follow_their_exact_discrete_response_and_p_hat_carries_the_balance_point(observer):
    model = load_params().to_vector()
    x = balance_point(TRUE)
    o = com_observer_initial_state(x, model)
    c = observable_offset([TRUE.com_x, TRUE.com_y], TRUE.l, load_params().l)
    t_obs, t_com = 0.3, 2.0
    k = [t_obs, t_com, 0.1, 0.1]
    b, g = 1 - np.exp(-TS / t_obs), 1 - np.exp(-TS / t_com)
    bal, com = np.zeros(2), np.zeros(2)
    for _ in range(400):
        o, p_hat, com_hat, _ = _run(observer, x, o, model, k)
        bal = bal + b * (c - bal)
        com = com + g * (bal - com)
    np.testing.assert_allclose(o[O["com_bal"]], bal, rtol=0, atol=1e-15)
    np.testing.assert_allclose(com_hat, com, rtol=0, atol=1e-15)
    i = [PARAM_NAMES.index("com_x"), PARAM_NAMES.index("com_y")]
    np.testing.assert_array_equal(p_hat[i], o[O["com_bal"]])
    np.testing.assert_array_equal(np.delete(p_hat, i), np.delete(model, i))
    # 2 s: the balance point's error is exp(-2 s / t_obs) of the initial one, the
    # average (two cascaded filters) is on its way
    np.testing.assert_allclose(np.linalg.norm(c - bal) / np.linalg.norm(c), np.exp(-2.0 / t_obs), rtol=1e-9)
    assert 0.5 < np.linalg.norm(com) / np.linalg.norm(c) < 0.7


def test_estimates_freeze_while_a_motion_is_commanded(observer):
    model = load_params().to_vector()
    x = balance_point(TRUE)
    o = np.array(com_observer_initial_state(x, model), dtype=float).ravel()
    o[O["com"]] = o[O["com_bal"]] + [0.01, -0.02]  # the average lags the balance point
    for v_ref in ([0.1, 0.0, 0.0], [0.0, 0.0, 0.2]):
        o_next, _, com_hat, _ = _run(observer, x, o, model, v_ref=np.array(v_ref))
        np.testing.assert_array_equal(o_next[O["com_bal"]], o[O["com_bal"]])
        np.testing.assert_array_equal(com_hat, o[O["com"]])


@pytest.mark.parametrize("v_ref, still", [
    ([0.6e-9, 0.0, 0.7e-9], True),       # |v_ref| = 0.92e-9: still a standstill command
    ([0.0, -0.6e-9, 0.0], True),
    ([0.7e-9, 0.0, 0.8e-9], False),      # |v_ref| = 1.06e-9: a motion command
    ([0.0, 0.0, -1.05e-9], False),
])
def test_the_standstill_command_is_one_below_1e_9_in_norm(observer, v_ref, still):
    """Speeds below 1e-9 (m/s, rad/s, the norm of the command) count as standing still:
    the filters update; above it they freeze."""
    model = load_params().to_vector()
    x = balance_point(TRUE)
    o = com_observer_initial_state(x, model)
    o_next, _, com_hat, _ = _run(observer, x, o, model, v_ref=np.array(v_ref))
    moved = np.abs(o_next[O["com_bal"]] - o[O["com_bal"]])
    if still:
        assert np.all(moved > 1e-6), moved
    else:
        np.testing.assert_array_equal(o_next[O["com_bal"]], o[O["com_bal"]])
        np.testing.assert_array_equal(com_hat, o[O["com"]])


def test_initial_state_is_bumpless_for_a_robot_at_rest(observer):
    p = TRUE.to_vector()
    x = balance_point(TRUE, yaw=-2.0)
    o = com_observer_initial_state(x, p)
    o_next, p_hat, _, _ = _run(observer, x, o, p)
    np.testing.assert_allclose(o_next, o, rtol=0, atol=1e-15)
    np.testing.assert_allclose(p_hat, p, rtol=0, atol=1e-15)
    with pytest.raises(ShapeError, match="12-state"):
        com_observer_initial_state(np.zeros(5), p)


@pytest.mark.parametrize("bad, msg", [([1.0, 2.0, 0.1], "need 4 entries"),
                                      ([0.0, 2.0, 0.1, 0.1], "t_obs = 0.0"),
                                      ([0.3, 2.0, -0.1, 0.1], "t_diff = -0.1"),
                                      ([0.3, np.nan, 0.1, 0.1], "t_com = nan"),
                                      ("fast", "must be numbers")])
def test_gain_checks_name_what_is_wrong(bad, msg):
    with pytest.raises(ArgumentError, match=msg):
        check_com_observer_gains(bad)
    np.testing.assert_array_equal(check_com_observer_gains(COM_OBSERVER_DEFAULT_GAINS),
                                  COM_OBSERVER_DEFAULT_GAINS)

"""LQR velocity controller with integral action (thesis §7.1, §7.3)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.control import (
    VELOCITY_NKV,
    VELOCITY_NZ,
    check_velocity_gains,
    default_balance_gains,
    default_velocity_gains,
    design_velocity_lqr,
    make_flc,
    make_velocity_controller,
    saturate_torques,
    velocity_initial_state,
)
from ballbot_casadi.control.velocity import _NX_LQR, _Q_DEFAULT, _R_DEFAULT, design_model, measured_tilt
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.errors import ArgumentError, BallbotTypeError, ShapeError
from ballbot_casadi.model.integrators import make_rk4_n
from ballbot_casadi.model.numeric import make_state

TS = 0.005


@pytest.fixture(scope="module")
def vel():
    return make_velocity_controller()


@pytest.fixture(scope="module")
def kv(model_functions, default_params):
    return default_velocity_gains(model_functions["jac"], default_params.to_vector(), TS)


def test_interface(vel, kv):
    assert vel.name() == "ballbot_velocity"
    assert vel.name_in() == ["x", "v_ref", "z", "p", "k", "Ts"]
    assert vel.name_out() == ["q_ref", "dq_ref", "ddq_ref", "z_next"]
    assert vel.size1_in(2) == VELOCITY_NZ and vel.size1_in(4) == VELOCITY_NKV
    assert kv.shape == (VELOCITY_NKV,)
    np.testing.assert_array_equal(check_velocity_gains(kv), kv)


def test_reduced_design_model_is_exact_at_upright(model_functions, default_params):
    """The ball-velocity and tilt rows do not depend on x, y, q0, yaw (reduction is exact)."""
    x0 = make_state()
    A, _ = (np.asarray(M) for M in model_functions["jac"](x0, np.zeros(3), default_params.to_vector()))
    assert np.abs(A[np.ix_([6, 7, 9, 10], [0, 1, 2, 5, 8, 11])]).max() < 1e-12


def test_design_model_is_the_linearised_plant_under_the_flc(model_functions):
    """The continuous design model's plant rows (ball velocity, tilt, tilt rate) equal the
    Jacobian of the plant ODE closed by the FLC itself (default gains, CasADi AD), on a robot
    with rolling friction so that every reduced coordinate acts: the columns of the reduced
    state ``[dx, dy, th_x, th_y, dth_x, dth_y]`` (``th = 2 q_vec``), of the tilt reference and
    its rate (``q_ref = [1, th_r / 2]``, ``dq_ref = [0, dth_r / 2]``) and of the input, the
    tilt-reference acceleration (``ddq_ref = [0, a / 2]``)."""
    import casadi as ca

    from ballbot_casadi import load_params
    from ballbot_casadi.control import FLC_DEFAULT_GAINS

    p = load_params(Bvk=0.4, Bvm=0.01, Bvb=0.05).to_vector()
    x, r, dr, a = (ca.MX.sym(n, k) for n, k in (("x", 12), ("r", 2), ("dr", 2), ("a", 2)))
    q_ref = ca.vertcat(1, r / 2, 0)
    tau = make_flc(model_functions["affine"])(x, q_ref / ca.norm_2(q_ref), ca.vertcat(0, dr / 2, 0),
                                              ca.vertcat(0, a / 2, 0), p, FLC_DEFAULT_GAINS)[0]
    xd = model_functions["ode"](x, tau, p)
    J = ca.Function("J", [x, r, dr, a], [ca.jacobian(xd, v) for v in (x, r, dr, a)])
    Jx, Jr, Jdr, Ja = (np.asarray(m) for m in J(make_state(), np.zeros(2), np.zeros(2), np.zeros(2)))
    T = np.zeros((12, 6))  # reduced -> full state
    T[6, 0] = T[7, 1] = 1.0
    T[[3, 4, 9, 10], [2, 3, 4, 5]] = 0.5
    S = np.zeros((6, 12))  # full derivative -> reduced derivative
    S[0, 6] = S[1, 7] = 1.0
    S[[2, 3, 4, 5], [3, 4, 9, 10]] = 2.0
    Ac, Bc, _, _ = design_model(model_functions["jac"], p, TS)
    scale = np.abs(Ac).max()
    assert abs(Ac[0, 0]) > 1e-3 and abs(Ac[1, 1]) > 1e-3  # friction acts on the ball velocity
    for got, want in ((Ac[0:6, 0:6], S @ Jx @ T), (Ac[0:6, 6:8], S @ Jr), (Ac[0:6, 8:10], S @ Jdr),
                      (Bc[0:6], S @ Ja)):
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-9 * scale)


def test_lqr_closed_loop_is_stable_and_slower_than_the_balance_loop(model_functions, default_params):
    p = default_params.to_vector()
    K = design_velocity_lqr(model_functions["jac"], p, TS)
    Ac, _, Ad, Bd = design_model(model_functions["jac"], p, TS)
    # open loop: the balance loop's double poles at -10 and integrators (velocity, ref, p_e)
    ev_open = np.linalg.eigvals(Ac)
    assert np.sum(np.abs(ev_open + 10.0) < 1e-5) == 4
    assert np.sum(np.abs(ev_open) < 1e-9) == 8
    z = np.linalg.eigvals(Ad - Bd @ K)
    assert np.abs(z).max() < 1.0
    s = np.log(z.astype(complex)) / TS
    outer = s[np.abs(s.real + 10.0) > 1e-3]
    assert outer.real.max() < -0.2  # stable, integral mode not negligibly slow
    assert np.sort(-outer.real)[:4].max() < 10.0 / 3.0  # velocity poles >= 3x slower (§7.1)
    np.testing.assert_array_equal(K, design_velocity_lqr(model_functions["jac"], p, TS))


def test_initial_state_is_bumpless(vel, kv, default_params):
    x = make_state(roll=0.03, pitch=-0.02, yaw=2.0)
    z = velocity_initial_state(x)
    q_ref = np.asarray(vel(x, np.zeros(3), z, default_params.to_vector(), kv, TS)[0]).ravel()
    np.testing.assert_allclose(q_ref, x[2:6], atol=1e-12)
    with pytest.raises(ShapeError):
        velocity_initial_state(np.zeros(5))


def _run_fixed_state(vel, kv, p, x, v_ref, n):
    z = velocity_initial_state(make_state())
    out = []
    for _ in range(n):
        q, dq, ddq, z = (np.asarray(a).ravel() for a in vel(x, v_ref, z, p, kv, TS))
        out.append(np.concatenate([q, dq, ddq, z]))
    return np.array(out)


def test_reference_derivatives_are_consistent(vel, kv, default_params):
    """q_ref(k+1) = q_ref + Ts dq_ref + Ts^2/2 ddq_ref + O(Ts^3) along the reference model."""
    x = make_state(dx=0.3, dy=-0.2, roll=0.01)
    R = _run_fixed_state(vel, kv, default_params.to_vector(), x, np.array([0.0, 0.1, 0.8]), 150)
    q, dq, ddq = R[:, 0:4], R[:, 4:8], R[:, 8:12]
    pred = q[:-1] + TS * dq[:-1] + 0.5 * TS**2 * ddq[:-1]
    # O(Ts^3) ~ 3e-8; the final step onto the tilt limit (clamp) may add a few 1e-6
    np.testing.assert_allclose(q[1:], pred, atol=5e-6)
    assert np.abs(dq).max() > 1e-3 and np.abs(ddq).max() > 1e-2  # the test is not vacuous
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-14)


def test_limits_are_respected(vel, kv, default_params):
    """Tilt <= 5 deg, tilt rate <= 20 deg/s, heading rate <= 1 rad/s (thesis §7.1)."""
    x = make_state(dx=-3.0, dy=2.0)
    R = _run_fixed_state(vel, kv, default_params.to_vector(), x, np.array([2.0, 0.0, 5.0]), 400)
    z = R[:, 12:]
    assert np.abs(z[:, 0:2]).max() <= math.radians(5) + 1e-12
    assert np.abs(z[:, 0:2]).max() > math.radians(4.9)  # the limit was reached
    assert np.abs(z[:, 2:4]).max() <= math.radians(20) + 1e-12
    assert np.abs(z[:, 7]).max() <= 1.0 + 1e-12
    tilt = np.array([measured_tilt(q) for q in R[:, 0:4]])
    assert np.abs(tilt).max() <= math.radians(5) + 1e-9


def _cascade(model_functions, vel, kv, p_plant, p_ctrl, tau_max, T, v_ref):
    flc = make_flc(model_functions["affine"])
    kb = default_balance_gains("flc")
    step = make_rk4_n(model_functions["ode"], 5)
    x = make_state()
    z = velocity_initial_state(x)
    X = [x]
    for i in range(int(round(T / TS))):
        q, dq, ddq, z = (np.asarray(a).ravel() for a in vel(x, v_ref(i * TS), z, p_ctrl, kv, TS))
        tau = saturate_torques(np.asarray(flc(x, q, dq, ddq, p_ctrl, kb)[0]).ravel(), tau_max)
        x = np.asarray(step(x, tau, p_plant, TS)).ravel()
        X.append(x)
    return np.array(X)


def test_com_offset_standstill(vel, kv, model_functions, default_params):
    """Thesis §9.2: COM offset (-2, -3, +3) cm; speed -> 0, COM settles over the ball centre."""
    P = default_params
    plant = P.replace(com_x=-0.02, com_y=-0.03, l=P.l + 0.03)
    X = _cascade(model_functions, vel, kv, plant.to_vector(), P.to_vector(), P.tau_max, 18.0,
                 lambda t: np.zeros(3))
    assert np.abs(X[-1, 6:8]).max() < 2e-3
    com = Q.rotate(X[-1, 2:6], np.array([-0.02, -0.03, P.l + 0.03]))
    assert np.abs(com[:2]).max() < 1e-4
    assert np.degrees(np.abs([measured_tilt(x[2:6]) for x in X])).max() < 6.0


def test_velocity_step_is_tracked(vel, kv, model_functions, default_params):
    """A 0.3 m/s ramp in x with a heading rate: tracked without steady-state error."""
    P = default_params
    X = _cascade(model_functions, vel, kv, P.to_vector(), P.to_vector(), P.tau_max, 10.0,
                 lambda t: np.array([min(0.3, 0.5 * t), 0.0, 0.2]))
    np.testing.assert_allclose(X[-1, 6:8], [0.3, 0.0], atol=5e-3)
    assert np.degrees(np.abs([measured_tilt(x[2:6]) for x in X])).max() <= 5.05


def test_bad_inputs(model_functions, default_params, kv):
    bad = kv.copy()
    bad[3] = np.nan
    with pytest.raises(ArgumentError, match="finite"):
        check_velocity_gains(bad)
    with pytest.raises(ArgumentError, match="entries"):
        check_velocity_gains(kv[:-1])
    bad = kv.copy()
    bad[-8] = 0.0
    with pytest.raises(ArgumentError, match="tilt_max"):
        check_velocity_gains(bad)
    with pytest.raises(ArgumentError, match="Ts"):
        design_velocity_lqr(model_functions["jac"], default_params.to_vector(), -1.0)
    with pytest.raises(BallbotTypeError, match="jac"):
        design_velocity_lqr(model_functions["affine"], default_params.to_vector(), TS)


def test_lqr_weights_of_the_wrong_size_are_refused_and_given_ones_are_used(model_functions, default_params):
    p = default_params.to_vector()
    for Qw, Rw in ((np.ones(_NX_LQR - 1), None), (np.ones(_NX_LQR + 1), None), (None, np.ones(3)),
                   (None, np.ones(1))):
        with pytest.raises(ShapeError, match=rf"^Qw must have {_NX_LQR} and Rw 2 diagonal entries$"):
            design_velocity_lqr(model_functions["jac"], p, TS, Qw=Qw, Rw=Rw)
    K = design_velocity_lqr(model_functions["jac"], p, TS)
    # the defaults given explicitly (as a column) are the same design; other weights are not
    same = design_velocity_lqr(model_functions["jac"], p, TS, Qw=_Q_DEFAULT.reshape(-1, 1),
                               Rw=list(_R_DEFAULT))
    np.testing.assert_array_equal(same, K)
    heavier = design_velocity_lqr(model_functions["jac"], p, TS, Rw=4.0 * _R_DEFAULT)
    assert np.abs(heavier).sum() < np.abs(K).sum()   # dearer inputs, smaller gains


def test_default_lqr_weights_are_brysons_rule_on_the_documented_excursions():
    """1/max^2 of: 0.04 m/s velocity error, 1 rad and 1 rad/s on the plant's tilt and
    rate, the thesis §7.1 limits 5 deg / 20 deg/s on the tilt reference and its rate,
    0.1 m position error (x and y alike); 1 rad/s^2 on the inputs."""
    per_axis = [0.04, 1.0, 1.0, math.radians(5.0), math.radians(20.0), 0.1]
    want = 1.0 / np.repeat(per_axis, 2) ** 2
    np.testing.assert_allclose(_Q_DEFAULT, want, rtol=1e-15, atol=0)
    np.testing.assert_array_equal(_R_DEFAULT, [1.0, 1.0])

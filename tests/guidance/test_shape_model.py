"""Shape-accelerated prediction model of the balance feed: the condensed prediction
against an independent integration of the continuous model, the gains against the
nonlinear model, the outputs."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from ballbot_casadi.errors import ShapeError
from ballbot_casadi.guidance.condensed import condense
from ballbot_casadi.guidance.prediction import NXL
from ballbot_casadi.guidance.shape_model import ShapeGains, shape_model
from ballbot_casadi.model.dynamics import make_ode
from ballbot_casadi.sim.balance_feed import shape_gains
from ballbot_casadi.sim.path_following import path_scenario
from ballbot_casadi.guidance.paths import line_path

BLOCKS = (1, 1, 1, 1, 2, 2, 2, 2, 4, 4)


@pytest.fixture(scope="module")
def p_ctrl():
    return path_scenario(line_path((0.0, 0.0), (1.0, 0.0)), 0.1).inputs(periods=(0, 1))["p_ctrl"]


@pytest.fixture(scope="module")
def gains(p_ctrl):
    return shape_gains(p_ctrl)


def test_condensed_prediction_equals_an_integration_of_the_continuous_model(gains, rng):
    """Per axis ``p' = v, v' = K_th theta + K_u u + ..., theta' = dtheta, dtheta' = u``
    written out here and integrated by an adaptive Runge-Kutta method (not the matrix
    exponential) under the blocked, held inputs: the condensed prediction agrees."""
    model = shape_model(gains, 0.1)
    cond = condense(model, BLOCKS)
    x0 = np.zeros(NXL + 2)
    x0[0:2], x0[2:4], x0[4:6], x0[12:14] = [0.2, -0.1], [0.01, -0.02], [0.05, 0.0], [1.0, 2.0]
    x0[NXL:] = [0.3, 0.4]
    ub = rng.uniform(-1.5, 1.5, cond.n_u)
    U = cond.inputs(ub)

    def f(t, y):
        k = min(int(t / 0.1 + 1e-9), len(U) - 1)
        u, dds = U[k, 0:2], U[k, 2]
        v, th, dth = y[2:4], y[4:6], y[6:8]
        acc = gains.K_v @ v + gains.K_th @ th + gains.K_dth @ dth + gains.K_u @ u
        return np.r_[v, acc, dth, u, y[9], dds]

    y = np.r_[x0[12:14], x0[0:2], x0[2:4], x0[4:6], x0[NXL:]]
    ref = [y]
    for k in range(len(U)):
        sol = solve_ivp(f, (0.1 * k, 0.1 * (k + 1)), ref[-1], rtol=1e-11, atol=1e-12,
                        first_step=1e-3, max_step=0.02)
        ref.append(sol.y[:, -1])
    ref = np.array(ref)
    X = cond.states(x0, ub)
    np.testing.assert_allclose(X[:, 12:14], ref[:, 0:2], rtol=0, atol=1e-8)  # position
    np.testing.assert_allclose(X[:, 0:2], ref[:, 2:4], rtol=0, atol=1e-8)  # velocity
    np.testing.assert_allclose(X[:, 2:4], ref[:, 4:6], rtol=0, atol=1e-9)  # tilt
    np.testing.assert_allclose(X[:, 4:6], ref[:, 6:8], rtol=0, atol=1e-9)  # tilt rate
    np.testing.assert_allclose(X[:, NXL:], ref[:, 8:10], rtol=0, atol=1e-9)  # progress
    np.testing.assert_array_equal(X[:, 6:12], 0.0)  # the unused loop-model states


def test_gains_match_the_nonlinear_model_at_a_small_tilt(p_ctrl, gains):
    """Hold a small tilt with zero tilt acceleration: the torque that zeroes the
    quaternion's vector acceleration in the *nonlinear* ODE (found by a Newton step on
    the torque, in which the ODE is affine) makes the ball accelerate by K_th theta."""
    ode = make_ode()
    for th in ([0.01, 0.0], [0.0, -0.015]):
        x = np.zeros(12)
        half = np.array(th) / 2
        q = np.array([np.cos(np.linalg.norm(half)), half[0], half[1], 0.0])
        x[2:6] = q / np.linalg.norm(q)
        f0 = np.asarray(ode(x, np.zeros(3), p_ctrl), float).ravel()
        J = np.column_stack([np.asarray(ode(x, e, p_ctrl), float).ravel() - f0
                             for e in np.eye(3)])
        tau = np.linalg.solve(J[9:12], -f0[9:12])
        acc = np.asarray(ode(x, tau, p_ctrl), float).ravel()[6:8]
        np.testing.assert_allclose(acc, gains.K_th @ np.array(th), rtol=2e-2, atol=1e-6)
    # shape accelerated: x is driven by the pitch tilt, y by the roll tilt with a minus
    # (Kugle's ddx ~ k q3, ddy ~ -k q2), of the size of g times the body's mass fraction
    assert gains.K_th[0, 1] > 0 and gains.K_th[1, 0] < 0
    np.testing.assert_allclose(gains.K_th[0, 1], -gains.K_th[1, 0], rtol=1e-3)
    assert 3.0 < gains.K_th[0, 1] < 9.82
    # the non-minimum phase: a tilt acceleration first pushes the ball backwards
    assert gains.K_u[0, 1] < 0 and gains.K_u[1, 0] > 0


def test_outputs_and_kugle_only(gains):
    model = shape_model(gains, 0.1)
    x = np.arange(NXL, dtype=float) / 10
    u = np.array([0.3, -0.2])
    acc = gains.K_v @ x[0:2] + gains.K_th @ x[2:4] + gains.K_dth @ x[4:6] + gains.K_u @ u
    np.testing.assert_allclose(model.C["acc"] @ x + model.D["acc"] @ u, acc, rtol=1e-12)
    np.testing.assert_array_equal(model.C["tilt_acc"] @ x + model.D["tilt_acc"] @ u, u)
    np.testing.assert_array_equal(model.C["tilt"] @ x, x[2:4])
    k = shape_model(gains, 0.1, kugle_only=True)
    np.testing.assert_array_equal(k.D["acc"], 0.0)
    np.testing.assert_allclose(k.C["acc"][:, 2:4], gains.K_th)


def test_bad_gains_and_step_are_refused(gains):
    with pytest.raises(ShapeError, match="K_th"):
        ShapeGains(gains.K_v, np.ones(3), gains.K_dth, gains.K_u)
    with pytest.raises(ShapeError, match="dt"):
        shape_model(gains, 0.0)


@pytest.mark.parametrize("dt", [0.0, -0.1, float("inf"), float("nan")])
def test_a_step_that_is_not_a_positive_number_is_refused_before_the_exponential(gains, dt):
    """The shape model refuses the step itself, with its own line, before the matrix
    exponential sees it (an infinite or negative step would reach the loop model's check
    only after ``expm``, or not at all)."""
    with pytest.raises(ShapeError, match=rf"^dt must be > 0 s, got {dt!r}$"):
        shape_model(gains, dt)

"""Balance LQR, the linear baseline balance controller."""

from __future__ import annotations

import casadi as ca
import control
import numpy as np
import pytest

from ballbot_casadi.control import BALANCE_DIAG_NAMES, saturate_torques
from ballbot_casadi.control.balance_lqr import (
    ATTITUDE_STATES,
    LQR_GAIN_NAMES,
    balance_design_model,
    design_balance_lqr,
    make_balance_lqr,
)
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.constants import TS_CONTROL
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.model.integrators import make_rk4_n
from ballbot_casadi.model.linearization import linearize, sorted_eig
from ballbot_casadi.model.numeric import make_state


@pytest.fixture(scope="module")
def design(model_functions, default_params):
    lm = linearize(default_params, functions=model_functions)
    return lm, design_balance_lqr(lm)


@pytest.fixture(scope="module")
def lqr(model_functions):
    return make_balance_lqr(model_functions["affine"])


def test_interface(lqr, design):
    assert lqr.name() == "ballbot_lqr"
    assert lqr.name_in() == ["x", "q_ref", "dq_ref", "ddq_ref", "p", "k"]
    assert lqr.name_out() == ["tau", "diag"]
    assert lqr.numel_in(5) == len(LQR_GAIN_NAMES) == 18
    assert lqr.numel_out(1) == len(BALANCE_DIAG_NAMES)
    assert design[1].shape == (3, 6)
    with pytest.raises(ScenarioError, match="Qw needs 6 and Rw 3"):
        design_balance_lqr(design[0], Qw=np.ones(5))


def test_design_closed_loop_is_stable_and_optimal(design):
    lm, K = design
    _, _, Ad, Bd = balance_design_model(lm)
    eig = np.linalg.eigvals(Ad - Bd @ K)
    assert np.abs(eig).max() < 1.0
    # the open loop is unstable (the inverted pendulum): 2 continuous poles near +3.7 rad/s
    assert np.abs(np.linalg.eigvals(Ad)).max() > 1.01
    # an independent Riccati solution gives the same closed loop
    Qw = np.diag(1 / np.array([np.sin(np.radians(2.5))] * 2 + [np.sin(np.radians(5))]
                              + [np.radians(10)] * 2 + [np.radians(30)]) ** 2)
    K2, _, E2 = control.dlqr(Ad, Bd, Qw, np.eye(3) / lm.tau_max**2)
    # entries that are zero by symmetry come out at round-off of the solver: 1e-9 of the gain scale
    np.testing.assert_allclose(K, K2, rtol=1e-6, atol=1e-9 * np.abs(K2).max())
    np.testing.assert_allclose(sorted_eig(Ad - Bd @ K), sorted_eig(np.diag(E2)), rtol=1e-8, atol=1e-10)


def test_controller_function_realises_the_design(design, lqr, model_functions, default_params):
    """Jacobian of the sampled nonlinear loop (RK4 plant + the CasADi controller) at upright,
    reduced to the attitude tangent block: its eigenvalues are the design's."""
    lm, K = design
    p = default_params.to_vector()
    k = K.ravel()  # row-major
    step = make_rk4_n(model_functions["ode"], 5)
    x = ca.MX.sym("x", 12)
    up, z4 = ca.DM([1, 0, 0, 0]), ca.DM.zeros(4)
    xn = step(x, lqr(x, up, z4, z4, p, k)[0], p, TS_CONTROL)
    J = np.asarray(ca.Function("J", [x], [ca.jacobian(xn, x)])(lm.op.x))
    Jr = lm.T.T @ J @ lm.T
    i = list(ATTITUDE_STATES)
    _, _, Ad, Bd = balance_design_model(lm)
    np.testing.assert_allclose(sorted_eig(Jr[np.ix_(i, i)]), sorted_eig(Ad - Bd @ K),
                               rtol=0, atol=1e-6)


def test_nonlinear_recovery_from_a_small_tilt(design, lqr, model_functions, default_params):
    _, K = design
    p, k = default_params.to_vector(), K.ravel()
    step = make_rk4_n(model_functions["ode"], 5)
    x = make_state(roll=np.radians(2), pitch=np.radians(-1.5), yaw=np.radians(20))
    q_ref = Q.from_rpy(0, 0, np.radians(20))
    U = []
    for _ in range(600):
        tau = saturate_torques(np.asarray(lqr(x, q_ref, np.zeros(4), np.zeros(4), p, k)[0]).ravel(),
                               default_params.tau_max)
        U.append(tau)
        x = np.asarray(step(x, tau, p, TS_CONTROL)).ravel()
    rpy = np.degrees(Q.to_rpy(x[2:6]))
    np.testing.assert_allclose(rpy, [0, 0, 20], rtol=0, atol=0.01)
    assert np.abs(U).max() < default_params.tau_max  # no saturation for a 2 deg tilt

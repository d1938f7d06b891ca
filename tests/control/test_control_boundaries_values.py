"""Control helpers at and just past their limits, against hand values: the velocity gain
check (the LQR part may have any sign, the limits must be > 0), the tilt and heading of a
quaternion built from known angles (numpy and CasADi), the bumpless initial state, the
disturbance observer's arming threshold and the balance LQR's refusals."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.control import default_balance_gains, make_balance_controller
from ballbot_casadi.control.balance_lqr import design_balance_lqr
from ballbot_casadi.control.disturbance_observer import DOB_STATE
from ballbot_casadi.control.velocity import (
    VELOCITY_DEFAULT_LIMITS,
    VELOCITY_LIMIT_NAMES,
    check_velocity_gains,
    measured_tilt,
    tilt_heading_quaternion,
    velocity_initial_state,
)
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import STATE
from ballbot_casadi.core.layout import VELOCITY_CONTROLLER_STATE as Z
from ballbot_casadi.core.params import load_params
from ballbot_casadi.errors import ArgumentError, ScenarioError
from ballbot_casadi.model.dynamics import make_affine
from ballbot_casadi.model.linearization import linearize


def _k(lqr=None, **lim):
    K = np.linspace(-1.0, 1.0, 24) if lqr is None else lqr
    vals = dict(zip(VELOCITY_LIMIT_NAMES, VELOCITY_DEFAULT_LIMITS), **lim)
    return np.r_[K, [vals[n] for n in VELOCITY_LIMIT_NAMES]]


def test_velocity_gain_check_limits():
    k = _k(**{n: 1e-300 for n in VELOCITY_LIMIT_NAMES})  # any positive limit, any-sign gain
    np.testing.assert_array_equal(check_velocity_gains(list(k)), k)
    with pytest.raises(ArgumentError, match="^velocity limits must be > 0; invalid: v_max, k_r$"):
        check_velocity_gains(_k(v_max=0.0, k_r=-1.0))
    with pytest.raises(ArgumentError, match="invalid: tilt_max$"):
        check_velocity_gains(_k(tilt_max=-1e-300))
    with pytest.raises(ArgumentError, match=r"need 32 entries \(2x12 LQR gain, then tilt_max, "
                                            r"tilt_rate_max, .*k_r\), got 33"):
        check_velocity_gains(np.r_[_k(), 1.0])
    with pytest.raises(ArgumentError, match=r"must be finite \(NaN or inf found\)"):
        check_velocity_gains(_k(lqr=np.r_[np.zeros(23), math.inf]))
    with pytest.raises(ArgumentError, match="velocity gains must be numbers"):
        check_velocity_gains(["x"] * 32)


@pytest.mark.parametrize("th", [(0.1, 0.0), (0.0, 0.2), (0.07, -0.05), (-0.3, 0.25)])
def test_measured_tilt_inverts_the_tilt_heading_quaternion(th):
    for psi in (0.0, 1.3, -2.9):
        q = tilt_heading_quaternion(th[0], th[1], psi)
        np.testing.assert_allclose(measured_tilt(q), th, rtol=0, atol=1e-14)
        s = ca.SX.sym("q", 4)
        f = ca.Function("t", [s], [measured_tilt(s)])
        np.testing.assert_allclose(np.asarray(f(q)).ravel(), th, rtol=0, atol=1e-14)
    # the composition order: x tilt, then y tilt, then heading
    want = Q.mul(Q.mul([math.cos(th[0] / 2), math.sin(th[0] / 2), 0, 0],
                       [math.cos(th[1] / 2), 0, math.sin(th[1] / 2), 0]),
                 [math.cos(0.35), 0, 0, math.sin(0.35)])
    np.testing.assert_allclose(tilt_heading_quaternion(th[0], th[1], 0.7), want, atol=1e-15)


def test_initial_state_reads_tilt_and_heading_back():
    x = np.zeros(12)
    x[STATE["q"]] = 3.0 * tilt_heading_quaternion(0.04, -0.03, 2.2)  # normalised inside
    x[STATE["dx"]], x[STATE["dy"]] = 0.3, -0.2
    z = velocity_initial_state(x)
    want = np.zeros(Z.size)
    want[Z["theta_r"]] = [0.04, -0.03]
    want[Z.index("psi_r")] = 2.2
    np.testing.assert_allclose(z, want, rtol=0, atol=1e-14)
    x[0] = math.nan
    with pytest.raises(Exception, match="x0 must be a finite 12-state"):
        velocity_initial_state(x)


@pytest.mark.parametrize("armed,used", [(0.5, False), (0.5 + 1e-9, True), (0.0, False), (1.0, True)])
def test_observer_arms_strictly_above_one_half(armed, used):
    p = load_params().to_vector()
    x = np.zeros(12)
    x[STATE["q"]] = Q.from_rpy(0.02, -0.01, 0.3)
    x[STATE["dq"]] = Q.mul(x[STATE["q"]], np.array([0.0, 0.4, -0.3, 0.2])) / 2
    k = default_balance_gains("flc_dob")
    d_prev, w_pred = np.array([0.5, -0.3, 0.2]), np.array([0.1, 0.2, -0.3])
    out = make_balance_controller("flc_dob", make_affine())(
        x, [1.0, 0, 0, 0], np.zeros(4), np.zeros(4), p, k, np.r_[d_prev, w_pred, armed])
    d_hat = np.asarray(out[2]).ravel()[DOB_STATE["d_hat"]]
    omega = 2 * Q.vee(Q.mul(Q.conj(x[STATE["q"]]), x[STATE["dq"]]))
    want = d_prev + k[6:9] * (omega - w_pred) if used else d_prev
    np.testing.assert_allclose(d_hat, want, rtol=1e-12, atol=1e-12)


def test_balance_lqr_refusals():
    lin = linearize(load_params())
    for Ts in (0.0, -0.005, math.nan, "0.005"):
        with pytest.raises(ScenarioError, match="^Ts must be a finite number > 0, got "):
            design_balance_lqr(lin, Ts)
    with pytest.raises(ScenarioError, match="Qw needs 6 and Rw 3 diagonal entries, got 5 and 3"):
        design_balance_lqr(lin, 0.005, Qw=np.ones(5))
    with pytest.raises(ScenarioError, match="got 6 and 2"):
        design_balance_lqr(lin, 0.005, Rw=np.ones(2))
    assert design_balance_lqr(lin, 0.005).shape == (3, 6)

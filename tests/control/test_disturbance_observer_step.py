"""One period of the disturbance observer against the module's equations evaluated by hand
from the model's affine form, with a command beyond the torque limit (the prediction
uses the *applied*, limited torque) and a carried, non-zero estimate."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.control import default_balance_gains, make_balance_controller, saturate_torques
from ballbot_casadi.control.disturbance_observer import DOB_GAIN_NAMES, DOB_STATE
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import GENERALISED, STATE
from ballbot_casadi.core.params import load_params
from ballbot_casadi.model.dynamics import make_affine
from ballbot_casadi.sim.scenario import initial_state

TS = 0.005


def _body_terms(x, p):
    """F = 2 vec(q* o f_q), G = 2 vec(q* o g_q) and omega = 2 vec(q* o dq)."""
    f, g = (np.asarray(v) for v in make_affine()(x, p))
    q, dq = x[STATE["q"]], x[STATE["dq"]]
    F = 2 * Q.vee(Q.mul(Q.conj(q), f[GENERALISED["q"]].ravel()))
    G = np.column_stack([2 * Q.vee(Q.mul(Q.conj(q), g[GENERALISED["q"], j])) for j in range(3)])
    return F, G, 2 * Q.vee(Q.mul(Q.conj(q), dq))


@pytest.mark.parametrize("armed", [1.0, 0.0])
def test_one_period_with_a_saturated_command(armed):
    params = load_params()
    p = params.to_vector()
    x = np.array(initial_state(12.0, -9.0, 20.0))
    x[STATE["dq"]] = Q.mul(x[STATE["q"]], np.array([0.0, 0.8, -0.6, 0.4])) / 2
    args = (x, np.array([1.0, 0, 0, 0]), np.zeros(4), np.zeros(4), p)
    k = default_balance_gains("flc_dob", Ts=TS)
    L = k[[DOB_GAIN_NAMES.index(f"L{i}") for i in (1, 2, 3)]]
    F, G, omega = _body_terms(x, p)
    d_prev = np.array([0.5, -0.3, 0.2])
    w_pred = omega + np.array([0.01, -0.02, 0.005])
    zb = np.r_[d_prev, w_pred, armed]
    tau, _, zb_next = (np.asarray(v).ravel() for v in
                       make_balance_controller("flc_dob", make_affine())(*args, k, zb))
    d_hat = d_prev + L * (omega - w_pred) if armed else d_prev
    np.testing.assert_allclose(zb_next[DOB_STATE["d_hat"]], d_hat, rtol=1e-12, atol=1e-12)
    tau_flc = np.asarray(make_balance_controller("flc", make_affine())(
        *args, default_balance_gains("flc"))[0]).ravel()
    np.testing.assert_allclose(tau, tau_flc - np.linalg.solve(G, d_hat), rtol=1e-9, atol=1e-9)
    assert np.abs(tau).max() > 2 * params.tau_max  # the limit acts on this command
    tau_a = saturate_torques(tau, params.tau_max)
    np.testing.assert_allclose(zb_next[DOB_STATE["w_pred"]], omega + TS * (F + G @ tau_a + d_hat),
                               rtol=1e-10, atol=1e-10)
    assert zb_next[DOB_STATE["armed"]] == 1.0

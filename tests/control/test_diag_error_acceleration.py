"""Every balance controller's ``diag`` against the plant: ``y`` and ``dy`` are the error
output and its rate, and ``v`` is the error acceleration ``ddy`` that the controller's
torque produces on the model (FLC, SMC, STA, DOB: the commanded one they realise; LQR: the
one its torque gives, ``D + E tau``).  ``ddy`` is measured by central differences of the
controllers' own ``y`` along the model integrated forwards and backwards with the torque
held, ``dy`` by the first difference."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.control import (
    BALANCE_CONTROLLERS,
    balance_state_size,
    default_balance_gains,
    make_balance_controller,
)
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.model.integrators import make_rk4_n
from ballbot_casadi.model.linearization import linearize
from ballbot_casadi.model.numeric import make_state

H = 1e-4


@pytest.mark.parametrize("name", sorted(BALANCE_CONTROLLERS))
def test_v_is_the_error_acceleration_of_the_torque(name, model_functions, default_params):
    p = default_params.to_vector()
    ctrl = make_balance_controller(name, model_functions["affine"])
    k = default_balance_gains(name, linearize(default_params, functions=model_functions))
    zb = [np.zeros(balance_state_size(name))] if balance_state_size(name) else []
    x = make_state(roll=np.radians(1.5), pitch=np.radians(-1.0), yaw=np.radians(20.0))
    x[8:12] = Q.mul(x[2:6], np.array([0.0, 0.02, -0.03, 0.05])) / 2
    q_ref = np.asarray(Q.from_rpy(0.0, 0.0, np.radians(15.0)), float).ravel()
    z4 = np.zeros(4)
    out = ctrl(x, q_ref, z4, z4, p, k, *zb)
    tau, diag = np.asarray(out[0]).ravel(), np.asarray(out[1]).ravel()
    rk4 = make_rk4_n(model_functions["ode"], 4)

    def y_of(xx):
        return np.asarray(ctrl(xx, q_ref, z4, z4, p, k, *zb)[1]).ravel()[3:6]

    xp = np.asarray(rk4(x, tau, p, H)).ravel()
    xm = np.asarray(rk4(x, tau, p, -H)).ravel()
    y0, yp, ym = diag[3:6], y_of(xp), y_of(xm)
    np.testing.assert_allclose(y_of(x), y0, rtol=0, atol=0)
    np.testing.assert_allclose((yp - ym) / (2 * H), diag[6:9], rtol=1e-6, atol=1e-9)
    ddy = (yp - 2 * y0 + ym) / H**2
    v = diag[9:12]
    assert np.abs(v).max() > 1e-2  # a non-trivial error acceleration
    np.testing.assert_allclose(ddy, v, rtol=1e-4, atol=1e-4 * np.abs(v).max())

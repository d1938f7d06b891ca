"""The super-twisting controller's commanded error acceleration ``v`` against the
zero-order-hold kinematics it must realise: held over one period ``h`` on ``ddy = v``,
``y+ = y + h dy + h^2/2 v``, ``dy+ = dy + h v``, so ``S+ = dy+ + K y+`` must equal the
implicit step's ``s_next`` (computed here by ``ballbot_sta_step`` from ``S = dy + K y``)."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.control.super_twisting import STA_DEFAULT_GAINS, make_sta_step, make_super_twisting
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.model.numeric import make_state


@pytest.mark.parametrize("zb", [np.zeros(3), np.array([0.2, -0.1, 0.05])])
def test_commanded_acceleration_realises_the_next_sliding_variable_under_the_zoh(
        model_functions, default_params, zb):
    k = np.array(STA_DEFAULT_GAINS, float)
    K, k1, k2, h = k[0:3], k[3:6], k[6:9], k[9]
    x = make_state(roll=np.radians(3.0), pitch=np.radians(-2.0), yaw=np.radians(10.0))
    x[8:12] = Q.mul(x[2:6], np.array([0.0, 0.05, -0.03, 0.1])) / 2  # dq: a body rate
    up, z4 = np.array([1.0, 0, 0, 0]), np.zeros(4)
    st = make_super_twisting(model_functions["affine"])
    _, diag, zb_next = (np.asarray(v).ravel() for v in
                        st(x, up, z4, z4, default_params.to_vector(), k, zb))
    y, dy, v = diag[3:6], diag[6:9], diag[9:12]
    S = dy + K * y
    s_next, z_next, _ = (np.asarray(a).ravel() for a in make_sta_step()(S, zb, k1, k2, h))
    y1 = y + h * dy + 0.5 * h**2 * v
    dy1 = dy + h * v
    np.testing.assert_allclose(dy1 + K * y1, s_next, rtol=0, atol=1e-12)
    np.testing.assert_allclose(zb_next, z_next, rtol=0, atol=1e-15)
    assert np.abs(S).min() > 1e-3  # away from the manifold: the step is not trivial

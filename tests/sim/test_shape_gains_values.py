"""The balance feed's shape-model gains (sim.balance_feed.shape_gains) against the
linearised model itself: for a reduced state ``s = [v, theta, dtheta]`` (asymmetric, every
entry non-zero) and a tilt acceleration ``u``, the torque that gives the quaternion's vector
part the acceleration ``[u/2, 0]`` (``q_{1,2} = theta_{x,y} / 2``, solved here by
``numpy.linalg.solve``) makes the ball accelerate by ``K_v v + K_th theta + K_dth dtheta +
K_u u`` (issue 23: a wrong half-angle factor, a dropped row or a swapped block must show)."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.core.params import PARAM_NAMES, load_params
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.model.dynamics import make_jacobians
from ballbot_casadi.sim.balance_feed import shape_gains


@pytest.fixture(scope="module", params=["com offset", "friction"])
def p(request):
    """A COM offset; and rolling and motor friction, under which the tilt rate acts on the
    ball (at the upright robot without friction its column is zero)."""
    if request.param == "friction":
        return load_params().replace(Bvk=0.4, Bvm=0.01, Bvb=0.05).to_vector()
    return load_params().replace(com_x=0.004, com_y=-0.003).to_vector()


def _state(s: np.ndarray) -> np.ndarray:
    """The 12-state of the reduced state: ball velocity, q_{1,2} = theta / 2, omega = dtheta."""
    x = np.zeros(12)
    x[6:8] = s[0:2]
    x[3:5] = s[2:4] / 2
    x[9:11] = s[4:6] / 2
    return x


def test_ball_acceleration_of_the_reduced_state_and_tilt_acceleration(p):
    g = shape_gains(p)
    up = np.zeros(12)
    up[2] = 1.0
    A, B = (np.asarray(M, float) for M in make_jacobians()(up, np.zeros(3), p))
    for s, u in ((np.array([0.3, -0.2, 0.05, -0.04, 0.7, 0.25]), np.array([1.3, -0.6])),
                 (np.array([-0.1, 0.4, -0.02, 0.06, -0.3, 0.9]), np.array([-0.4, 2.0]))):
        x = _state(s)
        tau = np.linalg.solve(B[9:12], np.r_[u / 2, 0.0] - A[9:12] @ x)
        dx = A @ x + B @ tau
        np.testing.assert_allclose(dx[9:12], np.r_[u / 2, 0.0], rtol=0, atol=1e-12)
        want = dx[6:8]
        got = g.K_v @ s[0:2] + g.K_th @ s[2:4] + g.K_dth @ s[4:6] + g.K_u @ u
        np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12)
        # each block on its own (a swapped block would still sum alike only by chance)
        for blk, sl in ((g.K_v, slice(0, 2)), (g.K_th, slice(2, 4)), (g.K_dth, slice(4, 6))):
            e = np.zeros(6)
            e[sl] = s[sl]
            xe = _state(e)
            te = np.linalg.solve(B[9:12], -A[9:12] @ xe)
            np.testing.assert_allclose(blk @ s[sl], (A @ xe + B @ te)[6:8], rtol=1e-9, atol=1e-12)
        if p[PARAM_NAMES.index("Bvm")] > 0:
            assert np.abs(np.fliplr(g.K_dth).diagonal()).min() > 1e-3  # tilt about x moves y
        tu = np.linalg.solve(B[9:12], np.r_[u / 2, 0.0])
        np.testing.assert_allclose(g.K_u @ u, (B @ tu)[6:8], rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("bad", [np.zeros(3), np.full(21, np.nan)])
def test_a_bad_parameter_vector_is_refused(bad):
    with pytest.raises(ScenarioError, match="finite parameter vector of 21 entries"):
        shape_gains(bad)

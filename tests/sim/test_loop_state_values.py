"""The guidance layer's loop-model state ``X`` of plant + velocity controller, entry by entry.

``X = [v(2), theta(2), dtheta(2), theta_r(2), dtheta_r(2), p_e(2), p(2)]``: the ball
velocity and position from the plant state, the inertial tilts of the body axis and their
rate (checked by a central difference of the tilts along ``dq``), and the velocity
controller's tilt reference, its rate and the position-error integrators by name.
"""

from __future__ import annotations

import numpy as np

from ballbot_casadi.control.velocity import measured_tilt
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import STATE, STATE_DXY, STATE_XY
from ballbot_casadi.core.layout import VELOCITY_CONTROLLER_STATE as Z
from ballbot_casadi.guidance.prediction import NXL
from ballbot_casadi.sim.path_following import make_loop_state, path_scenario
from ballbot_casadi.guidance.paths import line_path


def test_every_entry_of_the_loop_state():
    q = np.asarray(Q.from_rpy(0.04, -0.03, 0.7), float).reshape(4)
    w = np.array([0.3, -0.2, 0.5])
    dq = 0.5 * np.asarray(Q.mul(q, np.r_[0.0, w]), float).reshape(4)
    x = np.zeros(12)
    x[STATE_XY], x[STATE["q"]], x[STATE_DXY], x[STATE["dq"]] = [1.5, -2.5], q, [0.4, -0.1], dq
    z = np.arange(1.0, Z.size + 1) / 10
    X = np.asarray(make_loop_state()(x, z), float).ravel()
    assert X.size == NXL
    np.testing.assert_array_equal(X[0:2], [0.4, -0.1])
    np.testing.assert_allclose(X[2:4], measured_tilt(q), rtol=0, atol=1e-15)
    h = 1e-6
    dth = (measured_tilt(q + h * dq) - measured_tilt(q - h * dq)) / (2 * h)
    np.testing.assert_allclose(X[4:6], dth, rtol=1e-6, atol=1e-9)
    assert np.all(np.abs(X[4:6]) > 0.02)  # both tilt rates present
    np.testing.assert_array_equal(X[6:8], z[Z["theta_r"]])
    np.testing.assert_array_equal(X[8:10], z[Z["dtheta_r"]])
    np.testing.assert_array_equal(X[10:12], z[Z["p_e"]])
    np.testing.assert_array_equal(X[12:14], [1.5, -2.5])


def test_path_scenario_starts_upright_at_rest_on_the_path_start():
    sc = path_scenario(line_path([0.7, -0.3], [3.0, 1.0], speed=0.4), 2.5)
    x0 = np.asarray(sc.x0, float)
    expect = np.zeros(12)
    expect[STATE_XY] = [0.7, -0.3]
    expect[STATE["q"].start] = 1.0
    np.testing.assert_array_equal(x0, expect)
    assert sc.cascade and sc.duration == 2.5 and sc.controller == "flc"

"""Pure pursuit on a straight line against hand-computed references: the velocity towards
the look-ahead point at the path's reference speed plus the lateral pull, limited to the
path's speed, and the speed ramp near the end of an open path."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.guidance.paths import line_path
from ballbot_casadi.guidance.pure_pursuit import PurePursuit


def _x(px, py):
    x = np.zeros(14)
    x[12:14] = px, py  # the loop state ends with the position
    return x


def test_reference_towards_the_look_ahead_point_with_the_lateral_pull():
    path = line_path([0.0, 0.0], [4.0, 0.0], speed=0.5)
    pp = PurePursuit(path, lookahead=0.3, k_lat=0.5)
    v = pp.step(_x(1.0, 0.1))
    assert pp.progress() == pytest.approx(1.0, abs=1e-6)
    # towards (1.3, 0): direction (0.3, -0.1) / sqrt(0.1), times 0.5 m/s; pull 0.5 * (0, -0.1)
    d = np.array([0.3, -0.1]) / math.sqrt(0.1)
    want = 0.5 * d + np.array([0.0, -0.05])
    want *= min(1.0, 0.5 / np.linalg.norm(want))  # limited to the path's speed
    np.testing.assert_allclose(v, want, rtol=0, atol=1e-6)
    assert np.linalg.norm(v) == pytest.approx(0.5, abs=1e-9)
    # on the path, well before the end: straight along it at the path's speed
    np.testing.assert_allclose(pp.step(_x(1.1, 0.0)), [0.5, 0.0], rtol=0, atol=1e-6)


def test_speed_ramps_down_before_the_end_of_an_open_path():
    path = line_path([0.0, 0.0], [4.0, 0.0], speed=0.5)
    pp = PurePursuit(path, lookahead=0.3, k_lat=1.0)
    pp.step(_x(3.0, 0.0))
    v = pp.step(_x(3.9, 0.0))
    # 0.1 m before the end at the default stopping deceleration a_max / 2 = 0.5 m/s^2:
    # sqrt(2 * 0.5 * 0.1) = 0.316 m/s, towards the end of the line
    np.testing.assert_allclose(v, [math.sqrt(0.1), 0.0], rtol=0, atol=1e-6)
    with pytest.raises(ScenarioError, match="lookahead"):
        PurePursuit(path, lookahead=0.0)


def test_a_look_ahead_point_on_the_robot_gives_no_direction():
    # a closed circle as long as the look-ahead: the target is the robot's own projection
    from ballbot_casadi.guidance.paths import arc_path

    circle = arc_path((0.0, 0.0), 1.0, 0.0, 2 * math.pi)
    for off, pulled in ((7e-10, True), (2e-9, False)):  # within 1e-9 m: lateral pull only
        pp = PurePursuit(circle, lookahead=circle.length, k_lat=1.0)
        tx, ty = circle.tangent(0.7)
        p = circle.point(0.7) + off * np.array([ty, -tx])  # off the path, outwards
        v = pp.step(np.r_[np.zeros(12), p])
        if pulled:
            assert np.linalg.norm(v) == pytest.approx(off, rel=1e-3)
        else:  # the direction to the target: the full reference speed, towards the path
            assert np.linalg.norm(v) == pytest.approx(circle.speed, rel=1e-6)
            assert v @ np.array([ty, -tx]) == pytest.approx(-circle.speed, rel=1e-6)

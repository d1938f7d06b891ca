"""The COM-observer metrics' geometry by hand: the vertical seen from the body for a
quaternion that is *not* of unit norm (the function normalises), each component's sign
on rotations about x and y separately, the inclination error's angle and vector, the
trailing window mean, the standstill start and the commanded position on asymmetric
commands (x and y differ, so a swapped column shows)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.analysis.com_observer import (
    commanded_position,
    inclination_error_deg,
    standstill_start,
    trailing_mean_angle_deg,
    vertical_in_body,
)


def _qx(a: float) -> np.ndarray:
    return np.array([math.cos(a / 2), math.sin(a / 2), 0.0, 0.0])


def _qy(a: float) -> np.ndarray:
    return np.array([math.cos(a / 2), 0.0, math.sin(a / 2), 0.0])


def test_vertical_in_body_by_hand_and_normalised():
    a, b = 0.3, -0.2
    # R = Rx(a): R^T e_z = (0, sin a, cos a); R = Ry(b): R^T e_z = (-sin b, 0, cos b)
    want = np.array([[0.0, math.sin(a), math.cos(a)], [-math.sin(b), 0.0, math.cos(b)]])
    q = np.vstack([_qx(a), _qy(b)])
    np.testing.assert_allclose(vertical_in_body(q), want, rtol=0, atol=1e-15)
    # a quaternion of norm 3 (and one of norm 0.5) gives the same unit vertical
    np.testing.assert_allclose(vertical_in_body(q * np.array([[3.0], [0.5]])), want, rtol=0, atol=1e-14)
    # yaw does not move the vertical
    qz = np.array([math.cos(0.4), 0.0, 0.0, math.sin(0.4)])
    np.testing.assert_allclose(vertical_in_body(qz), [[0.0, 0.0, 1.0]], atol=1e-15)


def test_inclination_error_angle_and_vector():
    q = np.vstack([_qx(0.1), _qy(0.05)])
    q_ref = np.vstack([_qx(0.04), 2.0 * _qy(0.05)])   # the second: the same attitude, norm 2
    e, ang = inclination_error_deg(q, q_ref)
    np.testing.assert_allclose(ang, [math.degrees(0.06), 0.0], rtol=1e-12, atol=1e-12)
    # n x n_ref for two verticals in the body y-z plane: along x, sin(0.1 - 0.04)
    np.testing.assert_allclose(e[0], [math.sin(0.1 - 0.04), 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(e[1], 0.0, atol=1e-15)


def test_trailing_mean_over_the_window_from_the_start_while_shorter():
    t = np.arange(6) * 1.0
    s = np.array([0.1, 0.2, 0.3, 0.0, 0.0, 0.4])
    e = np.column_stack([s, np.zeros(6), np.zeros(6)])
    got = trailing_mean_angle_deg(e, t, window_s=3.0)
    # window (t - 3, t]: means 0.1, 0.15, 0.2, 0.5/3, 0.1, 0.4/3
    want = np.degrees(np.arcsin([0.1, 0.15, 0.2, 0.5 / 3, 0.1, 0.4 / 3]))
    np.testing.assert_allclose(got, want, rtol=1e-12)


def test_standstill_start_and_commanded_position_by_hand():
    Ts = 0.5
    v = np.zeros((6, 3))
    v[1] = [0.2, -0.1, 0.0]
    v[3] = [0.0, 0.0, 0.3]          # a heading-rate command alone still moves
    assert standstill_start(v, Ts) == pytest.approx(2.0)
    assert standstill_start(np.zeros((4, 3)), Ts) == 0.0
    v_all = np.ones((4, 3))
    assert standstill_start(v_all, Ts) == pytest.approx(4 * Ts)
    x0 = np.zeros(12)
    x0[0:2] = [1.0, -2.0]
    v2 = np.array([[0.2, 0.4, 9.0], [0.1, -0.6, 9.0]])
    np.testing.assert_allclose(commanded_position(x0, v2, Ts), [1.0 + 0.15, -2.0 - 0.1], atol=1e-15)

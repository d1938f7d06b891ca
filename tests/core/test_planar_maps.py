"""The planar state of the outer-loop designs (core.layout.planar_maps) by hand: a planar
state with every entry different lands in the plant state as ball velocity, half tilt in
``q_{1,2}`` and half tilt rate in ``dq_{1,2}`` (q = [q0, q1, q2, q3], x = [x, y, q, dx, dy,
dq]); the plant state's derivative reads back through ``S``; nothing else is touched."""

from __future__ import annotations

import numpy as np

from ballbot_casadi.core.layout import PLANAR_STATE, planar_maps


def test_a_planar_state_lands_where_the_thesis_puts_it():
    T, S = planar_maps()
    assert T.shape == (12, 6) and S.shape == (6, 12)
    assert PLANAR_STATE.names == ("dx", "dy", "th_x", "th_y", "dth_x", "dth_y")
    s = np.array([0.3, -0.2, 0.05, -0.04, 0.7, 0.25])
    #                x    y    q0   q1      q2     q3   dx   dy    dq0  dq1    dq2    dq3
    want = np.array([0.0, 0.0, 0.0, 0.025, -0.02, 0.0, 0.3, -0.2, 0.0, 0.35, 0.125, 0.0])
    np.testing.assert_array_equal(T @ s, want)
    np.testing.assert_array_equal(S @ want, s)
    np.testing.assert_array_equal(S @ T, np.eye(6))
    # S reads only those entries: a change of position, q0, yaw or their rates is invisible
    other = np.zeros(12)
    other[[0, 1, 2, 5, 8, 11]] = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]
    np.testing.assert_array_equal(S @ other, np.zeros(6))
    T2, _ = planar_maps()
    T2[0, 0] = 9.0  # a fresh pair on every call: a caller's change stays its own
    assert planar_maps()[0][0, 0] == 0.0

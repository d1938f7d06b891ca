"""The thesis sweep mean's grid: its default span is +-5 deg about each axis (a rotation
outside is reached only up to the edge of the grid), negative angles included."""

from __future__ import annotations

import numpy as np

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.estimation.quaternion_mean import sweep_mean


def test_default_span_ends_at_five_degrees_on_each_axis():
    # roll beyond the span: the grid's edge 5; pitch and yaw inside, on the 0.5 deg grid
    q = Q.from_rpy(*np.radians([7.0, -3.5, 1.5]))
    got = np.degrees(Q.to_rpy(sweep_mean(np.asarray(q).reshape(1, 4), step_deg=0.5)))
    np.testing.assert_allclose(got, [5.0, -3.5, 1.5], rtol=0, atol=1e-9)
    # a rotation about one axis only, past the negative edge: the edge -5
    q = Q.from_rpy(*np.radians([0.0, -6.0, 0.0]))
    got = np.degrees(Q.to_rpy(sweep_mean(np.asarray(q).reshape(1, 4), step_deg=0.5)))
    np.testing.assert_allclose(got, [0.0, -5.0, 0.0], rtol=0, atol=1e-9)

"""measured_tilt's numpy and CasADi branches against hand values, including a body-axis
component past +-1 (a non-unit quaternion): both clip it to +-1, i.e. a pitch of +-90 deg."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.control.velocity import measured_tilt

_Q = ca.SX.sym("q", 4)
_CAS = ca.Function("tilt", [_Q], [measured_tilt(_Q)])


@pytest.mark.parametrize("q, want", [
    # nx = 2 (q1 q3 + q0 q2) = -1.28, ny = 0, nz = q0^2 - q2^2 = 0: clipped to -90 deg
    ([-0.8, 0.0, 0.8, 0.0], [0.0, -math.pi / 2]),
    ([0.8, 0.0, 0.8, 0.0], [0.0, math.pi / 2]),  # nx = +1.28
    # unit: roll by 0.3 rad about x, ny = -sin 0.3, nz = cos 0.3; nx = 0
    ([math.cos(0.15), math.sin(0.15), 0.0, 0.0], [0.3, 0.0]),
    # unit: pitch 0.2 rad, nx = sin 0.2
    ([math.cos(0.1), 0.0, math.sin(0.1), 0.0], [0.0, 0.2]),
])
def test_numpy_and_casadi_tilts_are_the_hand_values(q, want):
    np.testing.assert_allclose(measured_tilt(np.array(q)), want, rtol=0, atol=1e-15)
    np.testing.assert_allclose(np.asarray(_CAS(q)).ravel(), want, rtol=0, atol=1e-15)

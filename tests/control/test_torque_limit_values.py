"""The direction-preserving torque limit on numbers and on symbols against hand values:
scaled by tau_max / max|tau_i| when over the limit (the direction kept), unchanged within."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.control.torque_limit import saturate_torques

CASES = [
    (np.array([3.0, -1.5, 0.75]), 1.5, np.array([1.5, -0.75, 0.375])),  # scaled by 1/2
    (np.array([-0.2, 4.0, 1.0]), 1.0, np.array([-0.05, 1.0, 0.25])),  # by 1/4
    (np.array([0.5, -1.0, 0.25]), 1.0, np.array([0.5, -1.0, 0.25])),  # at the limit: as is
    (np.array([0.1, -0.2, 0.3]), 2.0, np.array([0.1, -0.2, 0.3])),
]


@pytest.mark.parametrize("tau,tau_max,expected", CASES)
def test_numbers_and_symbols_give_the_hand_values(tau, tau_max, expected):
    out = saturate_torques(tau, tau_max)
    np.testing.assert_allclose(out, expected, rtol=1e-15, atol=0)
    assert out is not tau  # a copy, never the caller's array
    t, m = ca.SX.sym("t", 3), ca.SX.sym("m")
    f = ca.Function("lim", [t, m], [saturate_torques(t, m)])
    np.testing.assert_allclose(np.asarray(f(tau, tau_max)).ravel(), expected, rtol=1e-15, atol=0)
    # the direction is kept: the result is parallel to the command
    assert np.linalg.norm(np.cross(out, tau)) <= 1e-15 * np.linalg.norm(tau) ** 2

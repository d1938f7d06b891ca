"""The embedded software's state at power-on against hand-computed values from a
tilted, yawed, moving and rotating start (every rate and offset non-zero, so a sign, a
swapped component or a frame mix-up shows)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.control.velocity import VELOCITY_NZ
from ballbot_casadi.core.layout import VELOCITY_FILTER_STATE
from ballbot_casadi.core.params import load_params
from ballbot_casadi.estimation.com_observer import COM_OBSERVER_STATE
from ballbot_casadi.sim.embedded import controller_layout, initial_controller_state


def _mul(a, b):
    a0, av, b0, bv = a[0], np.asarray(a[1:]), b[0], np.asarray(b[1:])
    return np.concatenate([[a0 * b0 - av @ bv], a0 * bv + b0 * av + np.cross(av, bv)])


def _conj(q):
    return np.array([q[0], -q[1], -q[2], -q[3]])


def _rot(q):
    """R(q) by hand: columns are the body axes in {K}."""
    return np.column_stack([_mul(_mul(q, np.r_[0, e]), _conj(q))[1:] for e in np.eye(3)])


ROLL, PITCH, YAW = 0.05, -0.03, 0.8
W_BODY = np.array([0.2, -0.35, 0.6])


def _x0(scale: float = 1.0) -> np.ndarray:
    qx = np.array([math.cos(ROLL / 2), math.sin(ROLL / 2), 0, 0])
    qy = np.array([math.cos(PITCH / 2), 0, math.sin(PITCH / 2), 0])
    qz = np.array([math.cos(YAW / 2), 0, 0, math.sin(YAW / 2)])
    q = _mul(_mul(qz, qy), qx)
    dq = 0.5 * _mul(q, np.r_[0, W_BODY])
    return np.concatenate([[0.7, -1.2], scale * q, [0.25, -0.4], dq]), q


@pytest.mark.parametrize("estimator", ["ukf", "ekf"])
def test_power_on_state_from_a_moving_rotating_start(estimator):
    x0, q = _x0()
    p = load_params().replace(com_x=-0.02, com_y=0.015)
    c = initial_controller_state(estimator, x0, p.to_vector(), observer=True)
    L = controller_layout(estimator, VELOCITY_NZ, COM_OBSERVER_STATE.size)
    xa = c[L["xa"]]
    np.testing.assert_allclose(xa[:4], q, rtol=0, atol=1e-15)
    np.testing.assert_allclose(xa[4:7], W_BODY, rtol=0, atol=1e-14)       # body rate, not -w, not world
    xv = c[L["xv"]]
    np.testing.assert_array_equal(xv[VELOCITY_FILTER_STATE["v"]], [0.25, -0.4])
    np.testing.assert_array_equal(c[L["pos"]], [0.7, -1.2])
    z = c[L["z"]]
    n = _rot(q)[:, 2]
    np.testing.assert_allclose(z[0:2], [math.atan2(-n[1], n[2]), math.asin(n[0])], rtol=0, atol=1e-14)
    np.testing.assert_array_equal(z[2:6], 0.0)
    obs = c[L["obs"]]
    w_world = _rot(q) @ W_BODY
    np.testing.assert_allclose(obs[8:10], w_world[:2], rtol=0, atol=1e-14)
    np.testing.assert_array_equal(obs[6:8], [0.25, -0.4])
    np.testing.assert_array_equal(obs[0:4], [-0.02, 0.015, -0.02, 0.015])
    # s_f solves R_h s = -l R[0:2, 2] (the static measurement at the initial attitude)
    R = _rot(q)
    np.testing.assert_allclose(R[0:2, 0:2] @ obs[4:6], -p.l * R[0:2, 2], rtol=0, atol=1e-14)
    # a non-unit quaternion in x0 is normalised first: the same state
    x_scaled, _ = _x0(1.7)
    c2 = initial_controller_state(estimator, x_scaled, p.to_vector(), observer=True)
    np.testing.assert_allclose(c2[L["xa"]][:4], q, rtol=0, atol=1e-15)
    np.testing.assert_allclose(c2[L["xa"]][4:7], W_BODY, rtol=0, atol=1e-14)

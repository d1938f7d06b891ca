"""The MPC's prediction model (closed velocity loop) against an RK4 simulation written here.

A random 12-state design model with a gain ``K`` is simulated with a zero-order-held
tilt-reference acceleration ``a = -K (X - E v_ref)`` per control period (RK4, 50
sub-steps) and the velocity reference held over the MPC step; ``p_e' = ... - v_ref``
and ``p' = v``.  The outputs are checked against their definitions.
"""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.errors import ShapeError
from ballbot_casadi.guidance.prediction import NXL, closed_velocity_loop

TS, DT = 0.01, 0.05


@pytest.fixture(scope="module")
def system():
    rng = np.random.default_rng(3)
    Ac = 0.5 * rng.normal(size=(12, 12)) - 0.5 * np.eye(12)
    Bc = rng.normal(size=(12, 2))
    K = 0.3 * rng.normal(size=(2, 12))
    return Ac, Bc, K


def _xdot(Ac, Bc, x, a, v_ref):
    X = x[:12]
    dX = Ac @ X + Bc @ a
    dX[10:12] -= v_ref
    return np.concatenate([dX, X[0:2]])


def _rk4_period(Ac, Bc, K, x, v_ref, n_sub=50):
    E = np.zeros((12, 2))
    E[0:2] = np.eye(2)
    a = -K @ (x[:12] - E @ v_ref)  # held over the period
    h = TS / n_sub
    for _ in range(n_sub):
        k1 = _xdot(Ac, Bc, x, a, v_ref)
        k2 = _xdot(Ac, Bc, x + h / 2 * k1, a, v_ref)
        k3 = _xdot(Ac, Bc, x + h / 2 * k2, a, v_ref)
        k4 = _xdot(Ac, Bc, x + h * k3, a, v_ref)
        x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return x


def test_one_mpc_step_matches_a_zoh_rk4_simulation(system):
    Ac, Bc, K = system
    lm = closed_velocity_loop(Ac, Bc, K, TS, DT)
    assert lm.A.shape == (NXL, NXL) and lm.B.shape == (NXL, 2) and lm.dt == DT
    rng = np.random.default_rng(4)
    x0, v = rng.normal(size=NXL), np.array([0.7, -0.4])
    x = x0.copy()
    for _ in range(int(round(DT / TS))):
        x = _rk4_period(Ac, Bc, K, x, v)
    np.testing.assert_allclose(lm.A @ x0 + lm.B @ v, x, rtol=1e-9, atol=1e-10)


def test_simulate_chains_steps_with_each_held_reference(system):
    Ac, Bc, K = system
    lm = closed_velocity_loop(Ac, Bc, K, TS, DT)
    x0 = np.linspace(-1, 1, NXL)
    v = np.array([[0.2, 0.1], [-0.3, 0.5], [0.0, 0.0]])
    xs = lm.simulate(x0, v)
    assert xs.shape == (4, NXL)
    np.testing.assert_array_equal(xs[0], x0)
    for k in range(3):
        np.testing.assert_allclose(xs[k + 1], lm.A @ xs[k] + lm.B @ v[k], rtol=1e-14, atol=1e-14)


def test_outputs_are_their_definitions(system):
    Ac, Bc, K = system
    lm = closed_velocity_loop(Ac, Bc, K, TS, DT)
    rng = np.random.default_rng(6)
    x, v = rng.normal(size=NXL), rng.normal(size=2)
    y = {k: lm.C[k] @ x + lm.D[k] @ v for k in ("v", "tilt", "tilt_rate", "acc", "tilt_acc")}
    E = np.zeros((12, 2))
    E[0:2] = np.eye(2)
    a = -K @ (x[:12] - E @ v)
    np.testing.assert_allclose(y["v"], x[0:2], atol=1e-14)
    np.testing.assert_allclose(y["tilt"], x[2:4], atol=1e-14)
    np.testing.assert_allclose(y["tilt_rate"], x[4:6], atol=1e-14)
    np.testing.assert_allclose(y["tilt_acc"], a, rtol=1e-12, atol=1e-14)
    # ball acceleration: the velocity rows of the continuous closed loop
    np.testing.assert_allclose(y["acc"], _xdot(Ac, Bc, x, a, v)[0:2], rtol=1e-12, atol=1e-14)
    for k in lm.C:
        assert lm.C[k].shape == (2, NXL) and lm.D[k].shape == (2, 2)


def test_single_period_step_and_bad_inputs(system):
    Ac, Bc, K = system
    lm = closed_velocity_loop(Ac, Bc, K, TS, TS)
    x0, v = np.ones(NXL), np.array([0.1, 0.2])
    np.testing.assert_allclose(lm.A @ x0 + lm.B @ v, _rk4_period(Ac, Bc, K, x0, v), rtol=1e-9, atol=1e-10)
    with pytest.raises(ShapeError, match="integer multiple"):
        closed_velocity_loop(Ac, Bc, K, TS, 0.025)
    with pytest.raises(ShapeError, match="12x12"):
        closed_velocity_loop(Ac, Bc.T, K, TS, DT)

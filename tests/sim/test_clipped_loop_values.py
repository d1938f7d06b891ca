"""ClippedLoop, the NMPC's linearisation: per node, its step against its own one-point
step, its Jacobians against central differences, its outputs and small-signal matrices
against the shipped linear loop model (built independently), its clip against the
linear model where the velocity controller's limits act."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.guidance.paths import line_path
from ballbot_casadi.guidance.prediction import NXL
from ballbot_casadi.sim.path_following import path_scenario, velocity_loop_model
from ballbot_casadi.sim.prediction_models import ClippedLoop

DT = 0.1


@pytest.fixture(scope="module")
def loop():
    inp = path_scenario(line_path((0.0, 0.0), (3.0, 0.0), 0.5), DT).inputs()
    return ClippedLoop(inp, DT), velocity_loop_model(inp["p_ctrl"], inp["k_vel"], DT)


def _nodes():
    """Three distinct nodes: small signals, a moderate tilted state, a fast one (clips)."""
    rng = np.random.default_rng(77)
    X = np.zeros((NXL, 3))
    X[:, 0] = 1e-4 * rng.standard_normal(NXL)
    X[:, 1] = 0.01 * rng.standard_normal(NXL)
    X[0:2, 2] = [0.9, -0.4]
    X[12:14, 2] = [1.0, 2.0]
    v = np.array([[2e-4, 0.05, 0.0], [-1e-4, -0.03, 0.6]])
    return X, v


def test_each_node_steps_like_the_one_point_step(loop) -> None:
    cl, _ = loop
    X, v = _nodes()
    Xn = cl(X, v)[0]
    for k in range(3):
        np.testing.assert_allclose(Xn[:, k], cl.step(X[:, k], v[:, k]), rtol=1e-12, atol=1e-14)


def test_jacobians_are_central_differences_of_the_step(loop) -> None:
    cl, _ = loop
    X, v = _nodes()
    _, A, B, *_ = cl(X, v)
    h = 1e-6
    for k in range(3):
        Ak, Bk = A[:, NXL * k:NXL * (k + 1)], B[:, 2 * k:2 * (k + 1)]
        fd_A = np.column_stack([(cl.step(X[:, k] + h * e, v[:, k]) - cl.step(X[:, k] - h * e, v[:, k]))
                                / (2 * h) for e in np.eye(NXL)])
        fd_B = np.column_stack([(cl.step(X[:, k], v[:, k] + h * e) - cl.step(X[:, k], v[:, k] - h * e))
                                / (2 * h) for e in np.eye(2)])
        np.testing.assert_allclose(Ak, fd_A, rtol=0, atol=1e-6 * max(1.0, np.abs(fd_A).max()))
        np.testing.assert_allclose(Bk, fd_B, rtol=0, atol=1e-6 * max(1.0, np.abs(fd_B).max()))


def test_small_signals_are_the_linear_model_and_outputs_are_its_rows(loop) -> None:
    cl, lin = loop
    X, v = _nodes()
    Xn, A, B, y, C, D = cl(X, v)
    scale = np.abs(lin.A).max()
    np.testing.assert_allclose(A[:, :NXL], lin.A, rtol=0, atol=1e-7 * scale)
    np.testing.assert_allclose(B[:, :2], lin.B, rtol=0, atol=1e-7 * np.abs(lin.B).max())
    np.testing.assert_allclose(Xn[:, 0], lin.A @ X[:, 0] + lin.B @ v[:, 0], rtol=0,
                               atol=1e-6 * np.abs(X[:, 0]).max())
    Cy = np.vstack([lin.C["acc"], lin.C["tilt_acc"]])
    Dy = np.vstack([lin.D["acc"], lin.D["tilt_acc"]])
    assert C.shape == (4, 3 * NXL) and D.shape == (4, 6)
    for k in range(3):
        np.testing.assert_allclose(C[:, NXL * k:NXL * (k + 1)], Cy, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(D[:, 2 * k:2 * (k + 1)], Dy, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(y[:, k], Cy @ X[:, k] + Dy @ v[:, k], rtol=1e-10, atol=1e-12)


def test_the_clip_holds_back_a_fast_robot(loop) -> None:
    """0.9 m/s with v_ref 0.6 m/s along y only: the linear model's demanded tilt
    acceleration is beyond the controller's limits, so the clipped step moves the speed
    less than the linear one (both first speed up along x: the ball moves under the body
    before braking), by a clear margin."""
    cl, lin = loop
    X, v = _nodes()
    Xc, Xl = cl.step(X[:, 2], v[:, 2]), lin.A @ X[:, 2] + lin.B @ v[:, 2]
    dv_clip, dv_lin = Xc[0] - X[0, 2], Xl[0] - X[0, 2]
    assert 0.0 < dv_clip < 0.5 * dv_lin


def test_lift_inverts_the_loop_state(loop) -> None:
    """lift_function then make_loop_state returns the loop coordinates (every entry
    distinct, tilts of a few degrees): the lift puts each coordinate in its own slot."""
    from ballbot_casadi.core.layout import STATE
    from ballbot_casadi.sim.path_following import make_loop_state
    from ballbot_casadi.sim.prediction_models import NW, lift_function

    rng = np.random.default_rng(3)
    X = rng.uniform(-0.08, 0.08, NXL) + 0.01 * np.arange(NXL)
    w_ref = rng.standard_normal(NW)
    w = np.asarray(lift_function()(X, w_ref), float).ravel()
    back = np.asarray(make_loop_state()(w[:STATE.size], w[STATE.size:]), float).ravel()
    np.testing.assert_allclose(back, X, rtol=0, atol=1e-12)
    q = w[STATE["q"]]
    assert np.linalg.norm(q) == pytest.approx(1.0, abs=1e-14)

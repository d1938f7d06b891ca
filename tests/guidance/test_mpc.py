"""Path-following MPC: prediction model, QP against another solver, limits, progress,
corners, generated C (obstacle avoidance: not yet)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.core.constants import THESIS_LIMITS
from ballbot_casadi.guidance.mpc import MpcConfig, PathMPC, make_mpc, mpc_library, workspace_bytes
from ballbot_casadi.guidance.paths import figure_eight, line_path, waypoint_path
from ballbot_casadi.sim.closed_loop import ClosedLoop
from ballbot_casadi.sim.path_following import (
    make_loop_state,
    path_scenario,
    run_path,
    velocity_loop_model,
)


@pytest.fixture(scope="module")
def inputs():
    inp = path_scenario(figure_eight(), 2.0).inputs()
    for key in ("com_observer", "k_obs", "estimator"):
        inp.pop(key)
    return inp


@pytest.fixture(scope="module")
def model(inputs):
    return velocity_loop_model(inputs["p_ctrl"], inputs["k_vel"], 0.1)


@pytest.fixture(scope="module")
def sim():
    return ClosedLoop()


def test_prediction_model_matches_the_nonlinear_closed_loop(inputs, model, sim):
    """Held v_ref for 2 s: the linear loop model predicts the compiled nonlinear cascade."""
    v = np.array([0.2, -0.1])
    inp = dict(inputs)
    inp["v_ref"] = np.tile([v[0], v[1], 0.0], (400, 1))
    out = sim.simulate("flc", **inp)
    ls = make_loop_state()
    X = np.array([np.asarray(ls(out["state"][k], out["z"][k])).ravel() for k in range(0, 401, 20)])
    Xm = model.simulate(X[0], np.tile(v, (20, 1)))
    np.testing.assert_allclose(Xm[:, 0:2], X[:, 0:2], atol=3e-2)  # velocity, m/s (largest in the first 0.3 s)
    np.testing.assert_allclose(Xm[:, 2:4], X[:, 2:4], atol=6e-3)  # tilt, rad
    np.testing.assert_allclose(Xm[:, 4:6], X[:, 4:6], atol=3e-2)  # tilt rate, rad/s
    np.testing.assert_allclose(Xm[:, 12:14], X[:, 12:14], atol=1e-2)  # position, m
    # and the steady state: the velocity follows v_ref (integral action)
    np.testing.assert_allclose(model.simulate(X[0], np.tile(v, (200, 1)))[-1, 0:2], v, atol=1e-3)


def _parameters(model, path, cfg):
    mpc = PathMPC(model, path, cfg)
    x = np.zeros(14)
    x[12:14] = path.point(0.0) + np.array([0.0, 0.05])
    x[0:2] = [0.2, 0.0]
    guess = mpc._guess(x, 0.0, 0.3)
    return mpc, guess[mpc.layout.x(0)], mpc.parameters(guess), guess


def test_qp_matches_an_independent_solver(model):
    """qrqp (the generated solver) against OSQP at tight tolerances on the same QP."""
    path = line_path((0.0, 0.0), (3.0, 0.0), obstacles=[(1.0, 0.2, 0.2)])
    cfg = MpcConfig(N=8)
    mpc, x0, p, guess = _parameters(model, path, cfg)
    f_qrqp = mpc.function
    f_osqp, _ = make_mpc(model, MpcConfig(N=8, solver="osqp", solver_options={
        "osqp": {"verbose": False, "eps_abs": 1e-10, "eps_rel": 1e-10, "max_iter": 200000,
                 "polishing": True}}))
    z_w, z_a = np.zeros(mpc.layout.n_w), np.zeros(mpc.n_g)
    a = f_qrqp(x0, p, guess, z_w, z_a)
    b = f_osqp(x0, p, guess, z_w, z_a)
    np.testing.assert_allclose(np.asarray(a[0]).ravel(), np.asarray(b[0]).ravel(), atol=1e-5)
    np.testing.assert_allclose(np.asarray(a[1]).ravel(), np.asarray(b[1]).ravel(), atol=1e-4)
    np.testing.assert_allclose(float(a[4]), float(b[4]), rtol=1e-6)


def _lateral(path, pos):
    s, out = 0.0, []
    for p in pos:
        s = path.project(p, s_guess=s)
        out.append(np.linalg.norm(path.point(s) - p))
    return np.array(out)


def _check_limits(run, tau_max):
    st = run.log["state"]
    # inclination: cos(tilt) = R33 = 1 - 2 (q1^2 + q2^2) for a unit quaternion
    tilt = np.arccos(np.clip(1.0 - 2.0 * (st[:, 3] ** 2 + st[:, 4] ** 2), -1.0, 1.0))
    assert np.degrees(tilt.max()) <= 5.0
    assert np.linalg.norm(st[:, 6:8], axis=1).max() <= THESIS_LIMITS["v_max"]
    assert np.abs(run.log["tau"]).max() <= tau_max + 1e-12
    assert np.all(np.diff(run.progress) >= -1e-12), "progress decreased"


@pytest.mark.slow
def test_figure_eight_true_state(model, inputs, sim):
    """Acceptance: lateral error RMS <= 2 cm at 0.5 m/s, limits on every sample, progress monotone.

    Not checked: the acceleration a_max (not an MPC row; exceeded at the start, see the report).
    """
    path = figure_eight(4.0, 2.0, speed=0.5)
    mpc = PathMPC(model, path)
    _, mpc.function = mpc_library(mpc.function)  # the generated C, cached by hash under build/
    run = run_path(path, mpc, 30.0, sim=sim)
    lat = _lateral(path, run.log["state"][::20, 0:2])
    assert np.sqrt(np.mean(lat[50:] ** 2)) <= 0.02
    _check_limits(run, 1.98)
    assert run.progress[-1] >= path.length  # one full lap
    assert mpc.failures <= 0.2 * len(run.t_guidance)  # measured: see the report


@pytest.mark.xfail(strict=True, reason="known issue: at this corner the robot peaks at "
                   "0.527 m/s (> v_max) and 5.06 deg; the MPC's limits hold in its model only")
def test_sharp_corner_slows_instead_of_tilting(model, sim):
    """A 90 deg corner with a 0.1 m smoothing: the robot slows down, tilt stays within 5 deg."""
    path = waypoint_path([(0.0, 0.0), (1.2, 0.0), (1.3, 0.0), (1.3, 0.1), (1.3, 1.3)])
    kappa = np.abs(path.curvature(np.linspace(0, path.length, 500))).max()
    assert kappa > 10.0  # the corner needs a speed below 0.5 m/s to stay within the limits
    run = run_path(path, PathMPC(model, path), 8.0, sim=sim)
    st = run.log["state"]
    _check_limits(run, 1.98)
    speed = np.linalg.norm(st[:, 6:8], axis=1)
    near = np.linalg.norm(st[:, 0:2] - [1.3, 0.0], axis=1) < 0.1
    assert near.any() and speed[near].min() < 0.5 * speed.max()
    assert np.linalg.norm(st[-1, 0:2] - [1.3, 1.3]) < 0.1  # and gets to the end


def test_generated_c_equals_the_casadi_function(model, tmp_path):
    """Strict C99 (-Wall -Wextra -Wpedantic -Werror) and equal to the Function to 1e-12."""
    path = figure_eight(obstacles=[(1.0, 0.9, 0.2)])
    mpc, x0, p, guess = _parameters(model, path, MpcConfig(N=4, n_obstacles=1))
    _, compiled = mpc_library(mpc.function, tmp_path)
    z_w, z_a = np.zeros(mpc.layout.n_w), np.zeros(mpc.n_g)
    for a, b in zip(mpc.function(x0, p, guess, z_w, z_a), compiled(x0, p, guess, z_w, z_a)):
        np.testing.assert_allclose(np.asarray(b), np.asarray(a), rtol=0, atol=1e-12)
    assert workspace_bytes(mpc.function) > 0
    assert math.isfinite(float(compiled(x0, p, guess, z_w, z_a)[4]))


def test_failed_qp_keeps_the_shifted_plan(model):
    """A solver error (the generated qrqp at max_iter) -> the previous plan's next input, counted."""
    path = line_path((0.0, 0.0), (3.0, 0.0))
    mpc = PathMPC(model, path, MpcConfig(N=6))
    x = np.zeros(14)
    mpc.step(x)
    planned = mpc.w[mpc.layout.u(1)][:2].copy()
    assert np.linalg.norm(planned) > 0.01  # a plan that moves

    def failing(*args):
        raise RuntimeError("Evaluation failed")

    mpc.function = failing
    v = mpc.step(x)
    np.testing.assert_allclose(v, planned, rtol=0, atol=1e-15)
    assert mpc.failures == 1 and len(mpc.solve_s) == 2
    assert not mpc.lam_a.any() and not mpc.lam_x.any()

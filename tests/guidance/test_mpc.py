"""Path-following MPC: prediction model, condensing, the ADMM QP against analytic and
independent solves, limits on every sample, progress, corners, obstacles, generated C."""

from __future__ import annotations

import re

import numpy as np
import pytest

import casadi as ca

from ballbot_casadi.core.constants import THESIS_LIMITS
from ballbot_casadi.core.toolchain import generate_sources
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.guidance.condensed import condense
from ballbot_casadi.guidance.mpc import (
    MpcConfig,
    PathMPC,
    make_mpc,
    make_mpc_parts,
    mpc_library,
    workspace_bytes,
)
from ballbot_casadi.guidance.qp_admm import make_admm
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


def test_condensed_prediction_equals_stepping_the_model(model):
    """X_k = Phi_k x0 + Gamma_k ub against the one-step model applied step by step."""
    rng = np.random.default_rng(3)
    cond = condense(model, (1, 2, 3))
    x0, ub = rng.normal(size=16), rng.normal(size=cond.n_u)
    steps = cond.inputs(ub)
    np.testing.assert_array_equal(steps[1], steps[2])  # held over the second block
    x, xs = x0, [x0]
    for k in range(6):
        x = cond.A @ x + cond.B @ steps[k]
        xs.append(x)
    np.testing.assert_allclose(cond.states(x0, ub), np.array(xs), rtol=0, atol=1e-9)
    np.testing.assert_allclose(cond.block(steps), ub, rtol=0, atol=0)


def test_admm_has_the_analytic_solution_of_a_small_qp():
    """min 1/2 |u - a|^2 with a = (3, 3, 3) and |u_i| <= 1: hard row -> u = 1; soft rows
    with L1 penalty c -> u = max(3 - c, 1) and multiplier min(c, 2); a parametric row
    (2 u_0 >= -5) inactive."""
    f = make_admm(3, np.eye(3), np.eye(3)[:1], ca.Sparsity.dense(1, 1),
                  np.array([np.inf, 0.5, 10.0, np.inf]), rho=0.1, sigma=1e-6, alpha=1.6,
                  iterations=400)
    lo, hi = np.array([-1.0, -1.0, -1.0, -5.0]), np.array([1.0, 1.0, 1.0, np.inf])
    u, z, y, r = f(np.eye(3), -3.0 * np.ones(3), lo, hi, [2.0], np.zeros(3), np.zeros(4),
                   np.zeros(4))
    np.testing.assert_allclose(np.asarray(u).ravel(), [1.0, 2.5, 1.0], rtol=0, atol=1e-6)
    np.testing.assert_allclose(np.asarray(y).ravel(), [2.0, 0.5, 2.0, 0.0], rtol=0, atol=1e-6)
    assert float(r) <= 1e-6


def _state(path):
    x = np.zeros(14)
    x[12:14] = path.point(0.0) + np.array([0.0, 0.05])
    x[0:2] = [0.3, 0.1]
    return x


def test_qp_matches_an_independent_solver(model):
    """The ADMM (prox of the L1 penalty) against OSQP on the slack formulation of the same
    condensed QP, at a sample with an obstacle row and the limits in play."""
    path = figure_eight(obstacles=[(1.0, 0.9, 0.2)])
    mpc = PathMPC(model, path, MpcConfig(iterations=400))
    for _ in range(3):
        mpc.step(_state(path))
    x0, p, u0 = mpc.last["x0"], mpc.last["p"], mpc.last["u0"]
    ref, _ = make_mpc(model, MpcConfig(solver="osqp", solver_options={"osqp": {
        "verbose": False, "eps_abs": 1e-9, "eps_rel": 1e-9, "max_iter": 100000,
        "polishing": True}}))
    z0, y0 = mpc.rows(u0, p), np.zeros(mpc.layout.n_rows)
    b = ref(x0, p, u0, z0, y0)
    a = mpc.function(x0, p, u0, z0, y0)
    np.testing.assert_allclose(np.asarray(a[0]).ravel(), np.asarray(b[0]).ravel(), atol=1e-5)
    np.testing.assert_allclose(np.asarray(a[1]).ravel(), np.asarray(b[1]).ravel(), atol=1e-4)
    np.testing.assert_allclose(float(mpc.cost(a[1], x0, p)), float(mpc.cost(b[1], x0, p)),
                               rtol=1e-6)
    # the default (fixed) iteration count: the applied input within 1 mm/s
    short, _ = make_mpc(model, MpcConfig())
    np.testing.assert_allclose(np.asarray(short(x0, p, u0, z0, y0)[0]).ravel(),
                               np.asarray(b[0]).ravel(), atol=1e-3)


def _lateral(path, pos):
    s, out = 0.0, []
    for p in pos:
        s = path.project(p, s_guess=s)
        out.append(np.linalg.norm(path.point(s) - p))
    return np.array(out)


def _check_limits(run, tau_max, a_max=THESIS_LIMITS["a_max"]):
    """The §7.1 limits on every sample of the run (200 Hz) and a monotone progress."""
    st = run.log["state"]
    # inclination: cos(tilt) = R33 = 1 - 2 (q1^2 + q2^2) for a unit quaternion
    tilt = np.arccos(np.clip(1.0 - 2.0 * (st[:, 3] ** 2 + st[:, 4] ** 2), -1.0, 1.0))
    assert np.degrees(tilt.max()) <= 5.0
    assert np.linalg.norm(st[:, 6:8], axis=1).max() <= THESIS_LIMITS["v_max"]
    acc = np.diff(st[:, 6:8], axis=0) / (run.log["time"][1] - run.log["time"][0])
    assert np.linalg.norm(acc, axis=1).max() <= a_max
    assert np.abs(run.log["tau"]).max() <= tau_max + 1e-12
    assert np.all(np.diff(run.progress) >= -1e-12), "progress decreased"


@pytest.mark.slow
def test_figure_eight_true_state(model, inputs, sim):
    """Acceptance: lateral error RMS <= 2 cm at 0.5 m/s, the §7.1 limits (acceleration
    included) on every sample, progress monotone, no failed QP.  (The CasADi Function; the
    generated C equals it, see test_generated_c_equals_the_casadi_function.)"""
    path = figure_eight(4.0, 2.0, speed=0.5)
    mpc = PathMPC(model, path)
    run = run_path(path, mpc, 30.0, sim=sim)
    lat = _lateral(path, run.log["state"][::20, 0:2])
    assert np.sqrt(np.mean(lat[50:] ** 2)) <= 0.02
    _check_limits(run, 1.98)
    assert run.progress[-1] >= 0.95 * path.length  # about one lap (speed limit with margin)
    assert mpc.failures == 0


@pytest.mark.slow
def test_sharp_corner_slows_instead_of_tilting(model, sim):
    """A 90 deg corner with a 0.1 m smoothing: the robot slows down, tilt (and the other
    §7.1 limits, acceleration included) stay within bounds on every sample."""
    # legs anchored every 0.2 m (the chord-length spline through the five corner points
    # alone overshoots to a 7.4 m loop)
    path = waypoint_path([(x, 0.0) for x in np.arange(0.0, 1.21, 0.2)] + [(1.3, 0.0), (1.3, 0.1)]
                         + [(1.3, y) for y in np.arange(0.3, 1.31, 0.2)])
    kappa = np.abs(path.curvature(np.linspace(0, path.length, 500))).max()
    assert kappa > 10.0  # the corner needs a speed below 0.5 m/s to stay within the limits
    run = run_path(path, PathMPC(model, path), 8.0, sim=sim)
    st = run.log["state"]
    _check_limits(run, 1.98)
    speed = np.linalg.norm(st[:, 6:8], axis=1)
    near = np.linalg.norm(st[:, 0:2] - [1.3, 0.0], axis=1) < 0.1
    assert near.any() and speed[near].min() < 0.7 * speed.max()  # measured: 0.28 of 0.43 m/s
    assert np.linalg.norm(st[-1, 0:2] - [1.3, 1.3]) < 0.1  # and gets to the end


@pytest.mark.slow
def test_obstacle_on_the_path_is_avoided(model, sim):
    """An obstacle centred on a straight path: the robot goes around it with a clearance
    >= 0.10 m (the ball centre to the circle) and completes the course."""
    path = line_path((0.0, 0.0), (4.0, 0.0), obstacles=[(2.0, 0.0, 0.25)])
    mpc = PathMPC(model, path)
    run = run_path(path, mpc, 14.0, sim=sim)
    st = run.log["state"]
    assert path.clearance(st[:, 0:2]).min() >= 0.10
    _check_limits(run, 1.98)
    assert np.linalg.norm(st[-1, 0:2] - [4.0, 0.0]) < 0.1


def _small(model, path):
    cfg = MpcConfig(N=4, blocks=(1, 1, 2), nodes=(1, 2, 4), iterations=3, n_obstacles=1)
    mpc = PathMPC(model, path, cfg)
    mpc.step(_state(path))
    L = mpc.last
    return mpc, (L["x0"], L["p"], L["u0"], mpc.rows(L["u0"], L["p"]), mpc.y)


def test_generated_c_equals_the_casadi_function(model, tmp_path):
    """Strict C99 (-Wall -Wextra -Wpedantic -Werror), equal to the Function to 1e-12, and
    deterministic (two calls give the same bits)."""
    path = figure_eight(obstacles=[(1.0, 0.9, 0.2)])
    mpc, args = _small(model, path)
    _, compiled = mpc_library(mpc.function, tmp_path)
    a, b = mpc.function(*args), compiled(*args)
    for x, y in zip(a, b):
        np.testing.assert_allclose(np.asarray(y), np.asarray(x), rtol=0, atol=1e-12)
    for x, y in zip(b, compiled(*args)):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))
    assert 0 < workspace_bytes(mpc.function) <= 65536


def test_failed_qp_keeps_the_shifted_plan(model):
    """A non-finite solve -> the previous plan's next input, counted, cold multipliers."""
    path = line_path((0.0, 0.0), (3.0, 0.0))
    mpc = PathMPC(model, path)
    x = np.zeros(14)
    mpc.step(x)
    planned = mpc.cond.inputs(mpc.u)[1, :2].copy()
    assert np.linalg.norm(planned) > 0.01  # a plan that moves
    good = mpc.function

    def failing(*args):
        out = list(good(*args))
        out[1] = out[1] * np.nan
        return out

    mpc.function = failing
    v = mpc.step(x)
    np.testing.assert_allclose(v, planned, rtol=0, atol=1e-15)
    assert mpc.failures == 1 and len(mpc.solve_s) == 6  # 5 at the (cold) first sample
    assert not mpc.y.any()


@pytest.mark.parametrize("kw, key", [({"blocks": (1, 2)}, "blocks"), ({"nodes": (0, 3)}, "nodes"),
                                     ({"iterations": 0}, "iterations"), ({"margin": 1.5}, "margin")])
def test_bad_configuration_is_refused(kw, key):
    with pytest.raises(ScenarioError, match=key):
        MpcConfig(**kw)


def test_generated_c_multiplies_in_loops(model):
    """The ADMM iteration, the KKT matrix and the cost's Hessian are matrix operations
    (loops in the C), not one scalar line per product: the default ballbot_mpc generates
    to ~0.54 MB of C (1.78 MB with the scalar form, minutes of -O3 in every mission
    library); the heavy products are a few called Functions (rows, transposed rows, K^-1
    times a vector, the KKT matrix, the gradient, the two scalar setups)."""
    f, _ = make_mpc(model)
    c_src, _ = generate_sources("ballbot_mpc", [f])
    assert len(c_src) < 700_000
    assert len(re.findall(r"^static int casadi_f\d+\(", c_src, re.M)) <= 8


def test_default_workspace_fits_64_kib(model):
    """Issue 18: the static workspace of the default solver (N = 20, 30 unknowns, 310
    rows, 60 iterations) <= 64 KiB of doubles, argument pointers included (was 120,128 B
    before the iteration was written flat and the KKT matrix from the cost quantities)."""
    f, _ = make_mpc(model)
    assert workspace_bytes(f) <= 65536


def _dense_admm(P, q, A, lo, hi, penalty, cfg, u, z, y):
    """OSQP's iteration with the L1 prox (the solver's docstring) on dense numpy data."""
    rho, sigma, alpha = cfg.rho, cfg.sigma, cfg.alpha
    Kinv = np.linalg.inv(P + sigma * np.eye(P.shape[0]) + rho * A.T @ A)
    cr = np.where(np.isfinite(penalty), penalty / rho, np.inf)
    for _ in range(cfg.iterations):
        ut = Kinv @ (sigma * u - q + A.T @ (rho * z - y))
        zt = A @ ut
        u, v = alpha * ut + (1 - alpha) * u, alpha * zt + (1 - alpha) * z
        wv = v + y / rho
        zn = wv - np.minimum(np.maximum(wv - hi, 0), cr) + np.minimum(np.maximum(lo - wv, 0), cr)
        z, y = zn, y + rho * (v - zn)
    return u, z, y, np.abs(A @ u - z).max()


def test_solver_equals_a_dense_reference_iteration(model):
    """The generated-form solver (K from the cost quantities, flat iteration, row products
    by the factors) equals the same 60 ADMM steps on the dense QP formed directly (P from
    the cost's Hessian, A from A_c and N(p) G, K^-1 by numpy) to 1e-9, at a warm-started
    sample with obstacle rows and active limits."""
    path = figure_eight(obstacles=[(1.0, 0.9, 0.2)])
    cfg = MpcConfig()
    mpc = PathMPC(model, path, cfg)
    for _ in range(3):
        mpc.step(_state(path))
    _, _, parts = make_mpc_parts(model, cfg)
    x0, p, u0 = mpc.last["x0"], mpc.last["p"], mpc.last["u0"]
    z0, y0 = mpc.rows(u0, p), mpc.y
    assert np.abs(y0).max() > 0.1  # active multipliers
    P, q, lo, hi, nobs = (np.asarray(v, float) for v in parts["qp_data"](x0, p))
    N = np.asarray(ca.DM(parts["N_sp"], nobs.ravel()))
    A = np.vstack([parts["A_c"], N @ parts["G"]])  # N carries the obstacle scale
    assert np.abs(N).max() > 0  # an obstacle row in play
    ref = _dense_admm(P, q.ravel(), A, lo.ravel(), hi.ravel(), parts["penalty"], cfg,
                      u0, z0, y0)
    out = mpc.function(x0, p, u0, z0, y0)
    for got, want in zip(out[1:], ref):
        np.testing.assert_allclose(np.asarray(got, float).ravel(), np.ravel(want), rtol=0,
                                   atol=1e-9 * max(1.0, np.abs(want).max()))


@pytest.mark.parametrize("blocks", [(), (2, 0, 1), (-1,)])
def test_condensing_needs_positive_block_lengths(model, blocks):
    with pytest.raises(ScenarioError, match=rf"^blocks must be positive step counts, got "
                                            rf"{re.escape(repr(blocks))}$"):
        condense(model, blocks)
    assert condense(model, (1,)).n_u == 3  # one block of one step: one input (v_x, v_y, a_s)


def test_the_warm_start_moves_the_steps_one_ahead_and_repeats_the_last(model):
    """Blocks (2, 1, 1): steps 0, 0, 1, 2 shifted are 0, 1, 2, 2, so the blocks start at
    steps 0, 2, 3: blocks 0, 2, 2 (as the NMPC's shift)."""
    cfg = MpcConfig(N=4, blocks=(2, 1, 1), nodes=(1, 3, 4), n_obstacles=1)
    mpc = PathMPC(model, line_path((0.0, 0.0), (3.0, 0.0), 0.5), cfg)
    ub = np.arange(9, dtype=float)
    np.testing.assert_array_equal(mpc.shift(ub), np.concatenate([ub[0:3], ub[6:9], ub[6:9]]))

"""The MPC guidance sample (the real-time iteration on symbols, for the control period)
equals PathMPC.step sample by sample: warm start, parameters (path window, lateral weight,
obstacle half-planes), the cold first sample, and a failed QP."""

from __future__ import annotations

import dataclasses

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.guidance.blocks import make_mpc_sample, mpc_initial_state, mpc_state_layout
from ballbot_casadi.guidance.mpc import MpcConfig, PathMPC, make_mpc_parts
from ballbot_casadi.guidance.path_table import pack_path
from ballbot_casadi.guidance.paths import Obstacle, waypoint_path
from ballbot_casadi.sim.path_following import path_scenario, velocity_loop_model

CONFIG = MpcConfig()


@pytest.fixture(scope="module")
def path():
    p = waypoint_path([[0.0, 0.0], [0.6, 0.2], [1.2, 0.0]])
    # beside the path from the first samples on (no waypoint check: it is a test fixture)
    return dataclasses.replace(p, obstacles=(Obstacle((0.3, 0.3), 0.1),))


@pytest.fixture(scope="module")
def model(path):
    inp = path_scenario(path, 1.0).inputs()
    return velocity_loop_model(inp["p_ctrl"], inp["k_vel"], CONFIG.dt)


def _compare(path, model, mpc_function=None, samples=6):
    f, L, parts = make_mpc_parts(model, CONFIG)
    mpc = PathMPC(model, path, CONFIG)
    if mpc_function is not None:
        f = mpc.function = mpc_function(f)
    sample = make_mpc_sample(f, L, parts, CONFIG)
    S = mpc_state_layout(L)
    k = pack_path(path, CONFIG.n_obstacles)
    rng = np.random.default_rng(7)
    X = np.zeros(14)
    X[12:14] = [0.02, -0.01]
    g = mpc_initial_state(L, path, X)
    params = []
    for _ in range(samples):
        v_ref = mpc.step(X)
        v, g = (np.asarray(a, float).ravel() for a in sample(X, g, k))
        # path table (linear interpolation) vs spline: ~1e-7
        np.testing.assert_allclose(v, v_ref, rtol=0, atol=1e-6)
        for name, ref in (("x0", mpc.x0), ("u", mpc.u), ("z", mpc.z), ("y", mpc.y),
                          ("v", mpc.v_prev)):
            np.testing.assert_allclose(g[S[name]], ref, rtol=0, atol=2e-6, err_msg=name)
        assert g[S["first"]] == 0.0
        params.append(L.unpack(mpc.last["p"]))
        X = mpc.cond.states(mpc.x0, mpc.u)[1][:14] + 1e-3 * rng.standard_normal(14)
    return mpc, params


def test_mpc_sample_equals_path_mpc_with_an_obstacle_beside_the_path(path, model):
    mpc, params = _compare(path, model)
    # the obstacle shaped the problem: half-planes set and the lateral weight relaxed
    assert any(np.any(np.asarray(p["obs_b"]) != -1.0) for p in params)
    assert any(np.any(np.asarray(p["w_lat"]) < 1.0) for p in params)
    assert len(mpc.solve_s) == 5 + 5  # the cold first sample re-linearises 5 times
    assert mpc.failures == 0
    # a solve's CPU seconds (the calling thread's, differenced) never above its wall seconds
    cpu, wall = np.array(mpc.solve_cpu_s), np.array(mpc.solve_s)
    assert cpu.size == wall.size and np.all(cpu >= 0.0) and np.all(cpu <= wall + 1e-3)


def test_failed_qp_in_the_sample_keeps_the_shifted_plan(path, model):
    """A QP that returns NaN: the sample, like PathMPC, keeps the shifted guess (here the
    cold zero plan), z = A u0 and cold multipliers, and the robot is not commanded NaN."""

    def failing(f):
        args = [ca.MX.sym(f.name_in(i), f.sparsity_in(i)) for i in range(f.n_in())]
        out = list(f(*args))
        out[0], out[1] = out[0] * np.nan, out[1] * np.nan
        return ca.Function("ballbot_mpc", args, out, f.name_in(), f.name_out())

    mpc, _ = _compare(path, model, mpc_function=failing, samples=3)
    assert mpc.failures == 3
    assert not mpc.y.any() and not mpc.u.any()


def test_the_sample_packs_the_parameters_of_path_mpc(path, model):
    """The sample's parameter vector (guidance.blocks.mpc_parameters, the path read from its
    table) is PathMPC.parameters at the same state, guess and previous reference: every
    block to the table's interpolation, the inactive obstacle rows (-1: never binding) and
    the lateral weights exactly as PathMPC writes them."""
    from ballbot_casadi.guidance.blocks import mpc_parameters
    from ballbot_casadi.guidance.path_table import PathSymbols

    _, L, parts = make_mpc_parts(model, CONFIG)
    mpc = PathMPC(model, path, CONFIG)
    X = np.zeros(14)
    X[12:14] = [0.25, 0.05]   # beside the obstacle: some rows active, some not
    mpc.step(X)
    x0, guess, v_prev = mpc.x0, mpc.shift(mpc.u), np.array([0.3, -0.1])
    mpc.v_prev = v_prev
    want = L.unpack(mpc.parameters(x0, guess))
    P = PathSymbols(ca.DM(pack_path(path, CONFIG.n_obstacles)), CONFIG.n_obstacles)
    got = L.unpack(np.asarray(mpc_parameters(L, CONFIG, parts["cond"], P, ca.DM(x0), ca.DM(guess),
                                             ca.DM(v_prev)), float).ravel())
    assert set(got) == set(want)
    for name in want:
        np.testing.assert_allclose(np.asarray(got[name], float), np.asarray(want[name], float),
                                   rtol=0, atol=1e-6, err_msg=name)
    ob = np.asarray(want["obs_b"], float)
    assert np.any(ob == -1.0) and np.any(ob != -1.0)
    np.testing.assert_array_equal(np.asarray(got["obs_b"], float)[ob == -1.0], -1.0)

"""Path following inside the compiled period: the guidance slot with the real MPC and pure
pursuit equals the Python driver above the compiled cascade; the slot runs every 20th
period; the path table reproduces the spline; noise + UKFs in the loop."""

from __future__ import annotations

import functools

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.guidance.blocks import mpc_initial_state, pursuit_initial_state
from ballbot_casadi.guidance.mpc import PathMPC
from ballbot_casadi.guidance.path_table import PathSymbols, pack_path, path_eval
from ballbot_casadi.guidance.paths import figure_eight, line_path, waypoint_path
from ballbot_casadi.guidance.pure_pursuit import PurePursuit
from ballbot_casadi.sim.guided import (
    GUIDANCE_EVERY,
    PURSUIT_GAINS,
    predictions,
    pursuit_law,
    run_guided,
)
from ballbot_casadi.sim.path_following import (
    make_loop_state,
    run_path,
    velocity_loop_model,
)

DURATION = 3.0


@pytest.fixture(scope="module")
def mpc_runs(guided_path, guided_inputs, guided_law):
    mission = run_guided(guided_path, guided_law, DURATION)
    mpc = PathMPC(velocity_loop_model(guided_inputs["p_ctrl"], guided_inputs["k_vel"], 0.1),
                  guided_path)
    return mission, run_path(guided_path, mpc, DURATION)


def test_mpc_in_the_compiled_period_equals_the_python_driver(mpc_runs, guided_law):
    """The compiled mission with the MPC in the guidance slot == the Python driver calling
    PathMPC every 0.1 s above the compiled cascade (path table vs spline: ~1e-7 m)."""
    mission, ref = mpc_runs
    assert mission["state"].shape == ref.log["state"].shape
    np.testing.assert_allclose(mission["state"], ref.log["state"], rtol=0, atol=1e-6)
    np.testing.assert_allclose(mission["v_ref_used"][::GUIDANCE_EVERY, :2], ref.v_ref,
                               rtol=0, atol=1e-6)
    _, pos = predictions(guided_law, mission)
    np.testing.assert_allclose(pos, np.array(ref.predictions), rtol=0, atol=1e-6)
    # and it went somewhere: 3 s along the path at up to 0.5 m/s
    assert np.linalg.norm(mission["state"][-1, :2] - mission["state"][0, :2]) > 0.8


def test_the_guidance_runs_every_20th_period_and_holds_between(mpc_runs, guided_law):
    mission, _ = mpc_runs
    v = mission["v_ref_used"]
    held = np.repeat(v[::GUIDANCE_EVERY], GUIDANCE_EVERY, axis=0)[:v.shape[0]]
    np.testing.assert_array_equal(v, held)
    assert np.any(np.abs(np.diff(v[::GUIDANCE_EVERY, 0])) > 1e-3)  # it does change at samples
    g = mission["guide"]
    count = g[:, 0]
    np.testing.assert_array_equal(count[:41], np.r_[np.arange(20), np.arange(20), 0.0])
    # the plan changes only in the sample's period
    w = g[:, 1 + guided_law.state.offset("x0"):]
    changed = np.flatnonzero(np.any(w[1:] != w[:-1], axis=1))
    assert set(changed % GUIDANCE_EVERY) == {0}


def test_pure_pursuit_in_the_period_equals_the_python_driver(guided_path):
    mission = run_guided(guided_path, pursuit_law(), DURATION)
    ref = run_path(guided_path, PurePursuit(guided_path, *PURSUIT_GAINS), DURATION)
    # projection: Gauss-Newton on the table vs the class's dense search
    np.testing.assert_allclose(mission["state"], ref.log["state"], rtol=0, atol=1e-5)
    np.testing.assert_allclose(mission["v_ref_used"][::GUIDANCE_EVERY, :2], ref.v_ref,
                               rtol=0, atol=1e-5)


@pytest.mark.parametrize("make", [lambda: figure_eight(), lambda: line_path((0, 0), (2.0, 1.0)),
                                  lambda: waypoint_path([[0, 0], [1, 1], [2, 0], [3, 1]])])
def test_the_path_table_reproduces_the_path(make):
    """Points, tangents and the reference speed from the table == the spline's, also past the
    ends of an open path and modulo the length of a closed one."""
    p = make()
    k = ca.MX.sym("k", pack_path(p, 1).size)
    s = np.linspace(-0.5, p.length + 0.5, 301)
    ev = path_eval(PathSymbols(k, 1), ca.DM(s))
    f = ca.Function("f", [k], [ev["point"], ev["tangent"], ev["speed"], ev["s_max"]])
    pt, tg, sp, smax = (np.asarray(v) for v in f(pack_path(p, 1)))
    np.testing.assert_allclose(pt.T, p.point(s), rtol=0, atol=1e-4)
    np.testing.assert_allclose(tg.T, p.tangent(s), rtol=0, atol=2e-3)
    np.testing.assert_allclose(sp.ravel(), p.reference_speed(s), rtol=0, atol=1e-9)
    assert smax.item() == (1e9 if p.closed else p.length)


@functools.lru_cache(maxsize=None)
def _pursuit_with(estimator: str) -> dict:
    return run_guided(figure_eight(), pursuit_law(), 4.0, estimator=estimator, seed=3)


@pytest.mark.parametrize("estimator", ["ukf", "ukf_adaptive"])
def test_pure_pursuit_with_noise_and_the_ukfs_follows_the_figure_eight(estimator):
    """Noise + QUKF/VUKF (the thesis's, and the matched VUKF adapting its walk): the
    guidance reads the estimate; the true position stays near the path (the estimate's
    position integrates the velocity estimate: no position sensor)."""
    p = figure_eight()
    log = _pursuit_with(estimator)
    assert "x_hat" in log and log["v_ref_used"].shape == (800, 3)
    s, lat = 0.0, []
    for q in log["state"][::20, :2]:
        s = p.project(q, s)
        lat.append(np.linalg.norm(p.point(s) - q))
    assert max(lat) < 0.10
    assert np.linalg.norm(log["state"][-1, :2] - log["state"][0, :2]) > 1.0
    if estimator != "ukf":  # the other filter really ran: same readings, other estimate
        ref = _pursuit_with("ukf")
        np.testing.assert_array_equal(log["meas"][0], ref["meas"][0])
        assert np.max(np.abs(log["x_hat"] - ref["x_hat"])) > 1e-4


def test_the_initial_function_starts_the_guidance_as_the_python_samples(guided_path, guided_inputs,
                                                                       guided_law):
    # g0 of the mission and of the path-following controller FMU (one Function) packs what
    # the sample's Python start packs, at a position off the path and a moving start
    x0 = np.array(guided_inputs["x0"], float).reshape(-1)
    x0[0:2], x0[6:8] = (0.4, 0.25), (0.1, -0.05)
    z0 = np.linspace(0.01, 0.08, make_loop_state().numel_in(1))
    X0 = np.asarray(make_loop_state()(x0, z0), float).reshape(-1)
    for lw, ref in ((guided_law, mpc_initial_state(guided_law.mpc_layout, guided_path, X0)),
                    (pursuit_law(), pursuit_initial_state(guided_path, X0))):
        g0 = lw.initial_state(guided_path, x0, z0)
        assert g0[0] == 0.0
        np.testing.assert_array_equal(g0[1:], ref)
        assert lw.initial_function().name() == f"ballbot_guidance_{lw.name}_initial"

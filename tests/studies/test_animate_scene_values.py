"""``animation_scene`` against hand values on a log whose states are set by the test: the
frames chosen, the view limits (following the ball; the whole course for a path run), the
body axes drawn from the attitude (roll 30 deg), the trace and the title."""

from __future__ import annotations

import copy
import functools
import math

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from ballbot_casadi.core.layout import STATE  # noqa: E402
from ballbot_casadi.errors import ScenarioError  # noqa: E402
from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario  # noqa: E402
from ballbot_casadi.sim.log import PATH_KEY  # noqa: E402
from ballbot_casadi.sim.scenario import Scenario  # noqa: E402
from ballbot_casadi.studies.animate import (BALL_GID, HEADING_GID, OBSTACLE_GID, PATH_GID,
                                            animation_scene)  # noqa: E402

ROLL = math.radians(30.0)


@functools.lru_cache(maxsize=None)
def _base():
    return run_scenario(Scenario("anim", duration=0.05), ClosedLoop())  # 11 samples, 5 ms


def _log():
    """Sample k: ball at (1 + 0.1 k, -0.5 - 0.2 k), rolled 30 deg about x."""
    log = copy.deepcopy(_base())
    x = np.zeros_like(np.asarray(log.arrays["state"], float))
    k = np.arange(x.shape[0])
    x[:, STATE.index("x")] = 1.0 + 0.1 * k
    x[:, STATE.index("y")] = -0.5 - 0.2 * k
    x[:, STATE["q"]] = [math.cos(ROLL / 2), math.sin(ROLL / 2), 0.0, 0.0]
    log.arrays["state"] = x
    return log


def test_frames_at_the_frame_rate_and_at_most_max_frames():
    log = _log()
    for fps, most, want in ((50.0, 200, [0, 4, 8]), (15.0, 200, [0]), (200.0, 200, list(range(11))),
                            (200.0, 3, [0, 5, 10])):
        fig, _, idx = animation_scene(log, fps=fps, max_frames=most)
        plt.close(fig)
        np.testing.assert_array_equal(idx, want, err_msg=f"fps {fps}, max {most}")


def test_frames_stop_at_the_first_non_finite_state():
    log = _log()
    log.arrays["state"][6:, STATE.index("y")] = np.nan
    fig, _, idx = animation_scene(log, fps=200.0)
    plt.close(fig)
    np.testing.assert_array_equal(idx, range(6))
    log.arrays["state"][:, 0] = np.inf
    with pytest.raises(ScenarioError, match="^my.npz: the log has no finite state"):
        animation_scene(log, "my.npz")


def test_a_frame_draws_the_ball_its_axes_and_the_trace_in_a_view_following_it():
    log = _log()
    p = log.params
    rk, l = float(p.rk), float(p.l)
    fig, draw, _ = animation_scene(log)
    try:
        draw(4)
        ax = fig.axes[0]
        px, py = 1.4, -1.3
        span = max(0.6, l + 2 * rk)
        np.testing.assert_allclose(ax.get_xlim(), (px - span, px + span), rtol=0, atol=1e-12)
        np.testing.assert_allclose(ax.get_ylim(), (py - span, py + span), rtol=0, atol=1e-12)
        np.testing.assert_allclose(ax.get_zlim(), (0.0, 2 * span), rtol=0, atol=1e-12)
        ends = {}
        for ln in ax.lines:
            xs, ys, zs = ln.get_data_3d()
            if len(xs) == 2:
                ends[ln.get_color()] = np.array([xs[1], ys[1], zs[1]]) - [xs[0], ys[0], zs[0]]
                np.testing.assert_allclose([xs[0], ys[0], zs[0]], [px, py, rk], rtol=0, atol=1e-12)
        c, s = math.cos(ROLL), math.sin(ROLL)
        np.testing.assert_allclose(ends["r"], [0.5 * l, 0.0, 0.0], rtol=0, atol=1e-12)
        np.testing.assert_allclose(ends["g"], [0.0, 0.5 * l * c, 0.5 * l * s], rtol=0, atol=1e-12)
        np.testing.assert_allclose(ends["b"], [0.0, -l * s, l * c], rtol=0, atol=1e-12)
        trace = next(ln for ln in ax.lines if len(ln.get_data_3d()[0]) == 5)
        tx, ty, tz = trace.get_data_3d()
        np.testing.assert_allclose(tx, 1.0 + 0.1 * np.arange(5), rtol=0, atol=1e-12)
        np.testing.assert_allclose(ty, -0.5 - 0.2 * np.arange(5), rtol=0, atol=1e-12)
        np.testing.assert_allclose(tz, 0.0, atol=0)
        # every line is drawn (visible, a line of some width), the body's z axis thickest
        assert all(ln.get_visible() and ln.get_linewidth() > 0 for ln in ax.lines)
        widths = {ln.get_color(): ln.get_linewidth() for ln in ax.lines
                  if len(ln.get_data_3d()[0]) == 2}
        assert widths["b"] > widths["r"] == widths["g"]
        assert ax.get_title() == "anim  t =   0.02 s"
        # the ball: a wire sphere of radius rk about (px, py, rk), reaching the floor and 2 rk
        wire = next(c for c in ax.collections if c.get_gid() == BALL_GID)
        pts = np.concatenate([np.asarray(seg, float) for seg in wire._segments3d])
        np.testing.assert_allclose(np.linalg.norm(pts - [px, py, rk], axis=1), rk, rtol=1e-12)
        for axis, centre in enumerate((px, py, rk)):
            np.testing.assert_allclose((pts[:, axis].min(), pts[:, axis].max()),
                                       (centre - rk, centre + rk), rtol=0, atol=1e-12)
    finally:
        plt.close(fig)


@pytest.mark.parametrize("yaw_deg", [0.0, 90.0, -135.0])
def test_the_heading_arrow_points_along_the_body_x_axis_on_the_floor(yaw_deg):
    """From the ball's floor point, 0.3 of the view's half-width long, along the body x
    axis projected on the floor (yaw after the 30 deg roll: the roll does not turn it)."""
    log = _log()
    yaw = math.radians(yaw_deg)
    qz = np.array([math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)])
    qx = np.array([math.cos(ROLL / 2), math.sin(ROLL / 2), 0.0, 0.0])
    w1, v1, w2, v2 = qz[0], qz[1:], qx[0], qx[1:]  # Hamilton product qz * qx
    q = np.r_[w1 * w2 - v1 @ v2, w1 * v2 + w2 * v1 + np.cross(v1, v2)]
    log.arrays["state"][:, STATE["q"]] = q
    p = log.params
    span = max(0.6, float(p.l) + 2 * float(p.rk))
    fig, draw, _ = animation_scene(log)
    try:
        draw(4)
        arrow = next(c for c in fig.axes[0].collections if c.get_gid() == HEADING_GID)
        tip, tail = np.asarray(arrow._segments3d[0], float)  # the shaft, drawn tip to tail
        np.testing.assert_allclose(tail, [1.4, -1.3, 0.0], rtol=0, atol=1e-12)
        want = 0.3 * span * np.array([math.cos(yaw), math.sin(yaw), 0.0])
        np.testing.assert_allclose(tip - tail, want, rtol=0, atol=1e-12)
    finally:
        plt.close(fig)


def test_a_path_run_shows_the_whole_course_with_a_margin():
    """Limits: the path's points, the trace and the obstacles' extents, 0.3 m beyond."""
    log = _log()
    log.extra[PATH_KEY] = {"xy": [[0.0, 0.0], [2.0, 1.0], [4.0, 0.0]],
                           "obstacles": [[3.0, -2.5, 0.5], [-1.0, 1.0, 0.25]]}
    fig, draw, _ = animation_scene(log)
    try:
        draw(0)
        ax = fig.axes[0]
        # x: from the obstacle at -1 (-1.25) to the path's 4.0; y: from the trace's -2.5 and
        # the obstacle's -3.0 to the obstacle's 1.25
        np.testing.assert_allclose(ax.get_xlim(), (-1.25 - 0.3, 4.0 + 0.3), rtol=0, atol=1e-12)
        np.testing.assert_allclose(ax.get_ylim(), (-3.0 - 0.3, 1.25 + 0.3), rtol=0, atol=1e-12)
        l, rk = float(log.params.l), float(log.params.rk)
        np.testing.assert_allclose(ax.get_zlim(), (0.0, max(l + 2 * rk, 0.25 * 5.85)), rtol=0,
                                   atol=1e-12)
        line = next(ln for ln in ax.lines if ln.get_gid() == PATH_GID)
        np.testing.assert_allclose(np.array(line.get_data_3d()[:2]).T, [[0, 0], [2, 1], [4, 0]])
        assert len([p for p in ax.patches if p.get_gid() == OBSTACLE_GID]) == 2
        assert (ax.elev, ax.azim) == (40, -70)  # the course seen from above, at an angle
    finally:
        plt.close(fig)

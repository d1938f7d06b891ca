"""What the path study's figures draw (``path_xy.png``, ``path_errors_limits.png``), read
back from the saved figures for stand-in runs along a straight path, where the lateral
error is the distance from the x axis and every number is computed here by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _figures import assert_style, hlines, line

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.constants import THESIS_LIMITS
from ballbot_casadi.core.layout import STATE
from ballbot_casadi.core.params import load_params
from ballbot_casadi.sim.log import SimulationLog
from ballbot_casadi.studies.path import path_plots

N = 60  # periods; the error panel samples every 20th row


def _log(name: str, k: float, **scenario) -> SimulationLog:
    t = np.arange(N + 1) * 0.01
    state = np.zeros((N + 1, 12))
    state[:, STATE.index("x")] = 0.5 + 2 * t
    state[:, STATE.index("y")] = k * 0.01 * np.sin(3 * t)
    roll = np.radians(k * (1 + 2 * t))
    pitch = np.radians(k * 0.5 * t ** 2)
    state[:, STATE["q"]] = [Q.from_rpy(r, p, 0.0) for r, p in zip(roll, pitch)]
    j = np.arange(N)[:, None]
    tau = np.hstack([0.01 * k * j, -0.03 * k * j, 0.02 * np.ones_like(j)])
    p = load_params().replace(tau_max=2.0 + k)
    sc = {"name": name, "guidance": "pursuit", "estimator": "true",
          "path": {"type": "line", "start": [0.0, 0.0], "end": [4.0, 0.0]}, **scenario}
    return SimulationLog(arrays={"time": t, "state": state, "tau_cmd": tau}, scenario=sc, params=p,
                         ctrl_params=p)


def test_path_figures_draw_traces_errors_and_limits(saved, tmp_path):
    logs = [_log("path_fig8_pursuit", 1.0),
            _log("path_obstacles_pursuit", 2.0, obstacles=[[2.0, 0.5, 0.25], [3.0, -0.4, 0.1]])]
    path_plots(logs, {}, tmp_path)
    fig8, obst = saved["path_xy.png"]
    for ax, log in ((fig8, logs[0]), (obst, logs[1])):
        x, y = line(ax, "path")
        np.testing.assert_allclose([x[0], x[-1]], [0.0, 4.0], rtol=0, atol=1e-12)
        np.testing.assert_allclose(y, 0.0, rtol=0, atol=1e-12)
        x, y = line(ax, log.scenario["name"].removeprefix("path_"))
        np.testing.assert_array_equal(x, log.arrays["state"][:, STATE.index("x")])
        np.testing.assert_array_equal(y, log.arrays["state"][:, STATE.index("y")])
        assert (ax["xlabel"], ax["ylabel"]) == ("x (m)", "y (m)")
    assert fig8["circles"] == [] and obst["circles"] == [((2.0, 0.5), 0.25), ((3.0, -0.4), 0.1)]

    err, tilt, rate, torque = saved["path_errors_limits.png"]
    t = np.arange(N + 1) * 0.01
    for k, log in ((1.0, logs[0]), (2.0, logs[1])):
        x, y = line(err, log.scenario["name"].removeprefix("path_"))
        np.testing.assert_array_equal(x, t[::20])
        np.testing.assert_allclose(y, 100 * k * 0.01 * np.abs(np.sin(3 * t[::20])), rtol=0, atol=1e-9)
    series = [[y for lab, _, y in ax["lines"] if lab.startswith("_child") and y.size > 2]
              for ax in (tilt, rate, torque)]
    for k, i in ((1.0, 0), (2.0, 1)):
        roll, pitch = np.radians(k * (1 + 2 * t)), np.radians(k * 0.5 * t ** 2)
        expected = np.degrees(np.arccos(np.cos(roll) * np.cos(pitch)))  # angle of the body vertical
        np.testing.assert_allclose(series[0][i], expected, rtol=0, atol=1e-9)
        np.testing.assert_allclose(series[1][i], np.abs(np.gradient(expected, t)), rtol=0, atol=1e-6)
        j = np.arange(N)
        np.testing.assert_allclose(series[2][i], k * np.maximum(0.03 * j, 0.02 / k), rtol=1e-12, atol=0)
    assert hlines(tilt) == pytest.approx([math.degrees(THESIS_LIMITS["tilt_max"])], rel=1e-15)
    assert hlines(rate) == pytest.approx([math.degrees(THESIS_LIMITS["tilt_rate_max"])], rel=1e-15)
    assert hlines(torque) == [logs[-1].params.tau_max] == [4.0]
    assert [ax["ylabel"] for ax in (err, tilt, rate, torque)] == [
        "lateral error (cm)", "tilt (deg)", "|tilt rate| (deg/s)", "max |torque cmd| (N m)"]
    assert_style(saved, "path_xy.png")
    assert_style(saved, "path_errors_limits.png")

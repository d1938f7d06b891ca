"""What the path study's figures draw (``path_xy.png``, ``path_errors_limits.png``), read
back from the saved figures for stand-in runs along a straight path, where the lateral
error is the distance from the x axis and every number is computed here by hand."""

from __future__ import annotations

import math
import warnings

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
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # e.g. an empty legend
        files = path_plots(logs, {}, tmp_path)
    assert [f.name for f in files] == ["path_xy.png", "path_errors_limits.png"]  # no samples logged
    assert "path_samples.png" not in saved
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


class _Law:
    """Stand-in for the scenario's MPC law: only the ADMM's iteration count is read."""

    class config:
        iterations = 7


def _mpc_predictions(n_samples: int):
    """Predicted positions (n_samples, N+1 = 4, 2) that tell every sample and node apart."""
    i, n = np.meshgrid(np.arange(n_samples), np.arange(4), indexing="ij")
    return np.stack([10.0 * i + n, -(100.0 * i + 0.5 * n)], axis=-1)


def test_path_figures_draw_the_mpc_horizons_and_the_sample_times(saved, tmp_path, monkeypatch):
    import ballbot_casadi.studies.path as study

    pos = _mpc_predictions(12)
    calls = []
    monkeypatch.setattr(study, "scenario_law", lambda sc: calls.append(sc.name) or _Law())
    monkeypatch.setattr(study, "predictions", lambda law, arrays, every: (
        np.arange(12) * every, pos))
    log = _log("path_fig8_mpc", 1.0, guidance="mpc", cascade=True)
    other = _log("path_obstacles_mpc_ukf", 2.0, guidance="mpc", estimator="ukf", cascade=True)
    t = [0.0, 0.1, 0.2, 0.3]
    log.extra[study.SAMPLES_KEY] = {"t_s": t, "wall_us": [900.0, 40.0, 35.0, 50.0],
                                    "cpu_us": [800.0, 30.0, 33.0, 45.0], "r_prim": [1e-3, 0.0, 2e-6, 1e-15]}
    files = path_plots([log, other], {}, tmp_path)
    assert [f.name for f in files] == ["path_xy.png", "path_errors_limits.png", "path_samples.png"]

    fig8, obst = saved["path_xy.png"]
    shown = study.horizon_samples(12)
    np.testing.assert_array_equal(shown, [1, 4, 6, 8, 11])
    drawn = [(lab, x, y) for lab, x, y in fig8["lines"] if x.size == 4]
    assert len(drawn) == len(shown)
    for j, (i, (lab, x, y)) in enumerate(zip(shown, drawn)):
        assert lab == "fig8_mpc: predicted horizons (2 s)" if j == 0 else lab.startswith("_")
        np.testing.assert_array_equal(x, pos[i, :, 0])
        np.testing.assert_array_equal(y, pos[i, :, 1])
    starts = [(x[0], y[0]) for lab, x, y in fig8["lines"] if x.size == 1]
    assert starts == [tuple(pos[i, 0]) for i in shown]
    assert not [1 for _, x, _ in obst["lines"] if x.size in (1, 4)]  # no horizons with an estimator
    assert calls == ["path_fig8_mpc", "path_fig8_mpc"]  # the horizons, then the samples' title

    times, resid = saved["path_samples.png"]
    x, y = line(times, "fig8_mpc wall-clock")
    np.testing.assert_array_equal(x, t)
    np.testing.assert_array_equal(y, [900.0, 40.0, 35.0, 50.0])
    x, y = line(times, "fig8_mpc CPU")
    np.testing.assert_array_equal(y, [800.0, 30.0, 33.0, 45.0])
    assert hlines(times) == [1000.0]
    x, y = line(resid, "fig8_mpc")
    np.testing.assert_array_equal(y, [1e-3, 1e-12, 2e-6, 1e-12])  # zero floored for the log scale
    assert [(ax["yscale"], ax["xscale"]) for ax in (times, resid)] == [("log", "linear")] * 2
    assert resid["title"].startswith("ADMM: a fixed 7 iterations per QP (first sample: 5 QPs)")
    assert (times["ylabel"], resid["ylabel"], resid["xlabel"]) == (
        "time per sample (µs)", "ADMM primal residual r_prim", "t (s)")
    assert_style(saved, "path_samples.png")

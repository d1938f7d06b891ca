"""What the estimator study's figures draw (thesis Fig. 6.4-6.10), read back from the
saved figures for stand-in runs whose estimate errors are set by the test: roll and pitch
errors of different sizes, a heading error, velocity and position errors along x and y,
and a quaternion-norm deviation; the runs grouped by scenario (velocity loop or sine)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _figures import assert_style, line

from ballbot_casadi.analysis.estimates import tilt_heading_error_deg
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import STATE
from ballbot_casadi.core.params import load_params
from ballbot_casadi.sim.log import SimulationLog
from ballbot_casadi.studies.estimators import plot_estimates

N = 25


def _log(estimator: str, cascade: bool, k: float) -> SimulationLog:
    t = np.arange(N + 1) * 0.01
    s = np.linspace(0, 1, N)[:, None]
    x = np.zeros((N + 1, 12))
    x[:, STATE["q"]] = [Q.from_rpy(0.02 * j, -0.01 * j, 0.3) for j in range(N + 1)]
    x[:, STATE.index("dx")], x[:, STATE.index("dy")] = 0.2, -0.1
    xh = x[:N].copy()
    q_hat = [Q.from_rpy(0.02 * j + math.radians(k * 1.0), -0.01 * j + math.radians(k * 0.5),
                        0.3 + math.radians(k * 2.0)) for j in range(N)]
    xh[:, STATE["q"]] = np.array(q_hat) * (1 + k * 1e-6 * s)  # a norm deviation growing to k e-6
    xh[:, STATE.index("dx")] += 0.03 * k
    xh[:, STATE.index("dy")] += 0.04 * k
    xh[:, STATE.index("x")] += 0.5 * k * s[:, 0]
    xh[:, STATE.index("y")] -= 1.2 * k * s[:, 0]
    p = load_params()
    return SimulationLog(arrays={"time": t, "state": x, "x_hat": xh},
                         scenario={"name": f"r{k}", "controller": "flc", "estimator": estimator,
                                   "cascade": cascade}, params=p, ctrl_params=p)


def test_estimate_errors_are_drawn_per_scenario_and_panel(saved, tmp_path):
    logs = [_log("ukf", True, 1.0), _log("ekf", False, 2.0), _log("ekf_heading", True, 3.0)]
    paths = plot_estimates(logs, {}, tmp_path)
    assert [p.name for p in paths] == ["estimates_velocity.png", "estimates_sine.png"]
    assert saved["estimates_velocity.png:suptitle"] == "estimates against the truth: velocity"
    t = np.arange(N) * 0.01
    s = np.linspace(0, 1, N)
    for fig, runs in (("estimates_velocity.png", ((1.0, "ukf"), (3.0, "ekf_heading"))),
                      ("estimates_sine.png", ((2.0, "ekf"),))):
        att, heading, vel, pos, norm = saved[fig]
        labels = [lab for lab, *_ in att["lines"]]
        assert labels == [f"{ax} flc+{e}" for _, e in runs for ax in ("roll", "pitch")]
        for k, est in runs:
            lab = f"flc+{est}"
            x, y = line(att, f"roll {lab}")
            np.testing.assert_array_equal(x, t)
            np.testing.assert_allclose(y, k * 1.0, rtol=0, atol=1e-9)
            np.testing.assert_allclose(line(att, f"pitch {lab}")[1], k * 0.5, rtol=0, atol=1e-9)
            log = next(g for g in logs if g.scenario["estimator"] == est)
            _, h = tilt_heading_error_deg(log["state"][:N, STATE["q"]], log["x_hat"][:, STATE["q"]])
            np.testing.assert_array_equal(line(heading, lab)[1], h)
            assert h[0] == pytest.approx(k * 2.0, rel=0.01)  # about the heading error set above (tilted)
            np.testing.assert_allclose(line(vel, lab)[1], k * 0.05, rtol=1e-12, atol=0)
            np.testing.assert_allclose(line(pos, lab)[1], k * 1.3 * s, rtol=1e-12, atol=0)
            np.testing.assert_allclose(line(norm, lab)[1], np.maximum(k * 1e-6 * s, 1e-17), rtol=1e-6, atol=1e-15)
        assert [a["ylabel"] for a in (att, heading, vel, pos, norm)] == [
            "estimate - true (deg)", "heading drift (deg)", "|v error| (m/s)", "|position error| (m)",
            "| |q| - 1 |"]
        assert norm["yscale"] == "log" and norm["xlabel"] == "time (s)"
        assert_style(saved, fig)

"""What the main run plot (every study's ``plot.png``) and the COM observer plot draw, read
back from the saved figures (``saved`` in conftest.py) and compared with values computed
here from stand-in runs whose arrays differ by axis, wheel and run (issue 23: plot mutants
-- a limit line on the wrong axes or at the wrong value, a series drawn on the wrong
panel -- changed no number a test looked at)."""

from __future__ import annotations

import math

import numpy as np
from _figures import assert_style, hlines, line

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import STATE
from ballbot_casadi.core.params import load_params
from ballbot_casadi.sim.log import SimulationLog
from ballbot_casadi.studies import com as COM
from ballbot_casadi.studies.registry import STUDIES
from ballbot_casadi.studies.study import plot_run

N, TS = 40, 0.01


def _log(name: str, rpy_deg, rpy_ref_deg, *, cascade=True, scale=1.0, **scenario) -> SimulationLog:
    """A run of N periods: attitude rows ``rpy_deg`` (N + 1, 3) against ``rpy_ref_deg`` (N, 3)."""
    t = np.arange(N + 1) * TS
    state = np.zeros((N + 1, 12))
    state[:, STATE["q"]] = [Q.from_rpy(*np.radians(r)) for r in rpy_deg]
    state[:, STATE.index("x")] = scale * 0.3 * t
    state[:, STATE.index("y")] = -scale * 0.1 * t ** 2
    state[:, STATE.index("dx")] = scale * 0.3
    state[:, STATE.index("dy")] = -scale * 0.2 * t
    k = np.arange(N)[:, None]
    tau = np.hstack([0.01 * k, -0.02 * k, 0.5 * np.sin(k)]) * scale
    v_ref = np.column_stack([0.25 * np.ones(N), -0.15 * np.ones(N), np.zeros(N)])
    arrays = {"time": t, "state": state, "q_ref": np.array([Q.from_rpy(*np.radians(r)) for r in rpy_ref_deg]),
              "tau": tau, "tau_cmd": tau, "v_ref": v_ref}
    p = load_params()
    return SimulationLog(arrays=arrays, scenario={"name": name, "controller": "smc", "cascade": cascade,
                                                  **scenario}, params=p, ctrl_params=p)


def _angles(scale: float = 1.0):
    s = np.linspace(0, 1, N + 1)[:, None]
    rpy = scale * np.hstack([4 * s, -2.5 * s, 10 * s ** 2])
    ref = scale * np.hstack([3 * s[:N], -2 * s[:N], 12 * s[:N]])
    return rpy, ref


def test_run_plot_draws_angles_velocities_torques_and_errors_on_their_panels(saved, tmp_path):
    rpy, ref = _angles()
    other = _log("other", *_angles(0.5), scale=2.0)
    main = _log("main", rpy, ref)
    plot_run("study demo", [other, main], tmp_path / "plot.png")
    ang_ax, vel_ax, tau_ax, err_ax = saved["plot.png"]
    t = np.arange(N + 1) * TS
    for i, lab in enumerate(("roll", "pitch", "yaw")):
        x, y = line(ang_ax, lab)
        np.testing.assert_allclose(x, t, rtol=0, atol=0)
        np.testing.assert_allclose(y, rpy[:, i], rtol=0, atol=1e-9)
        x, y = line(err_ax, f"|{lab} error|")
        np.testing.assert_allclose(x, t[:N], rtol=0, atol=0)
        np.testing.assert_allclose(y, np.maximum(np.abs(rpy[:N, i] - ref[:, i]), 1e-12), rtol=0, atol=1e-9)
        assert y[0] == 1e-12  # no error at the start: drawn at the log axis' floor
    refs = [y for lab, _, y in ang_ax["lines"] if lab.startswith("_")]  # the dashed references
    np.testing.assert_allclose(np.array(refs).T, ref, rtol=0, atol=1e-9)
    assert ang_ax["ylabel"] == "angle (deg), -- ref" and err_ax["yscale"] == "log"
    assert err_ax["ylabel"] == "attitude error (deg)" and err_ax["xlabel"] == "time (s)"
    np.testing.assert_allclose(line(vel_ax, "dx")[1], 0.3, rtol=0, atol=0)
    np.testing.assert_allclose(line(vel_ax, "dy")[1], -0.2 * t, rtol=0, atol=1e-15)
    np.testing.assert_allclose(line(vel_ax, "vx ref")[1], 0.25, rtol=0, atol=0)
    np.testing.assert_allclose(line(vel_ax, "vy ref")[1], -0.15, rtol=0, atol=0)
    np.testing.assert_allclose(line(vel_ax, "|v|")[1], np.hypot(0.3, 0.2 * t), rtol=1e-15, atol=0)
    np.testing.assert_allclose(line(vel_ax, "|v| other")[1], np.hypot(0.6, 0.4 * t), rtol=1e-15, atol=0)
    assert vel_ax["ylabel"] == "ball velocity (m/s)"
    tau = main.arrays["tau"]
    for i in range(3):
        x, y = line(tau_ax, f"tau{i}")
        np.testing.assert_allclose(x, t[:N], rtol=0, atol=0)
        np.testing.assert_allclose(y, tau[:, i], rtol=0, atol=0)
    tau_max = main.params.tau_max
    assert hlines(tau_ax) == [tau_max, -tau_max] and tau_ax["ylabel"] == "wheel torque (N m)"
    peak = max(math.degrees(math.acos(math.cos(math.radians(r)) * math.cos(math.radians(p))))
               for r, p, _ in rpy)
    assert saved["plot.png:suptitle"] == f"study demo (smc): peak tilt {peak:.2f} deg"
    assert_style(saved, "plot.png")


def test_run_plot_without_the_velocity_loop_draws_no_velocity_reference(saved, tmp_path):
    plot_run("x", [_log("main", *_angles(), cascade=False)], tmp_path / "plot.png")
    labels = [lab for lab, *_ in saved["plot.png"][1]["lines"]]
    assert labels == ["dx", "dy", "|v|"]


def test_com_plot_draws_distance_com_error_and_inclination_with_the_spec_limits(saved, tmp_path):
    """Roll-only attitudes, so the angle between the body verticals is |roll - roll_ref|."""
    s = np.linspace(0, 1, N + 1)[:, None]
    rpy = np.hstack([0.2 + 0.3 * s, 0 * s, 0 * s])
    ref = np.hstack([0.1 + 0 * s[:N], 0 * s[:N], 0 * s[:N]])
    runs = []
    for k, name in enumerate(("com_observer_true", "com_balance_only", "com_no_observer")):
        log = _log(name, rpy * (k + 1), ref, scale=k + 1.0, com_observer=name == "com_observer_true")
        log.params = log.params.replace(com_x=-0.02, com_y=-0.03)
        log.arrays["com_hat"] = np.column_stack([np.full(N, -0.021 + 0.001 * k), np.linspace(-0.03, -0.02, N)])
        # the first samples exactly on the observable part: drawn at the log scale's floor
        log.arrays["com_hat"][:3] = log.ctrl_params.l / log.params.l * np.array([-0.02, -0.03])
        runs.append(log)
    COM.plot_com(runs, {}, tmp_path)
    dist, com_ax, inc_ax = saved["com_observer.png"]
    t = np.arange(N + 1) * TS
    assert [lab for lab, *_ in dist["lines"]] == ["com_observer_true", "com_no_observer"]
    np.testing.assert_allclose(line(dist, "com_no_observer")[1], 3 * np.hypot(0.3 * t, 0.1 * t ** 2),
                               rtol=1e-14, atol=0)
    for k, name, label in ((0, "com_observer_true", "com_observer_true"),
                           (2, "com_no_observer", "com_no_observer (shadow)")):
        p = runs[k].params
        obs = runs[k].ctrl_params.l / p.l * np.array([p.com_x, p.com_y])
        mm = np.hypot(*(runs[k].arrays["com_hat"] - obs).T) * 1e3
        np.testing.assert_allclose(line(com_ax, label)[1], np.maximum(mm, 1e-6), rtol=1e-12, atol=0)
        np.testing.assert_array_equal(line(com_ax, label)[1][:3], 1e-6)
        thin = [y for lab, _, y in inc_ax["lines"] if lab.startswith("_") and y.size == N]
        np.testing.assert_allclose(thin[0 if k == 0 else 1], np.maximum(np.abs((k + 1) * rpy[:N, 0] - ref[:, 0]),
                                                                       1e-9), rtol=1e-9, atol=1e-12)
    specs = {s.metric: s.threshold for s in STUDIES["com"].extra_specs}
    assert hlines(com_ax) == [specs["observer_true_com_estimate_error_max_mm"]]
    assert hlines(inc_ax) == [specs["observer_true_standing_tilt_error_deg"]]
    assert com_ax["yscale"] == inc_ax["yscale"] == "log"
    assert dist["ylabel"] == "distance from start (m)"
    assert com_ax["ylabel"] == "|COM estimate - observable| (mm)"
    assert inc_ax["ylabel"] == "inclination error vs ref (deg)"
    assert (dist["xlabel"], com_ax["xlabel"], inc_ax["xlabel"]) == ("", "", "time (s)")
    assert f"{COM.WINDOW_S:g} s" in inc_ax["title"]
    assert_style(saved, "com_observer.png")

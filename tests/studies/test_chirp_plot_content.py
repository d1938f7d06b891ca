"""What the chirp study's two figures draw (thesis Fig. 9.1-9.2 and the Bode comparison),
read back from the saved figures and compared with stand-in runs, metrics and linear
responses whose numbers differ by axis, wheel and feed-forward mode."""

from __future__ import annotations

import math

import numpy as np
from _figures import assert_style, hlines, line, vlines

from ballbot_casadi.analysis.bandwidth import FALL_TILT_DEG
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import STATE
from ballbot_casadi.core.params import load_params
from ballbot_casadi.sim.log import SimulationLog
from ballbot_casadi.studies.chirp import THESIS_BANDWIDTH_HZ, plot_chirp

N = 30


def _log(ff: str, k: float, limit: str = "direction") -> SimulationLog:
    t = np.arange(N + 1) * 0.01
    s = np.linspace(0, 1, N + 1)
    rpy = np.column_stack([k * 2 * s, k * 30 * s, k * 0.5 * s])  # pitch passes the +-20 deg clip
    state = np.zeros((N + 1, 12))
    state[:, STATE["q"]] = [Q.from_rpy(*np.radians(r)) for r in rpy]
    ref = [Q.from_rpy(0.0, math.radians(3 * x), 0.0) for x in s[:N]]
    j = np.arange(N)[:, None]
    tau = k * np.hstack([0.1 * j, -0.05 * j, 0.02 * j ** 1.5])
    p = load_params()
    return SimulationLog(arrays={"time": t, "state": state, "q_ref": np.array(ref), "tau_cmd": tau},
                         scenario={"name": f"chirp_{ff}", "feedforward": ff, "torque_limit": limit,
                                   "controller": "flc"}, params=p, ctrl_params=p)


def _response(k: float) -> dict:
    f = np.array([0.1, 0.5, 1.0, 2.0])
    return {"f_hz": f, "gain_db": -k * f, "phase_deg": -40 * k * f}


def test_chirp_plots_draw_both_modes_their_torques_and_the_linear_responses(saved, tmp_path):
    logs = [_log("none", 1.0), _log("none", 1.5, limit="scale"), _log("exact", 0.5)]
    metrics = {"chirp_axis": "pitch",
               "by_feedforward": {"none": {"response": _response(1.0), "bandwidth_hz": 0.8,
                                           "first_saturation_s": 0.12},
                                  "exact": {"response": _response(2.0), "bandwidth_hz": None,
                                            "first_saturation_s": 0.2}}}
    w = np.array([1.0, 2.0, 4.0])
    linear = {"none": {"omega": w, "mag": np.array([1.0, 0.5, 0.1]), "phase_deg": np.array([-10, -50, -120])},
              "analyze": {"omega": w, "mag": np.array([2.0, 1.0, 0.2]), "phase_deg": np.array([-5, -20, -60])}}
    plot_chirp(logs, metrics, linear, tmp_path)
    main_ax, other_ax, tau_ax = saved["chirp_time.png"]
    t = np.arange(N) * 0.01
    s = np.linspace(0, 1, N + 1)[:N]
    for k, ff in ((1.0, "none"), (1.5, "none, scale limit"), (0.5, "exact")):
        x, y = line(main_ax, f"pitch ({ff} feed-forward)")
        np.testing.assert_allclose(x, t, rtol=0, atol=0)
        np.testing.assert_allclose(y, np.clip(k * 30 * s, -20, 20), rtol=0, atol=1e-9)
        np.testing.assert_allclose(line(other_ax, f"roll ({ff})")[1], k * 2 * s, rtol=0, atol=1e-9)
    np.testing.assert_allclose(line(main_ax, "reference")[1], 3 * s, rtol=0, atol=1e-9)
    tau = logs[-1].arrays["tau_cmd"]
    for m in range(3):  # only the last run's mode draws its torques
        np.testing.assert_allclose(line(tau_ax, f"tau_cmd {m} (exact)")[1], tau[:, m], rtol=0, atol=0)
    assert not [lab for lab, *_ in tau_ax["lines"] if "(none" in lab]
    tau_max = logs[-1].params.tau_max
    assert hlines(tau_ax) == [tau_max, -tau_max] and tau_ax["ylim"] == (-3 * tau_max, 3 * tau_max)
    for ax in (main_ax, other_ax, tau_ax):
        assert vlines(ax) == [0.12, 0.2]
    assert (main_ax["ylabel"], other_ax["ylabel"], tau_ax["ylabel"]) == (
        "pitch (deg)", "other tilt (deg)", "commanded torque (N m)")
    assert f"fall: tilt > {FALL_TILT_DEG:g} deg" in saved["chirp_time.png:suptitle"]
    assert "pitch reference" in saved["chirp_time.png:suptitle"]

    gain, phase = saved["chirp_bode.png"]
    for k, ff in ((1.0, "none"), (2.0, "exact")):
        r = _response(k)
        x, y = line(gain, f"measured, {ff} feed-forward")
        np.testing.assert_array_equal(x, r["f_hz"])
        np.testing.assert_array_equal(y, r["gain_db"])
        np.testing.assert_array_equal(line(phase, f"measured, {ff}")[1], r["phase_deg"])
    f = w / (2 * math.pi)
    x, y = line(gain, "linear FLC, no feed-forward (8.45)")
    np.testing.assert_allclose(x, f, rtol=1e-15)
    np.testing.assert_allclose(y, [0.0, -6.0206, -20.0], rtol=0, atol=1e-4)
    np.testing.assert_array_equal(line(phase, "linear, no feed-forward")[1], [-10, -50, -120])
    np.testing.assert_allclose(line(gain, "linear, ballbot analyze (q_ref only)")[1], [6.0206, 0.0, -13.9794],
                               rtol=0, atol=1e-4)
    np.testing.assert_array_equal(line(phase, "linear, analyze")[1], [-5, -20, -60])
    assert vlines(gain) == [0.8, THESIS_BANDWIDTH_HZ]  # the exact mode has no bandwidth
    assert hlines(gain) == [0.0, -3.0] and hlines(phase) == [-90.0]
    assert gain["xscale"] == "log" and gain["xlim"] == (0.05, 5.0)
    assert gain["ylim"] == (-20.0, 6.0) and phase["ylim"] == (-200.0, 30.0)
    assert (gain["ylabel"], phase["ylabel"], phase["xlabel"]) == ("gain (dB)", "phase (deg)", "frequency (Hz)")
    assert_style(saved, "chirp_time.png")
    assert_style(saved, "chirp_bode.png")


def test_a_yaw_chirp_shows_roll_as_the_other_tilt(saved, tmp_path):
    metrics = {"chirp_axis": "yaw", "by_feedforward": {"none": {"response": _response(1.0)}}}
    w = np.array([1.0])
    plot_chirp([_log("none", 1.0)], metrics, {"none": {"omega": w, "mag": w, "phase_deg": w}}, tmp_path)
    main_ax, other_ax, _ = saved["chirp_time.png"]
    s = np.linspace(0, 1, N + 1)[:N]
    np.testing.assert_allclose(line(main_ax, "yaw (none feed-forward)")[1], 0.5 * s, rtol=0, atol=1e-9)
    np.testing.assert_allclose(line(other_ax, "roll (none)")[1], 2 * s, rtol=0, atol=1e-9)
    assert main_ax["ylabel"] == "yaw (deg)"


def test_a_run_is_labelled_with_its_limit_when_it_differs_from_the_main_runs(saved, tmp_path):
    """The main run (last) sets the torque-limit mode left unsaid; any other run with
    another mode, first or not, names it."""
    logs = [_log("none", 1.0, limit="per-wheel"), _log("none", 1.5), _log("exact", 0.5)]
    metrics = {"chirp_axis": "pitch", "by_feedforward": {
        "none": {"response": _response(1.0), "bandwidth_hz": 0.8, "first_saturation_s": 0.12},
        "exact": {"response": _response(2.0), "bandwidth_hz": None, "first_saturation_s": 0.2}}}
    w = np.array([1.0, 2.0, 4.0])
    linear = {k: {"omega": w, "mag": np.ones(3), "phase_deg": np.zeros(3)} for k in ("none", "analyze")}
    plot_chirp(logs, metrics, linear, tmp_path)
    main_ax = saved["chirp_time.png"][0]
    labels = [lab for lab, *_ in main_ax["lines"]]
    assert "pitch (none, per-wheel limit feed-forward)" in labels
    assert "pitch (none feed-forward)" in labels and "pitch (exact feed-forward)" in labels
    assert not [lab for lab in labels if "direction limit" in lab]

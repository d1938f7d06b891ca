"""Metric computations on synthetic logs with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest
from ballbot_casadi.studies.registry import STUDIES, Spec, get_study

from ballbot_casadi.analysis.metrics import (
    com_equilibrium_deg,
    rpy_deg,
    sine_lag,
    sine_metrics,
    tilt_deg,
    total_variation,
    velocity_metrics,
    zero_metrics,
)
from ballbot_casadi.core import quaternion as Q


def _quats(rpy: np.ndarray) -> np.ndarray:
    return np.array([Q.from_rpy(*r) for r in rpy])


def test_rpy_and_tilt_match_quaternion_module():
    rng = np.random.default_rng(4)
    rpy = rng.uniform(-0.5, 0.5, (50, 3))
    q = _quats(rpy)
    np.testing.assert_allclose(rpy_deg(q), np.degrees(rpy), rtol=0, atol=1e-12)
    single = _quats(np.column_stack([rpy[:, 0], np.zeros(50), rpy[:, 2]]))
    np.testing.assert_allclose(tilt_deg(single), np.degrees(np.abs(rpy[:, 0])), rtol=0, atol=1e-6)


@pytest.mark.parametrize("a_ref", [1.0, 2.0])  # 2: the ratio is a quotient, not a product
def test_sine_lag_recovers_delay(a_ref):
    t = np.arange(0, 10, 0.005)
    f = 0.5
    y = 0.9 * a_ref * np.sin(2 * np.pi * f * (t - 0.0123))
    lag, ratio = sine_lag(t, y, a_ref * np.sin(2 * np.pi * f * t), f)
    assert lag == pytest.approx(0.0123, abs=1e-9)
    assert ratio == pytest.approx(0.9, abs=1e-9)


def test_total_variation():
    assert total_variation(np.array([[0.0, 1.0], [1.0, 1.0], [0.5, 0.0]])) == pytest.approx(2.5, abs=1e-15)
    assert total_variation(np.zeros((1, 3))) == 0.0
    assert total_variation(np.array([[1.0, -2.0], [0.5, 1.0]])) == pytest.approx(3.5, abs=1e-15)  # two samples


def _sine_log(chatter: float) -> dict:
    Ts, f = 0.005, 0.5
    t = np.arange(0, 4, Ts)
    roll = np.radians(3) * np.sin(2 * np.pi * f * t)
    q_ref = _quats(np.column_stack([roll, np.zeros_like(t), np.zeros_like(t)]))
    lagged = np.radians(3) * np.sin(2 * np.pi * f * (t - 0.01))
    state = np.zeros((t.size + 1, 12))
    state[:-1, 2:6] = _quats(np.column_stack([lagged, np.radians(0.002) * np.ones_like(t), np.zeros_like(t)]))
    state[-1] = state[-2]
    tau = 0.5 * np.sin(2 * np.pi * f * t)[:, None] * np.ones(3)
    tau += chatter * np.where(np.arange(t.size) % 2 == 0, 1.0, -1.0)[:, None]
    return {"time": np.arange(t.size + 1) * Ts, "state": state, "q_ref": q_ref, "tau": tau, "tau_cmd": tau}


def test_sine_metrics_values_and_chattering_detection():
    smooth = sine_metrics(_sine_log(0.0), 0.5)
    assert smooth["roll_lag_s"] == pytest.approx(0.01, abs=1e-6)
    # 3 deg (sin wt - sin w(t - 0.01)) peaks at 6 sin(w 0.005) deg, on the sample t = 0.005 s
    assert smooth["roll_error_max_deg"] == pytest.approx(6 * np.sin(np.pi * 0.005), abs=1e-5)
    assert smooth["pitch_error_max_deg"] == pytest.approx(0.002, abs=1e-6)
    assert smooth["yaw_error_max_deg"] < 1e-6
    assert smooth["torque_tv_ratio"] == pytest.approx(1.0, abs=0.01)
    assert smooth["torque_total_variation"] == pytest.approx(3 * 4 * 0.5 * 2, rel=0.01)  # 3 wheels x 4A per period x 2 periods
    chatter = sine_metrics(_sine_log(0.05), 0.5)
    assert chatter["torque_tv_ratio"] > 5


def test_zero_metrics_settling():
    t = np.arange(0, 3, 0.005)
    roll = np.radians(5) * np.exp(-3 * t)
    q = _quats(np.column_stack([roll, np.zeros_like(t), np.zeros_like(t)]))
    state = np.zeros((t.size + 1, 12))
    state[:-1, 2:6] = q
    state[-1] = state[-2]
    log = {"time": np.append(t, 3.0), "state": state, "q_ref": np.tile([1.0, 0, 0, 0], (t.size, 1))}
    m = zero_metrics(log, window_s=1.0, band_deg=0.1)
    assert m["settling_time_s"] == pytest.approx(math.log(50) / 3, abs=0.006)
    assert m["steady_state_error_deg"] == pytest.approx(5 * math.exp(-3 * 1.995), rel=1e-6)


def test_com_equilibrium_puts_com_over_ball_centre():
    roll, pitch = com_equilibrium_deg(-0.02, -0.03, 0.4513)
    r = Q.rotate(Q.from_rpy(math.radians(roll), math.radians(pitch), 0.7), np.array([-0.02, -0.03, 0.4513]))
    np.testing.assert_allclose(r[:2], 0.0, atol=1e-15)
    assert (roll, pitch) == pytest.approx((-3.80, 2.53), abs=0.01)  # thesis §9.2: about -4 and 2.5 deg


def test_velocity_metrics_delay():
    Ts = 0.005
    t = np.arange(0, 10, Ts)
    vr = np.zeros((t.size, 3))
    vr[:, 0] = np.clip(t - 1, 0, 0.3)
    state = np.zeros((t.size + 1, 12))
    state[:, 2] = 1.0
    state[:-1, 6] = np.clip(t - 1.25, 0, 0.3)
    log = {"time": np.arange(t.size + 1) * Ts, "state": state, "v_ref": vr}
    m = velocity_metrics(log)
    assert m["velocity_lag_s"] == pytest.approx(0.25, abs=1e-9)
    assert m["velocity_error_rms_delayed_mps"] < 1e-12
    assert m["velocity_error_max_mps"] == pytest.approx(0.25, abs=1e-9)
    # a residual 1 Hz ripple of 10 mm/s on top: RMS and max must tell it apart (A/sqrt(2), A)
    state[:-1, 7] = 0.01 * np.sin(2 * np.pi * t)
    m = velocity_metrics({**log, "state": state})
    assert m["velocity_lag_s"] == pytest.approx(0.25, abs=1e-9)
    assert m["velocity_error_rms_delayed_mps"] == pytest.approx(0.01 / np.sqrt(2), rel=1e-3)
    assert m["velocity_error_max_delayed_mps"] == pytest.approx(0.01, rel=1e-3)


def test_specs_evaluate_each_criterion():
    rows = STUDIES["sine_asym"].check({"finite": True, "roll_lag_s": -0.005, "pitch_error_max_deg": 0.6,
                                       "yaw_error_max_deg": math.nan})
    ok = [(r["metric"], r["ok"]) for r in rows]
    assert ok == [("finite", True), ("pitch_error_max_deg", True), ("pitch_error_max_deg", False),
                  ("yaw_error_max_deg", False), ("roll_lag_s", True)]
    assert STUDIES["zero"].check({})[1]["ok"] is False  # a missing metric fails
    # boundaries: strict and non-strict operators differ exactly at the threshold
    assert Spec("m", "<", 1.0, "").evaluate({"m": 1.0})["ok"] is False
    assert Spec("m", "<=", 1.0, "").evaluate({"m": 1.0})["ok"] is True
    assert Spec("m", "abs<=", 1.0, "").evaluate({"m": -1.0})["ok"] is True
    with pytest.raises(ValueError, match="unknown study"):
        get_study("nope")


def test_sine_metrics_torque_ratio_without_torque_is_infinite():
    """No torque at all: both total variations are exactly 0 and the ratio is reported as
    inf (no smooth reference to compare with), not 0/0."""
    log = _sine_log(0.0)
    log["tau"] = np.zeros_like(log["tau"])
    m = sine_metrics(log, 0.5)
    assert m["torque_total_variation"] == 0.0
    assert m["torque_tv_ratio"] == math.inf


def test_final_velocity_error_is_read_at_the_last_sample():
    """Errors 0, 0, 0.05, 0.03 m/s at 1 s steps (no delay candidate but 0): the final error
    is 0.03 (the sample before it is 0.05)."""
    vr = np.zeros((4, 3))
    vr[:, 0] = 0.2
    state = np.zeros((5, 12))
    state[:, 2] = 1.0
    state[:4, 6] = [0.2, 0.2, 0.15, 0.23]
    m = velocity_metrics({"time": np.arange(5) * 1.0, "state": state, "v_ref": vr})
    assert m["final_velocity_error_mps"] == pytest.approx(0.03, abs=1e-12)
    assert m["velocity_error_max_mps"] == pytest.approx(0.05, abs=1e-12)


def test_velocity_metrics_of_a_one_period_log():
    """A run stopped after one control period logs one reference sample: the metrics are
    those of that sample (speed 0.1 m/s tracked exactly: no error, no delay, no
    acceleration, which needs two samples), not an IndexError or a NaN."""
    vr = np.array([[0.1, 0.0, 0.0]])
    state = np.zeros((2, 12))
    state[:, 2] = 1.0
    state[:, 6] = 0.1
    m = velocity_metrics({"time": np.array([0.0, 0.005]), "state": state, "v_ref": vr})
    assert m["max_speed_mps"] == pytest.approx(0.1, abs=1e-15)
    assert m["velocity_error_max_mps"] == 0.0
    assert m["velocity_lag_s"] == 0.0
    assert m["velocity_error_rms_delayed_mps"] == 0.0
    assert m["max_acceleration_mps2"] == 0.0
    assert m["max_yaw_accel_rps2"] == 0.0

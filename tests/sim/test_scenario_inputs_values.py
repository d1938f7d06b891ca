"""A scenario's input sequences (sim.scenario.scenario.Scenario) against hand values on a
ten-period run: each push at the NEAREST control instant (2.48 -> 2, 2.52 -> 3, the last
period clamped) about its own axis, torque disturbances on ``[t_start, t_end)``, sensor
glitches scaled by their axis's noise sigma in the right noise column, dropouts, the first
encoder sample, and every one of these in a window ``(k0, k1)`` of the run (issue 23:
truncation for rounding, a window test inverted, a swapped axis must show)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.core.sensor_params import load_sensor_params
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.estimation.com_observer import COM_OBSERVER_DEFAULT_GAINS
from ballbot_casadi.sim.embedded import NOISE, VALID
from ballbot_casadi.sim.scenario import parse_scenario

D = math.radians
TABLE = {
    "name": "inp", "duration_s": 0.05, "estimator": "ukf", "noise": False,
    "push": [{"t_s": 0.0124, "roll_deg": 3.0}, {"t_s": 0.0126, "yaw_deg": 4.0},
             {"t_s": 0.0476, "pitch_deg": -2.0}],
    "torque_disturbance": [{"t_start_s": 0.01, "t_end_s": 0.02, "tau_nm": [0.1, -0.2, 0.3]}],
    "sensor_glitch": [{"t_s": 0.0126, "sensor": "gyro", "axis": "y", "value": 0.5},
                      {"t_s": 0.0124, "sensor": "acc", "axis": "z", "value": -2.0}],
    "sensor_dropout": [{"t_start_s": 0.02, "t_end_s": 0.03, "sensor": "acc"}],
    "sensors": {"gyro_bias0": [0.01, -0.02, 0.03]},
}


@pytest.fixture(scope="module")
def sc():
    return parse_scenario(TABLE, "inp.toml").scenario


def test_window_and_time(sc):
    assert sc.n_periods == 10 and sc.window() == (0, 10) and sc.window((9, 10)) == (9, 10)
    np.testing.assert_allclose(sc.time((2, 5)), [0.01, 0.015, 0.02], rtol=1e-15)
    for bad in ((0, 11), (3, 3), (-1, 2), (5, 4)):
        with pytest.raises(ScenarioError, match=r"outside \[0, 10\)"):
            sc.window(bad)


def test_pushes_and_torques_per_period(sc):
    w = sc.disturbance()
    want = np.zeros((10, 6))
    want[2, 0] = D(3.0)      # roll at 2.48 periods -> period 2
    want[3, 2] = D(4.0)      # yaw at 2.52 periods -> period 3
    want[9, 1] = D(-2.0)     # pitch at 9.52 periods -> the last period, 9
    want[2:4, 3:6] = [0.1, -0.2, 0.3]  # t in [0.01, 0.02): periods 2 and 3
    np.testing.assert_allclose(w, want, rtol=0, atol=1e-15)
    np.testing.assert_allclose(sc.disturbance((3, 10)), want[3:], rtol=0, atol=1e-15)
    np.testing.assert_allclose(sc.disturbance((0, 3)), want[:3], rtol=0, atol=1e-15)


def test_glitches_dropouts_and_first_encoder_sample(sc):
    sp = load_sensor_params()
    e = sc.estimation_inputs()
    noise = np.zeros((10, NOISE.size))
    noise[3, NOISE["gyro"].start + 1] = 0.5 / math.sqrt(sp.gyro_noise_var[1])
    noise[2, NOISE["acc"].start + 2] = -2.0 / math.sqrt(sp.acc_noise_var[2])
    np.testing.assert_allclose(e["noise"], noise, rtol=1e-15, atol=0)
    valid = np.ones((10, VALID.size))
    valid[:, VALID.index("heading")] = 0.0   # no heading sensor
    valid[0, VALID.index("enc")] = 0.0       # nothing to difference at the first sample
    valid[4:6, VALID.index("acc")] = 0.0     # dropout [0.02, 0.03): periods 4 and 5
    np.testing.assert_array_equal(e["valid"], valid)
    np.testing.assert_allclose(e["s0"], [0, 0, 0, 0.01, -0.02, 0.03, 0, 0, 0], rtol=0, atol=0)
    w = sc.estimation_inputs(periods=(3, 10))
    np.testing.assert_allclose(w["noise"], noise[3:], rtol=1e-15, atol=0)
    want_valid = valid[3:].copy()
    np.testing.assert_array_equal(w["valid"], want_valid)  # the encoder valid from the window's start
    w = sc.estimation_inputs(periods=(0, 3))
    np.testing.assert_allclose(w["noise"], noise[:3], rtol=1e-15, atol=0)


def test_noise_rows_are_the_same_in_any_window():
    sc = parse_scenario({**TABLE, "noise": True, "seed": 12, "sensor_glitch": []}, "n.toml").scenario
    full = sc.estimation_inputs()["noise"]
    assert np.all(full[:, :9] != 0.0)
    np.testing.assert_array_equal(sc.estimation_inputs(periods=(4, 9))["noise"], full[4:9])
    other = parse_scenario({**TABLE, "noise": True, "seed": 13, "sensor_glitch": []}, "n.toml").scenario
    assert not np.any(other.estimation_inputs()["noise"][:, :9] == full[:, :9])


def test_feedforward_torque_limit_and_observer_gains_in_the_inputs():
    sine = {"roll": {"type": "sine", "amplitude_deg": 2.0, "frequency_hz": 1.0}}
    base = {"name": "ff", "duration_s": 0.05, "attitude": sine}
    exact = parse_scenario(base, "a.toml").scenario.inputs()
    assert exact["feedforward"] is True and np.any(exact["dq_ref"] != 0) and np.any(exact["ddq_ref"] != 0)
    no_rate = parse_scenario({**base, "feedforward": "no-rate", "torque_limit": "per-wheel"},
                             "b.toml").scenario.inputs()
    assert no_rate["feedforward"] is False
    np.testing.assert_array_equal(no_rate["q_ref"], exact["q_ref"])
    assert not np.any(no_rate["dq_ref"]) and not np.any(no_rate["ddq_ref"])
    none = parse_scenario({**base, "feedforward": "none"}, "c.toml").scenario.inputs()
    assert none["feedforward"] is False and np.any(none["dq_ref"] != 0)
    from ballbot_casadi.core.params import PARAM_NAMES
    i = PARAM_NAMES.index("tau_max")
    assert math.isinf(no_rate["p_ctrl"][i]) and exact["p_ctrl"][i] == exact["p_plant"][i] == no_rate["p_plant"][i]
    np.testing.assert_array_equal(exact["k_obs"], np.asarray(COM_OBSERVER_DEFAULT_GAINS, float))
    assert exact["Ts"] == 0.005 and exact["cascade"] is False and exact["estimator"] == "true"
    assert "estimation" not in exact and exact["w"].shape == (10, 6) and exact["v_ref"].shape == (10, 3)

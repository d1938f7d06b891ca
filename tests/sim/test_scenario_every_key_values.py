"""Every scenario-file key at a non-default value that separates it from its neighbours
(vx != vy, roll != pitch != yaw, plant != controller_model != estimator_model), read back
attribute by attribute and through a write/read round trip (issue 23: a swapped key, a
key read from the wrong table or dropped by the writer must show)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.sim.scenario import parse_scenario

BALANCE = {
    "name": "every", "description": "all keys", "study": "tests", "controller": "smc",
    "duration_s": 0.5, "control_period_s": 0.004, "rk4_substeps": 3, "feedforward": "none",
    "torque_limit": "per-wheel",
    "initial": {"roll_deg": 1.5, "pitch_deg": -2.5, "yaw_deg": 30.0, "x_m": 0.1, "y_m": -0.2,
                "vx_mps": 0.3, "vy_mps": -0.4},
    "attitude": {"pitch": {"type": "step", "amplitude_deg": 2.0, "t_step_s": 0.1},
                 "yaw": {"type": "const", "value_deg": 5.0}},
    "plant": {"Mb": {"scale": 1.1}, "com_x": -0.02},
    "controller_model": {"l": {"add": 0.01}},
    "estimator_model": {"Jk": 0.02},
    "sensors": {"acc_bias": [0.05, 0.0, -0.01], "gyro_noise_var": {"scale": 2.0}},
    "estimator": "ekf_heading", "heading_sensor": True, "seed": 9, "noise": False,
    "estimator_tuning": {"encoder_var": 0.2, "acc_bias_process_var": 2e-8, "acc_process_var_y": 3e-3},
    "com_observer": True,
    "gains": {"k_obs": [0.4, 2.5, 0.2, 0.05]},
}

CASCADE = {
    "name": "cascade", "duration_s": 0.5, "cascade": True, "feedforward": "no-rate",
    "velocity": [{"t_s": 0.0, "vx_mps": 0.2, "vy_mps": -0.1, "yaw_rate_rps": 0.3, "accel_mps2": 0.5},
                 {"t_s": 0.45, "vx_mps": 0.0, "vy_mps": 0.1, "yaw_rate_rps": 0.0, "accel_mps2": 1.0}],
    "estimator": "ukf_consistent",
}

PATH = {
    "name": "path", "duration_s": 0.5, "cascade": True, "guidance_latency": 3,
    "path": {"type": "waypoints", "speed": 0.3, "waypoints": [[0.0, 0.0], [1.0, 0.5], [2.0, 0.0]]},
    "obstacle": [{"x": 1.0, "y": -0.5, "r": 0.2}],
}


def test_the_balance_file_reads_every_key_where_it_belongs():
    sc = parse_scenario(BALANCE, "every.toml").scenario
    assert (sc.name, sc.description, sc.study, sc.controller) == ("every", "all keys", "tests", "smc")
    assert (sc.duration, sc.Ts, sc.n_sub, sc.n_periods) == (0.5, 0.004, 3, 125)
    assert (sc.feedforward, sc.torque_limit, sc.cascade) == ("none", "per-wheel", False)
    x = np.asarray(sc.x0)
    np.testing.assert_allclose(np.degrees(Q.to_rpy(x[2:6])), [1.5, -2.5, 30.0], rtol=0, atol=1e-12)
    assert (x[0], x[1], x[6], x[7]) == (0.1, -0.2, 0.3, -0.4)
    assert sc.attitude == {"pitch": {"type": "step", "amplitude_deg": 2.0, "t_step": 0.1},
                           "yaw": {"type": "const", "value_deg": 5.0}}
    assert sc.plant_changes == {"Mb": ["scale", 1.1], "com_x": ["set", -0.02]}
    assert sc.ctrl_changes == {"l": ["add", 0.01]}
    assert sc.est_changes == {"Jk": ["set", 0.02]}
    assert sc.sensor_changes == {"acc_bias": ["set", [0.05, 0.0, -0.01]], "gyro_noise_var": ["scale", 2.0]}
    assert (sc.estimator, sc.heading_sensor, sc.seed, sc.noise) == ("ekf_heading", True, 9, False)
    assert sc.estimator_tuning == {"encoder_var": 0.2, "acc_bias_process_var": 2e-8, "acc_process_var_y": 3e-3}
    assert sc.com_observer is True and sc.k_obs == (0.4, 2.5, 0.2, 0.05)
    assert sc.k_bal == () and sc.k_vel == () and sc.path == {} and sc.guidance == "mpc"
    # the changes land on their own parameter sets
    from ballbot_casadi.core.params import load_params
    p = load_params()
    assert sc.plant_params().Mb == pytest.approx(1.1 * p.Mb, rel=1e-15) and sc.plant_params().com_x == -0.02
    assert sc.controller_params().l == pytest.approx(p.l + 0.01, rel=1e-15) and sc.controller_params().Mb == p.Mb
    assert sc.estimator_params().Jk == 0.02 and sc.estimator_params().l == p.l
    assert tuple(sc.sensor_params().acc_bias) == (0.05, 0.0, -0.01)


def test_the_cascade_and_path_files_read_their_keys():
    sc = parse_scenario(CASCADE, "c.toml").scenario
    assert sc.cascade is True and sc.feedforward == "no-rate" and sc.estimator == "ukf_consistent"
    assert sc.velocity_keyframes == ((0.0, 0.2, -0.1, 0.3, 0.5), (0.45, 0.0, 0.1, 0.0, 1.0))
    v = sc.velocity_reference()
    assert v.shape == (100, 3)
    # the ramp to (0.2, -0.1, 0.3) at 0.5 m/s^2 lasts |(0.2, -0.1)| / 0.5 s; at t = 0.01 s:
    dur = max(math.hypot(0.2, -0.1) / 0.5, 0.3 / 10.0)
    np.testing.assert_allclose(v[2], np.array([0.2, -0.1, 0.3]) * 0.01 / dur, rtol=1e-12)
    sp = parse_scenario(PATH, "p.toml").scenario
    assert (sp.guidance, sp.guidance_latency) == ("mpc", 3)
    assert sp.obstacles == ((1.0, -0.5, 0.2),)
    assert sp.path == {"type": "waypoints", "speed": 0.3, "waypoints": [[0.0, 0.0], [1.0, 0.5], [2.0, 0.0]]}
    path = sp.route.build()
    np.testing.assert_allclose(np.asarray(path.point(0.0), float).ravel(), [0.0, 0.0], atol=1e-12)
    assert len(path.obstacles) == 1 and path.obstacles[0].radius == 0.2


@pytest.mark.parametrize("table", [BALANCE, CASCADE, PATH], ids=["balance", "cascade", "path"])
def test_write_and_read_back_keeps_every_key(table):
    sf = parse_scenario(table, "t.toml")
    written = sf.to_file()
    for key, value in table.items():  # every key written, none moved
        assert written[key] == value, key
    again = parse_scenario(written, "t2.toml")
    assert again.scenario == sf.scenario and again.to_file() == written

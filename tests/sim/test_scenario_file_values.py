"""Scenario files against hand-written values: defaults of a minimal file, a file using
every row type written back and read again key by key, and where the estimator tuning
keys land in the covariances (issue 23: wrong defaults, dropped keys in the writer and
swapped slices survived the tests)."""

from __future__ import annotations

import re
import tomllib

import numpy as np
import pytest

from ballbot_casadi.errors import ScenarioFileError
from ballbot_casadi.estimation import DEFAULT_TUNING
from ballbot_casadi.sim.embedded import ESTIMATOR_FILTERS
from ballbot_casadi.sim.scenario import dump_toml, load_scenario_file, parse_scenario
from ballbot_casadi.sim.scenario.sections import initial_state


def test_a_minimal_file_gets_the_documented_defaults():
    sf = parse_scenario({"duration_s": 1.0}, "m.toml", "m")
    sc = sf.scenario
    assert (sc.name, sc.controller, sc.Ts, sc.n_sub, sc.feedforward, sc.torque_limit) == \
        ("m", "flc", 0.005, 5, "exact", "direction")
    assert (sc.cascade, sc.estimator, sc.seed, sc.noise, sc.heading_sensor, sc.com_observer) == \
        (False, "true", 0, True, False, False)
    assert sc.x0 == initial_state() and sc.x0[2] == 1.0
    assert sf.specs == () and sf.montecarlo is None
    assert sf.to_file() == {"name": "m", "duration_s": 1.0}


FULL = {
    "name": "full", "duration_s": 2.0, "seed": 5, "noise": False, "estimator": "ukf",
    "initial": {"roll_deg": 1.5, "x_m": 0.25, "y_m": -0.5, "vx_mps": 0.3, "vy_mps": -0.1},
    "push": [{"t_s": 0.0, "roll_deg": 2.0}, {"t_s": 1.0, "pitch_deg": -1.0, "yaw_deg": 3.0}],
    "torque_disturbance": [{"t_start_s": 0.5, "t_end_s": 0.75, "tau_nm": [0.123456789, -2.0, 3.0]}],
    "sensor_dropout": [{"t_start_s": 0.25, "t_end_s": 0.5, "sensor": "gyro"}],
    "sensor_glitch": [{"t_s": 0.3, "sensor": "acc", "value": 4.0},
                      {"t_s": 0.4, "sensor": "gyro", "axis": "y", "value": -1.0}],
    "estimator_tuning": {"rate_process_var": 2e-4},
    "spec": [{"metric": "max_tilt_deg", "op": "<=", "threshold": 5, "source": "why", "thesis": "§7.1"},
             {"metric": "finite", "op": "==", "threshold": True}],
    "montecarlo": {"seed": 3, "dispersion": [
        {"param": "plant.Mb", "dist": "normal", "sd": 0.05, "relative": True},
        {"param": "initial.y_m", "dist": "uniform", "low": -0.1, "high": 0.2}]},
}


def test_every_row_type_is_read_as_written():
    sf = parse_scenario(FULL, "full.toml")
    sc = sf.scenario
    x = sc.x0
    assert (x[0], x[1], x[6], x[7]) == (0.25, -0.5, 0.3, -0.1)  # x, y, vx, vy in that order
    assert sc.pushes == ((0.0, 2.0, 0.0, 0.0), (1.0, 0.0, -1.0, 3.0))
    assert sc.torque_disturbances == ((0.5, 0.75, 0.123456789, -2.0, 3.0),)
    assert sc.sensor_dropouts == ((0.25, 0.5, "gyro"),)
    assert sc.sensor_glitches == ((0.3, "acc", "x", 4.0), (0.4, "gyro", "y", -1.0))  # default axis x
    assert (sc.seed, sc.noise) == (5, False)
    assert sf.specs[0] == {"metric": "max_tilt_deg", "op": "<=", "threshold": 5, "source": "why",
                           "thesis": "§7.1"}
    assert sf.specs[1]["source"] == "scenario file" and sf.specs[1]["thesis"] == ""
    assert sf.montecarlo == {"seed": 3, "dispersion": [
        {"param": "plant.Mb", "dist": "normal", "relative": True, "sd": 0.05},
        {"param": "initial.y_m", "dist": "uniform", "relative": False, "low": -0.1, "high": 0.2}]}


def test_the_writer_keeps_every_key_and_digit():
    sf = parse_scenario(FULL, "full.toml")
    back = sf.to_file()
    assert back["push"] == [{"t_s": 0.0, "roll_deg": 2.0}, {"t_s": 1.0, "pitch_deg": -1.0, "yaw_deg": 3.0}]
    assert back["torque_disturbance"] == FULL["torque_disturbance"]
    assert back["sensor_dropout"] == FULL["sensor_dropout"]
    assert back["sensor_glitch"] == [{"t_s": 0.3, "sensor": "acc", "axis": "x", "value": 4.0},
                                     {"t_s": 0.4, "sensor": "gyro", "axis": "y", "value": -1.0}]
    assert back["spec"] == [FULL["spec"][0], {"metric": "finite", "op": "==", "threshold": True,
                                              "source": "scenario file"}]
    assert (back["seed"], back["noise"], back["estimator"]) == (5, False, "ukf")
    # through TOML text and back: the same scenario, specs and dispersions
    again = parse_scenario(tomllib.loads(dump_toml(back)), "again.toml")
    assert again.scenario == sf.scenario and again.specs == sf.specs and again.montecarlo == sf.montecarlo


@pytest.mark.parametrize("key, cov, block", [
    ("rate_process_var", "Qa", slice(3, 6)), ("encoder_var", "Rv", slice(0, 3)),
    ("acc_process_var", "Qv", slice(2, 4)), ("acc_process_var_x", "Qv", slice(2, 3)),
    ("acc_process_var_y", "Qv", slice(3, 4)), ("acc_bias_process_var", "Qv", slice(4, 7))])
def test_estimator_tuning_sets_its_own_diagonal_block_only(key, cov, block):
    sc = parse_scenario({"duration_s": 0.05, "estimator": "ukf", "estimator_tuning": {key: 7.5e-3}},
                        "t.toml").scenario
    got = sc.estimation_inputs(periods=(0, 1))[cov]
    att, vel = (DEFAULT_TUNING[f] for f in ESTIMATOR_FILTERS["ukf"])
    want = np.array({"Qa": att.Q, "Ra": att.R, "Qv": vel.Q, "Rv": vel.R}[cov], float)
    want[block, block] = np.eye(block.stop - block.start) * 7.5e-3
    np.testing.assert_array_equal(got, want)


def test_a_file_that_is_not_utf8_text_or_is_a_folder_cannot_be_read(tmp_path):
    bad = tmp_path / "latin1.toml"
    bad.write_bytes('name = "Müller"\nduration_s = 1.0\n'.encode("latin-1"))
    with pytest.raises(ScenarioFileError, match=rf"^{re.escape(str(bad))}: cannot read the "
                                                r"scenario file \('utf-8' codec can't decode"):
        load_scenario_file(bad)
    with pytest.raises(ScenarioFileError, match=r": cannot read the scenario file \(\[Errno 21\]"):
        load_scenario_file(tmp_path)
    bad.write_bytes('name = "Müller"\nduration_s = 1.0\n'.encode("utf-8"))
    assert load_scenario_file(bad).scenario.name == "Müller"

"""``[[sensor_glitch]]`` rows of a scenario file: parsing, round trip, the noise sample
they set, and the one-line refusals (exit 2 on the command line)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ballbot_casadi.cli import main
from ballbot_casadi.core.sensor_params import load_sensor_params
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.sim.embedded import NOISE
from ballbot_casadi.sim.log import load_log
from ballbot_casadi.sim.scenario import parse_scenario

BASE = {"name": "g", "estimator": "ukf", "duration_s": 1.0, "noise": False}


def _rows(*rows):
    return parse_scenario({**BASE, "sensor_glitch": list(rows)}).scenario


def test_glitch_rows_parse_round_trip_and_land_in_the_noise_at_the_nearest_instant():
    sc = _rows({"t_s": 0.5013, "sensor": "gyro", "value": 1000.0},
               {"t_s": 0.7, "sensor": "acc", "axis": "z", "value": 1e20})
    assert sc.sensor_glitches == ((0.5013, "gyro", "x", 1000.0), (0.7, "acc", "z", 1e20))
    assert parse_scenario(sc.to_file()).scenario == sc
    noise = sc.estimation_inputs()["noise"]
    sp = load_sensor_params()
    expected = np.zeros_like(noise)
    expected[100, NOISE["gyro"].start + 0] = 1000.0 / np.sqrt(sp.gyro_noise_var[0])  # 0.5013 s -> k = 100
    expected[140, NOISE["acc"].start + 2] = 1e20 / np.sqrt(sp.acc_noise_var[2])
    np.testing.assert_allclose(noise, expected, rtol=1e-15, atol=0)
    # a chunk of the run carries the glitches of its own periods only
    chunk = sc.estimation_inputs(periods=(120, 200))["noise"]
    np.testing.assert_allclose(chunk, expected[120:200], rtol=1e-15, atol=0)
    # added to the drawn noise when there is noise
    noisy = sc.replace(noise=True)
    diff = noisy.estimation_inputs()["noise"] - noisy.replace(sensor_glitches=()).estimation_inputs()["noise"]
    np.testing.assert_allclose(diff, expected, rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("row,key", [
    ({"t_s": 1.0, "sensor": "gyro", "value": 1.0}, "sensor_glitch[0]"),  # t at the end
    ({"t_s": -0.1, "sensor": "gyro", "value": 1.0}, "sensor_glitch[0].t_s"),
    ({"t_s": 0.1, "sensor": "enc", "value": 1.0}, "sensor_glitch[0].sensor"),
    ({"t_s": 0.1, "sensor": "gyro", "axis": 1, "value": 1.0}, "sensor_glitch[0].axis"),
    ({"t_s": 0.1, "sensor": "gyro", "value": float("inf")}, "sensor_glitch[0].value"),
    ({"t_s": 0.1, "sensor": "gyro"}, "sensor_glitch[0].value"),
    ({"t_s": 0.1, "sensor": "gyro", "value": 1.0, "duration_s": 1}, "sensor_glitch[0].duration_s"),
])
def test_bad_rows_are_refused_with_the_key(row, key):
    with pytest.raises(ScenarioError) as e:
        _rows(row)
    assert f"key '{key}'" in str(e.value) and "\n" not in str(e.value)


def test_glitches_need_sensors_and_a_noise_variance():
    with pytest.raises(ScenarioError) as e:
        parse_scenario({**BASE, "estimator": "true",
                        "sensor_glitch": [{"t_s": 0.1, "sensor": "gyro", "value": 1.0}]})
    assert "key 'sensor_glitch[0]'" in str(e.value) and "estimator" in str(e.value)
    sc = parse_scenario({**BASE, "sensors": {"gyro_noise_var": [0.0, 1e-4, 1e-4]},
                         "sensor_glitch": [{"t_s": 0.1, "sensor": "gyro", "value": 1.0}]}).scenario
    with pytest.raises(ScenarioError) as e:
        sc.estimation_inputs()
    assert e.value.key == "sensor_glitch[0]" and "gyro_noise_var" in str(e.value)


def test_simulate_refuses_a_bad_glitch_row_exit_2_one_line(tmp_path, capsys):
    path = tmp_path / "bad.toml"
    path.write_text('duration_s = 1.0\nestimator = "ukf"\n[[sensor_glitch]]\nt_s = 0.5\n'
                    'sensor = "gyro"\nvalue = 1.0\nsize = 3\n')
    assert main(["simulate", str(path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "key 'sensor_glitch[0].size'" in err[0]
    assert not (tmp_path / "o").exists()


def test_simulate_reproduces_a_glitch_from_a_file(tmp_path, capsys):
    path = tmp_path / "glitch.toml"
    path.write_text('duration_s = 1.5\nestimator = "ukf"\ncontroller = "flc"\n'
                    '[[sensor_glitch]]\nt_s = 0.5\nsensor = "gyro"\nvalue = 1000.0\n')
    out = tmp_path / "o"
    rc = main(["simulate", str(path), "--out", str(out)])
    capsys.readouterr()
    assert rc == 0
    log = load_log(out / "run.npz")
    assert log["rejections"].shape == (300, 4) and log["rejections"][100].tolist() == [0, 1, 0, 0]
    assert int(log["rejections"].sum()) == 1
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["metrics"]["gate_rejections"] == 1


@pytest.mark.parametrize("row", [(True, "gyro", "x", 1.0), (0.1, "gyro", "x", True), (0.1, "gyro", "x", "1e3"),
                                 ("0.1", "gyro", "x", 1.0), (0.1, "gyro", "x", float("nan")),
                                 (0.1, "gyro", "w", 1.0), (0.1, "mag", "x", 1.0), (1.0, "gyro", "x", 1.0),
                                 (0.1, "gyro", "x")])
def test_a_wrong_glitch_row_given_in_python_is_refused_by_its_row(row):
    """Rows given to ``Scenario.replace`` directly (not from a file): a bool or a string
    for the time or the value, a non-finite value, an unknown axis or sensor, a time at the
    end, a short row: one ScenarioError keyed by the row, never a TypeError."""
    sc = _rows()
    with pytest.raises(ScenarioError, match=r"^scenario 'g': sensor glitch .* must be \(t, sensor, axis, value\)") as e:
        sc.replace(sensor_glitches=(row,))
    assert e.value.key == "sensor_glitch[0]"

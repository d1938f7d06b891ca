"""Writing scenario tables (sim.scenario.toml_write) and the path table of a log
(sim.log.log_path) against hand-written text and values: each TOML value form, inline
parameter changes, nested tables and arrays of tables, a dotted key set at any depth, a
``tomllib`` round trip of every form, and each refusal of a damaged path table (issue 23:
a value written in the wrong form, a change table expanded, a bound at the wrong side
must show)."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

from ballbot_casadi.core.params import load_params
from ballbot_casadi.errors import FileFormatError, ScenarioFileError
from ballbot_casadi.sim.log import PATH_KEY, SimulationLog, log_path
from ballbot_casadi.sim.scenario import dump_toml, set_value


def test_dump_toml_by_hand():
    table = {"name": "t", "duration_s": 1.0, "seed": 3, "cascade": True, "noise": False,
             "plant": {"Mb": {"scale": 1.1}, "com_x": -0.02},
             "attitude": {"roll": {"type": "sine", "amplitude_deg": 2.0}},
             "push": [{"t_s": 0.5, "roll_deg": 1.0}, {"t_s": 0.75, "pitch_deg": -1.0}],
             "gains": {"k_obs": [0.3, 2, 0.1, 0.1]}, "description": "a \"quoted\" é"}
    text = dump_toml(table, header="line one\n\nline three")
    assert text == (
        "# line one\n#\n# line three\n"
        'name = "t"\nduration_s = 1.0\nseed = 3\ncascade = true\nnoise = false\n'
        'description = "a \\"quoted\\" é"\n'
        "\n[plant]\nMb = { scale = 1.1 }\ncom_x = -0.02\n"
        '\n[attitude]\n\n[attitude.roll]\ntype = "sine"\namplitude_deg = 2.0\n'
        "\n[[push]]\nt_s = 0.5\nroll_deg = 1.0\n\n[[push]]\nt_s = 0.75\npitch_deg = -1.0\n"
        "\n[gains]\nk_obs = [0.3, 2, 0.1, 0.1]\n")
    assert tomllib.loads(text) == table


def test_dump_toml_round_trips_digits_keys_and_nesting():
    table = {"a": 0.1 + 0.2, "b": -1e-300, "c": 123456789012, "odd key": 1, "t": {"u": {"v": [[1, 2], [3]]}},
             "sensors": {"acc_bias": [0.05, 0.0, -0.01], "gyro_scale": {"scale": [1.0, 1.01, 0.99]}},
             "montecarlo": {"seed": 1, "dispersion": [{"param": "plant.Mb", "relative": True}]}}
    assert tomllib.loads(dump_toml(table)) == table
    for bad in (math.inf, math.nan, None, object()):
        with pytest.raises(ScenarioFileError, match="cannot write"):
            dump_toml({"x": bad})


def test_set_value_at_any_depth_leaves_the_source_alone():
    src = {"plant": {"Mb": 1.0}, "name": "n"}
    out = set_value(src, "plant.Jk", 0.5)
    assert out == {"plant": {"Mb": 1.0, "Jk": 0.5}, "name": "n"} and src == {"plant": {"Mb": 1.0}, "name": "n"}
    assert set_value(src, "name", "m")["name"] == "m"
    assert set_value(src, "attitude.roll.amplitude_deg", 3.0)["attitude"] == {"roll": {"amplitude_deg": 3.0}}
    assert set_value(src, "name.x", 1)["name"] == {"x": 1}  # a scalar on the way becomes a table


def _log(meta):
    return SimulationLog(arrays={"time": np.zeros(1), "state": np.zeros((1, 12))}, scenario={},
                         params=load_params(), ctrl_params=load_params(), diag_names=(),
                         extra={PATH_KEY: meta} if meta is not None else {})


def test_log_path_reads_points_and_obstacles():
    assert log_path(_log(None)) is None
    xy, obs = log_path(_log({"xy": [[0, 0], [1, 2]], "obstacles": [[1, 1, 0.5]]}))
    np.testing.assert_array_equal(xy, [[0, 0], [1, 2]])
    np.testing.assert_array_equal(obs, [[1, 1, 0.5]])
    _, obs = log_path(_log({"xy": [[0, 0], [1, 2]]}))
    assert obs.shape == (0, 3)


@pytest.mark.parametrize("meta, needle", [
    ({"xy": [[0, 0]]}, "expected (n >= 2, 2)"),
    ({"xy": [[0, 0, 0], [1, 1, 1]]}, "expected (n >= 2, 2)"),
    ({"xy": [[0, 0], [1, 1]], "obstacles": [[1, 1]]}, "expected (n >= 2, 2) and (m, 3)"),
    ({"xy": [[0, 0], [1, math.nan]]}, "non-finite points"),
    ({"xy": [[0, 0], [1, 1]], "obstacles": [[1, 1, 0.0]]}, "radius <= 0"),
    ({"xy": [[0, 0], [1, 1]], "obstacles": [[1, 1, -0.1]]}, "radius <= 0"),
    ({"points": [[0, 0], [1, 1]]}, "KeyError"),
    ([[0, 0], [1, 1]], "a table expected, got list"),
    ({"xy": [[0, 0], [1, "a"]]}, "ValueError"),
])
def test_a_damaged_path_table_is_refused_naming_the_source(meta, needle):
    with pytest.raises(FileFormatError) as info:
        log_path(_log(meta), "run.npz")
    assert str(info.value).startswith("run.npz: damaged path metadata") and needle in str(info.value)

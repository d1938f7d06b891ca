"""A scenario built in code with numpy numbers and arrays (sim.scenario.scenario.Scenario.to_dict):
the dict is plain JSON (numpy scalars as Python floats, arrays as lists) and reads back into the
same run; and a drawn obstacle within 1e-9 m of a waypoint moves straight along +y
(sim.scenario.dispersions; issue 23: a JSON conversion branch taken wrongly, the floor of the
radial direction moved must show)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ballbot_casadi.sim.scenario import Scenario
from ballbot_casadi.sim.scenario.dispersions import _clear_waypoints


def test_numpy_values_become_plain_json():
    sc = Scenario("np", "flc", 0.5, estimator="ukf",
                  estimator_tuning={"encoder_var": np.float64(0.2)},
                  attitude={"roll": {"type": "sine", "amplitude_deg": np.float64(2.0), "frequency_hz": 1.0}},
                  sensor_changes={"acc_bias": ["set", np.array([0.1, 0.0, -0.2])]})
    d = sc.to_dict()
    text = json.dumps(d)  # plain JSON, no default needed
    assert json.loads(text) == d
    assert type(d["estimator_tuning"]["encoder_var"]) is float and d["estimator_tuning"]["encoder_var"] == 0.2
    assert type(d["attitude"]["roll"]["amplitude_deg"]) is float
    assert d["sensor_changes"] == {"acc_bias": ["set", [0.1, 0.0, -0.2]]}
    back = Scenario.from_dict(d)
    assert back.to_dict() == d and back.estimator_tuning == {"encoder_var": 0.2}
    np.testing.assert_array_equal(back.sensor_params().acc_bias, [0.1, 0.0, -0.2])


@pytest.mark.parametrize("offset", [0.0, 5e-10])
def test_an_obstacle_on_a_waypoint_moves_along_plus_y(offset):
    table = {"initial": {"x_m": -5.0, "y_m": 0.0},
             "path": {"type": "waypoints", "waypoints": [[1.0, 2.0], [3.0, 0.0]]},
             "obstacle": [{"x": 1.0 + offset, "y": 2.0, "r": 0.2}]}
    _clear_waypoints(table, margin=0.05)
    o = table["obstacle"][0]
    assert (o["x"], o["y"]) == pytest.approx((1.0, 2.25), abs=1e-15)

"""A path given in code with numpy values is stored as plain data (as a file's table is),
and a value with no JSON form is refused with one line naming ``path`` (not a bare
``TypeError`` from ``json``)."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.core.validation import plain_json
from ballbot_casadi.errors import BallbotTypeError, ScenarioError
from ballbot_casadi.sim.scenario import Scenario

WAYPOINTS = [[0.0, 0.0], [1.5, 0.25], [2.0, -1.0]]


def test_numpy_waypoints_are_stored_as_the_files_lists():
    as_list = Scenario("p", cascade=True, path={"type": "waypoints", "waypoints": WAYPOINTS, "speed": 0.3})
    as_numpy = Scenario("p", cascade=True, path={"type": "waypoints", "waypoints": np.array(WAYPOINTS),
                                                 "speed": np.float64(0.3)})
    assert as_numpy.path == as_list.path
    assert type(as_numpy.path["speed"]) is float and as_numpy.path["waypoints"][1] == [1.5, 0.25]
    assert as_numpy.to_dict() == as_list.to_dict()


def test_a_value_without_json_form_is_refused_naming_path():
    with pytest.raises(ScenarioError, match=r"^scenario 'p': path: a value of type object has no JSON form") as e:
        Scenario("p", cascade=True, path={"type": "waypoints", "waypoints": WAYPOINTS, "speed": object()})
    assert e.value.key == "path"


def test_plain_json_converts_numpy_and_names_what_it_refuses():
    got = plain_json({"a": np.arange(3), "b": np.int64(4), "c": np.bool_(True), "d": (1, 2)}, "x")
    assert got == {"a": [0, 1, 2], "b": 4, "c": True, "d": [1, 2]}
    assert type(got["b"]) is int and type(got["c"]) is bool
    with pytest.raises(BallbotTypeError, match=r"^thing: a value of type set has no JSON form"):
        plain_json({"s": {1}}, "thing")

"""A scenario's path section built in Python refuses what a file would, with the file key:
a path that is not a table, an unknown guidance law, obstacles that are not (x, y, r) or
have no path to stand beside; obstacle rows are kept as numbers."""

from __future__ import annotations

import pytest

from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.sim.scenario import Scenario
from ballbot_casadi.sim.scenario.path_section import GUIDANCE_CHOICES

LINE = {"type": "line", "start": [0.0, 0.0], "end": [3.0, 0.0]}


@pytest.mark.parametrize("fields, key, message", [
    ({"path": [1, 2]}, "path", r"^scenario 's': path must be a table, got list$"),
    ({"path": LINE, "cascade": True, "guidance": "lqr"}, "guidance",
     rf"^scenario 's': guidance must be one of {', '.join(GUIDANCE_CHOICES)}, got 'lqr'$"),
    ({"path": LINE, "cascade": True, "obstacles": [(1.0, 2.0)]}, "obstacle[0]",
     r"^scenario 's': obstacle\[0\] must be \(x, y, r\) in m, got \(1\.0, 2\.0\)$"),
    ({"path": LINE, "cascade": True, "obstacles": [(5.0, 5.0, 0.2), ("a", 1.0, 0.2)]}, "obstacle[1]",
     r"^scenario 's': obstacle\[1\] must be \(x, y, r\) in m, got \('a', 1\.0, 0\.2\)$"),
    ({"path": LINE, "cascade": True, "obstacles": [(5.0, 5.0, 0.2, 1.0)]}, "obstacle[0]",
     r"^scenario 's': obstacle\[0\] must be \(x, y, r\) in m, got \(5\.0, 5\.0, 0\.2, 1\.0\)$"),
    ({"obstacles": [(5.0, 5.0, 0.2)]}, "obstacle", r"^scenario 's': obstacles need a \[path\] to follow$"),
])
def test_python_path_fields_are_refused_with_the_file_key(fields, key, message):
    with pytest.raises(ScenarioError, match=message) as exc:
        Scenario(name="s", **fields)
    assert exc.value.key == key


def test_obstacle_rows_are_kept_as_numbers():
    sc = Scenario(name="s", path=LINE, cascade=True, obstacles=[[5, "5.5", 0.25]])
    assert sc.obstacles == ((5.0, 5.5, 0.25),)
    assert sc.route.build().obstacles[0].center == (5.0, 5.5)

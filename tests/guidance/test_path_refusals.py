"""The path builders refuse malformed geometry with one line naming the key and what is
allowed: points that are not numbers or not 2-D, obstacles in any of their three forms
that are not numbers, not finite or not 2-D, a speed that is not a number, a closed path
of one distinct point, a [path] that is not a table, a non-numeric size; keys already
named pass through unchanged."""

from __future__ import annotations

import pytest

from ballbot_casadi.core.constants import THESIS_LIMITS
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.guidance.paths import Obstacle, path_from_spec, waypoint_path

SQUARE = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]]
V_MAX = THESIS_LIMITS["v_max"]


@pytest.mark.parametrize("kwargs, message", [
    ({"points": [["a", 0.0], [1.0, 1.0]]}, r"^waypoints must be a list of \[x, y\] points in metres$"),
    ({"points": [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]]},
     r"^waypoints must be a list of \[x, y\] points, got shape \(2, 3\)$"),
    ({"points": [[1.0, 1.0], [1.0, 1.0]], "closed": True},
     r"^waypoints needs at least two distinct points for a closed path$"),
    ({"points": SQUARE, "speed": "fast"}, rf"^speed must be a number in \(0, {V_MAX}\] m/s, got 'fast'$"),
    ({"points": SQUARE, "obstacles": [{"center": [5.0, "x"], "radius": 0.2}]},
     r"^obstacles\[0\] must be \{center: \[x, y\], radius: r\} or \[x, y, r\]$"),
    ({"points": SQUARE, "obstacles": [(5.0, 5.0, 0.1), (5.0, 5.0)]},
     r"^obstacles\[1\] must be \{center: \[x, y\], radius: r\} or \[x, y, r\]$"),
    ({"points": SQUARE, "obstacles": [{"center": [5.0, 5.0, 1.0], "radius": 0.2}]},
     r"^obstacles\[0\] must have a finite 2-D center and radius$"),
    ({"points": SQUARE, "obstacles": [Obstacle((5.0, float("nan")), 0.2)]},
     r"^obstacles\[0\] must have a finite 2-D center and radius$"),
    ({"points": SQUARE, "obstacles": [(5.0, 5.0, float("inf"))]},
     r"^obstacles\[0\] must have a finite 2-D center and radius$"),
])
def test_waypoint_path_refusals(kwargs, message):
    with pytest.raises(ScenarioError, match=message):
        waypoint_path(**kwargs)


def test_the_three_obstacle_forms_are_one_obstacle():
    forms = [Obstacle((5.0, 4.0), 0.35), {"center": [5.0, 4.0], "radius": 0.35}, (5.0, 4.0, 0.35)]
    built = [waypoint_path(SQUARE, obstacles=[f]).obstacles for f in forms]
    assert built == [(Obstacle((5.0, 4.0), 0.35),)] * 3


@pytest.mark.parametrize("spec, key, message", [
    ([1, 2], "path", r"^path must be a table, got list$"),
    ({"type": "arc", "center": [0, 0], "radius": "1", "sweep_deg": 90}, "path.radius",
     r"^path\.radius must be a finite number, got '1'$"),
    ({"type": "arc", "center": [0, 0], "radius": 1.0, "sweep_deg": True}, "path.sweep_deg",
     r"^path\.sweep_deg must be a finite number, got True$"),
    ({"type": "figure_eight", "length": float("nan")}, "path.length",
     r"^path\.length must be a finite number, got nan$"),
    ({"type": "waypoints", "waypoints": [[0, 0], [1, "b"]]}, "path.waypoints",
     r"^waypoints must be a list of \[x, y\] points in metres$"),
    ({"type": "line", "start": [0, 0], "end": [1, 0], "speed": "x"}, "path.speed",
     r"^speed must be a number in"),
])
def test_path_table_refusals_carry_the_key(spec, key, message):
    with pytest.raises(ScenarioError, match=message) as exc:
        path_from_spec(spec)
    assert exc.value.key == key


def test_an_obstacle_key_is_the_row():
    with pytest.raises(ScenarioError, match=r"^obstacles\[1\] must have a finite") as exc:
        path_from_spec({"type": "line", "start": [0, 0], "end": [3, 0]},
                       obstacles=[(9.0, 9.0, 0.1), (9.0, float("nan"), 0.1)])
    assert exc.value.key == "obstacle[1]"

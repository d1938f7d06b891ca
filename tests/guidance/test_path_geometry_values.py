"""Path geometry against closed forms: a clockwise arc from a scenario table, an offset
figure-eight, closed waypoints, the stopping ramp, clearance to several circles, unwrapped
local projection on a closed path, and the keys of refused tables."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.guidance.paths import (
    DEFAULT_SPEED,
    Obstacle,
    arc_path,
    figure_eight,
    line_path,
    path_from_spec,
    waypoint_path,
)


def test_clockwise_arc_from_a_table():
    path = path_from_spec({"type": "arc", "center": [1.0, 2.0], "radius": 0.5,
                           "start_angle_deg": 90.0, "sweep_deg": -90.0, "speed": 0.3})
    assert not path.closed and path.speed == 0.3
    assert path.length == pytest.approx(0.25 * math.pi, rel=1e-6)
    np.testing.assert_allclose(path.point(0.0), [1.0, 2.5], atol=1e-9)
    np.testing.assert_allclose(path.point(path.length), [1.5, 2.0], atol=1e-9)
    np.testing.assert_allclose(path.tangent(0.0), [1.0, 0.0], atol=1e-3)   # clockwise from the top
    np.testing.assert_allclose(path.tangent(path.length), [0.0, -1.0], atol=1e-3)
    s = np.linspace(0.1, path.length - 0.1, 9)
    np.testing.assert_allclose(path.curvature(s), -2.0, rtol=2e-3)       # turning right
    mid = path.point(path.length / 2)
    np.testing.assert_allclose(mid, [1.0 + 0.5 * math.cos(math.pi / 4), 2.0 + 0.5 * math.sin(math.pi / 4)],
                               atol=1e-6)


def test_offset_figure_eight_starts_at_its_centre_heading_up_right():
    path = figure_eight(3.0, 1.0, center=(1.0, -1.0), speed=0.2)
    same = path_from_spec({"type": "figure_eight", "length": 3.0, "width": 1.0,
                           "center": [1.0, -1.0], "speed": 0.2})
    assert path.closed and path.speed == 0.2
    np.testing.assert_allclose(path.point(0.0), [1.0, -1.0], atol=1e-9)
    np.testing.assert_allclose(path.tangent(0.0), np.array([1.5, 1.0]) / math.hypot(1.5, 1.0), atol=1e-4)
    s = np.linspace(0.0, path.length, 3001)
    pts = path.point(s)
    np.testing.assert_allclose(pts.min(axis=0), [-0.5, -1.5], atol=1e-3)
    np.testing.assert_allclose(pts.max(axis=0), [2.5, -0.5], atol=1e-3)
    assert same.length == pytest.approx(path.length, rel=1e-12)
    np.testing.assert_allclose(same.point(s[::100]), pts[::100], atol=1e-12)


def test_a_table_without_the_optional_keys_takes_the_documented_defaults():
    """A figure-eight table with only its type: 4 m x 2 m about the origin at the default
    speed; an arc without ``start_angle_deg`` starts at angle 0 (east of its centre)."""
    eight = path_from_spec({"type": "figure_eight"})
    pts = eight.point(np.linspace(0.0, eight.length, 4001))
    np.testing.assert_allclose(pts.min(axis=0), [-2.0, -1.0], atol=1e-3)
    np.testing.assert_allclose(pts.max(axis=0), [2.0, 1.0], atol=1e-3)
    np.testing.assert_allclose(eight.point(0.0), [0.0, 0.0], atol=1e-12)
    assert eight.speed == DEFAULT_SPEED
    arc = path_from_spec({"type": "arc", "center": [1.0, 2.0], "radius": 0.5, "sweep_deg": 90.0})
    np.testing.assert_allclose(arc.point(0.0), [1.5, 2.0], atol=1e-12)
    np.testing.assert_allclose(arc.point(arc.length), [1.0, 2.5], atol=1e-9)


def test_closed_waypoints_drop_a_repeated_last_point_and_pass_through_all():
    sq = [(0.0, 0.0), (2.0, 0.0), (2.0, 1.0), (0.0, 1.0)]
    a = waypoint_path(sq, closed=True)
    b = waypoint_path(sq + [sq[0]], closed=True)
    assert a.closed and b.closed and a.length == pytest.approx(b.length, rel=1e-12)
    assert a.length > 6.0  # the smooth loop through the corners is longer than the 6 m polygon
    for p in sq:
        s = a.project(p)
        np.testing.assert_allclose(a.point(s), p, atol=1e-5)
    # periodic: s and s + length are one point, also far outside [0, length]
    np.testing.assert_allclose(a.point(-0.3), a.point(a.length - 0.3), atol=1e-9)
    np.testing.assert_allclose(a.point(2 * a.length + 0.7), a.point(0.7), atol=1e-9)


def test_stopping_ramp_of_an_open_path_and_constant_speed_of_a_closed_one():
    line = line_path((0.0, 0.0), (3.0, 0.0), speed=0.4)
    s = np.array([-1.0, 0.0, 2.0, 2.9, 2.99, 3.0, 5.0])
    a_stop = 0.5  # half the thesis's a_max
    want = np.minimum(0.4, np.sqrt(2 * a_stop * np.clip(3.0 - s, 0.0, None)))
    np.testing.assert_allclose(line.reference_speed(s), want, rtol=1e-12)
    np.testing.assert_allclose(line.reference_speed(2.99, a_stop=2.0), 0.2, rtol=1e-9)
    circle = arc_path((0.0, 0.0), 1.0, 0.0, 2 * math.pi, speed=0.25)
    np.testing.assert_array_equal(circle.reference_speed(np.array([0.0, 6.2, 100.0])), 0.25)
    assert line_path((0, 0), (1, 0)).speed == DEFAULT_SPEED == 0.5


def test_clearance_is_the_nearest_circle_and_window_matches_point_and_tangent():
    path = line_path((0.0, 0.0), (4.0, 0.0),
                     obstacles=[Obstacle((1.0, 1.0), 0.5), Obstacle((3.0, -0.8), 0.3)])
    np.testing.assert_allclose(path.clearance([[1.0, 0.0], [3.0, 0.0], [2.0, 0.0]]),
                               [0.5, 0.5, min(math.sqrt(2) - 0.5, math.hypot(1.0, 0.8) - 0.3)],
                               rtol=1e-12)
    assert np.all(np.isinf(line_path((0, 0), (1, 0)).clearance([[0.0, 0.0]])))
    s = np.array([0.5, 1.5, 4.5])
    P, T = path.window(s)
    np.testing.assert_allclose(P, [[0.5, 0.0], [1.5, 0.0], [4.5, 0.0]], atol=1e-12)
    np.testing.assert_allclose(T, [[1.0, 0.0]] * 3, atol=1e-12)


def test_projection_is_unwrapped_next_to_the_guess_and_clipped_on_an_open_path():
    circle = arc_path((0.0, 0.0), 1.0, 0.0, 2 * math.pi)
    L = circle.length
    p = circle.point(0.1)
    assert circle.project(p, s_guess=L + 0.05) == pytest.approx(L + 0.1, abs=1e-6)
    assert circle.project(p, s_guess=0.05) == pytest.approx(0.1, abs=1e-6)
    line = line_path((0.0, 0.0), (3.0, 0.0))
    assert line.project([5.0, 0.2]) == pytest.approx(3.0, abs=1e-9)
    assert line.project([-1.0, 0.2], s_guess=0.1) == pytest.approx(0.0, abs=1e-9)
    assert line.project([1.234, -0.4]) == pytest.approx(1.234, abs=1e-7)


@pytest.mark.parametrize("spec,key", [
    ({"type": "arc", "center": [0.0, 0.0], "radius": -1.0, "sweep_deg": 90.0}, "path.radius"),
    ({"type": "arc", "center": [0.0, 0.0], "radius": 1.0, "sweep_deg": 0.0}, "path.sweep_deg"),
    ({"type": "figure_eight", "width": 0.0}, "path.width"),
    ({"type": "line", "start": [0.0, 0.0], "end": [1.0, 0.0], "speed": 0.9}, "path.speed"),
    ({"type": "line", "start": [0.0, 0.0]}, "path.end"),
    ({"type": "line", "start": [0.0, 0.0], "end": [1.0, 0.0], "bogus": 1}, "path.bogus"),
    ({"type": "spiral"}, "path.type"),
])
def test_refused_tables_name_their_key(spec, key):
    with pytest.raises(ScenarioError) as err:
        path_from_spec(spec)
    assert err.value.key == key and "\n" not in str(err.value)


def test_pure_pursuit_at_the_end_of_an_open_path_commands_exactly_zero_without_warnings():
    import warnings

    from ballbot_casadi.guidance.pure_pursuit import PurePursuit

    path = line_path((0.0, 0.0), (2.0, 0.0), speed=0.4)
    pp = PurePursuit(path, lookahead=0.3, k_lat=0.0)
    x = np.zeros(14)
    x[12:14] = [2.5, 0.0]  # past the end: projected onto it, where the ramp's speed is zero
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        v = pp.step(x)
    np.testing.assert_array_equal(v, [0.0, 0.0])
    assert pp.progress() == pytest.approx(2.0, abs=1e-9)


def test_a_wide_projection_window_is_searched_as_finely_as_a_narrow_one():
    # a wave of 1.5 m wavelength: a window searched with fewer points per metre than the
    # path's _DENSITY (e.g. spaced by the reach) lands on another wave's local minimum
    x = np.linspace(0.0, 12.0, 97)
    path = waypoint_path(np.c_[x, 0.4 * np.sin(2 * np.pi * x / 1.5)])
    s_all = np.linspace(0.0, path.length, 200001)
    pts = path.point(s_all)
    rng = np.random.default_rng(1)
    for _ in range(30):
        p = path.point(rng.uniform(0.0, path.length)) + rng.normal(0.0, 0.05, 2)
        nearest = s_all[np.argmin(np.sum((pts - p) ** 2, axis=1))]
        s = path.project(p, s_guess=rng.uniform(0.0, path.length), reach=30.0)  # the whole path
        assert s == pytest.approx(nearest, abs=2e-4)
        assert s == pytest.approx(path.project(p), abs=1e-9)

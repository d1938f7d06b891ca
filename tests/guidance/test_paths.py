"""Paths: arc-length parametrisation, C2 smoothness, projection, validation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.guidance.paths import (
    Obstacle,
    arc_path,
    figure_eight,
    line_path,
    path_from_spec,
    waypoint_path,
)


def test_arc_length_parametrisation_unit_speed():
    path = figure_eight(4.0, 2.0)
    s = np.linspace(0.0, path.length, 4001)
    np.testing.assert_allclose(np.linalg.norm(path.spline(s, 1), axis=1), 1.0, atol=1e-4)
    # the curve spans 4 m x 2 m
    pts = path.point(s)
    np.testing.assert_allclose(np.ptp(pts, axis=0), [4.0, 2.0], atol=1e-3)


def test_arc_length_and_curvature_of_a_circle():
    path = arc_path((1.0, -1.0), 0.8, 0.0, 2 * math.pi)
    assert path.closed
    np.testing.assert_allclose(path.length, 2 * math.pi * 0.8, rtol=1e-6)
    s = np.linspace(0.0, path.length, 200)
    np.testing.assert_allclose(path.curvature(s), 1.0 / 0.8, rtol=1e-3)


def test_c2_continuity_at_the_seam_of_a_closed_path():
    path = figure_eight()
    for order in (0, 1, 2):
        np.testing.assert_allclose(path.spline(0.0, order), path.spline(path.length, order),
                                   atol=1e-9)


def test_projection_is_orthogonal_and_local():
    path = figure_eight()
    rng = np.random.default_rng(3)
    for s0 in rng.uniform(0.0, path.length, 10):
        n = np.array([-path.tangent(s0)[1], path.tangent(s0)[0]])
        p = path.point(s0) + 0.05 * n
        s = path.project(p, s_guess=s0 + 0.1)
        np.testing.assert_allclose(s, s0, atol=1e-6)
    # at the crossing the local projection keeps the branch of the guess
    s_cross = path.length / 2.0
    assert abs(path.project(path.point(s_cross), s_guess=s_cross - 0.05) - s_cross) < 1e-6


def test_open_path_continues_straight_and_stops():
    path = line_path((0.0, 0.0), (3.0, 0.0))
    np.testing.assert_allclose(path.point([-1.0, 1.5, 4.0]), [[-1, 0], [1.5, 0], [4, 0]], atol=1e-12)
    assert path.reference_speed(path.length) == 0.0
    assert path.reference_speed(0.0) == pytest.approx(path.speed)


def test_clearance_to_circles():
    path = waypoint_path([(0, 0), (2, 0), (2, 2)], obstacles=[Obstacle((1.0, 1.0), 0.5)])
    np.testing.assert_allclose(path.clearance([[1.0, 0.0], [3.0, 1.0]]), [0.5, 1.5])


@pytest.mark.parametrize("make,key", [
    (lambda: waypoint_path([(0, 0)]), "at least two points"),
    (lambda: waypoint_path([(0, 0), (float("nan"), 1)]), "NaN"),
    (lambda: waypoint_path([(0, 0), (0, 0), (1, 1)]), "coincide"),
    (lambda: figure_eight(speed=0.6), "speed"),
    (lambda: figure_eight(speed=0.0), "speed"),
    (lambda: line_path((0, 0), (3, 0), obstacles=[(3.0, 0.1, 0.3)]), "obstacles[0]"),
    (lambda: line_path((0, 0), (3, 0), obstacles=[(1.0, 1.0, -0.3)]), "obstacles[0].radius"),
    (lambda: figure_eight(length=-1.0), "length"),
])
def test_bad_paths_refused_with_one_line(make, key):
    with pytest.raises(ScenarioError) as err:
        make()
    assert key in str(err.value) and "\n" not in str(err.value)


def test_coincident_waypoints_are_those_closer_than_a_micrometre():
    """The tolerance is 1e-6 m: points 0.9 um apart are one point (named by index), 1.5 um
    apart two (the path through them is built and passes both); the pair named is the
    first closer than the tolerance, after a pair just above it."""
    with pytest.raises(ScenarioError, match=r"^waypoints 3 and 4 coincide; consecutive points must differ$"):
        waypoint_path([(0, 0), (1, 0), (1 + 1.5e-6, 0), (2, 1), (2, 1 + 0.9e-6), (3, 1), (3, 1)])
    path = waypoint_path([(0, 0), (1, 0), (1 + 1.5e-6, 0), (2, 1)])
    np.testing.assert_allclose(path.waypoints[2], [1 + 1.5e-6, 0], rtol=0, atol=0)
    assert np.all(np.isfinite(path.point(np.linspace(0, path.length, 50))))


def test_a_waypoint_on_an_obstacles_circle_is_allowed_inside_it_is_not():
    """An obstacle is ``|p - center| >= radius`` (the ball centre may touch the circle): a
    waypoint exactly on it (distance 4 from (3, 4), exact in floats) is allowed; the next
    float of radius covers it, and the refusal names the first waypoint covered."""
    pts = [(0.0, 0.0), (3.0, 0.0), (6.0, 0.0), (3.0, 8.0)]
    path = waypoint_path(pts, obstacles=[Obstacle((3.0, 4.0), 4.0)])
    assert path.clearance([[3.0, 0.0]])[0] == 0.0
    r = float(np.nextafter(4.0, np.inf))
    with pytest.raises(ScenarioError, match=r"^obstacles\[0\] \(radius 4\.000000000000001 m at \[3\.0, 4\.0\]\) "
                       r"covers waypoint 1 \[3\.0, 0\.0\]: the path cannot pass through it$"):
        waypoint_path(pts, obstacles=[Obstacle((3.0, 4.0), r)])


@pytest.mark.parametrize("start_deg, sweep_deg", [(0.0, 360.0), (0.0, -360.0), (17.1887, 360.0)])
def test_a_full_circle_of_any_radius_closes(start_deg, sweep_deg):
    """A 10 m circle (scenario file: type "arc", sweep_deg = +-360): cos and sin of the start
    and of start + 2 pi differ in the last bits, times 10 m; the path still closes at its
    start (was a raw ValueError of the periodic spline), 2 pi r long, every point r from the
    centre."""
    path = path_from_spec({"type": "arc", "center": [0.5, -1.0], "radius": 10.0,
                           "sweep_deg": sweep_deg, "start_angle_deg": start_deg})
    assert path.closed
    np.testing.assert_allclose(path.length, 2 * math.pi * 10.0, rtol=1e-9)
    s = np.linspace(0.0, path.length, 2001)
    np.testing.assert_allclose(np.linalg.norm(path.point(s) - [0.5, -1.0], axis=1), 10.0, atol=1e-9)
    a = math.radians(start_deg)
    np.testing.assert_allclose(path.point(0.0), [0.5 + 10 * math.cos(a), -1.0 + 10 * math.sin(a)], atol=1e-12)
    np.testing.assert_array_equal(path.point(0.0), path.point(path.length))

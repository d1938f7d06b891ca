"""Monte Carlo draws against hand-computed values: a drawn obstacle that covers a waypoint
moves to ``r + margin`` from it, and a ``[montecarlo]`` table with a seed but no
dispersion rows keeps its seed with the default set (issue 23, test strength)."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.sim.scenario import parse_scenario
from ballbot_casadi.sim.scenario.dispersions import DEFAULT_DISPERSIONS, _clear_waypoints, dispersions_of, draw_runs


def test_an_obstacle_over_a_waypoint_moves_radially_to_r_plus_the_margin():
    table = {"initial": {"x_m": -5.0, "y_m": 0.0},
             "path": {"type": "waypoints", "waypoints": [[1.0, 0.22], [3.0, 0.0]]},
             "obstacle": [{"x": 1.0, "y": 0.0, "r": 0.2}, {"x": 2.0, "y": 1.0, "r": 0.1}]}
    _clear_waypoints(table, margin=0.05)
    moved, kept = table["obstacle"]
    # clear of the obstacle (0.22 > r) but inside the margin: moved straight down to 0.25 m
    # from the waypoint, (1.0, 0.22 - 0.25)
    assert (moved["x"], moved["y"]) == pytest.approx((1.0, -0.03), abs=1e-15)
    assert (kept["x"], kept["y"]) == (2.0, 1.0)
    table["obstacle"] = [{"x": 0.0, "y": 0.0, "r": 0.3}]
    table["initial"] = {}
    _clear_waypoints(table)  # over the start: moved off it too, by the default 5 cm margin
    o = table["obstacle"][0]
    assert np.hypot(o["x"], o["y"]) == pytest.approx(0.35, abs=1e-12)


def test_an_obstacle_off_axis_moves_along_its_own_direction():
    """Centre 0.1 m from the waypoint along (0.6, -0.8): moved to 0.25 m along it."""
    table = {"initial": {"x_m": -5.0, "y_m": 0.0},
             "path": {"type": "waypoints", "waypoints": [[1.0, 0.22]]},
             "obstacle": [{"x": 1.06, "y": 0.14, "r": 0.2}]}
    _clear_waypoints(table, margin=0.05)
    o = table["obstacle"][0]
    assert (o["x"], o["y"]) == pytest.approx((1.0 + 0.15, 0.22 - 0.2), abs=1e-12)


def test_a_seed_without_dispersion_rows_keeps_the_seed_and_the_default_set():
    sf = parse_scenario({"name": "m", "duration_s": 0.1, "montecarlo": {"seed": 11}}, "m.toml")
    dispersions, seed = dispersions_of(sf)
    assert dispersions == DEFAULT_DISPERSIONS and seed == 11
    runs = draw_runs(sf, 2)
    assert [r["seed"] for r in runs] == [int(np.random.default_rng([11, i]).integers(0, 2**32)) for i in range(2)]
    assert dispersions_of(parse_scenario({"duration_s": 0.1}, "n.toml"))[1] == 0

"""Monte Carlo runs drawn from a file (sim.scenario.dispersions.draw_runs) against values
computed by hand from the documented order of draws (the run's noise seed first, then one
value per dispersion in file order): relative dispersions scale the nominal value, absolute
ones add to it, on the plant and on the initial state; a course draw moves every obstacle
row and every interior waypoint by its own value (issue 23: relative and absolute swapped,
a draw used for the wrong row, an end waypoint moved must show)."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.core.params import load_params
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.sim.scenario import parse_scenario
from ballbot_casadi.sim.scenario.dispersions import DEFAULT_DISPERSIONS, draw_runs

TABLE = {
    "name": "mc", "duration_s": 0.1, "description": "base",
    "initial": {"roll_deg": 2.0, "pitch_deg": 3.0},
    "montecarlo": {"seed": 7, "dispersion": [
        {"param": "plant.Mb", "dist": "normal", "sd": 0.1, "relative": True},
        {"param": "plant.com_x", "dist": "uniform", "low": -0.01, "high": 0.02},
        {"param": "initial.roll_deg", "dist": "normal", "sd": 1.0},
        {"param": "initial.pitch_deg", "dist": "uniform", "low": -0.5, "high": 0.25, "relative": True},
    ]},
}


def test_relative_and_absolute_draws_on_plant_and_initial_state():
    runs = draw_runs(parse_scenario(TABLE, "mc.toml"), 3)
    p = load_params()
    for i, run in enumerate(runs):
        rng = np.random.default_rng([7, i])
        seed = int(rng.integers(0, 2**32))
        d_mb, d_cx = rng.normal(0.0, 0.1), rng.uniform(-0.01, 0.02)
        d_roll, d_pitch = rng.normal(0.0, 1.0), rng.uniform(-0.5, 0.25)
        want = {"plant.Mb": p.Mb * (1 + d_mb), "plant.com_x": p.com_x + d_cx,
                "initial.roll_deg": 2.0 + d_roll, "initial.pitch_deg": 3.0 * (1 + d_pitch)}
        assert run["index"] == i and run["seed"] == seed
        assert run["values"] == pytest.approx(want, rel=1e-15, abs=1e-15)
        t = run["table"]
        assert t["name"] == f"mc_mc{i:04d}" and t["seed"] == seed
        assert t["description"] == f"Monte Carlo run {i} of mc (set seed 7); base"
        assert t["plant"] == pytest.approx({"Mb": want["plant.Mb"], "com_x": want["plant.com_x"]}, rel=1e-15)
        assert t["initial"] == pytest.approx({"roll_deg": want["initial.roll_deg"],
                                              "pitch_deg": want["initial.pitch_deg"]}, rel=1e-15)
        assert "montecarlo" not in t
        sc = parse_scenario(t, "run.toml").scenario  # each run is a complete scenario file
        assert sc.seed == seed


def test_the_seed_argument_overrides_the_files_and_runs_differ():
    sf = parse_scenario(TABLE, "mc.toml")
    a, b = draw_runs(sf, 2, seed=8)
    assert a["seed"] == int(np.random.default_rng([8, 0]).integers(0, 2**32))
    assert b["seed"] == int(np.random.default_rng([8, 1]).integers(0, 2**32))
    assert a["values"] != b["values"]
    assert "(set seed 8)" in a["table"]["description"]


def test_course_draws_move_each_obstacle_and_interior_waypoint():
    table = {"name": "c", "duration_s": 0.1, "cascade": True,
             "path": {"type": "waypoints", "speed": 0.3,
                      "waypoints": [[0.0, 0.0], [1.0, 0.0], [2.0, 0.5], [3.0, 0.0]]},
             "obstacle": [{"x": 1.5, "y": 2.0, "r": 0.1}, {"x": 2.5, "y": -2.0, "r": 0.1}],
             "montecarlo": {"seed": 4, "dispersion": [
                 {"param": "path.waypoint_y_m", "dist": "normal", "sd": 0.01},
                 {"param": "obstacle.x_m", "dist": "uniform", "low": -0.05, "high": 0.05},
                 {"param": "obstacle.y_m", "dist": "normal", "sd": 0.02}]}}
    run = draw_runs(parse_scenario(table, "c.toml"), 1)[0]
    rng = np.random.default_rng([4, 0])
    rng.integers(0, 2**32)
    rng.normal(0.0, 0.01)  # the row's own draw, unused for a course dispersion
    w1, w2 = rng.normal(0.0, 0.01), rng.normal(0.0, 0.01)
    rng.uniform(-0.05, 0.05)
    x0, x1 = rng.uniform(-0.05, 0.05), rng.uniform(-0.05, 0.05)
    rng.normal(0.0, 0.02)
    y0, y1 = rng.normal(0.0, 0.02), rng.normal(0.0, 0.02)
    want = {"path.waypoints[1].y_m": 0.0 + w1, "path.waypoints[2].y_m": 0.5 + w2,
            "obstacle[0].x_m": 1.5 + x0, "obstacle[1].x_m": 2.5 + x1,
            "obstacle[0].y_m": 2.0 + y0, "obstacle[1].y_m": -2.0 + y1}
    assert run["values"] == pytest.approx(want, rel=1e-15, abs=1e-15)
    wp = run["table"]["path"]["waypoints"]
    assert wp[0] == [0.0, 0.0] and wp[3] == [3.0, 0.0]  # the ends stay
    assert wp[1] == pytest.approx([1.0, w1], abs=1e-15) and wp[2] == pytest.approx([2.0, 0.5 + w2], abs=1e-15)
    obs = run["table"]["obstacle"]
    assert (obs[1]["x"], obs[1]["y"]) == pytest.approx((2.5 + x1, -2.0 + y1), abs=1e-15)


def test_refusals_and_the_default_set():
    sf = parse_scenario({"name": "d", "duration_s": 0.1}, "d.toml")
    for bad in (0, -1, True, 1.0):
        with pytest.raises(ScenarioError, match="int >= 1"):
            draw_runs(sf, bad)
    run = draw_runs(sf, 1)[0]
    assert set(run["values"]) == {d["param"] for d in DEFAULT_DISPERSIONS}
    assert run["seed"] == int(np.random.default_rng([0, 0]).integers(0, 2**32))
    line = {"name": "l", "duration_s": 0.1, "cascade": True,
            "path": {"type": "line", "start": [0.0, 0.0], "end": [1.0, 0.0], "speed": 0.3},
            "montecarlo": {"dispersion": [{"param": "path.waypoint_y_m", "dist": "normal", "sd": 0.01}]}}
    with pytest.raises(ScenarioError) as info:
        draw_runs(parse_scenario(line, "l.toml"), 1)
    assert info.value.key == "montecarlo.dispersion"

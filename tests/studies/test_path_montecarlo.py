"""Monte Carlo over random courses (issue 18): the drawn runs are complete, valid, followable
scenario files (rerunnable alone), deterministic in the set seed; one run evaluates with
the path metrics.  The 100-run figure is measured once (report), not here."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.sim.scenario import load_scenario_file
from ballbot_casadi.sim.scenario.dispersions import draw_runs
from ballbot_casadi.sim.scenario.file import parse_scenario
from ballbot_casadi.studies.montecarlo_runner import evaluate_run
from ballbot_casadi.studies.registry import shipped_scenarios


@pytest.fixture(scope="module")
def source():
    return load_scenario_file(shipped_scenarios()["path_mc"])


def test_random_courses_are_valid_followable_and_deterministic(source):
    runs = draw_runs(source, 12)
    again = draw_runs(source, 12)
    base = np.array(source.table["path"]["waypoints"], float)
    moved = []
    for r, r2 in zip(runs, again):
        assert r["table"] == r2["table"]
        wp = np.array(r["table"]["path"]["waypoints"], float)
        np.testing.assert_array_equal(wp[[0, -1]], base[[0, -1]])  # ends fixed
        np.testing.assert_array_equal(wp[:, 0], base[:, 0])
        assert np.all(np.abs(wp[1:-1, 1]) <= 0.6)
        moved.append(wp[1:-1, 1])
        init = r["table"].get("initial", {})
        start = np.array([init.get("x_m", 0.0), init.get("y_m", 0.0)])
        assert np.all(np.abs(start) <= 0.1)
        for ob in r["table"]["obstacle"]:
            c = np.array([ob["x"], ob["y"]])
            for p in (*wp, start):
                assert np.linalg.norm(c - p) >= ob["r"] + 0.05 - 1e-12
        parse_scenario(r["table"], r["table"]["name"])  # a complete scenario file
    assert np.std(np.concatenate(moved)) > 0.2  # uniform +-0.6 m: sd 0.35
    assert draw_runs(source, 2, seed=1)[0]["table"] != runs[0]["table"]


def test_an_obstacle_drawn_onto_a_waypoint_is_moved_off_it(source):
    table = dict(source.table)
    table["montecarlo"] = {"seed": 0, "dispersion": [
        {"param": "obstacle.x_m", "dist": "uniform", "low": 0.0, "high": 0.0}]}
    table["obstacle"] = [{"x": 1.5, "y": 0.1, "r": 0.2}]  # covers the waypoint (1.5, 0)
    src = parse_scenario({k: v for k, v in table.items() if k != "obstacle"} | {
        "obstacle": [{"x": 1.0, "y": 1.0, "r": 0.2}]}, "base")
    src = type(src)(src.path, {**src.table, "obstacle": table["obstacle"]}, src.scenario,
                    src.specs, src.montecarlo)
    (run,) = draw_runs(src, 1)
    ob = run["table"]["obstacle"][0]
    assert np.hypot(ob["x"] - 1.5, ob["y"]) == pytest.approx(0.25, abs=1e-12)
    parse_scenario(run["table"], "drawn")


def test_one_random_course_evaluates_with_the_path_metrics(source):
    run = draw_runs(source, 1)[0]
    table = {**run["table"], "guidance": "pursuit", "duration_s": 4.0}
    res = evaluate_run(table, source.specs)
    assert res["error"] is None
    m = res["metrics"]
    for key in ("path_collision", "path_completed", "path_min_clearance_m", "path_lateral_rms_m"):
        assert key in m
    assert m["path_completed"] == 0.0  # 4 s is not enough for 6 m at 0.5 m/s
    assert 0.1 < m["path_progress_fraction"] < 0.5

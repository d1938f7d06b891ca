"""Scenario files with a [path], [[obstacle]] rows and a guidance law: validated by building
the path (one line naming the key, exit 2), round-tripped, run through the guidance slot."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi import cli
from ballbot_casadi.errors import ScenarioError, ScenarioFileError
from ballbot_casadi.guidance.paths import figure_eight
from ballbot_casadi.sim.closed_loop import run_scenario
from ballbot_casadi.sim.scenario import Scenario
from ballbot_casadi.sim.scenario.file import parse_scenario

BASE = {"duration_s": 2.0, "cascade": True}


@pytest.mark.parametrize("path, obstacles, key, needle", [
    ({"type": "waypoints", "waypoints": [[0.0, 0.0]]}, [], "path.waypoints", "at least two"),
    ({"type": "waypoints", "waypoints": [[0.0, 0.0], [float("nan"), 1.0]]}, [], "path.waypoints",
     "NaN"),
    ({"type": "line", "start": [0.0, 0.0], "end": [2.0, 0.0], "speed": 0.6}, [], "path.speed",
     "v_max"),
    ({"type": "line", "start": [0.0, 0.0], "end": [2.0, 0.0]}, [{"x": 2.0, "y": 0.1, "r": 0.3}],
     "obstacle[0]", "cannot pass through"),
    ({"type": "spiral"}, [], "path.type", "figure_eight"),
    ({"type": "arc", "center": [0.0, 0.0], "radius": 1.0}, [], "path.sweep_deg", "missing"),
    ({"type": "line", "start": [0.0, 0.0], "end": [2.0, 0.0]}, [{"x": 1.0, "y": 1.0, "r": -0.1}],
     "obstacle[0].r", "> 0"),
])
def test_bad_paths_are_refused_naming_the_key(path, obstacles, key, needle):
    with pytest.raises(ScenarioFileError) as exc:
        parse_scenario({**BASE, "path": path, "obstacle": obstacles})
    msg = str(exc.value)
    assert f"key '{key}'" in msg and needle in msg and "\n" not in msg


def test_a_path_needs_the_cascade():
    with pytest.raises(ScenarioFileError, match="key 'path'.*cascade"):
        parse_scenario({"duration_s": 2.0, "path": {"type": "figure_eight"}})


def test_a_path_scenario_round_trips_and_builds_the_path():
    sf = parse_scenario({**BASE, "path": {"type": "figure_eight", "length": 4.0, "width": 2.0,
                                          "speed": 0.5},
                         "obstacle": [{"x": 1.0, "y": 0.9, "r": 0.1}], "guidance": "pursuit"})
    sc = sf.scenario
    assert sc.guidance == "pursuit" and sc.obstacles == ((1.0, 0.9, 0.1),)
    assert parse_scenario(sc.to_file()).scenario == sc
    assert Scenario.from_dict(sc.to_dict()) == sc
    ref = figure_eight(4.0, 2.0)
    built = sc.route.build()
    assert built.length == pytest.approx(ref.length, rel=1e-12)
    np.testing.assert_allclose(built.point([0.0, 3.0]), ref.point([0.0, 3.0]), rtol=0, atol=1e-12)


def test_run_scenario_refuses_to_ignore_a_path():
    sc = parse_scenario({**BASE, "path": {"type": "figure_eight"}}).scenario
    with pytest.raises(ScenarioError, match="run_path_scenario"):
        run_scenario(sc)


def test_cli_simulate_refuses_a_bad_path_with_exit_2(tmp_path, capsys):
    f = tmp_path / "bad.toml"
    f.write_text('duration_s = 2.0\ncascade = true\n[path]\ntype = "waypoints"\n'
                 'waypoints = [[0.0, 0.0]]\n')
    assert cli.main(["simulate", str(f), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "path.waypoints" in err

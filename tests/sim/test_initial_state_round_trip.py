"""A state set in code (a moving, tilted, yawed robot) written to a scenario file and read
back: the same initial state entry by entry."""

from __future__ import annotations

import tomllib

import numpy as np

from ballbot_casadi.sim.scenario import Scenario, dump_toml, parse_scenario
from ballbot_casadi.sim.scenario.scenario import initial_state


def test_a_code_set_moving_state_round_trips_through_the_file():
    x0 = np.array(initial_state(3.0, -2.0, 25.0))
    x0[[0, 1, 6, 7]] = [0.4, -0.9, 0.35, -0.15]
    sc = Scenario(name="moving", controller="flc", duration=0.5, x0=tuple(x0))
    text = dump_toml(sc.to_file(), "header")
    again = parse_scenario(tomllib.loads(text)).scenario
    np.testing.assert_allclose(np.array(again.x0), x0, rtol=0, atol=1e-14)
    written = tomllib.loads(text)["initial"]
    assert (written["x_m"], written["y_m"], written["vx_mps"], written["vy_mps"]) == (0.4, -0.9, 0.35, -0.15)

"""The MPC refuses a prediction model whose step is not its own sample time (every entry
point: the Function, its parts and the stateful controller) and more obstacles than its
rows hold, naming both numbers; a model step equal within 1e-12 s is accepted."""

from __future__ import annotations

import dataclasses

import pytest

from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.guidance.mpc import MpcConfig, PathMPC, make_mpc, make_mpc_parts
from ballbot_casadi.guidance.paths import figure_eight
from ballbot_casadi.sim.guided import path_scenario, velocity_loop_model


@pytest.fixture(scope="module")
def model():
    inp = path_scenario(figure_eight(), 2.0).inputs()
    return velocity_loop_model(inp["p_ctrl"], inp["k_vel"], 0.1)


@pytest.mark.parametrize("build", [make_mpc, make_mpc_parts,
                                   lambda m, c: PathMPC(m, figure_eight(), c)])
def test_a_model_of_another_step_is_refused(model, build):
    config = MpcConfig(dt=0.05)
    with pytest.raises(ScenarioError, match=r"^prediction model step 0\.1 s differs from the MPC dt 0\.05 s$"):
        build(model, config)
    near = dataclasses.replace(model, dt=0.1 + 5e-13)   # within the tolerance: the same step
    assert build(near, MpcConfig()) is not None


def test_more_obstacles_than_rows_are_refused(model):
    config = MpcConfig()
    many = [(10.0 + 2.0 * j, 10.0, 0.1) for j in range(config.n_obstacles + 1)]
    with pytest.raises(ScenarioError, match=rf"^obstacles: at most {config.n_obstacles} allowed by this "
                                            rf"MPC, got {config.n_obstacles + 1}$"):
        PathMPC(model, figure_eight(obstacles=many), config)
    assert PathMPC(model, figure_eight(obstacles=many[:-1]), config).path.obstacles

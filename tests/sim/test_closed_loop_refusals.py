"""The closed-loop simulator refuses inconsistent inputs before it runs, with one line
naming what is wrong: an unknown estimator, an estimator without its inputs, an initial
estimate of the wrong size, and a run_scenario call without a Scenario."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.errors import ScenarioError, ShapeError
from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario
from ballbot_casadi.sim.scenario import Scenario
from ballbot_casadi.sim.closed_loop import ESTIMATOR_FILTERS


@pytest.fixture(scope="module")
def sim():
    return ClosedLoop(compiled=True)


def _inputs(estimator="ukf"):
    inp = Scenario(name="s", duration=0.02, estimator=estimator).inputs()
    return inp.pop("x0"), inp


def test_unknown_estimator(sim):
    x0, inp = _inputs()
    inp["estimator"] = "kalman"
    with pytest.raises(ScenarioError, match=rf"^unknown estimator 'kalman'; allowed: true, "
                                            rf"{', '.join(ESTIMATOR_FILTERS)}$"):
        sim.simulate("flc", x0, **inp)


def test_an_estimator_needs_its_inputs(sim):
    x0, inp = _inputs()
    del inp["estimation"]
    with pytest.raises(ScenarioError, match=r"^estimator 'ukf' needs the estimation inputs \(noise, \.\.\.\)$"):
        sim.simulate("flc", x0, **inp)


def test_the_initial_estimate_has_the_estimators_size(sim):
    x0, inp = _inputs()
    good = np.asarray(inp["estimation"]["e0"], float).size
    inp["estimation"] = {**inp["estimation"], "e0": np.zeros(good - 1)}
    with pytest.raises(ShapeError, match=rf"^e0 has {good - 1} entries, expected {good}$"):
        sim.simulate("flc", x0, **inp)
    _, ok = _inputs()
    log = sim.simulate("flc", x0, **ok)   # the right size runs
    assert log["state"].shape[0] == 5 and np.all(np.isfinite(log["state"]))


def test_run_scenario_needs_a_scenario(sim):
    with pytest.raises(ScenarioError, match=r"^run_scenario needs a Scenario, got dict$"):
        run_scenario({"name": "s"}, sim)

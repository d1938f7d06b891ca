"""What the guided-mission entry points refuse, each with one clear line, before anything
is built: latency on laws that have none, estimators and delays the loops do not run,
missions that are not the FLC cascade, a scenario without a path, predictions of a law
that does not predict, a balance-feed dt off the control period."""

from __future__ import annotations

import pytest

from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.guidance.mpc import MpcConfig
from ballbot_casadi.guidance.paths import line_path
from ballbot_casadi.sim.guided import (
    guided_simulator,
    guided_software,
    mpc_balance_law,
    predictions,
    pursuit_law,
    run_guided,
    run_path_scenario,
    scenario_law,
)
from ballbot_casadi.sim.path_following import path_scenario, run_path
from ballbot_casadi.sim.scenario.file import parse_scenario

BASE = {"duration_s": 1.0, "cascade": True,
        "path": {"type": "figure_eight", "length": 4.0, "width": 2.0, "speed": 0.5}}


def _one_line(exc) -> str:
    msg = str(exc.value)
    assert "\n" not in msg
    return msg


@pytest.mark.parametrize("guidance, needle", [("pursuit", "option of the MPC"),
                                              ("mpc_balance", "not of mpc_balance")])
@pytest.mark.parametrize("kw", [{"latency": 1}, {"split": True}])
def test_latency_and_split_only_for_the_velocity_feed_mpc(guidance, needle, kw):
    sc = parse_scenario({**BASE, "guidance": guidance}).scenario
    with pytest.raises(ScenarioError) as exc:
        scenario_law(sc, **kw)
    assert needle in _one_line(exc)


def test_a_pursuit_scenario_gets_pure_pursuit():
    sc = parse_scenario({**BASE, "guidance": "pursuit"}).scenario
    law = scenario_law(sc)
    assert law.name == "pursuit" and law.latency == 0 and not law.split


@pytest.mark.parametrize("estimator", ["true", "qukf", "none"])
def test_guided_software_reads_sensors(estimator):
    with pytest.raises(ScenarioError) as exc:
        guided_software(pursuit_law(), estimator)
    assert "allowed: ukf, ekf" in _one_line(exc)


def test_simulator_estimators_and_delay():
    with pytest.raises(ScenarioError) as exc:
        guided_simulator(pursuit_law(), "vukf")
    assert "allowed: true, ukf, ekf" in _one_line(exc)
    with pytest.raises(ScenarioError) as exc:
        guided_simulator(pursuit_law(), "true", actuation_delay=True)
    assert "actuation_delay needs an estimator" in _one_line(exc)


@pytest.mark.parametrize("change", [{"controller": "smc"}, {"cascade": False}])
def test_run_guided_needs_the_flc_cascade(change):
    path = line_path((0.0, 0.0), (1.0, 0.0))
    sc = path_scenario(path, 0.1).replace(**change)
    with pytest.raises(ScenarioError) as exc:
        run_guided(path, pursuit_law(), 0.1, scenario=sc)
    assert "FLC cascade" in _one_line(exc)


def test_run_path_scenario_needs_a_path():
    sc = parse_scenario({"duration_s": 1.0}).scenario
    with pytest.raises(ScenarioError) as exc:
        run_path_scenario(sc)
    assert "has no [path]" in _one_line(exc)


def test_predictions_only_for_the_mpc():
    with pytest.raises(ScenarioError, match="only the MPC predicts"):
        predictions(pursuit_law(), {"guide": None})


def test_balance_feed_dt_on_the_control_period(guided_inputs):
    with pytest.raises(ScenarioError) as exc:
        mpc_balance_law(guided_inputs["p_ctrl"], MpcConfig(dt=0.0123))
    assert "multiple of 0.005" in _one_line(exc)


@pytest.mark.parametrize("period", [0.0123, 0.001, 0.0, 0.0075])
def test_run_path_guidance_period_on_the_control_period(period):
    """Shorter than one control period, or not a whole number of them: refused first."""
    with pytest.raises(ScenarioError) as exc:
        run_path(None, None, 1.0, guidance_period=period, sim=object())
    assert _one_line(exc) == f"guidance_period must be a multiple of 0.005 s, got {period!r}"


@pytest.mark.parametrize("period", [0.005, 0.1 + 5e-10, 0.1 - 5e-10])
def test_run_path_guidance_period_within_round_off_passes_the_check(period):
    with pytest.raises(Exception) as exc:  # the stand-in path fails later, not the period check
        run_path(None, None, 1.0, guidance_period=period, sim=object())
    assert "guidance_period" not in str(exc.value)

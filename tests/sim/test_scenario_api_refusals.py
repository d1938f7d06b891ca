"""Scenarios built in Python (not read from a file) refuse what a file would: each bad
field gets one line naming the field, what it got and what is allowed, with the file key
the error carries; and the explicit velocity gains of a scenario are the ones it runs."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.control import VELOCITY_NKV
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.sim.scenario import Scenario
from ballbot_casadi.sim.scenario.sections import (
    ESTIMATOR_CHOICES,
    ESTIMATOR_TUNING_KEYS,
    FEEDFORWARD_MODES,
    TORQUE_LIMIT_MODES,
)


@pytest.mark.parametrize("fields, key, message", [
    ({"duration": 0.004, "Ts": 0.01}, "duration_s",
     r"^scenario 's': duration shorter than one control period \(0\.01 s\)$"),
    ({"feedforward": "full"}, "feedforward",
     rf"^scenario 's': feedforward 'full' unknown; allowed: {', '.join(FEEDFORWARD_MODES)}$"),
    ({"torque_limit": "wheel"}, "torque_limit",
     rf"^scenario 's': torque_limit 'wheel' unknown; allowed: {', '.join(TORQUE_LIMIT_MODES)}$"),
    ({"cascade": 1}, "cascade", r"^scenario 's': cascade must be true or false, got 1$"),
    ({"estimator": "ukf", "noise": "yes"}, "noise",
     r"^scenario 's': noise must be true or false, got 'yes'$"),
    ({"estimator": "kalman"}, "estimator",
     rf"^scenario 's': estimator 'kalman' unknown; allowed: {', '.join(ESTIMATOR_CHOICES)}$"),
    ({"estimator": "ukf", "estimator_tuning": {"gyro_var": 1.0}}, "estimator_tuning.gyro_var",
     rf"^scenario 's': estimator_tuning key 'gyro_var' unknown; allowed: "
     rf"{', '.join(ESTIMATOR_TUNING_KEYS)}$"),
])
def test_python_fields_are_refused_with_the_file_key(fields, key, message):
    with pytest.raises(ScenarioError, match=message) as exc:
        Scenario(name="s", **fields)
    assert exc.value.key == key


def test_the_shortest_run_is_one_control_period():
    """More than half a period rounds to one (kept); less than half to none (refused)."""
    assert Scenario(name="s", duration=0.0051, Ts=0.01).n_periods == 1
    with pytest.raises(ScenarioError, match="shorter than one control period"):
        Scenario(name="s", duration=0.0049, Ts=0.01)


def test_every_allowed_choice_is_accepted():
    for ff in FEEDFORWARD_MODES:
        assert Scenario(name="s", feedforward=ff).feedforward == ff
    for tl in TORQUE_LIMIT_MODES:
        assert Scenario(name="s", torque_limit=tl).torque_limit == tl


def test_estimation_inputs_need_an_estimator():
    with pytest.raises(ScenarioError, match=r"^scenario 'bare' has no estimator in the loop$"):
        Scenario(name="bare", estimator="true").estimation_inputs()


def test_explicit_velocity_gains_are_the_ones_run():
    """Given gains replace the LQR design of the cascade (and the open velocity loop's
    zeros without it)."""
    designed = np.asarray(Scenario(name="s", duration=0.02, cascade=True).inputs()["k_vel"], float)
    assert designed.size == VELOCITY_NKV and np.count_nonzero(designed[:-8]) > 10
    k_vel = designed * 1.5
    for cascade in (True, False):
        run = Scenario(name="s", duration=0.02, cascade=cascade, k_vel=tuple(k_vel)).inputs()["k_vel"]
        np.testing.assert_allclose(run, k_vel, rtol=1e-15, atol=0)

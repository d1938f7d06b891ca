"""The embedded software and its firmware values refuse an estimator they do not have
with one line listing the ones they do: the estimator blocks, the software blocks, and
the firmware values of a scenario without an estimator in the loop."""

from __future__ import annotations

import re

import pytest

from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.firmware.sources import firmware_function, scenario_values
from ballbot_casadi.model.dynamics import make_ode, make_wheel_speeds
from ballbot_casadi.sim.embedded import (
    ESTIMATOR_FILTERS,
    estimator_blocks,
    estimator_layout,
    readings_layout,
    software_blocks,
)
from ballbot_casadi.sim.scenario import Scenario

ALLOWED = ", ".join(ESTIMATOR_FILTERS)


@pytest.mark.parametrize("call", [lambda: estimator_blocks("true", make_ode(), make_wheel_speeds()),
                                  lambda: readings_layout("true"), lambda: estimator_layout("true")])
def test_the_estimators_parts_refuse_an_unknown_estimator(call):
    with pytest.raises(ScenarioError, match=rf"^unknown estimator 'true'; allowed: {re.escape(ALLOWED)}$"):
        call()


def test_software_blocks_refuse_an_unknown_estimator():
    with pytest.raises(ScenarioError, match=rf"^unknown estimator 'kalman'; the embedded software reads "
                                            rf"sensors: allowed {re.escape(ALLOWED)}$"):
        software_blocks("flc", "kalman")


def test_firmware_values_need_an_estimator():
    sc = Scenario(name="bare", estimator="true", cascade=True)
    with pytest.raises(ScenarioError, match=rf"^scenario 'bare': the firmware needs an estimator "
                                            rf"\(estimator = one of {re.escape(ALLOWED)}\)$"):
        scenario_values(firmware_function(), sc)

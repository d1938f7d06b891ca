"""The controller blocks without an estimator (loops on the true state, prediction
models): the same shared Functions the embedded software is built from, and no
estimator is named to get them."""

from __future__ import annotations

import pytest

from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.sim.embedded import controller_blocks, software_blocks


@pytest.mark.parametrize("controller", ["flc", "smc"])
def test_controller_blocks_are_the_embedded_softwares_blocks(controller):
    alone = controller_blocks(controller)
    with_filter, _ = software_blocks(controller, "ukf")
    assert alone.balance is with_filter.balance
    assert alone.velocity is with_filter.velocity
    assert alone.observer is with_filter.observer and alone.observer is not None
    assert alone.balance.name() != controller_blocks("smc" if controller == "flc" else "flc").balance.name()


def test_without_the_observer_and_unknown_controllers():
    assert controller_blocks("flc", observer=False).observer is None
    with pytest.raises(ScenarioError, match=r"unknown controller 'pid'; allowed: flc"):
        controller_blocks("pid")

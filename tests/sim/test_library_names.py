"""The compiled closed-loop libraries' names (their build folders and shared objects): the
default variant plain, each departure (an estimator, the actuation delay, another number of
plant sub-steps) named in that order."""

from __future__ import annotations

import pytest

from ballbot_casadi.core.constants import N_SUB
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.sim.library import closed_loop_steps, library_name


@pytest.mark.parametrize("args, name", [
    ((N_SUB,), "ballbot_closed_loop"),
    ((N_SUB + 1,), f"ballbot_closed_loop_sub{N_SUB + 1}"),
    ((1, "true", False), "ballbot_closed_loop_sub1"),
    ((N_SUB, "ukf"), "ballbot_closed_loop_ukf"),
    ((N_SUB, "true", True), "ballbot_closed_loop_delayed"),
    ((2, "ekf", True), "ballbot_closed_loop_ekf_delayed_sub2"),
])
def test_library_names(args, name):
    assert library_name(*args) == name


def test_the_actuation_delay_needs_an_estimator_in_the_loop():
    with pytest.raises(ScenarioError, match=r"^the actuation delay is an option of the missions "
                                            r"with an estimator \('ukf' or 'ekf'\)$"):
        closed_loop_steps(N_SUB, "true", actuation_delay=True)

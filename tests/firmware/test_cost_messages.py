"""The cost module's refusals, each one line naming the numbers that were wrong."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from ballbot_casadi.errors import BuildError
from ballbot_casadi.firmware import cost


@pytest.mark.parametrize("isr", [2.4e6, 2.5e6])
def test_an_interrupt_filling_the_period_names_its_instructions_and_the_period(isr):
    with pytest.raises(BuildError) as e:
        cost.min_latency(isr, 1e6)
    assert str(e.value) == (f"the interrupt step's {isr:.0f} instructions leave no time in a "
                            "5 ms period for the background")
    assert cost.min_latency(2.4e6 - 1.0, 1.0) == 1  # one instruction free: enough for one


def test_a_split_replay_needs_two_background_samples():
    r = SimpleNamespace(instructions_per_tick=2.0, ticks=np.ones(6),
                        bg_ticks=np.array([0, 0, 5.0, 0, 0, 0]))
    with pytest.raises(BuildError, match=r"^the split replay ran 1 background samples; need two$"):
        cost.split_cost(None, r, 2, 3)


def test_a_guided_replay_needs_two_samples():
    r = SimpleNamespace(instructions_per_tick=1.0, ticks=np.ones(20))
    with pytest.raises(BuildError, match=r"^the guided replay needs more than 20 periods \(two "
                       r"guidance samples\), got 20$"):
        cost.guided_cost(None, r, 20, 5)


def test_the_constants():
    assert (cost.CLOCK_HZ, cost.CLOCK_HZ_MAX, cost.IPC, cost.PERIOD_S, cost.SPLIT_MARGIN) == (
        400e6, 480e6, 1.0, 0.005, 1.5)

"""A scenario as a Python loop of control_period (ballbot_casadi.sim.period), for the tests."""

from __future__ import annotations

import numpy as np

from ballbot_casadi.model.dynamics import make_ode
from ballbot_casadi.sim.period import control_period, rk4_plant
from ballbot_casadi.sim.ports import PERIOD_SEQUENCES, PeriodBlocks
from ballbot_casadi.sim.scenario import Scenario


def period_loop(blocks: PeriodBlocks, scenario: Scenario, inp: dict, z0: np.ndarray,
                const: dict) -> dict[str, np.ndarray]:
    """``scenario``'s periods as a Python loop of control_period with the RK4 plant, from
    the controller state ``z0``, with the period constants ``const`` and the sequences of
    its inputs ``inp``: ``state`` (n + 1 rows), ``tau`` and the final controller state."""
    plant = rk4_plant(make_ode(), scenario.n_sub, const["p_plant"], const["Ts"])
    x, z = inp["x0"].copy(), z0
    states, taus = [], []
    for k in range(scenario.n_periods):
        out = control_period(blocks, x, z, {s: inp[s][k] for s in PERIOD_SEQUENCES}, const, plant)
        states.append(out["x"])
        taus.append(out["tau"])
        x, z = out["x_next"], out["z_next"]
    states.append(x)
    return {"state": np.array(states), "tau": np.array(taus), "c_final": z}

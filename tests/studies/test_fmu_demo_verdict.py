"""The ``make demo`` FMU step's verdict and what it asks of the engines, with stand-in
co-simulations whose errors against the Python references are set by the test: exit 0
only when both the open-loop and the closed-loop errors are below 1e-9."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from ballbot_casadi.fmi.plant.plant import X0_PREFIX
from ballbot_casadi.model.dynamics import STATE_NAMES, make_model_functions
from ballbot_casadi.model.integrators import make_rk4
from ballbot_casadi.model.numeric import make_state
from ballbot_casadi.core.params import load_params
from ballbot_casadi.studies import fmu_demo


@pytest.fixture(scope="module")
def open_loop_reference():
    """1000 RK4 steps of 1 ms from roll 0.002 rad under tau = (0.02, -0.01, 0.005) N m."""
    rk4 = make_rk4(make_model_functions()["ode"])
    x, p = make_state(roll=0.002), load_params().to_vector()
    for _ in range(1000):
        x = np.asarray(rk4(x, [0.02, -0.01, 0.005], p, 1e-3)).ravel()
    return x


@pytest.mark.parametrize("open_err, closed_err, code", [
    (0.0, 0.0, 0), (5e-10, 5e-10, 0), (2e-9, 0.0, 1), (0.0, 2e-9, 1), (2e-9, 2e-9, 1)])
def test_demo_step_passes_only_when_both_co_simulations_match(monkeypatch, tmp_path, open_loop_reference,
                                                              open_err, closed_err, code):
    asked = {}

    def open_loop(fmu, tau, duration, start_values):
        asked.update(fmu=fmu, tau=np.asarray(tau), duration=duration, start=start_values)
        names = (*STATE_NAMES, "roll")
        res = np.zeros(3, dtype=[(n, float) for n in names])
        for n, v in zip(STATE_NAMES, open_loop_reference + open_err):
            res[n][-1] = v
        return res

    def closed_loop(sc):
        asked["scenario"] = sc
        return {"time": np.arange(3) * 0.005, "state": np.full((3, 12), 0.1 + closed_err),
                "tau": np.zeros((2, 3))}

    monkeypatch.setattr(fmu_demo, "build_fmu", lambda: SimpleNamespace(fmu="plant.fmu", guid="g"))
    monkeypatch.setattr(fmu_demo, "cosim_open_loop", open_loop)
    monkeypatch.setattr(fmu_demo, "closed_loop_cosim", closed_loop)
    monkeypatch.setattr(fmu_demo, "run_scenario", lambda sc, sim: {"state": np.full((3, 12), 0.1)})
    assert fmu_demo.demo_step(tmp_path) == code
    assert asked["fmu"] == "plant.fmu" and asked["duration"] == 1.0
    np.testing.assert_array_equal(asked["tau"], [0.02, -0.01, 0.005])
    x0 = make_state(roll=0.002)
    assert asked["start"] == {X0_PREFIX + n: float(v) for n, v in zip(STATE_NAMES, x0)}
    assert asked["scenario"].name == "sine" and asked["scenario"].controller == "flc"
    text = (tmp_path / "fmu" / "summary.txt").read_text()
    assert f"max |x_fmu - x_python| = {open_err:.3e}" in text.splitlines()[0]
    assert f"max |x_fmu - x_python| = {closed_err:.3e}" in text.splitlines()[1]

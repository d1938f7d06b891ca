"""ClippedLoop (sim.prediction_models) on a robot whose controller model differs from the
plant (``[controller_model]`` changes): the NMPC predicts with the CONTROLLER's model, so
its small-signal step is the shipped linear loop model of ``p_ctrl``, not of ``p_plant``
(issue 23: the plant's parameters read for the controller's must show)."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.guidance.paths import line_path
from ballbot_casadi.guidance.prediction import NXL
from ballbot_casadi.sim.path_following import path_scenario, velocity_loop_model
from ballbot_casadi.sim.prediction_models import ClippedLoop

DT = 0.1


@pytest.fixture(scope="module")
def mismatched():
    sc = path_scenario(line_path((0.0, 0.0), (3.0, 0.0), 0.5), DT)
    sc = sc.replace(ctrl_changes={"l": ["add", 0.08], "Mb": ["scale", 1.4]})
    inp = sc.inputs()
    assert not np.allclose(inp["p_ctrl"], inp["p_plant"])
    return inp, ClippedLoop(inp, DT)


def test_the_small_signal_model_is_the_controllers(mismatched):
    inp, cl = mismatched
    ctrl = velocity_loop_model(inp["p_ctrl"], inp["k_vel"], DT)
    plant = velocity_loop_model(inp["p_plant"], inp["k_vel"], DT)
    X = 1e-4 * np.linspace(-1.0, 1.0, NXL)[:, None]
    v = np.array([[2e-4], [-1e-4]])
    _, A, B, *_ = cl(X, v)
    scale = np.abs(ctrl.A).max()
    np.testing.assert_allclose(A, ctrl.A, rtol=0, atol=1e-7 * scale)
    np.testing.assert_allclose(B, ctrl.B, rtol=0, atol=1e-7 * np.abs(ctrl.B).max())
    assert np.abs(plant.A - ctrl.A).max() > 1e-4 * scale  # the two models differ

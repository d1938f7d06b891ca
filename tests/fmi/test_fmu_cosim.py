"""Closed-loop co-simulation: the plant FMU stepped at 5 ms by a Python master running the
FLC (+ velocity controller) of ballbot_casadi, against the pure Python closed loop."""

from __future__ import annotations

import numpy as np
import pytest
from _fmu_support import plant_build
from ballbot_casadi.studies.registry import study_scenarios

from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.fmi.masters.plant_loop import closed_loop_cosim
from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario


@pytest.fixture(scope="module")
def python_loop():
    return ClosedLoop(compiled=False)


@pytest.fixture(scope="module")
def controllers():
    from ballbot_casadi.control import BALANCE_CONTROLLERS, make_velocity_controller
    from ballbot_casadi.model.dynamics import make_affine

    return BALANCE_CONTROLLERS["flc"](make_affine()), make_velocity_controller()


def _tilt(X):
    """Tilt angle of the body z axis from vertical (rad)."""
    q = X[:, 2:6] / np.linalg.norm(X[:, 2:6], axis=1, keepdims=True)
    return np.arccos(np.clip(1 - 2 * (q[:, 1] ** 2 + q[:, 2] ** 2), -1, 1))


@pytest.mark.parametrize("study", ["sine", "velocity"])
def test_fmu_closed_loop_balances_and_matches_python(study, python_loop, controllers):
    plant_build()
    sc = study_scenarios(study, "flc")[-1]
    ref = run_scenario(sc, python_loop)
    co = closed_loop_cosim(sc, controllers=controllers)
    X, Xf = ref["state"], co["state"]
    assert Xf.shape == X.shape and sc.Ts == 0.005
    err = np.max(np.abs(Xf - X))
    print(f"{study}: FMU co-simulation vs Python closed loop, max state error {err:.3e}, "
          f"max torque difference {np.max(np.abs(co['tau_cmd'] - ref['tau_cmd'])):.3e}")
    np.testing.assert_allclose(Xf, X, rtol=0, atol=1e-9)
    np.testing.assert_allclose(co["tau_cmd"], ref["tau_cmd"], rtol=0, atol=1e-7)
    # it balances: bounded tilt, finite, unit quaternion kept
    assert np.all(np.isfinite(Xf))
    assert _tilt(Xf).max() < np.radians(8)
    assert np.max(np.abs(np.linalg.norm(Xf[:, 2:6], axis=1) - 1)) < 1e-6
    if study == "sine":  # tracks the 3 deg roll sine (roll = 2 asin(q1) for pure roll)
        roll = 2 * np.arcsin(Xf[:, 3])
        assert np.radians(2.0) < roll[1000:].max() < np.radians(4.0)
    else:  # follows the velocity profile: the ball moves and ends near the reference
        v = Xf[:, 6:8]
        vr = np.asarray(ref["v_ref"])[:, :2]
        assert np.abs(v).max() > 0.1
        assert np.linalg.norm(v[-1] - vr[-1]) < 0.05


def test_pushes_cannot_be_co_simulated():
    sc = study_scenarios("push", "flc")[0]
    with pytest.raises(ScenarioError, match="pushes"):
        closed_loop_cosim(sc)


def test_demo_step_writes_the_co_simulation_outputs(tmp_path):
    from ballbot_casadi.studies.fmu_demo import demo_step

    assert demo_step(tmp_path) == 0
    d = tmp_path / "fmu"
    assert (d / "cosim_open_loop.csv").is_file() and (d / "cosim_closed_loop_sine.csv").is_file()
    data = np.genfromtxt(d / "cosim_closed_loop_sine.csv", delimiter=",", names=True)
    assert len(data) == 2001 and np.all(np.isfinite(data["q1"]))
    assert "max |x_fmu - x_python|" in (d / "summary.txt").read_text()

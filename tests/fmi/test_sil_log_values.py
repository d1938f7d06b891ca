"""The SIL log built from a synthetic co-simulation record with known signals: torques
saturated at the PLANT's tau_max (not the controller's), the disturbance added after, the
controller's outputs shifted by one communication point, the first encoder reading
missing."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.control import BALANCE_DIAG_NAMES
from ballbot_casadi.core.layout import STATE
from ballbot_casadi.fmi.controller.controller import (
    READING_NAMES,
    REFERENCE_NAMES,
    REJECTION_NAMES,
    XHAT_NAMES,
)
from ballbot_casadi.fmi.plant.plant import WHEEL_ANGLE_NAMES
from ballbot_casadi.fmi.reference_player.player import DISTURBANCE_NAMES
from ballbot_casadi.fmi.system.sil import CONTROLLER, PLANT, TORQUES, SilRun
from ballbot_casadi.fmi.system.sil_log import sil_log
from ballbot_casadi.sim.scenario import parse_scenario

N = 6
TAU_PLANT, TAU_CTRL = 0.5, 1.5


def _run() -> SilRun:
    sc = parse_scenario({"duration_s": N * 0.005, "estimator": "ukf", "plant": {"tau_max": TAU_PLANT},
                         "controller_model": {"tau_max": TAU_CTRL}}).scenario
    rng = np.random.default_rng(5)
    t = 1.0 + 0.005 * np.arange(N + 1)     # a start time that is not zero
    s: dict[str, np.ndarray] = {}
    for comp, names in ((PLANT, (*STATE.names, *READING_NAMES, *WHEEL_ANGLE_NAMES, *DISTURBANCE_NAMES)),
                        (CONTROLLER, (*XHAT_NAMES, *(f"tau_cmd{i}" for i in range(3)),
                                      *(f"{w}_ref_used{i}" for w in ("q", "dq", "ddq") for i in range(4)),
                                      *(f"diag_{m}" for m in BALANCE_DIAG_NAMES), "nis_attitude",
                                      "nis_velocity", "repairs", *REJECTION_NAMES,
                                      *REFERENCE_NAMES))):
        for n in names:
            s[f"{comp}.{n}"] = rng.standard_normal(N + 1)
    # plant torque inputs between the two limits, beyond both, and inside both
    s[f"{PLANT}.tau0"] = np.array([1.0, -1.0, 0.2, 2.0, -0.4, 0.0, 9.0])
    s[f"{PLANT}.tau1"] = np.array([-0.6, 0.6, 0.5, -2.0, 0.3, 1.2, 0.0])
    s[f"{PLANT}.tau2"] = np.zeros(N + 1)
    for i, d in enumerate((0.1, -0.2, 0.05)):
        s[f"{PLANT}.tau_dist{i}"] = np.full(N + 1, d)
    assert set(TORQUES) == {"tau0", "tau1", "tau2"}
    return SilRun(t, s, (), "gauss-seidel", sc, (), 0.0)


def test_sil_log_saturates_at_the_plants_tau_max_and_adds_the_disturbance():
    run = _run()
    log = sil_log(run)
    s = run.signals
    tau_in = np.column_stack([s[f"{PLANT}.tau{i}"][:N] for i in range(3)])
    want = np.clip(tau_in, -TAU_PLANT, TAU_PLANT) + np.array([0.1, -0.2, 0.05])
    np.testing.assert_array_equal(log["tau"], want)
    assert log.params.tau_max == TAU_PLANT
    np.testing.assert_array_equal(log["w"][:, 3:6], np.tile([0.1, -0.2, 0.05], (N, 1)))
    np.testing.assert_array_equal(log["w"][:, :3], 0.0)


def test_sil_log_rows_are_periods_controller_outputs_one_point_later():
    run = _run()
    log = sil_log(run)
    s = run.signals
    np.testing.assert_allclose(log["time"], 0.005 * np.arange(N + 1), rtol=0, atol=1e-12)
    np.testing.assert_array_equal(log["state"], np.column_stack([s[f"{PLANT}.{n}"] for n in STATE.names]))
    np.testing.assert_array_equal(log["x_hat"], np.column_stack([s[f"{CONTROLLER}.{n}"][1:] for n in XHAT_NAMES]))
    np.testing.assert_array_equal(log["tau_cmd"][:, 1], s[f"{CONTROLLER}.tau_cmd1"][1:])
    np.testing.assert_array_equal(log["q_ref"][:, 2], s[f"{CONTROLLER}.q_ref_used2"][1:])
    np.testing.assert_array_equal(log["nis"][:, 1], s[f"{CONTROLLER}.nis_velocity"][1:])
    np.testing.assert_array_equal(log["v_ref"], np.column_stack(
        [s[f"{CONTROLLER}.{n}"][:N] for n in ("v_ref_x", "v_ref_y", "yaw_rate_ref")]))
    meas = np.column_stack([s[f"{PLANT}.{n}"][:N] for n in READING_NAMES])
    assert np.all(np.isnan(log["meas"][0, 6:9]))
    np.testing.assert_array_equal(log["meas"][0, :6], meas[0, :6])
    np.testing.assert_array_equal(log["meas"][1:], meas[1:])
    np.testing.assert_array_equal(log["phi"][:, 2], s[f"{PLANT}.phi2"])
    assert log.ctrl_params.tau_max == pytest.approx(TAU_CTRL)

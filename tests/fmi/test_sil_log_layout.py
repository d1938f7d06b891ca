"""The SIL log's layout on a synthetic run (no FMU is built, no co-simulation runs).

Every signal of the run is a distinct ramp (column ``j`` of component ``c``: ``1000 c + 10
j + t``), so each array of the log is known by hand: the state and readings of period
``k`` at ``t_k`` (row ``k``), the controller's outputs of period ``k`` at ``t_k+1`` (row
``k + 1`` of the run), the torque on the plant clipped at the PLANT's ``tau_max`` (not the
controller's) plus the disturbance, the first encoder reading missing, the time from 0.
A column taken from the neighbouring signal, a row shifted by one, the wrong limit or a
dropped disturbance changes a checked value.
"""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.control import BALANCE_DIAG_NAMES
from ballbot_casadi.core.layout import STATE
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.fmi.controller.controller import (
    REFERENCE_NAMES,
    REJECTION_NAMES,
    V_REF_USED_NAMES,
    XHAT_NAMES,
    reading_names,
)
from ballbot_casadi.fmi.plant.plant import WHEEL_ANGLE_NAMES
from ballbot_casadi.fmi.reference_player.player import DISTURBANCE_NAMES
from ballbot_casadi.fmi.system.sil import SilRun
from ballbot_casadi.fmi.system.sil_log import sil_log
from ballbot_casadi.sim.embedded import MEAS
from ballbot_casadi.sim.scenario.file import parse_scenario

N = 6
T0 = 2.0
TAU_PLANT, TAU_CTRL = 1.5, 4.0
SC = parse_scenario({"name": "syn", "duration_s": 1.0, "estimator": "ukf",
                     "plant": {"tau_max": TAU_PLANT},
                     "controller_model": {"tau_max": TAU_CTRL}}).scenario

CTRL_OUT = (*(f"tau_cmd{i}" for i in range(3)), *XHAT_NAMES,
            *(f"{w}_ref_used{i}" for w in ("q", "dq", "ddq") for i in range(4)),
            *(f"diag_{m}" for m in BALANCE_DIAG_NAMES), "nis_attitude", "nis_velocity",
            "repairs", *REJECTION_NAMES)
PLANT_SIG = (*STATE.names, *(f"tau{i}" for i in range(3)), *DISTURBANCE_NAMES,
             *reading_names("ukf"), *WHEEL_ANGLE_NAMES)


def _ramp(c: int, j: int) -> np.ndarray:
    return 1000.0 * c + 10.0 * j + np.arange(N + 1, dtype=float)


def _run(path_outputs: bool = True, disturbance: bool = True, scenario=SC) -> SilRun:
    sig = {}
    for j, n in enumerate(PLANT_SIG):
        if n in DISTURBANCE_NAMES and not disturbance:
            continue
        sig[f"plant.{n}"] = _ramp(1, j)
    for j, n in enumerate(PLANT_SIG[12:15]):  # torques big enough to clip, both signs
        sig[f"plant.{n}"] = np.array([0.5, -3.0, 2.0, -1.0, 9.0, -0.2, 0.0]) * (j + 1)
    for j, n in enumerate((*CTRL_OUT, *REFERENCE_NAMES,
                           *(V_REF_USED_NAMES if path_outputs else ()))):
        sig[f"controller.{n}"] = _ramp(2, j)
    return SilRun(time=T0 + 0.005 * np.arange(N + 1), signals=sig, connections=(),
                  master="gauss_seidel", scenario=scenario, specs=(), wall_s=0.0)


def _plant(name: str) -> np.ndarray:
    return _ramp(1, PLANT_SIG.index(name))


def _ctrl(name: str) -> np.ndarray:
    return _ramp(2, (*CTRL_OUT, *REFERENCE_NAMES, *V_REF_USED_NAMES).index(name))


def test_rows_are_periods_with_the_controller_outputs_one_step_later():
    log = sil_log(_run())
    np.testing.assert_allclose(log["time"], 0.005 * np.arange(N + 1), rtol=0, atol=1e-12)
    np.testing.assert_array_equal(log["state"], np.column_stack([_plant(n) for n in STATE.names]))
    assert log["state"].shape == (N + 1, 12)
    np.testing.assert_array_equal(log["tau_cmd"], np.column_stack(
        [_ctrl(f"tau_cmd{i}")[1:] for i in range(3)]))
    np.testing.assert_array_equal(log["x_hat"], np.column_stack([_ctrl(n)[1:] for n in XHAT_NAMES]))
    for key, w in (("q_ref", "q"), ("dq_ref", "dq"), ("ddq_ref", "ddq")):
        np.testing.assert_array_equal(log[key], np.column_stack(
            [_ctrl(f"{w}_ref_used{i}")[1:] for i in range(4)]), err_msg=key)
    np.testing.assert_array_equal(log["diag"], np.column_stack(
        [_ctrl(f"diag_{m}")[1:] for m in BALANCE_DIAG_NAMES]))
    np.testing.assert_array_equal(log["nis"], np.column_stack(
        [_ctrl("nis_attitude")[1:], _ctrl("nis_velocity")[1:]]))
    np.testing.assert_array_equal(log["repairs"][:, 0], _ctrl("repairs")[1:])
    np.testing.assert_array_equal(log["rejections"], np.column_stack(
        [_ctrl(n)[1:] for n in REJECTION_NAMES]))
    np.testing.assert_array_equal(log["v_ref"], np.column_stack(
        [_ctrl(n)[:N] for n in ("v_ref_x", "v_ref_y", "yaw_rate_ref")]))
    assert REFERENCE_NAMES[12:15] == ("v_ref_x", "v_ref_y", "yaw_rate_ref")
    np.testing.assert_array_equal(log["v_ref_used"], np.column_stack(
        [_ctrl(n)[1:] for n in V_REF_USED_NAMES]))
    np.testing.assert_array_equal(log["phi"], np.column_stack(
        [_plant(n) for n in WHEEL_ANGLE_NAMES]))
    assert log.extra == {"master": "gauss_seidel", "sil": True}


def test_the_torque_is_clipped_at_the_plants_limit_plus_the_disturbance():
    log = sil_log(_run())
    raw = np.array([0.5, -3.0, 2.0, -1.0, 9.0, -0.2])
    dist = np.column_stack([_plant(n)[:N] for n in DISTURBANCE_NAMES])
    want = np.column_stack([np.clip(raw * (i + 1), -TAU_PLANT, TAU_PLANT) for i in range(3)]) + dist
    np.testing.assert_allclose(log["tau"], want, rtol=0, atol=1e-12)
    w = log["w"]
    assert w.shape == (N, 6)
    np.testing.assert_array_equal(w[:, :3], 0.0)
    np.testing.assert_array_equal(w[:, 3:], dist)
    assert log.params.tau_max == TAU_PLANT and log.ctrl_params.tau_max == TAU_CTRL


def test_without_a_disturbance_the_torque_is_only_clipped():
    log = sil_log(_run(disturbance=False))
    raw = np.array([0.5, -3.0, 2.0, -1.0, 9.0, -0.2])
    want = np.column_stack([np.clip(raw * (i + 1), -TAU_PLANT, TAU_PLANT) for i in range(3)])
    np.testing.assert_allclose(log["tau"], want, rtol=0, atol=0)
    np.testing.assert_array_equal(log["w"], 0.0)


def test_the_first_encoder_reading_is_missing_and_the_rest_kept():
    log = sil_log(_run())
    meas = log["meas"]
    names = reading_names("ukf")
    assert meas.shape == (N, len(names))
    want = np.column_stack([_plant(n)[:N] for n in names])
    enc = MEAS["enc"]
    assert np.all(np.isnan(meas[0, enc]))
    np.testing.assert_array_equal(meas[1:], want[1:])
    keep = np.ones(len(names), bool)
    keep[enc] = False
    np.testing.assert_array_equal(meas[0, keep], want[0, keep])


def test_the_balance_variant_has_no_guidance_outputs_and_errors_name_the_cause():
    log = sil_log(_run(path_outputs=False))
    assert "v_ref_used" not in log
    with pytest.raises(ScenarioError, match="pass the scenario to sil_log"):
        sil_log(_run(scenario=None))
    run = _run()
    del run.signals["plant.dq3"]
    with pytest.raises(ScenarioError, match="no outputs dq3"):
        sil_log(run)
    # a scenario given explicitly wins over the run's
    other = parse_scenario({"name": "o", "duration_s": 1.0, "estimator": "ukf",
                            "plant": {"tau_max": 0.5}}).scenario
    assert np.max(np.abs(sil_log(_run(disturbance=False), other)["tau"])) == 0.5

"""The estimating loop on a run built to separate the plausible wrong wirings: the robot
starts moving diagonally (different vx and vy), the plant saturates below the
controller's torque limit and a torque disturbance acts, a push lands between two
control instants.  Each check uses an independent reference (the sensor model at the
logged state, the integral of the logged estimate, hand-computed instants)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import DISTURBANCE, STATE
from ballbot_casadi.core.params import load_params
from ballbot_casadi.model.dynamics import make_model_functions
from ballbot_casadi.model.sensors import make_sensors
from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario
from ballbot_casadi.sim.scenario import parse_scenario

TS = 0.005
TAU_PLANT = 0.3
DIST = (0.15, -0.1, 0.05)
TABLE = {
    "duration_s": 0.6, "controller": "flc", "estimator": "ukf", "noise": False, "seed": 3,
    "initial": {"roll_deg": 3.0, "pitch_deg": -2.0, "yaw_deg": 20.0, "x_m": 0.25, "y_m": -0.4,
                "vx_mps": 0.3, "vy_mps": -0.12},
    "plant": {"tau_max": TAU_PLANT},
    "torque_disturbance": [{"t_start_s": 0.1, "t_end_s": 0.3, "tau_nm": list(DIST)}],
    "push": [{"t_s": 0.4149, "roll_deg": 2.0, "pitch_deg": -1.0}],
}


def _tau_lim(log) -> np.ndarray:
    """The command after the controller's direction-preserving limit at its own tau_max
    (the thesis value: the file changes only the plant's), scaled row by row."""
    cmd = log["tau_cmd"]
    m = np.max(np.abs(cmd), axis=1, keepdims=True)
    return cmd * np.minimum(1.0, load_params().tau_max / m)


@pytest.fixture(scope="module")
def run():
    sc = parse_scenario(TABLE).scenario
    return sc, run_scenario(sc, ClosedLoop(compiled=True))


def _zyx(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """ZYX quaternion written out by hand: qz(yaw) o qy(pitch) o qx(roll)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return np.array([cy * cp * cr + sy * sp * sr, cy * cp * sr - sy * sp * cr,
                     cy * sp * cr + sy * cp * sr, sy * cp * cr - cy * sp * sr])


def test_initial_keys_set_each_state_entry():
    sc = parse_scenario(TABLE).scenario
    x0 = np.array(sc.x0)
    np.testing.assert_allclose(x0[STATE["q"]], _zyx(*np.radians([3.0, -2.0, 20.0])), rtol=0, atol=1e-15)
    np.testing.assert_array_equal(x0[[0, 1, 6, 7]], [0.25, -0.4, 0.3, -0.12])
    np.testing.assert_array_equal(x0[STATE["dq"]], 0.0)


def test_the_run_starts_where_the_file_says_and_moves_diagonally(run):
    sc, log = run
    x = log["state"]
    np.testing.assert_array_equal(x[0], np.array(sc.x0))
    # over the first 50 ms the ball keeps its initial velocity to within a few mm/s
    np.testing.assert_allclose(x[10, 0:2], [0.25 + 0.3 * 0.05, -0.4 - 0.12 * 0.05], rtol=0, atol=5e-4)


def test_applied_torque_is_the_plants_saturation_plus_the_disturbance(run):
    sc, log = run
    t = log["time"][:-1]
    dist = np.where(((t >= 0.1 - 1e-12) & (t < 0.3 - 1e-12))[:, None], np.array(DIST), 0.0)
    lim = _tau_lim(log)
    expected = np.clip(lim, -TAU_PLANT, TAU_PLANT) + dist
    np.testing.assert_allclose(log["tau"], expected, rtol=0, atol=1e-14)
    # the run is built so that the plant saturates below the controller's limit and the
    # controller's own limit acts too
    assert np.max(np.abs(lim)) > TAU_PLANT + 0.1
    assert np.max(np.abs(log["tau_cmd"])) > load_params().tau_max


def test_imu_reads_the_torque_that_acted_in_the_previous_period(run):
    sc, log = run
    sensors = make_sensors(make_model_functions()["ode"])
    p = sc.plant_params().to_vector()
    x, tau, meas = log["state"], log["tau"], log["meas"]
    lim = _tau_lim(log)
    differs = [k for k in range(1, tau.shape[0]) if np.max(np.abs(tau[k - 1] - lim[k - 1])) > 0.05]
    assert len(differs) > 20                       # saturated or disturbed periods
    for k in differs[::7] + [1]:
        acc, gyro, _ = sensors(x[k], tau[k - 1], p)
        np.testing.assert_allclose(meas[k, 0:3], np.asarray(acc).ravel(), rtol=0, atol=1e-12)
        np.testing.assert_allclose(meas[k, 3:6], np.asarray(gyro).ravel(), rtol=0, atol=1e-12)
        wrong, _, _ = sensors(x[k], lim[k - 1], p)
        assert np.max(np.abs(np.asarray(wrong).ravel() - meas[k, 0:3])) > 1e-4


def test_position_estimate_integrates_this_periods_velocity_estimate(run):
    sc, log = run
    xh = log["x_hat"]
    pos, vel = xh[:, 0:2], xh[:, 6:8]
    # the estimate starts at the true position and then integrates the velocity
    # estimate of the same period (no position sensor): pos_k = pos_{k-1} + Ts v_k
    np.testing.assert_allclose(pos[0], np.array(sc.x0[0:2]) + TS * vel[0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(pos[1:] - pos[:-1], TS * vel[1:], rtol=0, atol=1e-14)
    # and the velocity estimate differs from one period to the next (so a one-sample
    # shift would show)
    assert np.max(np.abs(np.diff(vel, axis=0))) > 1e-3


def test_push_lands_on_the_nearest_control_instant_and_rotates_the_plant(run):
    sc, log = run
    w = sc.disturbance()
    k_push = np.nonzero(np.any(w[:, DISTURBANCE["push"]] != 0, axis=1))[0]
    assert list(k_push) == [83]                     # 0.4149 / 0.005 = 82.98 -> 83
    np.testing.assert_allclose(w[83, DISTURBANCE["push"]],
                               Q.to_rotation_vector(_zyx(math.radians(2.0), math.radians(-1.0), 0.0)),
                               rtol=0, atol=1e-15)
    for t_s, k in ((0.015, 3), (0.0112, 2), (0.0138, 3), (0.0125 - 1e-6, 2)):
        table = {**TABLE, "push": [{"t_s": t_s, "roll_deg": 1.0}]}
        w = parse_scenario(table).scenario.disturbance()
        assert list(np.nonzero(w[:, DISTURBANCE["push"]][:, 0])[0]) == [k], t_s
    # the logged state at t_83 is the pushed one: its tilt jumps there and not before
    tilt = np.degrees(2 * np.arctan2(np.hypot(log["state"][:, 3], log["state"][:, 4]),
                                     np.hypot(log["state"][:, 2], log["state"][:, 5])))
    jumps = np.abs(np.diff(tilt))
    assert int(np.argmax(jumps)) + 1 == 83 and jumps[82] > 1.0

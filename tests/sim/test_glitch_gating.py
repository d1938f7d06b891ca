"""Glitch readings in the compiled mission: the embedded software's innovation gates reject
a 1000 rad/s gyroscope sample and a 1e20 m/s^2 accelerometer sample, count them in the
``rejections`` output, and the estimate stays with the glitch-free run's."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from _step_support import run_steps

from ballbot_casadi.analysis.estimates import estimation_metrics
from ballbot_casadi.control import make_flc, make_velocity_controller
from ballbot_casadi.estimation import make_qekf, make_qukf, make_vekf, make_vukf
from ballbot_casadi.model.dynamics import make_affine, make_ode, make_wheel_speeds
from ballbot_casadi.sim.steps import make_estimating_step
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import STATE
from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario
from ballbot_casadi.sim.embedded import GATE_GROUPS, estimator_blocks
from ballbot_casadi.studies.registry import study_scenarios

#: The outputs a period row of run_steps holds.
_KEYS = ("x", "x_hat", "tau", "rejections")

T_GYRO, T_ACC = 1.0, 2.0
GLITCHES = ((T_GYRO, "gyro", "x", 1000.0), (T_ACC, "acc", "z", 1e20))


@pytest.fixture(scope="module")
def sim() -> ClosedLoop:
    return ClosedLoop(compiled=True)


def _sine(estimator: str, **kw):
    return study_scenarios("sine", "flc")[0].replace(
        **{"duration": 3.0, "estimator": estimator, "seed": 7, **kw})


def _roll_deg(q: np.ndarray) -> np.ndarray:
    return np.degrees(Q.to_rpy(q / np.linalg.norm(q, axis=1)[:, None])[:, 0])


@pytest.fixture(scope="module", params=["ukf", "ekf"])
def runs(request, sim):
    est = request.param
    return (run_scenario(_sine(est), sim),
            run_scenario(_sine(est, sensor_glitches=GLITCHES), sim), _sine(est).Ts)


def test_glitches_are_rejected_in_their_groups_and_counted(runs):
    ref, glitch, Ts = runs
    assert ref["rejections"].shape == (ref["x_hat"].shape[0], GATE_GROUPS.size)
    assert int(np.sum(ref["rejections"])) == 0  # a clean run rejects nothing
    r = glitch["rejections"]
    k_gyro, k_acc = round(T_GYRO / Ts), round(T_ACC / Ts)
    # the glitches are in the readings
    assert glitch["meas"][k_gyro, 3] > 999.0 and glitch["meas"][k_acc, 2] > 1e19
    expected = np.zeros_like(r)
    expected[k_gyro, GATE_GROUPS["attitude_gyro"]] = 1
    expected[k_acc, GATE_GROUPS["attitude_acc"]] = 1
    expected[k_acc, GATE_GROUPS["velocity_acc"]] = 1
    np.testing.assert_array_equal(r, expected)
    assert estimation_metrics(glitch)["gate_rejections"] == 3
    assert estimation_metrics(ref)["gate_rejections"] == 0


def test_estimate_recovers_within_a_second_of_each_glitch(runs):
    ref, glitch, Ts = runs
    t = glitch["time"][:-1]
    roll_true = _roll_deg(glitch["state"][:-1, STATE["q"]])
    err = np.abs(_roll_deg(glitch["x_hat"][:, STATE["q"]]) - roll_true)
    err_ref = np.abs(_roll_deg(ref["x_hat"][:, STATE["q"]]) - _roll_deg(ref["state"][:-1, STATE["q"]]))
    # before the gate the gyro sample swung the roll estimate by ~100 deg for ~30 s and the
    # accelerometer sample never recovered; now the estimate never leaves the clean run's
    # error band by more than a hundredth of a degree ...
    assert np.all(np.isfinite(glitch["x_hat"])) and np.all(np.isfinite(glitch["state"]))
    assert err.max() < err_ref.max() + 0.01
    # ... and within a second of each glitch it is back with the clean run's estimate
    for tg in (T_GYRO, T_ACC):
        after = (t >= tg + 1.0 - 1e-9) & (t < tg + 1.0 + 0.5)
        if after.any():
            dev = np.abs(glitch["x_hat"][after] - ref["x_hat"][after])
            assert dev[:, STATE["q"]].max() < 1e-4
    # the robot balances as in the clean run
    np.testing.assert_allclose(glitch["state"][:, STATE["q"]], ref["state"][:, STATE["q"]],
                               rtol=0, atol=1e-3)


@pytest.mark.parametrize("estimator", ["ukf", "ekf"])
def test_without_rejections_the_gated_loop_is_the_ungated_one_bit_for_bit(estimator):
    ode, ws = make_ode(), make_wheel_speeds()
    flc, vel = make_flc(make_affine()), make_velocity_controller()
    gated = estimator_blocks(estimator, ode, ws)
    att, velf = ((make_qukf, make_vukf) if estimator == "ukf" else (make_qekf, make_vekf))
    plain = dataclasses.replace(gated, attitude=att(compensate_acceleration=True),
                                velocity=velf(ws, midpoint=True))
    step_g = make_estimating_step(flc, vel, ode, ws, gated)
    step_p = make_estimating_step(flc, vel, ode, ws, plain)
    n = 30
    inp = _sine(estimator, duration=n * 0.005).inputs()
    a, b = run_steps(step_g, inp, n, _KEYS), run_steps(step_p, inp, n, _KEYS)
    assert np.all(np.isfinite(a))
    np.testing.assert_array_equal(a, b)  # the rejections columns are zero in both
    # with a glitch the gate acts and the runs part
    inp = _sine(estimator, duration=n * 0.005, sensor_glitches=((0.05, "gyro", "y", 500.0),)).inputs()
    a, b = run_steps(step_g, inp, n, _KEYS), run_steps(step_p, inp, n, _KEYS)
    assert a[10, -3] == 1.0 and np.sum(a[:, -4:]) == 1.0  # attitude_gyro at period 10
    assert np.max(np.abs(a[11:, 12:24] - b[11:, 12:24])) > 1e-3


def test_the_gate_counters_are_carried_across_periods_so_a_persistent_fault_opens_the_gate(sim):
    """A gyro offset lasting 25 periods: the mission carries each group's consecutive-rejection
    count in the controller state, so the gate rejects exactly GATE_MAX_REJECTIONS periods and
    then opens (a counter that restarts from zero every period would reject all 25)."""
    from ballbot_casadi.estimation.tuning import GATE_MAX_REJECTIONS

    sc = _sine("ukf")
    k0, n_bad = round(T_GYRO / sc.Ts), GATE_MAX_REJECTIONS + 5
    rows = tuple(((k0 + i) * sc.Ts, "gyro", "x", 5.0) for i in range(n_bad))
    r = run_scenario(sc.replace(sensor_glitches=rows), sim)["rejections"][:, GATE_GROUPS["attitude_gyro"]]
    np.testing.assert_array_equal(r[k0 - 5:k0].ravel(), 0)
    np.testing.assert_array_equal(r[k0:k0 + GATE_MAX_REJECTIONS].ravel(), 1)
    assert r[k0 + GATE_MAX_REJECTIONS, 0] == 0  # opened after GATE_MAX_REJECTIONS in a row

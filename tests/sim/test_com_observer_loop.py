"""The COM observer in the closed loop: off = the loop without it, bit for bit; on = the
estimate converges, the robot returns to where it stood, the balance controller reaches
its reference; with sensors and the UKFs too."""

from __future__ import annotations

import numpy as np
import pytest
from _step_support import run_steps

from ballbot_casadi.analysis.com_observer import com_observer_metrics
from ballbot_casadi.analysis.metrics import velocity_metrics
from ballbot_casadi.control import make_flc, make_velocity_controller
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.estimation.com_observer import make_com_observer
from ballbot_casadi.model.dynamics import make_affine, make_ode, make_wheel_speeds
from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario
from ballbot_casadi.sim.steps import make_closed_loop_step, make_estimating_step
from ballbot_casadi.sim.embedded import estimator_blocks, make_embedded_step
from ballbot_casadi.sim.scenario import load_scenario_file, parse_scenario
from ballbot_casadi.sim.scenario import Scenario
from ballbot_casadi.studies.registry import shipped_scenarios, study_scenarios

#: The outputs a period row of run_steps holds.
_KEYS = ("x", "x_hat", "tau", "meas")

OFFSET = {"com_x": ["set", -0.02], "com_y": ["set", -0.03], "l": ["add", 0.03]}


@pytest.fixture(scope="module")
def sim() -> ClosedLoop:
    return ClosedLoop(compiled=True)


@pytest.fixture(scope="module")
def blocks():
    ode, affine = make_ode(), make_affine()
    return make_flc(affine), make_velocity_controller(), ode


def _com(**kw) -> Scenario:
    sc = load_scenario_file(shipped_scenarios()["com_observer_true"]).scenario
    return sc.replace(**kw)


def test_observer_off_is_the_loop_without_observer_bit_for_bit(blocks):
    flc, vel, ode = blocks
    plain = ClosedLoop(compiled=False, steps={"flc": make_closed_loop_step(flc, vel, ode)})
    shadow = ClosedLoop(compiled=False, steps={"flc": make_closed_loop_step(flc, vel, ode, observer=make_com_observer())})
    sc = _com(com_observer=False, duration=0.4)
    a, b = run_scenario(sc, plain), run_scenario(sc, shadow)
    for key in ("state", "z", "tau", "tau_cmd", "q_ref", "diag"):
        np.testing.assert_array_equal(a[key], b[key])
    assert "com_hat" in b and "com_hat" not in a
    on = run_scenario(sc.replace(com_observer=True), shadow)
    assert np.max(np.abs(on["tau"] - b["tau"])) > 1e-3  # switched on, the estimate is used
    with pytest.raises(ScenarioError, match="no COM observer|have none"):
        run_scenario(sc.replace(com_observer=True), plain)


def test_observer_off_with_estimators_is_the_loop_without_observer_bit_for_bit(blocks):
    flc, vel, ode = blocks
    ws = make_wheel_speeds()
    est = estimator_blocks("ukf", ode, ws)
    step_plain = make_estimating_step(flc, vel, ode, ws, est)
    step_obs = make_estimating_step(flc, vel, ode, ws, est,
                                    embedded=make_embedded_step(flc, vel, est, make_com_observer()))
    assert step_obs.n_in() == step_plain.n_in() + 2
    inp = _com(com_observer=False, duration=0.1, estimator="ukf", seed=3).inputs()
    a, b = run_steps(step_plain, inp, 20, _KEYS), run_steps(step_obs, inp, 20, _KEYS)
    assert np.all(np.isfinite(a[1:]))
    np.testing.assert_array_equal(a, b)


def test_true_state_estimate_converges_and_the_robot_returns(sim):
    log = run_scenario(_com(), sim)
    m = com_observer_metrics(log)
    assert m["com_estimate_error_max_mm"] < 0.5       # 10 s after the standstill command
    assert m["com_estimate_error_mm"] < 1e-3          # 30 s: the observable part, exactly
    assert m["com_estimate_settle_s"] < 10.0
    # the raw error is the unobservable height's share: (1 - l / l_true) |(com_x, com_y)|
    l, lt = log.ctrl_params.l, log.params.l
    assert m["com_estimate_raw_error_mm"] == pytest.approx((1 - l / lt) * np.hypot(20, 30), rel=1e-3)
    assert m["final_position_error_m"] < 1e-4
    assert m["standing_tilt_error_deg"] < 1e-5
    # without the observer: 1.3 m away, ~0.6 deg from the reference (the wrong model)
    off = com_observer_metrics(run_scenario(_com(com_observer=False), sim))
    assert off["final_position_error_m"] > 1.0 and off["standing_tilt_error_deg"] > 0.4


def test_with_noisy_sensors_and_ukfs_the_acceptance_numbers_hold(sim):
    # seeds 1, 8 and 12 left the true attitude 0.09-0.12 deg off before the
    # velocity-aided tilt correction (the attitude filter's slow error)
    sc = load_scenario_file(shipped_scenarios()["com_observer"]).scenario
    for seed in (1, 8, 12):
        m = com_observer_metrics(run_scenario(sc.replace(seed=seed), sim))
        assert m["com_estimate_error_max_mm"] <= 2.0
        assert m["final_position_error_m"] <= 0.02
        assert m["standing_tilt_error_est_deg"] <= 0.05
        assert m["standing_tilt_error_deg"] <= 0.05


def test_the_tilt_correction_needs_a_bias_estimate_that_can_follow(sim):
    # with the predecessor's accelerometer-bias process noise (1e-9 per period) the
    # velocity filter's bias follows the attitude filter's slow error over minutes, not
    # seconds: the true attitude misses the 0.05 deg it meets with the tuned filter.  The
    # thesis-model velocity filter (estimator "ukf"), whose bias walk is this knob; the
    # shipped matched filter (ukf_adaptive) walks its offset by the attitude filter's own
    # rate covariance and meets 0.05 deg either way (measured 0.022 deg with 1e-9)
    sc = load_scenario_file(shipped_scenarios()["com_observer"]).scenario.replace(estimator="ukf")
    tuned = com_observer_metrics(run_scenario(sc, sim))
    slow = sc.replace(estimator_tuning={**sc.estimator_tuning, "acc_bias_process_var": 1e-9})
    m = com_observer_metrics(run_scenario(slow, sim))
    assert m["standing_tilt_error_deg"] > 0.05 >= 1.5 * tuned["standing_tilt_error_deg"]


def test_velocity_profile_with_observer_on_keeps_the_velocity_specs_and_freezes_the_estimate(sim):
    vel = study_scenarios("velocity")[-1]
    log = run_scenario(vel.replace(com_observer=True), sim)
    m = velocity_metrics(log)
    assert m["velocity_error_rms_delayed_mps"] <= 0.05
    assert m["max_abs_roll_pitch_deg"] <= 5.0
    assert m["final_velocity_error_mps"] <= 0.01
    moving = np.any(log["v_ref"] != 0.0, axis=1)
    first = np.argmax(moving)
    np.testing.assert_array_equal(log["com_hat"][moving], np.tile(log["com_hat"][first - 1], (moving.sum(), 1)))


def test_scenario_fields_are_checked():
    with pytest.raises(ScenarioError, match="com_observer must be true or false"):
        Scenario(name="x", com_observer="yes")
    with pytest.raises(ScenarioError, match="COM observer gains"):
        Scenario(name="x", k_obs=(1.0, 2.0))
    t = {"duration_s": 1.0, "com_observer": True, "gains": {"k_obs": [0.5, 3.0, 0.1, 0.1]}}
    sc = parse_scenario(t).scenario
    assert sc.com_observer and sc.k_obs == (0.5, 3.0, 0.1, 0.1)
    np.testing.assert_array_equal(sc.inputs()["k_obs"], [0.5, 3.0, 0.1, 0.1])
    with pytest.raises(ScenarioError, match="gains"):
        parse_scenario({"duration_s": 1.0, "gains": {"k_obs": [0.0, 3.0, 0.1, 0.1]}})

"""The heading sensor in the control period and the heading-aided QUKF in the embedded step
(issue 22): the reading port, the scenario switch (off: every shipped result unchanged),
and the heading error of the closed loop with and without the sensor."""

from __future__ import annotations

import tomllib

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.analysis.estimates import tilt_heading_error_deg
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.constants import TS_CONTROL
from ballbot_casadi.core.layout import STATE
from ballbot_casadi.core.params import load_params
from ballbot_casadi.core.rng import NoiseStream
from ballbot_casadi.core.sensor_params import load_sensor_params
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.estimation.heading import HEADING_FILTER_STATE
from ballbot_casadi.model.sensors import NOISE_STREAMS, heading_schedule
from ballbot_casadi.sim.closed_loop import ClosedLoop, power_on_inputs, run_scenario
from ballbot_casadi.sim.embedded import (
    MEAS,
    MEAS_HEADING,
    NOISE,
    SENSOR_STATE,
    VALID,
    controller_layout,
    embedded_software,
    readings_layout,
    sense,
    software_blocks,
)
from ballbot_casadi.sim.scenario import Scenario, parse_scenario
from ballbot_casadi.sim.steps import make_estimating_step
from ballbot_casadi.model.dynamics import make_ode, make_wheel_speeds
from ballbot_casadi.studies.registry import study_scenarios

DEG = np.pi / 180
BIAS_Z = 0.002  # rad/s (0.11 deg/s): a z gyro bias the filters do not know


@pytest.fixture(scope="module")
def sim() -> ClosedLoop:
    return ClosedLoop(compiled=True)


def _standing(**kw) -> Scenario:
    """The complete system (cascade, thesis mode, noisy sensors) on the velocity profile of
    ``full_velocity``, then standing, with a z gyro bias of :data:`BIAS_Z`."""
    base = study_scenarios("full", "flc")
    sc = next(s for s in base if s.name == "full_velocity")
    return sc.replace(**{"sensor_changes": {"gyro_bias0": ["set", [0.0, 0.0, BIAS_Z]]}, **kw})


def _heading_error_deg(log) -> tuple[np.ndarray, np.ndarray]:
    n = len(log["x_hat"])
    _, h = tilt_heading_error_deg(log["state"][:n, STATE["q"]], log["x_hat"][:, STATE["q"]])
    return np.asarray(log["time"][:n]), h


# ------------------------------------------------------------------ the reading port
def test_heading_reading_is_the_plant_yaw_with_its_noise_missing_when_invalid():
    _, est = software_blocks("flc", "ukf_heading")
    assert est.readings is MEAS_HEADING and readings_layout("ukf_heading") is MEAS_HEADING
    assert readings_layout("ukf") is MEAS and readings_layout("ekf") is MEAS
    s = load_sensor_params(heading_bias=[0.01])
    xk = np.zeros(STATE.size + 3)
    q = Q.from_rpy(0.02, -0.03, 2.5)
    xk[STATE["q"]] = q
    noise = np.zeros(NOISE.size)
    noise[NOISE["heading"]] = 0.7
    s_state = np.zeros(SENSOR_STATE.size)
    sym = [ca.MX.sym(n, k) for n, k in (("x", xk.size), ("s_state", SENSOR_STATE.size),
                                         ("noise", NOISE.size), ("valid", VALID.size),
                                         ("p", load_params().to_vector().size),
                                         ("s", s.to_vector().size), ("Ts", 1))]
    meas, _ = sense(est, *sym)
    f = ca.Function("f", sym, [meas])
    sigma = np.sqrt(s.heading_noise_var[0])
    want = 2.5 + 0.01 + 0.7 * sigma  # independent: the ZYX yaw of the plant's attitude
    args = (xk, s_state, noise, np.ones(VALID.size), load_params().to_vector(), s.to_vector(),
            TS_CONTROL)
    z = np.asarray(f(*args)).ravel()
    assert z.size == MEAS_HEADING.size
    assert z[MEAS_HEADING["heading"]][0] == pytest.approx(want, abs=1e-12)
    valid = np.ones(VALID.size)
    valid[VALID.index("heading")] = 0.0
    z = np.asarray(f(*args[:3], valid, *args[4:])).ravel()
    assert np.isnan(z[MEAS_HEADING["heading"]][0]) and np.all(np.isfinite(z[:MEAS.size - 3]))


def test_scenario_switch_schedule_dropout_and_noise_stream():
    off = _standing(duration=2.0, seed=5)
    on = off.replace(heading_sensor=True, sensor_dropouts=[(0.5, 1.0, "heading")])
    a, b = off.estimation_inputs(), on.estimation_inputs()
    # off by default: in the constructor and in a file without the key
    assert Scenario(name="d", duration=1.0).heading_sensor is False
    assert parse_scenario({"duration_s": 1.0}).scenario.heading_sensor is False
    assert off.heading_sensor is False
    assert not a["valid"][:, VALID.index("heading")].any()  # off by default
    n = a["valid"].shape[0]
    want = heading_schedule(0, n, TS_CONTROL, 10.0)
    t = np.arange(n) * TS_CONTROL
    want[(t >= 0.5) & (t < 1.0)] = 0.0
    np.testing.assert_array_equal(b["valid"][:, VALID.index("heading")], want)
    assert np.flatnonzero(want)[:3].tolist() == [0, 20, 40]  # 10 Hz at 200 Hz
    # the other sensors' availability and every noise column do not change
    np.testing.assert_array_equal(a["valid"][:, :VALID.index("heading")],
                                  b["valid"][:, :VALID.index("heading")])
    np.testing.assert_array_equal(a["noise"], b["noise"])
    rng = NoiseStream(5)
    np.testing.assert_array_equal(a["noise"][:, NOISE["heading"]],
                                  rng.normal(NOISE_STREAMS["heading"], n, 1, start=0))
    np.testing.assert_array_equal(a["noise"][:, NOISE["acc"]],
                                  rng.normal(NOISE_STREAMS["acc"], n, 3, start=0))
    with pytest.raises(ScenarioError, match="heading_sensor must be true or false"):
        off.replace(heading_sensor=1)


def test_scenario_file_keys_round_trip():
    text = ('name = "h"\nduration_s = 1.0\nestimator = "ukf_heading"\nheading_sensor = true\n'
            '[[sensor_dropout]]\nt_start_s = 0.1\nt_end_s = 0.2\nsensor = "heading"\n')
    sc = parse_scenario(tomllib.loads(text)).scenario
    assert sc.estimator == "ukf_heading" and sc.heading_sensor is True
    assert sc.sensor_dropouts == ((0.1, 0.2, "heading"),)
    assert Scenario.from_dict(sc.to_dict()) == sc


@pytest.mark.parametrize("estimator", ["ukf", "ekf"])
def test_ukf_and_ekf_periods_do_not_read_the_heading_sensor(estimator):
    """Switching the heading sensor on changes nothing for the shipped estimators: their
    period (sensors, embedded software, plant) does not depend on the heading sensor's
    noise or availability (structurally), so every shipped result is bit-identical."""
    blocks, est = software_blocks("flc", estimator)
    assert est.heading is None
    step = make_estimating_step(blocks.balance, blocks.velocity, make_ode(), make_wheel_speeds(),
                                est, embedded=embedded_software("flc", estimator))
    for name, layout in (("noise", NOISE), ("valid", VALID)):
        # per input entry: does any output depend on it (the period is smooth in noise)
        dep = step.which_depends(name, list(step.name_out()), 1, False)
        k = layout.index("heading") if layout is VALID else layout.offset("heading")
        assert not dep[k], name
        if name == "noise":
            assert all(dep[:k])  # every other sensor's noise does reach the outputs


def test_embedded_step_sizes_and_power_on_bias_zero():
    f = embedded_software("flc", "ukf_heading")
    assert f.size1_in(f.index_in("meas")) == MEAS_HEADING.size
    assert f.size1_in(f.index_in("Qa")) == 49 and f.size1_in(f.index_in("Ra")) == 49
    L = controller_layout("ukf_heading", 0 + 8)
    assert L.part("xa") is HEADING_FILTER_STATE
    sc = _standing(duration=1.0, estimator="ukf_heading")
    e0 = power_on_inputs("ukf_heading", sc.inputs())["estimation"]["e0"]
    assert e0[HEADING_FILTER_STATE.offset("b_z")] == 0.0


# ------------------------------------------------------------------ the closed loop
def test_heading_sensor_bounds_the_heading_error_and_finds_the_gyro_bias(sim):
    """60 s of the complete system with a 0.11 deg/s z gyro bias: with the heading sensor
    at 10 Hz the heading error stays within 0.5 deg and the bias state finds the bias;
    the thesis's QUKF (no heading sensor) drifts at the bias's rate.  The velocity profile
    turns the robot by about 70 deg, so a reading of the wrong sign fails this test."""
    aided = run_scenario(_standing(duration=60.0, estimator="ukf_heading", heading_sensor=True),
                         sim, log_every=20)
    t, h = _heading_error_deg(aided)
    assert np.abs(h[t >= 10.0]).max() <= 0.5  # measured 0.27 deg
    L = controller_layout("ukf_heading", 8, 7)
    b_hat = aided["c_final"][L["xa"]][HEADING_FILTER_STATE["b_z"]][0]
    assert b_hat == pytest.approx(BIAS_Z, abs=0.1 * BIAS_Z)
    # the same robot with the thesis's QUKF: the heading integrates the biased gyroscope
    blind = run_scenario(_standing(duration=60.0, estimator="ukf"), sim, log_every=20)
    tb, hb = _heading_error_deg(blind)
    assert abs(hb[-1]) >= 0.5 * np.degrees(BIAS_Z) * tb[-1]  # measured 6.0 deg of 6.9


def test_sixty_seconds_without_the_sensor_drift_at_the_gyro_rate_and_recover(sim):
    loss = (60.0, 120.0)
    sc = _standing(duration=150.0, estimator="ukf_heading", heading_sensor=True,
                   sensor_dropouts=[(*loss, "heading")])
    log = run_scenario(sc, sim)
    first = run_scenario(sc.replace(duration=loss[0], sensor_dropouts=[]), sim, log_every=100)
    L = controller_layout("ukf_heading", 8, 7)
    b_hat = first["c_final"][L["xa"]][HEADING_FILTER_STATE["b_z"]][0]
    t, h = _heading_error_deg(log)
    s = load_sensor_params()
    # the true z bias from the logged random-walk noise (thesis (3.9))
    steps = np.sqrt(TS_CONTROL) * s.gyro_bias_rw[2] * log["noise"][:, NOISE.offset("gyro_rw") + 2]
    bias = BIAS_Z + np.concatenate([[0.0], np.cumsum(steps)])[:len(t)]
    i0, i1 = np.searchsorted(t, loss)
    drift = np.degrees(np.sum(bias[i0:i1] - b_hat) * TS_CONTROL)
    arw = np.degrees(np.sqrt(s.gyro_noise_var[2] * TS_CONTROL * 60.0))
    grown = h[i1 - 1] - h[i0]
    assert abs(grown - drift) <= 4 * arw + 0.05
    back = t >= loss[1] + 10.0
    assert np.abs(h[back]).max() <= 0.5


def test_predecessor_ekf_with_heading_in_the_loop_finds_the_gyro_bias(sim):
    """``ekf_heading`` (the predecessor's QEKF with heading correction and gyro biases +
    VEKF): the heading stays bounded and its z bias state moves towards the bias.  Its heading is
    noisier than the heading-aided QUKF's (about the sensor's 0.2 deg RMS standing; the
    lateral ramps' acceleration leaks into it through the additive chart)."""
    log = run_scenario(_standing(duration=60.0, estimator="ekf_heading", heading_sensor=True),
                       sim, log_every=20)
    t, h = _heading_error_deg(log)
    assert np.abs(h[t >= 10.0]).max() <= 1.5  # measured 0.83 deg
    assert log["meas"].shape[1] == MEAS_HEADING.size
    L = controller_layout("ekf_heading", 8, 7)
    b = log["c_final"][L["xa"]][L.part("xa")["b"]]
    # with the thesis's tight initial bias variance ((0.1 deg/s)^2) the QEKF leaves most of
    # the offset in its rate state's random walk for a minute: the bias state moves towards
    # it with the right sign only (measured 0.00029 of 0.002 rad/s after 60 s; the
    # heading-aided QUKF's finds it within 10 %, test above)
    assert 0.05 * BIAS_Z < b[2] < BIAS_Z


@pytest.mark.slow
def test_one_hour_of_the_complete_system_with_the_heading_sensor(sim):
    """Issue 22 acceptance in the embedded step: the complete system (velocity profile, then
    standing) for an hour with the heading sensor at 10 Hz and a 0.11 deg/s z gyro bias:
    heading error <= 0.5 deg after the first 10 s (decimated log)."""
    sc = _standing(duration=3600.0, estimator="ukf_heading", heading_sensor=True, seed=3)
    log = run_scenario(sc, sim, log_every=200)
    t, h = _heading_error_deg(log)
    assert t[-1] >= 3599.0
    assert np.abs(h[t >= 10.0]).max() <= 0.5
    assert np.sqrt(np.mean(h[t >= 10.0] ** 2)) <= 0.2

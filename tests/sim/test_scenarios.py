"""Scenario validation, serialisation and the acceptance scenario definitions."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from ballbot_casadi.studies.registry import STUDY_NAMES, study_scenarios

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.params import load_params
from ballbot_casadi.errors import ScenarioError, StateError
from ballbot_casadi.sim import references as R
from ballbot_casadi.sim.scenario import Scenario, apply_changes, initial_state


def test_unknown_controller_rejected_with_allowed_names():
    with pytest.raises(ScenarioError, match=r"unknown controller 'pid'.*allowed: flc, smc"):
        Scenario("s", "pid")


def test_non_unit_initial_quaternion_rejected():
    x0 = list(initial_state(3, 0, 0))
    x0[2] *= 1.01
    with pytest.raises(StateError, match="norm"):
        Scenario("s", x0=tuple(x0))


def test_non_finite_reference_rejected():
    with pytest.raises(ScenarioError, match="finite"):
        Scenario("s", attitude={"roll": {"type": "sine", "amplitude_deg": math.nan, "frequency_hz": 1}})
    with pytest.raises(ScenarioError, match="finite"):
        Scenario("s", attitude={"pitch": {"type": "const", "value_deg": math.inf}})
    with pytest.raises(ScenarioError, match="NaN or Inf"):
        Scenario("s", cascade=True, velocity_keyframes=((1.0, math.nan, 0.0, 0.0),))


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"attitude": {"heave": {"type": "const"}}}, "axes"),
        ({"attitude": {"roll": {"type": "square"}}}, "type"),
        ({"duration": 0.0}, "duration"),
        ({"Ts": -1.0}, "Ts"),
        ({"n_sub": 0}, "n_sub"),
        ({"pushes": ((9.0, 4.0, 0.0, 0.0),)}, "push"),
        ({"plant_changes": {"mass": ["scale", 1.1]}}, "unknown parameter 'mass'"),
        ({"plant_changes": {"Mb": ["times", 1.1]}}, "op in"),
        ({"ctrl_changes": {"Mb": ["set", -1.0]}}, "Mb"),
        ({"velocity_keyframes": ((1.0, 0.9, 0.0, 0.0),)}, "exceeds"),
        ({"k_bal": (1.0, 2.0)}, "flc gains need 6"),
        ({"k_bal": (36.0, 36.0, 16.0, 12.0, 12.0, -8.0)}, "Kd3"),
        ({"k_vel": (1.0, 2.0)}, "k_vel needs"),
    ],
)
def test_invalid_fields_rejected(kwargs, match):
    with pytest.raises(ValueError, match=match):
        Scenario("s", **{"duration": 5.0, **kwargs})


def test_apply_changes_ops():
    base = load_params()
    p = apply_changes(base, {"Mb": ["scale", 1.1], "l": ["add", 0.03], "com_x": ["set", -0.02]}, "t")
    assert p.Mb == pytest.approx(base.Mb * 1.1, rel=1e-15)
    assert p.l == pytest.approx(base.l + 0.03, rel=1e-15)
    assert p.com_x == -0.02


def test_dict_round_trip_and_json():
    sc = study_scenarios("velocity", "smc")[-1]
    d = sc.to_dict()
    assert json.loads(json.dumps(d)) == d
    assert Scenario.from_dict(d) == sc
    with pytest.raises(ScenarioError, match="unknown scenario field"):
        Scenario.from_dict({**d, "colour": "red"})
    assert sc.replace(duration=1.0).n_periods == 200


def test_study_scenarios_definitions():
    assert STUDY_NAMES == ("zero", "sine", "sine_asym", "robustness", "com", "lag", "push", "path",
                           "mpc_models", "velocity", "chirp", "estimators", "predecessor", "full", "full_cascade",
                           "thesis_tuning", "yaw_seeds")
    with pytest.raises(ScenarioError, match="allowed: zero"):
        study_scenarios("nosuchstudy")
    with pytest.raises(ScenarioError, match="allowed"):
        study_scenarios("zero", "pid")
    nominal = load_params()
    (zero,) = study_scenarios("zero")
    np.testing.assert_allclose(Q.to_rpy(np.array(zero.x0[2:6])), np.radians([5, 5, 0]), atol=1e-15)
    nominal_run, rob = study_scenarios("robustness")
    assert nominal_run.plant_params() == nominal
    pp, pc = rob.plant_params(), rob.controller_params()
    assert pp.Mb == pytest.approx(1.1 * nominal.Mb, rel=1e-15)
    for j in ("Jbx", "Jby", "Jbz"):
        assert getattr(pp, j) == pytest.approx(3.2 * getattr(nominal, j), rel=1e-15)
    assert pc == nominal
    bal, cas, *with_observer = study_scenarios("com")
    assert not bal.cascade and cas.cascade
    assert bal.plant_changes == cas.plant_changes
    assert not cas.com_observer and with_observer[-1].com_observer  # the main run: with the observer
    p = cas.plant_params()
    assert (p.com_x, p.com_y) == (-0.02, -0.03) and p.l == pytest.approx(nominal.l + 0.03, abs=1e-15)
    _, vel = study_scenarios("velocity")
    assert vel.cascade and vel.velocity_keyframes == R.FIG93_KEYFRAMES


def test_sine_inputs_match_reference_generator():
    (sc,) = study_scenarios("sine")
    inp = sc.inputs()
    t = np.arange(sc.n_periods) * sc.Ts
    q, dq, ddq = R.rpy_reference(R.sine(t, math.radians(3), 0.5), 0.0, 0.0)
    np.testing.assert_array_equal(inp["q_ref"], q)
    np.testing.assert_array_equal(inp["dq_ref"], dq)
    np.testing.assert_array_equal(inp["ddq_ref"], ddq)
    # the plant starts on the reference
    np.testing.assert_allclose(inp["x0"][2:6], q[0], atol=1e-15)
    np.testing.assert_allclose(inp["x0"][8:12], dq[0], atol=1e-15)
    assert inp["k_bal"].size > 0 and inp["k_vel"].size > 0 and not inp["cascade"]


def test_push_disturbance_sequence():
    (sc,) = study_scenarios("push")
    w = sc.disturbance()
    k = int(round(1.0 / sc.Ts))
    assert np.count_nonzero(np.any(w != 0, axis=1)) == 1
    np.testing.assert_allclose(w[k], [math.radians(4), 0, 0, 0, 0, 0], rtol=0, atol=1e-15)


def test_velocity_reference_sequence():
    sc = study_scenarios("velocity")[-1]  # the shipped profile (the first run is at 1 m/s²)
    v = sc.velocity_reference()
    assert v.shape == (sc.n_periods, 3)
    np.testing.assert_allclose(v, R.velocity_profile(sc.time(), R.FIG93_KEYFRAMES).value, atol=0)

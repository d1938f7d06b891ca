"""Parameter changes (sim.scenario.changes.ParamChanges) against hand values: ``set``,
``scale`` and ``add`` on the model and sensor parameters, the file forms, the key every
refusal names, and a rebase onto another robot applying a change on top of the NEW
robot's value (issue 23: an op applied as another, a scale on the wrong base or an error
keyed to the wrong name must show)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.core.params import load_params
from ballbot_casadi.core.sensor_params import load_sensor_params
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.sim.scenario.changes import CHANGE_OPS, ParamChanges, apply_changes

PLANT = ParamChanges("plant")
SENS = ParamChanges("sensors", sensors=True)


def _key(call) -> tuple[str | None, str]:
    with pytest.raises(ScenarioError) as info:
        call()
    return info.value.key, str(info.value)


def test_set_scale_add_on_model_parameters():
    base = load_params()
    d = base.as_dict()
    new = PLANT.apply(base, {"Mb": ["set", 12.5], "l": ["scale", 1.5], "Jbx": ["add", 0.25],
                             "com_x": ["add", -0.01]})
    got = new.as_dict()
    assert got["Mb"] == 12.5
    assert got["l"] == pytest.approx(d["l"] * 1.5, rel=1e-15)
    assert got["Jbx"] == pytest.approx(d["Jbx"] + 0.25, rel=1e-15)
    assert got["com_x"] == pytest.approx(d["com_x"] - 0.01, rel=1e-15)
    assert got["Jby"] == d["Jby"] and got["Mk"] == d["Mk"]  # untouched
    assert PLANT.apply(base, {}) is base
    assert apply_changes(base, {"Mk": ["scale", 2.0]}, "plant").as_dict()["Mk"] == 2.0 * d["Mk"]
    assert CHANGE_OPS == ("set", "scale", "add")


def test_sensor_changes_broadcast_and_take_lists():
    base = load_sensor_params()
    d = base.as_dict()
    new = SENS.apply(base, {"acc_bias": ["set", [0.1, -0.2, 0.3]], "gyro_noise_var": ["scale", 2.0],
                            "gyro_bias0": ["add", [0.0, 0.01, 0.0]], "heading_rate": ["set", 5.0]})
    got = new.as_dict()
    assert tuple(got["acc_bias"]) == (0.1, -0.2, 0.3)
    np.testing.assert_allclose(got["gyro_noise_var"], 2.0 * np.array(d["gyro_noise_var"]), rtol=1e-15)
    np.testing.assert_allclose(got["gyro_bias0"], [0.0, 0.01, 0.0], rtol=0, atol=1e-15)
    assert tuple(got["heading_rate"]) == (5.0,)
    assert got["acc_scale"] == d["acc_scale"]


def test_parse_forms_and_their_ops():
    assert PLANT.parse({"Mb": 10, "l": {"scale": 1.1}, "Jk": {"add": -0.001}}) == {
        "Mb": ["set", 10.0], "l": ["scale", 1.1], "Jk": ["add", -0.001]}
    assert SENS.parse({"acc_bias": [0.1, 0.2, 0.3], "gyro_scale": {"scale": [1.0, 1.01, 0.99]},
                       "heading_bias": 0.02}) == {
        "acc_bias": ["set", [0.1, 0.2, 0.3]], "gyro_scale": ["scale", [1.0, 1.01, 0.99]],
        "heading_bias": ["set", 0.02]}


def test_every_refusal_is_keyed_section_dot_name():
    assert _key(lambda: PLANT.parse({"mass": 1.0}))[0] == "plant.mass"
    assert _key(lambda: PLANT.parse({"Mb": True}))[0] == "plant.Mb"
    assert _key(lambda: PLANT.parse({"Mb": [1.0]}))[0] == "plant.Mb"  # lists only for sensors
    assert _key(lambda: PLANT.parse({"Mb": {"times": 2.0}}))[0] == "plant.Mb"
    assert _key(lambda: PLANT.parse({"Mb": {"scale": 2.0, "add": 1.0}}))[0] == "plant.Mb"
    assert _key(lambda: PLANT.parse({"Mb": {"scale": math.nan}}))[0] == "plant.Mb.scale"
    assert _key(lambda: PLANT.parse({"Mb": {"add": "1"}}))[0] == "plant.Mb.add"
    assert _key(lambda: PLANT.parse([1]))[0] == "plant"
    assert _key(lambda: SENS.parse({"acc_bias": [0.1, 0.2]}))[0] == "sensors.acc_bias.set"
    assert _key(lambda: SENS.parse({"acc_bias": [0.1, True, 0.3]}))[0] == "sensors.acc_bias.set"
    assert _key(lambda: SENS.parse({"acc_bias": [0.1, math.inf, 0.3]}))[0] == "sensors.acc_bias.set"
    key, text = _key(lambda: PLANT.apply(load_params(), {"Mb": ["times", 2.0]}))
    assert key == "plant.Mb" and "set" in text
    assert _key(lambda: PLANT.apply(load_params(), {"Mb": ["set", math.inf]}))[0] == "plant.Mb"
    assert _key(lambda: PLANT.apply(load_params(), {"Mb": ["set"]}))[0] == "plant.Mb"


def test_an_invalid_result_names_the_change_that_is_invalid_alone():
    key, text = _key(lambda: PLANT.check({"l": ["scale", 1.0], "Mb": ["set", -1.0]}))
    assert key == "plant.Mb" and text.startswith("plant: ")
    assert _key(lambda: ParamChanges("controller_model").check({"Mk": ["add", -100.0]}))[0] == \
        "controller_model.Mk"
    PLANT.check({"Mb": ["set", 1.0]})  # a valid change passes


def test_rebase_applies_changes_on_the_new_robots_values():
    nominal = {"Mb": 10.0, "l": 0.4, "Jk": 0.02}
    new = {"Mb": 20.0, "l": 0.4, "Jk": 0.03}
    out = PLANT.rebased({"Mb": ["scale", 1.5], "l": ["add", 0.1]}, new, nominal)
    assert out == {"Mb": ["set", 30.0], "l": ["set", pytest.approx(0.5, rel=1e-15)], "Jk": ["set", 0.03]}
    assert PLANT.rebased({}, nominal, nominal) == {}

"""The controller FMU's specification, value by value (no FMU is built: the spec only).

The model identifiers and titles of every estimator, the C defines, the description,
the start values and ranges of the inputs and parameters, and the path-following
variant's fixed parameters (exactly the MPC's declared dependencies, nothing else), its
outputs and its ``path_s0`` start: each is written out here from the rules in
:mod:`ballbot_casadi.fmi.controller.controller` and the scenario, so a wrong default, a
flipped comparison or a swapped name changes a checked value.
"""

from __future__ import annotations

import pytest

from ballbot_casadi.core.params import PARAM_NAMES
from ballbot_casadi.errors import BuildError, ScenarioError
from ballbot_casadi.fmi.controller.controller import (
    REJECTION_NAMES,
    V_REF_USED_NAMES,
    X0_NAMES,
    controller_spec,
    controller_values,
    controller_variables,
    embedded_function,
    filters_title,
    model_identifier,
    path_embedded_function,
    reading_names,
)
from ballbot_casadi.fmi.controller.path import path_law
from ballbot_casadi.fmi.plant.plant import HEADING_OUTPUT_NAME, SENSOR_OUTPUT_NAMES
from ballbot_casadi.fmi.spec import INT32_MAX, value_range
from ballbot_casadi.sim.embedded import DEFAULT_ESTIMATOR, ESTIMATOR_FILTERS
from ballbot_casadi.sim.path_following import velocity_loop_dependencies
from ballbot_casadi.sim.scenario.file import parse_scenario

PATH = {"name": "pline", "duration_s": 2.0, "cascade": True, "estimator": "ukf",
        "path": {"type": "line", "start": [0.0, 0.0], "end": [2.0, 0.0], "speed": 0.4},
        "initial": {"x_m": 0.5, "y_m": 0.2}}


@pytest.fixture(scope="module")
def spec():
    return controller_spec()


@pytest.fixture(scope="module")
def path_spec():
    return controller_spec(path=parse_scenario(PATH).scenario)


def test_titles_and_identifiers_of_every_estimator():
    assert DEFAULT_ESTIMATOR == "ukf_adaptive"
    assert {e: filters_title(e) for e in ESTIMATOR_FILTERS} == {
        "ukf": "QUKF + VUKF", "ekf": "QEKF + VEKF", "ukf_heading": "QUKF_HEADING + VUKF",
        "ekf_heading": "QEKF_HEADING + VEKF", "ukf_consistent": "QUKF + VUKF (matched)",
        "ukf_adaptive": "QUKF + VUKF (matched, adaptive walk)"}
    assert model_identifier("flc", "ukf_adaptive") == "BallbotController"
    assert model_identifier("flc", "ukf") == "BallbotController_flc_ukf"
    assert model_identifier("smc", "ukf_adaptive") == "BallbotController_smc_ukf_adaptive"
    for e in ESTIMATOR_FILTERS:
        heading = e.endswith("_heading")
        assert reading_names(e) == (*SENSOR_OUTPUT_NAMES, *((HEADING_OUTPUT_NAME,) if heading
                                                           else ())), e


def test_no_estimator_is_refused_in_one_line():
    with pytest.raises(ScenarioError) as e:
        embedded_function("flc", "true")
    assert str(e.value) == (f"the controller FMU needs an estimator (one of {', '.join(ESTIMATOR_FILTERS)}); "
                            "the true state is not available to the embedded software")
    sc = parse_scenario({"name": "t", "duration_s": 1.0, "estimator": "true"}).scenario
    with pytest.raises(ScenarioError, match="'t': the controller FMU needs an estimator"):
        controller_values(sc)


def test_the_per_wheel_limit_is_refused_for_the_balance_fmu_too():
    sc = parse_scenario({"name": "pw", "duration_s": 1.0, "estimator": "ukf",
                         "torque_limit": "per-wheel"}).scenario
    with pytest.raises(ScenarioError) as exc:
        controller_values(sc)
    assert exc.value.key == "torque_limit"


def test_default_spec_defines_description_and_experiment(spec):
    assert spec.model_identifier == "BallbotController" and spec.prefix == "ctrl"
    assert dict(spec.defines) == {
        "NQV": "7", "NQA": "6", "NRA": "6", "HAS_OBSERVER": "1", "STEP_TOL": "1e-06",
        "MAX_PERIODS": "1000000.0", "PERIOD_MAX": "2147483647.0", "QUAT_TOL": "1e-06",
        "QUAT_TOL_RESTORED": "0.001", "HAS_GUIDANCE": "0"}
    assert "(FLC with the QUKF + VUKF (matched, adaptive walk), velocity LQR cascade, " \
        in spec.description
    assert spec.interfaces == ("cs",) and spec.default_experiment == (0.0, 5.0, 0.005)
    assert spec.extra_sources == ()
    assert [c for _, c in spec.function_aliases] == ["EMBEDDED", "INITIAL"]
    assert "v_ref_used" not in {b.name for b in spec.blocks}


def test_default_spec_inputs_and_parameters_start_where_the_robot_rests(spec):
    by = {v.name: v for v in spec.variables}
    assert [by[f"q_ref{i}"].start for i in range(4)] == [1.0, 0.0, 0.0, 0.0]
    assert all(by[f"{w}_ref{i}"].start == 0.0 for w in ("dq", "ddq") for i in range(4))
    assert [by[n].start for n in ("v_ref_x", "v_ref_y", "yaw_rate_ref")] == [0.0, 0.0, 0.0]
    assert [by[n].unit for n in ("v_ref_x", "v_ref_y", "yaw_rate_ref")] == \
        ["m/s", "m/s", "rad/s"]
    assert by["balance_only"].type == "Boolean" and by["balance_only"].start is False
    assert by["feedforward"].start is True  # the package's default (the thesis's: False)
    assert by["period"].type == "Integer" and by["period"].bounds == (0, INT32_MAX)
    assert by["period"].kind == "local"
    x0 = {n: by[n].start for n in X0_NAMES}
    assert x0["x0_q0"] == 1.0 and all(v == 0.0 for n, v in x0.items() if n != "x0_q0")
    assert by["Ts"].start == 0.005 and by["Ts"].rule == "pos" and by["Ts"].fixed is None
    for name in REJECTION_NAMES:
        assert by[name].description.endswith("(chi-square test), else 0")
        assert by[name].kind == "discrete_output"
    assert [by[f"tau{i}"].unit for i in range(3)] == ["N.m"] * 3
    assert [by[n].unit for n in ("roll_hat", "omega_hat_z", "pos_hat_y", "q_hat0")] == \
        ["rad", "rad/s", "m", "1"]
    assert not any(v.fixed for v in spec.variables)
    assert not any(n in by for n in V_REF_USED_NAMES)
    # each internal model's parameters: described by owner, with load_params' unit and rule
    for owner, who in (("ctrl", "controllers'"), ("est", "filters'")):
        assert by[f"{owner}_Mb"].description == ("body mass including wheels and motors "
                                                 f"(the {who} internal model, load_params name Mb)")
        assert (by[f"{owner}_Mb"].unit, by[f"{owner}_Mb"].rule) == ("kg", "mass")
        assert (by[f"{owner}_tau_max"].unit, by[f"{owner}_tau_max"].rule) == ("N.m", "torque")


def test_readings_are_inputs_named_and_united_as_the_plants_outputs(spec):
    """One input per reading of the default filters, named as the plant FMU's output it is
    connected to, in its unit, NaN accepted (missing) and starting at 0."""
    by = {v.name: v for v in spec.variables}
    names = list(reading_names(DEFAULT_ESTIMATOR))
    assert names == [n for n in SENSOR_OUTPUT_NAMES if n in names] and len(names) == 9
    units = {"acc": "m/s2", "gyro": "rad/s", "enc": "1/s"}
    for n in names:
        v = by[n]
        assert (v.kind, v.start, v.missing) == ("discrete_input", 0.0, True), n
        assert v.unit == units[n.removeprefix("sensor_").rstrip("xyz012_")], n
        assert "(the plant FMU's output of that name); NaN = missing" in v.description, n
    assert by["sensor_acc_y"].description.startswith("accelerometer reading along IMU axis y ")
    assert by["sensor_gyro_z"].description.startswith("gyroscope reading about IMU axis z ")
    assert by["sensor_enc1"].description.startswith("wheel 1 encoder reading in ticks per second ")


def test_controller_values_follow_the_scenario():
    sc = parse_scenario({"name": "v", "duration_s": 1.0, "estimator": "ukf", "cascade": True,
                         "controller_model": {"tau_max": 3.5, "Mb": 11.0},
                         "initial": {"x_m": 0.25, "y_m": -0.75, "vx_mps": 0.1,
                                     "vy_mps": -0.2}}).scenario
    v = controller_values(sc)
    assert v["ctrl_tau_max"] == 3.5 and v["ctrl_Mb"] == 11.0
    assert v["est_Mb"] != 11.0  # the filters' model stays nominal
    assert (v["x0_x"], v["x0_y"], v["x0_dx"], v["x0_dy"]) == (0.25, -0.75, 0.1, -0.2)
    assert v["x0_q0"] == 1.0 and v["Ts"] == 0.005
    assert v["feedforward"] is bool(sc.inputs()["feedforward"])
    assert v["com_observer"] is bool(sc.inputs()["com_observer"])
    sc_off = parse_scenario({"name": "v", "duration_s": 1.0, "estimator": "ukf",
                             "feedforward": "none"}).scenario
    assert controller_values(sc_off)["feedforward"] is False
    assert "path_s0" not in v


def test_the_path_variant_fixes_exactly_the_mpc_dependencies(path_spec):
    dep = velocity_loop_dependencies()
    by = {v.name: v for v in path_spec.variables}
    kvel = [n for n in by if n.startswith("k_vel_")]
    want = {"Ts", *(f"ctrl_{n}" for n in dep.params), *(kvel[i] for i in dep.gains)}
    assert {n for n, v in by.items() if v.fixed} == want
    assert "ctrl_tau_max" not in want and "est_Mb" not in want
    assert set(dep.params) < set(PARAM_NAMES) and "Ts" in by
    for n in want:
        lo, hi, _, _, text = value_range(by[n])
        assert lo == hi == by[n].start and "built" in text
    assert value_range(by["ctrl_tau_max"])[:2] != (by["ctrl_tau_max"].start,) * 2


def test_the_path_variant_identifier_outputs_and_start(path_spec):
    assert path_spec.model_identifier == "BallbotControllerPath_ukf"
    d = dict(path_spec.defines)
    assert d["HAS_GUIDANCE"] == "1" and d["S0_TOL"] == "0.01" and d["V_MAX"] == "0.5"
    assert "path-following MPC guidance at 10 Hz above the velocity LQR cascade" in \
        path_spec.description and "(FLC with the QUKF + VUKF, " in path_spec.description
    assert [p.name for p in path_spec.extra_sources] == ["controller_path.c", "controller_path.h"]
    assert [c for _, c in path_spec.function_aliases] == ["EMBEDDED", "INITIAL", "GUIDE_INITIAL"]
    by = {v.name: v for v in path_spec.variables}
    assert [(by[n].unit, by[n].kind) for n in V_REF_USED_NAMES] == \
        [("m/s", "discrete_output"), ("m/s", "discrete_output"), ("rad/s", "discrete_output")]
    assert "along x" in by["v_ref_used_x"].description
    assert "along y" in by["v_ref_used_y"].description
    assert by["path_s0"].start == pytest.approx(0.5, abs=1e-6) and by["path_s0"].unit == "m"
    assert by["x0_x"].start == 0.5 and by["x0_y"].start == 0.2
    assert by["path_speed"].start == 0.4 and by["path_p1_x"].unit == "m"
    blocks = {b.name: b for b in path_spec.blocks}
    assert blocks["v_ref_used"].variables == V_REF_USED_NAMES
    assert blocks["k_guid"].variables[:3] == ("path_length", "path_closed", "path_speed")


def test_the_path_variant_needs_its_start_values():
    sc = parse_scenario(PATH).scenario
    law = path_law(sc)
    emb = path_embedded_function(law, "ukf")
    with pytest.raises(BuildError, match="give start"):
        controller_variables(emb, "flc", "ukf", None, law)

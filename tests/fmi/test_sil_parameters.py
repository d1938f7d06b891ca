"""The SIL system's plant parameter set, connections and refusals, value by value (no FMU
is built: the refusals come before any build).

The scenario changes one plant parameter, the sensors, the substeps, the noise and
heading switches, the seed and the start so that each entry of the parameter set is
known by hand; the seed's 32-bit bounds are checked at and just past each end.
"""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.core.layout import STATE
from ballbot_casadi.core.params import PARAM_NAMES
from ballbot_casadi.core.sensor_params import SENSOR_VECTOR_NAMES
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.fmi.controller.controller import REFERENCE_NAMES
from ballbot_casadi.fmi.plant.plant import HEADING_OUTPUT_NAME, SENSOR_OUTPUT_NAMES
from ballbot_casadi.fmi.reference_player.player import DISTURBANCE_NAMES
from ballbot_casadi.fmi.spec import INT32_MAX
from ballbot_casadi.fmi.system.sil import (
    SilRun,
    plant_parameters,
    sil_connections,
    sil_system,
)
from ballbot_casadi.sim.scenario.file import parse_scenario

RAW = {"name": "sp", "duration_s": 1.0, "estimator": "ukf", "seed": 17, "noise": False,
       "heading_sensor": True, "rk4_substeps": 4, "plant": {"Mb": 13.5},
       "sensors": {"acc_bias": [0.05, -0.02, 0.01]},
       "initial": {"x_m": 0.3, "y_m": -0.4, "vx_mps": 0.05, "vy_mps": -0.07}}


def test_every_entry_of_the_plant_parameter_set():
    sc = parse_scenario(RAW).scenario
    v = plant_parameters(sc)
    assert v["Mb"] == 13.5
    p = sc.plant_params().to_vector()
    assert [v[n] for n in PARAM_NAMES] == [float(x) for x in p]
    assert v["h_internal"] == pytest.approx(0.005 / 4, rel=1e-15)
    assert v["Ts_sensor"] == 0.005
    s = dict(zip(SENSOR_VECTOR_NAMES, sc.sensor_params().to_vector()))
    assert {n: v[n] for n in SENSOR_VECTOR_NAMES} == {n: float(x) for n, x in s.items()}
    assert v["noise_on"] is False and v["heading_sensor"] is True
    assert v["seed"] == 17 and isinstance(v["seed"], int)
    x0 = {n: v[f"x0_{n}"] for n in STATE.names}
    assert (x0["x"], x0["y"], x0["dx"], x0["dy"], x0["q0"]) == (0.3, -0.4, 0.05, -0.07, 1.0)
    assert list(v)[:len(PARAM_NAMES)] == list(PARAM_NAMES)
    assert list(v)[-12:] == [f"x0_{n}" for n in STATE.names]


def test_switches_the_other_way_and_the_filter_by_variables():
    sc = parse_scenario({"name": "sp2", "duration_s": 1.0, "estimator": "ukf"}).scenario
    v = plant_parameters(sc)
    assert v["noise_on"] is True and v["heading_sensor"] is False and v["seed"] == 0
    assert v["h_internal"] == pytest.approx(0.005 / sc.n_sub, rel=1e-15)
    kept = plant_parameters(sc, ["Mb", "seed", "x0_q0", "nothing"])
    assert kept == {"Mb": v["Mb"], "seed": 0, "x0_q0": 1.0}


@pytest.mark.parametrize("seed, ok", [(0, True), (INT32_MAX, True), (INT32_MAX + 1, False)])
def test_the_seed_fits_a_32_bit_signed_integer(seed, ok):
    sc = parse_scenario({"name": "sd", "duration_s": 1.0, "estimator": "ukf",
                         "seed": seed}).scenario
    if ok:
        assert plant_parameters(sc)["seed"] == seed
    else:
        with pytest.raises(ScenarioError, match=f"seed {seed} does not fit .*0 .. {INT32_MAX}"):
            plant_parameters(sc)


def test_connections_of_each_estimator_with_and_without_the_disturbance():
    plant = ["tau0", "tau1", "tau2", *DISTURBANCE_NAMES]
    cons = [(c.start_element, c.start_connector, c.end_element, c.end_connector)
            for c in sil_connections(plant, "ukf")]
    want = [("plant", n, "controller", n) for n in SENSOR_OUTPUT_NAMES]
    want += [("controller", f"tau{i}", "plant", f"tau{i}") for i in range(3)]
    want += [("reference", n, "controller", n) for n in (*REFERENCE_NAMES, "balance_only")]
    want += [("reference", n, "plant", n) for n in DISTURBANCE_NAMES]
    assert cons == want
    cons = [(c.start_element, c.start_connector, c.end_element, c.end_connector)
            for c in sil_connections(plant[:5], "ukf_heading")]
    assert cons[len(SENSOR_OUTPUT_NAMES)] == ("plant", HEADING_OUTPUT_NAME, "controller",
                                              HEADING_OUTPUT_NAME)
    assert not any(c[1] in DISTURBANCE_NAMES for c in cons)
    assert len(cons) == len(SENSOR_OUTPUT_NAMES) + 1 + 3 + len(REFERENCE_NAMES) + 1


@pytest.mark.parametrize("extra, text", [
    ({"estimator": "true"}, "set estimator = one of ukf, ekf"),
    ({"sensor_dropout": [{"t_start_s": 0.2, "t_end_s": 0.3, "sensor": "enc"}]},
     "[[sensor_dropout]] rows, which the SSP cannot express"),
    ({"sensor_glitch": [{"t_s": 0.2, "sensor": "gyro", "value": 10.0}]},
     "[[sensor_glitch]] rows, which the SSP cannot express"),
])
def test_what_the_ssp_cannot_express_is_refused_before_any_build(extra, text, tmp_path):
    sc = parse_scenario({"name": "rf", "duration_s": 1.0, "estimator": "ukf", **extra}).scenario
    with pytest.raises(ScenarioError) as exc:
        sil_system(sc, out=tmp_path)
    assert text in str(exc.value) and "'rf'" in str(exc.value)
    assert list(tmp_path.iterdir()) == []


def test_write_connections_round_trips_exact_doubles(tmp_path):
    t = np.array([0.0, 0.005, 0.01])
    sig = {"plant.x": np.array([0.1, 1.0 / 3.0, -2.5e-17]), "controller.tau0": np.array(
        [1e300, -0.0, 7.0])}
    run = SilRun(time=t, signals=sig, connections=(), master="gauss_seidel", scenario=None,
                 specs=(), wall_s=0.0)
    p = run.write_connections(tmp_path / "c.csv")
    lines = p.read_text().splitlines()
    assert lines[0] == "time,plant.x,controller.tau0"
    data = np.loadtxt(p, delimiter=",", skiprows=1)
    np.testing.assert_array_equal(data, np.column_stack([t, sig["plant.x"], sig["controller.tau0"]]))

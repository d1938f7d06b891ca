"""Scenario sections: each owns its file keys once, validates its fields, and round-trips.

The shipped scenario files are the references: written back by their sections and read
again, every file gives the same scenario, specs and dispersions, bit-identical inputs
of the closed loop, and the same table again (a fixed point).
"""

from __future__ import annotations

import copy
import pickle
import tomllib

import numpy as np
import pytest

from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.sim.scenario import Scenario, dump_toml, initial_state, load_scenario_file, parse_scenario
from ballbot_casadi.sim.scenario.file import _TOP
from ballbot_casadi.sim.scenario.scenario import SCENARIO_FIELDS
from ballbot_casadi.sim.scenario.sections import (
    SCENARIO_SECTIONS,
    DispersionsSection,
    InitialSection,
    RunSection,
    SpecsSection,
)
from ballbot_casadi.studies.registry import shipped_scenarios


def _arrays_equal(a: dict, b: dict) -> None:
    assert a.keys() == b.keys()
    for k in a:
        if isinstance(a[k], dict):
            _arrays_equal(a[k], b[k])
        else:
            x, y = np.asarray(a[k]), np.asarray(b[k])
            assert x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes(), k


def _reread(table: dict, name: str):
    return parse_scenario(tomllib.loads(dump_toml(table)), "again", name)


@pytest.mark.parametrize("name", sorted(shipped_scenarios()))
def test_shipped_files_round_trip_through_their_sections(name):
    sf = load_scenario_file(shipped_scenarios()[name])
    table = sf.to_file()
    again = _reread(table, name)
    assert again.scenario == sf.scenario
    assert again.scenario.to_dict() == sf.scenario.to_dict()
    assert again.specs == sf.specs and again.montecarlo == sf.montecarlo
    assert again.to_file() == table                      # a fixed point
    _arrays_equal(again.scenario.inputs(), sf.scenario.inputs())


def test_every_file_key_is_owned_by_exactly_one_section():
    owners = [k for _, cls in SCENARIO_SECTIONS for k in cls.TABLE_KEYS]
    owners += list(SpecsSection.TABLE_KEYS) + list(DispersionsSection.TABLE_KEYS)
    assert len(owners) == len(set(owners))
    assert set(owners) == set(_TOP)
    fields = [f for _, cls in SCENARIO_SECTIONS for f in cls.FIELDS]
    assert sorted(fields) == sorted(SCENARIO_FIELDS)


def test_attributes_read_through_the_sections_and_stay_immutable():
    sc = Scenario("s", controller="smc", duration=2.0, pushes=[[1.0, 4, 0, 0]], k_obs=[0.3, 2.0, 0.1, 0.1])
    assert sc.controller is sc.run.controller == "smc"
    assert sc.pushes == sc.disturbances.pushes == ((1.0, 4.0, 0.0, 0.0),)
    assert sc.k_obs == (0.3, 2.0, 0.1, 0.1) and sc.gains.k_obs == sc.k_obs
    assert sc.replace(seed=7).sensors.seed == 7 and sc.seed == 0
    with pytest.raises(AttributeError, match="immutable"):
        sc.seed = 3
    assert Scenario.from_dict(sc.to_dict()) == sc
    assert pickle.loads(pickle.dumps(sc)) == sc and copy.deepcopy(sc) == sc   # Dask, caches
    assert Scenario("s", "smc", 2.0) == Scenario("s", controller="smc", duration=2.0)
    with pytest.raises(TypeError, match="unknown"):
        Scenario("s", colour="red")


@pytest.mark.parametrize("fields,key", [
    ({"pushes": ((3.0, 1.0, 0.0, 0.0),), "duration": 2.0}, "push[0]"),
    ({"sensor_dropouts": ((1.0, 0.5, "enc"),)}, "sensor_dropout[0]"),
    ({"estimator_tuning": {"encoder_var": -1.0}}, "estimator_tuning.encoder_var"),
    ({"k_vel": (1.0, 2.0)}, "gains.k_vel"),
    ({"com_observer": 1}, "com_observer"),
    ({"n_sub": 0}, "rk4_substeps"),
    ({"plant_changes": {"Mb": ["scale", -1.0]}}, "plant.Mb"),
])
def test_a_section_error_carries_its_file_key(fields, key):
    with pytest.raises(ScenarioError) as exc:
        Scenario("bad", **fields)
    assert exc.value.key == key
    assert "scenario 'bad'" in str(exc.value)


def test_a_scenario_built_in_code_writes_a_file_that_reads_back_equal():
    sc = Scenario("coded", controller="smc", duration=3.0, x0=initial_state(2.0, -1.5, 30.0), cascade=False,
                  attitude={"roll": {"type": "step", "amplitude_deg": 2.0, "t_step": 0.5}},
                  velocity_keyframes=((0.5, 0.2, 0.0, 0.0, 0.5),), pushes=((1.0, 0.0, 3.0, 0.0),),
                  torque_disturbances=((1.0, 1.5, 0.1, 0.0, -0.1),), plant_changes={"Mb": ["scale", 1.1]},
                  ctrl_changes={"com_x": ["set", 0.01]}, estimator="ukf", seed=5, noise=False,
                  sensor_changes={"acc_bias": ["set", [0.05, 0.0, 0.0]]}, est_changes={"l": ["add", 0.01]},
                  estimator_tuning={"encoder_var": 0.2}, sensor_dropouts=((1.0, 2.0, "gyro"),),
                  com_observer=True, k_obs=(0.3, 2.0, 0.1, 0.1), study="x", description="y")
    table = sc.to_file()
    assert table["attitude"]["roll"] == {"type": "step", "amplitude_deg": 2.0, "t_step_s": 0.5}
    assert table["plant"] == {"Mb": {"scale": 1.1}} and table["controller_model"] == {"com_x": 0.01}
    again = _reread(table, "coded").scenario
    np.testing.assert_allclose(again.x0, sc.x0, rtol=0, atol=1e-15)   # angles in degrees and back
    assert again.replace(x0=sc.x0) == sc


def test_defaults_are_omitted_and_body_rates_cannot_be_written():
    assert Scenario("d").to_file() == {"name": "d", "duration_s": 5.0}
    assert RunSection().to_file()["name"] == "scenario"
    for i in range(8, 12):  # any of dq0..dq3 (dq0 too: a state built in code may have it)
        moving = np.array(initial_state())
        moving[i] = 0.1
        with pytest.raises(ScenarioError) as exc:
            Scenario("m", x0=tuple(moving)).to_file()
        assert exc.value.key == "initial"
    # a state read from a file is written back as read, on_reference included
    sf = load_scenario_file(shipped_scenarios()["sine"])
    assert sf.to_file()["initial"] == sf.table["initial"]
    assert isinstance(sf.scenario.initial, InitialSection) and sf.scenario.initial.written is not None


def test_acceleration_random_walk_per_axis_overrides_both_axes_in_any_order():
    """``acc_process_var_x``/``_y`` set one diagonal entry of the velocity filter's Q
    after ``acc_process_var`` (both axes), whatever the order of the keys."""
    sc = Scenario("t", estimator="ukf_consistent", noise=False, duration=0.1,
                  estimator_tuning={"acc_process_var_y": 3e-2, "acc_process_var": 1e-2,
                                    "acc_process_var_x": 2e-2})
    Qv = sc.estimation_inputs()["Qv"]
    np.testing.assert_array_equal(np.diag(Qv)[2:4], [2e-2, 3e-2])
    assert Qv[2, 3] == 0.0
    table = sc.to_file()
    assert _reread(table, "t").scenario == sc


def test_the_matched_filter_runs_its_calibrated_random_walk_unless_the_file_sets_one():
    """``ukf_consistent`` without ``acc_process_var``/``_x``/``_y`` gets the shipped pair
    :data:`MATCHED_ACC_PROCESS_VAR`; a key the file sets wins on its axes; ``ukf`` keeps
    the thesis tuning's value."""
    from ballbot_casadi.estimation import DEFAULT_TUNING
    from ballbot_casadi.estimation.velocity import MATCHED_ACC_PROCESS_VAR

    def acc(estimator, **tuning):
        sc = Scenario("t", estimator=estimator, noise=False, duration=0.1, estimator_tuning=tuning)
        return np.diag(sc.estimation_inputs()["Qv"])[2:4]

    thesis = np.diag(DEFAULT_TUNING["vukf"].Q)[2:4]
    assert not np.allclose(MATCHED_ACC_PROCESS_VAR, thesis)
    np.testing.assert_array_equal(acc("ukf_consistent"), MATCHED_ACC_PROCESS_VAR)
    np.testing.assert_array_equal(acc("ukf_consistent", acc_bias_process_var=2e-8), MATCHED_ACC_PROCESS_VAR)
    np.testing.assert_array_equal(acc("ukf"), thesis)
    np.testing.assert_array_equal(acc("ukf_consistent", acc_process_var=1e-2), [1e-2, 1e-2])
    np.testing.assert_array_equal(acc("ukf_consistent", acc_process_var_y=3e-2),
                                  [MATCHED_ACC_PROCESS_VAR[0], 3e-2])

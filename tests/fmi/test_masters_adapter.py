"""The masters' one fmpy adapter (fmi/masters/adapter.py): it drives the plant FMU and the
controller FMU by variable name, adds nothing to the values (a closed loop on the adapter
equals the same loop on raw fmpy calls bit for bit), converts each type, and names an
unknown variable."""

from __future__ import annotations

import numpy as np
import pytest
from _controller_support import controller_build
from _fmu_support import plant_build
from fmpy import read_model_description
from fmpy.fmi2 import FMU2Slave

from ballbot_casadi.core.layout import STATE
from ballbot_casadi.errors import CosimError
from ballbot_casadi.fmi.controller.controller import READING_NAMES, controller_values
from ballbot_casadi.fmi.masters.adapter import FmuSlave
from ballbot_casadi.fmi.system.sil import TORQUES, plant_parameters
from ballbot_casadi.sim.scenario import Scenario
from ballbot_casadi.sim.scenario.scenario import initial_state

pytestmark = pytest.mark.needs_cc

TS = 0.005
N = 300
#: A tilted start with noise, so the controller acts and every reading changes.
SCENARIO = Scenario(name="adapter", controller="flc", estimator="ukf", duration=N * TS,
                    x0=initial_state(4.0, -3.0, 0.0), seed=7)


def _controller_start() -> dict:
    """The scenario's controller values; the balance-only mode towards upright (q_ref's
    start value)."""
    return {**controller_values(SCENARIO), "balance_only": True}


def _adapter_loop() -> tuple[np.ndarray, np.ndarray]:
    """Controller first, then the plant on its torque, both on the adapter."""
    plant = FmuSlave(plant_build().unzipped, "plant")
    ctrl = FmuSlave(controller_build("flc", SCENARIO.estimator).unzipped, "controller")
    states, taus = np.zeros((N + 1, STATE.size)), np.zeros((N, 3))
    try:
        plant.setup(0.0, plant_parameters(SCENARIO, list(plant.variables)))
        ctrl.setup(0.0, _controller_start())
        plant.exit_initialization()
        ctrl.exit_initialization()
        for k in range(N):
            states[k] = plant.get_reals(STATE.names)
            ctrl.set_reals(READING_NAMES, plant.get_reals(READING_NAMES))
            ctrl.do_step(k * TS, TS)
            taus[k] = ctrl.get_reals(TORQUES)
            plant.set_reals(TORQUES, taus[k])
            plant.do_step(k * TS, TS)
        states[N] = plant.get_reals(STATE.names)
    finally:
        plant.free()
        ctrl.free()
    return states, taus


def _raw(unzipped, name: str) -> tuple[FMU2Slave, dict]:
    md = read_model_description(str(unzipped))
    s = FMU2Slave(guid=md.guid, unzipDirectory=str(unzipped),
                  modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
    s.instantiate()
    return s, {v.name: v for v in md.modelVariables}


def _raw_set(s: FMU2Slave, variables: dict, values: dict) -> None:
    for n, v in values.items():
        var = variables[n]
        if var.type == "Real":
            s.setReal([var.valueReference], [float(v)])
        elif var.type == "Integer":
            s.setInteger([var.valueReference], [int(v)])
        else:
            s.setBoolean([var.valueReference], [bool(v)])


def _raw_loop() -> tuple[np.ndarray, np.ndarray]:
    """The same loop on fmpy's FMU2Slave calls by value reference (the independent path)."""
    plant, pv = _raw(plant_build().unzipped, "plant")
    ctrl, cv = _raw(controller_build("flc", SCENARIO.estimator).unzipped, "controller")
    vr = lambda table, names: [table[n].valueReference for n in names]  # noqa: E731
    states, taus = np.zeros((N + 1, STATE.size)), np.zeros((N, 3))
    try:
        for s, table, values in ((plant, pv, plant_parameters(SCENARIO, list(pv))),
                                 (ctrl, cv, _controller_start())):
            s.setupExperiment(startTime=0.0)
            s.enterInitializationMode()
            _raw_set(s, table, values)
        plant.exitInitializationMode()
        ctrl.exitInitializationMode()
        for k in range(N):
            states[k] = plant.getReal(vr(pv, STATE.names))
            ctrl.setReal(vr(cv, READING_NAMES), plant.getReal(vr(pv, READING_NAMES)))
            ctrl.doStep(k * TS, TS)
            taus[k] = ctrl.getReal(vr(cv, TORQUES))
            plant.setReal(vr(pv, TORQUES), list(taus[k]))
            plant.doStep(k * TS, TS)
        states[N] = plant.getReal(vr(pv, STATE.names))
    finally:
        plant.freeInstance()
        ctrl.freeInstance()
    return states, taus


def test_one_adapter_drives_plant_and_controller_bit_for_bit_as_raw_fmpy():
    states, taus = _adapter_loop()
    raw_states, raw_taus = _raw_loop()
    np.testing.assert_array_equal(states, raw_states)
    np.testing.assert_array_equal(taus, raw_taus)
    # the loop is closed: the controller acts and the tilt of the start shrinks
    assert np.max(np.abs(taus)) > 1e-3
    tilt = 2 * np.arccos(np.clip(np.abs(states[:, STATE["q"]][:, 0]), 0.0, 1.0))  # yaw 0
    assert tilt[-1] < 0.5 * tilt[0], (tilt[0], tilt[-1])


def test_values_are_converted_by_type():
    with FmuSlave(plant_build().unzipped, "plant") as plant:
        plant.setup(0.0, {"seed": 12345, "noise_on": True, "h_internal": 1e-3})
        plant.exit_initialization()
        assert plant.get("seed") == 12345.0
        assert plant.get("noise_on") == 1.0
        assert plant.get("h_internal") == 1e-3
        assert plant.causality("tau0") == "input"
        plant.terminate()


def test_an_unknown_variable_is_named():
    with FmuSlave(controller_build("flc", SCENARIO.estimator).unzipped, "controller") as ctrl:
        with pytest.raises(CosimError, match="no variable 'tau9'"):
            ctrl.set("tau9", 1.0)
        with pytest.raises(CosimError, match="no variable 'nope'"):
            ctrl.get_reals(["tau0", "nope"])
        ctrl.free()  # a second free is harmless

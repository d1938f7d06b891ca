"""FMI 3.0 versions of the plant and controller FMUs: the same tables and per-model C
behind the FMI 3.0 entry points (fmu/layer/fmi3_functions.c).  Checks: fmpy validation,
the model descriptions against the FMI 2.0 ones, only fmi3* exported, the plant (ME and
CS) bit for bit equal to the FMI 2.0 plant, directional and adjoint derivatives, the
controller against the compiled embedded step, and the FMI 3.0 system against the
compiled mission with the Jacobi delay."""

from __future__ import annotations

import functools
import math
import subprocess
import time
from xml.etree import ElementTree

import numpy as np
import pytest
from _controller_support import controller_build
from _fmu_support import ALL_STATES, plant_build
from fmpy import read_model_description, simulate_fmu
from fmpy.fmi3 import FMU3Model, FMU3Slave
from fmpy.validation import validate_fmu
from test_controller_fmu import VREF, _readings, _Reference

from ballbot_casadi.bench.fmu3 import casadi_export_fmu
from ballbot_casadi.cli import main as cli_main
from ballbot_casadi.errors import BuildError
from ballbot_casadi.fmi.controller.controller import READING_NAMES, XHAT_NAMES, controller_spec
from ballbot_casadi.fmi.package import FmuBuild, build_fmu_from_spec, generated_files
from ballbot_casadi.fmi.plant.plant import plant_spec
from ballbot_casadi.fmi.system.sil_log import sil_log
from ballbot_casadi.fmi.masters.fmi3_jacobi import FMI3_MASTER, run_fmi3_jacobi
from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario
from ballbot_casadi.sim.embedded import DEFAULT_ESTIMATOR
from ballbot_casadi.sim.scenario import load_scenario_file
from ballbot_casadi.studies.registry import resolve_scenario

pytestmark = pytest.mark.needs_cc

ROLL = 0.05
START = {"x0_q0": math.cos(ROLL / 2), "x0_q1": math.sin(ROLL / 2), "x0_dq2": 0.01,
         "tau0": 0.1, "tau1": -0.05, "tau2": 0.02}


@functools.lru_cache(maxsize=None)
def plant3() -> FmuBuild:
    return build_fmu_from_spec(plant_spec(), fmi_version=3)


@functools.lru_cache(maxsize=None)
def controller3(controller: str = "flc", estimator: str = DEFAULT_ESTIMATOR) -> FmuBuild:
    return build_fmu_from_spec(controller_spec(controller, estimator), fmi_version=3)


def test_both_fmi3_fmus_validate_and_keep_the_fmi2_names_and_value_references():
    for b3, b2, interfaces in ((plant3(), plant_build(), ("me", "cs")),
                               (controller3(), controller_build(), ("cs",))):
        assert validate_fmu(str(b3.fmu)) == [], b3.model_identifier
        md3, md2 = read_model_description(str(b3.fmu)), read_model_description(str(b2.fmu))
        assert (md3.fmiVersion, md2.fmiVersion) == ("3.0", "2.0")
        assert (md3.modelExchange is not None) == ("me" in interfaces)
        assert md3.coSimulation is not None and md3.instantiationToken == b3.guid
        v3 = {v.name: v for v in md3.modelVariables}
        v2 = {v.name: v for v in md2.modelVariables}
        assert set(v3) == set(v2) | {"time"} and v3["time"].causality == "independent"
        types = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean"}
        for name, v in v2.items():
            w = v3[name]
            assert (w.valueReference, w.causality, w.variability, w.initial, types[v.type],
                    w.start) == (v.valueReference, v.causality, v.variability, v.initial,
                                 w.type, v.start), name
            assert not w.dimensions  # scalars (see fmi/model_description3.py)
        # the same dependencies (FMI 3.0 lists value references)
        deps2 = {u.variable.name: sorted(d.name for d in u.dependencies) for u in md2.outputs}
        deps3 = {u.variable.name: sorted(d.name for d in u.dependencies) for u in md3.outputs}
        assert deps3 == deps2
        # the plant's initial state: x0_* parameters, the states calculated
        if "me" in interfaces:
            assert {u.variable.name for u in md3.initialUnknowns} >= set(ALL_STATES)
            # (fmpy 0.3 reads FMI 3.0's plural attribute under its FMI 2.0 name: read the XML)
            me = ElementTree.parse(b3.unzipped / "modelDescription.xml").find("ModelExchange")
            assert me.get("providesDirectionalDerivatives") == "true"
            assert me.get("providesAdjointDerivatives") == "true"


def test_the_fmi3_binary_exports_only_fmi3_functions():
    for b in (plant3(), controller3()):
        out = subprocess.run(["nm", "-D", "--defined-only", str(b.binary)], capture_output=True,
                             text=True, check=True).stdout
        names = [line.split()[-1] for line in out.splitlines() if line.strip()]
        assert names and all(n.startswith("fmi3") for n in names), [
            n for n in names if not n.startswith("fmi3")][:5]
        assert "fmi3GetAdjointDerivative" in names and "fmi3DoStep" in names


def test_fmi_version_must_be_2_or_3():
    with pytest.raises(BuildError, match="allowed: 2, 3"):
        generated_files(plant_spec(), "{x}", ("", ""), fmi_version=4)


@pytest.mark.parametrize("fmi_type,solver", [("ModelExchange", "Euler"),
                                             ("ModelExchange", "CVode"),
                                             ("CoSimulation", None)])
def test_the_fmi3_plant_equals_the_fmi2_plant_bit_for_bit(fmi_type, solver):
    kw = dict(fmi_type=fmi_type, stop_time=0.5, output_interval=0.005, start_values=START,
              output=[*ALL_STATES, "acc_x", "roll", "sensor_gyro_y", "sensor_enc0"])
    if solver is not None:
        kw.update(solver=solver, step_size=1e-3)
    r2 = simulate_fmu(str(plant_build().fmu), **kw)
    r3 = simulate_fmu(str(plant3().fmu), **kw)
    assert r2.shape == r3.shape
    for name in r2.dtype.names:
        np.testing.assert_array_equal(r3[name], r2[name], err_msg=name)
    assert abs(r2["q1"][-1] - r2["q1"][0]) > 1e-3  # it moved


def _me_instance(b: FmuBuild) -> FMU3Model:
    md = read_model_description(str(b.unzipped))
    m = FMU3Model(guid=b.guid, unzipDirectory=str(b.unzipped),
                  modelIdentifier=b.model_identifier, instanceName="dd")
    m.instantiate()
    m.enterInitializationMode()
    vr = {v.name: v.valueReference for v in md.modelVariables}
    for name, value in START.items():
        m.setFloat64([vr[name]], [value])
    m.exitInitializationMode()
    return m, vr


def test_directional_and_adjoint_derivatives_come_from_the_jacobian():
    m, vr = _me_instance(plant3())
    unknowns = [vr[n] for n in ("der(dq1)", "der(dx)", "acc_x", "roll")]
    knowns = [vr[n] for n in ("q1", "dq2", "tau0", "tau_dist1")]
    jac = np.zeros((len(unknowns), len(knowns)))
    for j in range(len(knowns)):
        seed = np.zeros(len(knowns))
        seed[j] = 1.0
        jac[:, j] = m.getDirectionalDerivative(unknowns, knowns, list(seed))
    # against central differences of the outputs in the states/inputs
    h = 1e-6
    for j, k in enumerate(knowns):
        x = m.getFloat64([k])[0]
        vals = []
        for d in (h, -h):  # event mode: states and inputs may be set
            m.setFloat64([k], [x + d])
            vals.append(np.array(m.getFloat64(unknowns)))
        m.setFloat64([k], [x])
        np.testing.assert_allclose(jac[:, j], (vals[0] - vals[1]) / (2 * h), rtol=1e-5,
                                   atol=1e-6)
    seed = np.array([0.3, -1.0, 2.0, 0.5])
    adj = m.getAdjointDerivative(unknowns, knowns, list(seed), nSensitivity=len(knowns))
    np.testing.assert_allclose(adj, seed @ jac, rtol=1e-14, atol=1e-14)
    m.terminate()
    m.freeInstance()


class _Controller3:
    """One fmpy FMI 3.0 Co-Simulation instance of the controller FMU."""

    def __init__(self, b: FmuBuild):
        md = read_model_description(str(b.unzipped))
        self.vars = {v.name: v for v in md.modelVariables if v.name != "time"}
        self.fmu = FMU3Slave(guid=b.guid, unzipDirectory=str(b.unzipped),
                             modelIdentifier=b.model_identifier, instanceName="ctrl3")
        self.fmu.instantiate()
        self.t = 0.0

    def vr(self, *names: str) -> list[int]:
        return [self.vars[n].valueReference for n in names]

    def get(self, *names: str) -> np.ndarray:
        return np.array(self.fmu.getFloat64(self.vr(*names)))


@pytest.mark.parametrize("est", ["ukf", "ukf_adaptive"])
def test_the_fmi3_controller_equals_the_compiled_embedded_step(est):
    rng = np.random.default_rng(11)
    fmu, ref = _Controller3(controller3("flc", est)), _Reference("flc", est)
    fmu.fmu.enterInitializationMode(startTime=0.0)
    fmu.fmu.exitInitializationMode()
    fmu.fmu.setFloat64(fmu.vr("v_ref_x", "v_ref_y", "yaw_rate_ref"), list(VREF))
    worst = 0.0
    for k in range(60):
        meas = _readings(rng)
        if k == 30:
            meas[3] = np.nan  # a gyroscope dropout
        fmu.fmu.setFloat64(fmu.vr(*READING_NAMES), list(meas))
        fmu.fmu.doStep(fmu.t, 0.005)
        fmu.t += 0.005
        out = ref.period(meas)
        c_names = [n for n in fmu.vars if n.startswith("c_")]
        for got, want in ((fmu.get("tau0", "tau1", "tau2"), out["tau_lim"]),
                          (fmu.get(*XHAT_NAMES), out["x_hat"]), (fmu.get(*c_names),
                                                                  out["c_next"])):
            worst = max(worst, float(np.max(np.abs(got - want))))
    assert worst <= 1e-12
    # the running-sum remainder of an importer's clock is a zero-period step (FMI 3.0 too)
    fmu.fmu.doStep(fmu.t, 3e-17)
    fmu.fmu.terminate()
    fmu.fmu.freeInstance()


def test_the_fmi3_system_under_a_jacobi_master_equals_the_mission_with_the_delay():
    sc = load_scenario_file(resolve_scenario("full_sine")).scenario.replace(duration=1.0)
    t0 = time.perf_counter()
    run = run_fmi3_jacobi(sc)
    assert 0.0 < run.wall_s <= time.perf_counter() - t0  # the co-simulation's wall time
    assert run.master == FMI3_MASTER and run.time.size == sc.n_periods + 1
    log = sil_log(run).arrays
    ref = run_scenario(sc, ClosedLoop(), actuation_delay=True).arrays
    assert np.max(np.abs(log["state"] - ref["state"])) <= 1e-9
    assert np.max(np.abs(log["tau"] - ref["tau"])) <= 1e-9
    no_delay = run_scenario(sc, ClosedLoop()).arrays  # the comparison can fail
    assert np.max(np.abs(log["tau"] - no_delay["tau"])) > 1e-3


def test_cli_builds_the_fmi3_versions(tmp_path, capsys):
    assert cli_main(["fmu", "build", "--fmi-version", "3", "--out", str(tmp_path)]) == 0
    assert "FMI 3.0" in capsys.readouterr().out
    assert read_model_description(str(tmp_path / "BallbotPlant.fmu")).fmiVersion == "3.0"
    assert cli_main(["fmu", "build-controller", "--fmi-version", "3", "--out",
                     str(tmp_path)]) == 0
    assert read_model_description(str(tmp_path / "BallbotController.fmu")).fmiVersion == "3.0"
    with pytest.raises(SystemExit) as exc:
        cli_main(["fmu", "build", "--fmi-version", "4"])
    assert exc.value.code == 2


def test_casadis_own_export_of_the_ode_agrees_with_the_fmi3_plant(tmp_path):
    """The peer: CasADi's DaeBuilder.export_fmu (FMI 3.0 ME) of the same ODE, same solver;
    the difference is CVode's step sequence (our plant also integrates the wheel angles)."""
    theirs = casadi_export_fmu(tmp_path, roll0=ROLL)
    assert read_model_description(str(theirs)).fmiVersion == "3.0"
    kw = dict(fmi_type="ModelExchange", solver="CVode", relative_tolerance=1e-10,
              stop_time=0.5, output_interval=0.005, output=list(ALL_STATES[:12]))
    taus = {k: v for k, v in START.items() if k.startswith("tau")}
    x0 = {k: v for k, v in START.items() if k.startswith("x0_") and k != "x0_dq2"}
    ours = simulate_fmu(str(plant3().fmu), start_values={**taus, **x0, "Ts_sensor": 100.0},
                        **kw)
    peer = simulate_fmu(str(theirs), start_values=taus, **kw)
    diff = max(float(np.max(np.abs(ours[n] - peer[n]))) for n in ALL_STATES[:12])
    assert diff <= 1e-7, diff
    assert abs(ours["q1"][-1] - ours["q1"][0]) > 1e-3


def test_the_fmi3_logger_receives_each_refusal_with_its_status_and_unescaped_text():
    """Messages reach the FMI 3.0 ``logMessage`` callback (through the FMI 2.0 layer's
    logger) with their status and category, and the layer's '#' -> '##' escape undone
    (FMI 3.0 messages have no value-reference syntax): a call out of order and a wrong
    instantiation token holding '#' alone, twice in a row and first."""
    b = plant3()
    got = []

    def log(env, status, category, message):
        got.append((status, category.decode(), message.decode()))

    m = FMU3Model(guid=b.guid, unzipDirectory=str(b.unzipped),
                  modelIdentifier=b.model_identifier, instanceName="logged")
    m.instantiate(loggingOn=True, logMessage=log)
    with pytest.raises(Exception, match="fmi3ExitInitializationMode failed with status 3"):
        m.exitInitializationMode()
    assert got[-1] == (3, "logStatusError", "fmi2ExitInitializationMode: not allowed in state instantiated")
    m.freeInstance()
    got.clear()
    token = "#bad##to#ken"  # a leading '#', a run of two and a single one
    bad = FMU3Model(guid=token, unzipDirectory=str(b.unzipped),
                    modelIdentifier=b.model_identifier, instanceName="wrong")
    with pytest.raises(Exception, match="Failed to instantiate"):
        bad.instantiate(logMessage=log)
    assert got == [(3, "logStatusError", f"fmi2Instantiate: wrong GUID '{token}', this binary of "
                                         f"{b.model_identifier} has GUID '{b.guid}'")]


def test_fmi3_set_boolean_takes_at_most_64_values_per_call():
    """The FMI 3.0 Boolean setter converts through a buffer of 64: 64 values are set, 65
    refused with its reason (not written past the buffer)."""
    b = plant3()
    got = []
    m = FMU3Model(guid=b.guid, unzipDirectory=str(b.unzipped),
                  modelIdentifier=b.model_identifier, instanceName="bools")
    m.instantiate(loggingOn=True, logMessage=lambda env, status, category, message:
                  got.append((status, message.decode())))
    vr = {v.name: v.valueReference for v in read_model_description(str(b.fmu)).modelVariables}["noise_on"]
    m.enterInitializationMode()
    m.setBoolean([vr] * 64, [False] * 63 + [True])
    assert m.getBoolean([vr]) == [True]
    with pytest.raises(Exception, match="status 3"):
        m.setBoolean([vr] * 65, [False] * 65)
    assert "at most 64 Booleans per call" in got[-1][1]
    assert m.getBoolean([vr]) == [True]
    m.freeInstance()


def test_the_fmi3_logger_receives_a_long_message_with_many_hashes_whole():
    """A 600-character wrong token holding 300 '#': escaped to 1000 characters by the FMI 2.0
    layer and unescaped again, the FMI 3.0 logger gets the whole message (its buffers hold
    two model messages, not one)."""
    b = plant3()
    got = []
    token = "t#" * 300
    bad = FMU3Model(guid=token, unzipDirectory=str(b.unzipped),
                    modelIdentifier=b.model_identifier, instanceName="long")
    with pytest.raises(Exception, match="Failed to instantiate"):
        bad.instantiate(logMessage=lambda env, status, category, message:
                        got.append(message.decode()))
    assert got == [f"fmi2Instantiate: wrong GUID '{token}', this binary of "
                   f"{b.model_identifier} has GUID '{b.guid}'"]

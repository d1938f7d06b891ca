"""The path-following controller FMU (``BallbotControllerPath``): the guided embedded software
of the compiled mission with the path table and obstacles as parameters; in the SIL system it
equals the compiled guided mission (Gauss-Seidel: exactly; libcosim: with the Jacobi delay).
The parameters its MPC was built from are fixed at their build values.  Its FMI 3.0 variant
(same table, same per-model C) equals the FMI 2.0 one and, in the FMI 3.0 system, the
mission with the Jacobi delay."""

from __future__ import annotations

import functools
import json
from pathlib import Path

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi3 import FMU3Slave
from fmpy.validation import validate_fmu

from ballbot_casadi.cli import main
from ballbot_casadi.core.params import PARAM_NAMES
from ballbot_casadi.core.toolchain import build_root
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.fmi.controller.controller import (
    V_REF_USED_NAMES,
    controller_spec,
    controller_values,
    path_embedded_function,
)
from ballbot_casadi.fmi.controller.path import PATH_MODEL_IDENTIFIER, path_law
from ballbot_casadi.fmi.spec import value_range
from ballbot_casadi.fmi.masters.adapter import FmuSlave
from ballbot_casadi.fmi.masters.fmi3_jacobi import run_fmi3_jacobi
from ballbot_casadi.fmi.masters.ssp_run import run_ssp
from ballbot_casadi.fmi.package import build_fmu_from_spec
from ballbot_casadi.fmi.system.sil import write_sil_ssp
from ballbot_casadi.fmi.system.sil_log import sil_log
from ballbot_casadi.sim.closed_loop import power_on_inputs
from ballbot_casadi.sim.embedded import DEFAULT_ESTIMATOR
from ballbot_casadi.sim.guided import guided_software, run_path_scenario
from ballbot_casadi.sim.path_following import velocity_loop_model
from ballbot_casadi.sim.scenario import initial_state
from ballbot_casadi.sim.scenario.file import parse_scenario

pytestmark = [pytest.mark.needs_cc, pytest.mark.fmi_extra]

#: 5 s of the figure-eight (4 m x 2 m at 0.5 m/s) from rest with noise and the UKFs, an
#: obstacle 8 cm beside the path 1.2 m ahead (passed within the run: the MPC's obstacle
#: rows act, the robot swerves: 14 cm clearance) and one far off it (a second slot in use).
SCENARIO = {"name": "sil_path_fig8", "duration_s": 5.0, "cascade": True, "estimator": "ukf",
            "seed": 3, "guidance": "mpc",
            "path": {"type": "figure_eight", "length": 4.0, "width": 2.0, "speed": 0.5},
            "obstacle": [{"x": 0.848, "y": 0.865, "r": 0.1}, {"x": 0.0, "y": -3.0, "r": 0.2}]}
#: Gauss-Seidel runs the same generated C on the same inputs as the mission: measured 0.
#: The bound is the SIL tests' (a wrong parameter or start moves the states by 0.3 m
#: within 5 s).
BOUND = 1e-9
#: libcosim hands the FMUs step sizes from its integer-nanosecond clock, which differ from
#: 5 ms in the last bit; the MPC's solves amplify that rounding to 5.2e-10 in the states
#: and 8.6e-9 N m in the torques over the 5 s with the obstacle (2.3e-13 / 1.6e-12
#: without it): bounded at 1e-7, still 6 orders below the effect of a wrong parameter.
LIBCOSIM_BOUND = 1e-7


@functools.lru_cache(maxsize=None)
def _scenario():
    return parse_scenario(SCENARIO).scenario


@functools.lru_cache(maxsize=None)
def _spec():
    return controller_spec(path=_scenario())


@functools.lru_cache(maxsize=None)
def _build():
    # in the folder write_sil_ssp / sil_controller builds this scenario's path FMU in (its
    # per-scenario default): the same generated C, so one compile serves this module and
    # the SIL tests
    return build_fmu_from_spec(_spec(), build_root() / "fmu" / "path" / _scenario().name)


@functools.lru_cache(maxsize=None)
def _build3():
    return build_fmu_from_spec(_spec(), build_root() / "fmu3" / "path" / _scenario().name,
                               fmi_version=3)


@pytest.fixture(scope="module")
def work(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("sil_path")


@functools.lru_cache(maxsize=None)
def _mission(delay: bool):
    return run_path_scenario(_scenario(), actuation_delay=delay).arrays


class _Ctrl:
    """The path FMU on the masters' adapter, with its log."""

    def __init__(self, tmp: Path):
        self.logs: list[tuple[int, str]] = []
        self.slave = FmuSlave(extract(str(_build().fmu), unzipdir=str(tmp)), "ctrl",
                              logger=lambda status, category, msg: self.logs.append((status, msg)))

    def init(self, values: dict) -> None:
        self.slave.setup(0.0, values)
        self.slave.exit_initialization()


def test_the_fmu_runs_the_missions_guided_software_and_exposes_the_path(tmp_path):
    sc = _scenario()
    law = path_law(sc)
    assert path_embedded_function(law, "ukf") is guided_software(law, "ukf")
    spec = controller_spec(path=sc)
    assert spec.model_identifier == PATH_MODEL_IDENTIFIER + (
        "" if sc.estimator == DEFAULT_ESTIMATOR else f"_{sc.estimator}")
    assert guided_software(law, "ukf") in spec.functions
    by_name = {v.name: v for v in spec.variables}
    values = controller_values(sc, guided_software(law, "ukf"), law)
    k = law.parameters(sc.route.build())
    assert by_name["path_length"].start == pytest.approx(k[0], rel=0, abs=0)
    assert by_name["obstacle0_x"].start == 0.848 and by_name["obstacle0_r"].start == 0.1
    assert by_name["obstacle1_y"].start == -3.0 and by_name["obstacle4_r"].start == 0.0
    assert by_name["path_p1_y"].kind == "parameter" and "table point 1" in \
        by_name["path_p1_y"].description
    for n in V_REF_USED_NAMES:
        assert by_name[n].kind == "discrete_output"
    assert all(by_name[n].start == v for n, v in values.items() if n in by_name
               and by_name[n].type == "Real")
    with pytest.raises(ScenarioError, match="guidance"):
        controller_spec(path=sc.replace(guidance="pursuit"))


#: standing at rest, and tilted, turned and moving off the start: the velocity controller's
#: power-on state (the measured tilt) and the shape state are then not zero
_TILTED = initial_state(3.0, -2.0, 20.0)
MOVING_X0 = (0.03, -0.02, *_TILTED[2:6], 0.1, -0.05, *_TILTED[8:])


@pytest.mark.parametrize("x0", [None, MOVING_X0], ids=["standing", "moving"])
def test_the_guide_state_starts_as_the_missions(tmp_path, x0):
    sc = _scenario() if x0 is None else _scenario().replace(x0=x0)
    law = path_law(sc)
    ctrl = _Ctrl(tmp_path)
    ctrl.init(controller_values(sc, guided_software(law, "ukf"), law))
    names = [n for n in ctrl.slave.variables if n.startswith("c_guide_")]
    g = ctrl.slave.get_reals(names)
    inp = power_on_inputs("ukf", sc.inputs(periods=(0, 1)))
    g0 = law.initial_state(sc.route.build(), inp["x0"], inp["z0"])
    assert len(names) == g0.size
    assert (np.count_nonzero(inp["z0"]) > 0) == (x0 is not None)
    np.testing.assert_array_equal(g, g0)
    assert g0[law.state["first"].start + 1] == 1.0


@pytest.mark.parametrize("name, value, needle", [
    ("path_p7_x", float("nan"), "finite"),
    ("path_speed", 0.6, "speed in (0, 0.5]"),
    ("path_closed", 0.5, "closed 0 or 1"),
    ("path_t3_y", 2.0, "path_t3"),
    ("obstacle0_r", -0.1, "obstacle0_r"),
    ("obstacle1_y", 0.0, "cannot pass through"),  # over the start (0, 0)
    ("path_s0", 3.0, "projection"),
])
def test_bad_path_parameters_are_logged_errors(tmp_path, name, value, needle):
    sc = _scenario()
    law = path_law(sc)
    ctrl = _Ctrl(tmp_path)
    values = controller_values(sc, guided_software(law, "ukf"), law)
    values[name] = value
    with pytest.raises(Exception):
        ctrl.init(values)
    errors = [m for s, m in ctrl.logs if s >= 3]
    assert any(needle in m for m in errors), errors


#: The ctrl_* the MPC's prediction model cannot depend on at the upright equilibrium: the
#: FLC's inversion cancels the wheel geometry and inertia and the wheel friction, the
#: heading inertia and the quaternion stabilisation do not act on the tilt, the torque
#: limit and the encoder resolution are not in the linear model.
NOT_IN_THE_MODEL = ("Jbz", "Jw", "rw", "alpha", "gamma", "Bvm", "tau_max", "n_ticks", "beta")


def test_the_parameters_the_mpc_was_built_from_are_fixed_and_the_others_free():
    """Independent of the probe in the code: a 10 % change of every ctrl_* and k_vel entry
    in the MPC's loop model (real dependencies move it by >= 1e-6, the others by rounding)."""
    sc = _scenario()
    inp = sc.inputs(periods=(0, 1))
    p, k = np.asarray(inp["p_ctrl"], float).ravel(), np.asarray(inp["k_vel"], float).ravel()
    dt = path_law(sc).config.dt
    base = velocity_loop_model(p, k, dt)

    def moves(pp, kk, ts=0.005) -> float:
        m = velocity_loop_model(pp, kk, dt, ts)
        return max(np.max(np.abs(m.A - base.A)), np.max(np.abs(m.B - base.B)))

    by_name = {v.name: v for v in _spec().variables}
    for i, n in enumerate(PARAM_NAMES):
        q = p.copy()
        q[i] = 1.1 * q[i] + 0.01
        move = moves(q, k)
        assert (move > 1e-6) == (n not in NOT_IN_THE_MODEL), (n, move)
        assert (move > 1e-6) == (by_name[f"ctrl_{n}"].fixed is not None), n
    k_names = [n for n in by_name if n.startswith("k_vel_")]
    assert len(k_names) == k.size
    for j, n in enumerate(k_names):
        q = k.copy()
        q[j] = 1.1 * q[j] + 0.01
        assert (moves(p, q) > 1e-6) == (by_name[n].fixed is not None) == n.startswith("k_vel_K_"), n
    assert moves(p, k, 0.004) > 1e-6 and by_name["Ts"].fixed is not None
    # a fixed parameter's range is its build value: min = max = start in the description
    lo, hi, _, _, text = value_range(by_name["ctrl_Mb"])
    assert lo == hi == by_name["ctrl_Mb"].start == p[PARAM_NAMES.index("Mb")]
    assert "build" in text
    # the plain controller FMU fixes nothing
    assert not any(v.fixed for v in controller_spec().variables)


@pytest.mark.parametrize("name, factor, refused", [
    ("ctrl_Mb", 1.1, True),            # the body mass: in the MPC's prediction model
    ("k_vel_K_0_1", 0.9, True),        # the velocity gain the MPC predicts with
    ("Ts", 2.0, True),                 # the period the MPC's steps are built on
    ("ctrl_Mb", 1.0, False),           # the build value itself: accepted
    ("ctrl_tau_max", 0.9, False),      # the torque limit: not in the prediction model
    ("ctrl_Jw", 1.1, False),           # cancelled by the FLC's inversion
])
def test_changing_a_parameter_the_mpc_was_built_from_is_a_logged_error(tmp_path, name, factor,
                                                                       refused):
    sc = _scenario()
    law = path_law(sc)
    values = controller_values(sc, guided_software(law, "ukf"), law)
    build_value = values[name]
    ctrl = _Ctrl(tmp_path)
    ctrl.slave.setup(0.0)
    if not refused:
        ctrl.slave.set(name, build_value * factor)
        ctrl.slave.exit_initialization()
        assert ctrl.slave.get(name) == build_value * factor
        assert not [m for s, m in ctrl.logs if s >= 3]
        return
    with pytest.raises(FMICallException) as exc:
        ctrl.slave.set(name, build_value * factor)
    assert exc.value.status == 3  # fmi2Error
    errors = [m for s, m in ctrl.logs if s >= 3]
    assert len(errors) == 1 and "\n" not in errors[0], errors
    assert f"'{name}'" in errors[0] and f"its build value {build_value!r}" in errors[0]
    assert "build-controller --scenario" in errors[0]
    assert ctrl.slave.get(name) == build_value  # nothing changed
    ctrl.slave.exit_initialization()  # and the instance runs on


def test_gauss_seidel_sil_equals_the_compiled_guided_mission(work):
    ssp = write_sil_ssp(_scenario(), work / "path.ssp")
    run = run_ssp(ssp, master="gauss-seidel")
    log = sil_log(run).arrays
    ref = _mission(False)
    for key in ("state", "tau", "tau_cmd", "x_hat", "v_ref_used"):
        np.testing.assert_allclose(log[key], ref[key], rtol=0, atol=BOUND, err_msg=key)
    # the obstacle on the path was reached: the guidance steered (not a trivial run)
    assert np.max(np.abs(log["v_ref_used"][:, :2])) > 0.3
    assert np.max(np.hypot(*log["state"][:, :2].T)) > 1.0


#: The same run with the matched VUKF adapting its acceleration walk (``ukf_adaptive``): a
#: path FMU of its own (the filter's walk estimate is part of the state ``c``).
ADAPTIVE = {**SCENARIO, "name": "sil_path_fig8_adaptive", "estimator": "ukf_adaptive"}


def test_gauss_seidel_sil_with_the_adaptive_filter_equals_the_compiled_guided_mission(work):
    sc = parse_scenario(ADAPTIVE).scenario
    spec = controller_spec(path=sc)
    assert spec.model_identifier == PATH_MODEL_IDENTIFIER + (
        "" if sc.estimator == DEFAULT_ESTIMATOR else f"_{sc.estimator}")
    names = {v.name for v in spec.variables}
    assert {"c_walk_0", "c_walk_1", "c_walk_2"} <= names
    run = run_ssp(write_sil_ssp(sc, work / "path_adaptive.ssp"), master="gauss-seidel")
    log = sil_log(run).arrays
    ref = run_path_scenario(sc).arrays
    for key in ("state", "tau", "tau_cmd", "x_hat", "v_ref_used"):
        np.testing.assert_allclose(log[key], ref[key], rtol=0, atol=BOUND, err_msg=key)
    # the adaptive filter ran, not the thesis's: same readings at the start, other estimate
    thesis = _mission(False)
    np.testing.assert_array_equal(log["meas"][0], thesis["meas"][0])
    assert np.max(np.abs(log["x_hat"] - thesis["x_hat"])) > 1e-4
    assert np.max(np.hypot(*log["state"][:, :2].T)) > 1.0


@pytest.mark.slow
def test_cli_runs_the_path_scenario_in_libcosim(work):
    f = work / "sil_path.toml"
    f.write_text('name = "sil_path_fig8"\nduration_s = 5.0\ncascade = true\nestimator = "ukf"\n'
                 'seed = 3\nguidance = "mpc"\n[path]\ntype = "figure_eight"\nlength = 4.0\n'
                 'width = 2.0\nspeed = 0.5\n[[obstacle]]\nx = 0.848\ny = 0.865\nr = 0.1\n'
                 '[[obstacle]]\nx = 0.0\ny = -3.0\nr = 0.2\n[[spec]]\n'
                 'metric = "path_min_clearance_m"\nop = ">="\nthreshold = 0.10\n'
                 'source = "minimum clearance >= 0.10 m (issue 18)"\n')
    ssp = work / "cli_path.ssp"
    assert main(["fmu", "ssp", "--scenario", str(f), "--out", str(ssp)]) == 0
    out = work / "run"
    code = main(["fmu", "cosim", str(ssp), "--out", str(out), "--no-plot"])
    doc = json.loads((out / "metrics.json").read_text())
    assert code == 0 and doc["passed"]
    v = doc["sil"]["vs_mission"]
    assert "actuation delay" in v["reference"]
    assert v["state_max"] <= LIBCOSIM_BOUND and v["tau_max"] <= LIBCOSIM_BOUND
    m = doc["metrics"]
    assert m["path_collision"] == 0.0 and m["path_min_clearance_m"] >= 0.10
    # swerving round the obstacle 8 cm beside the path costs lateral error (measured 7.9 cm)
    assert 0.03 <= m["path_lateral_rms_m"] <= 0.12 and m["path_progress_fraction"] > 0.1


@pytest.mark.parametrize("scenario, needle", [("path_fig8_pursuit_ukf", "guidance"),
                                              ("full_sine", "no [path]"),
                                              ("path_fig8_mpc", "estimator")])
def test_cli_refuses_what_the_path_fmu_cannot_run(tmp_path, capsys, scenario, needle):
    code = main(["fmu", "build-controller", "--scenario", scenario, "--out", str(tmp_path)])
    err = capsys.readouterr().err.strip()
    assert code == 2 and needle in err and "\n" not in err
    assert not list(tmp_path.iterdir())


#: The FMI 3.0 path FMU runs the same generated C through the FMI 3.0 entry points: measured
#: bit for bit equal to the FMI 2.0 one (tolerance 0) on 1 s of the standing robot's readings.
FMI3_BOUND = 0.0
#: Readings of the robot standing upright (specific force g along body z), held.
STANDING = {"sensor_acc_z": 9.81}
#: Outputs compared between the FMI 2.0 and FMI 3.0 path FMUs.
COMPARED = ("tau0", "tau1", "tau2", "pos_hat_x", "pos_hat_y", "q_hat1", "q_hat2",
            *V_REF_USED_NAMES, "c_guide_1", "c_guide_2")


@pytest.mark.slow  # the FMI 3.0 path FMU is a separate compile of the guided C (~3 min cold)
def test_the_fmi3_path_fmu_validates_and_equals_the_fmi2_one():
    b2, b3 = _build(), _build3()
    assert validate_fmu(str(b3.fmu)) == []
    md2, md3 = read_model_description(str(b2.fmu)), read_model_description(str(b3.fmu))
    assert (md2.fmiVersion, md3.fmiVersion) == ("2.0", "3.0")
    assert md3.coSimulation.modelIdentifier == _spec().model_identifier
    v2 = {v.name: v for v in md2.modelVariables}
    v3 = {v.name: v for v in md3.modelVariables}
    assert set(v3) == set(v2) | {"time"}
    for n, v in v2.items():  # the one table: names, VRs, starts and the fixed ranges
        assert (v3[n].valueReference, v3[n].start, v3[n].min, v3[n].max) == (
            v.valueReference, v.start, v.min, v.max), n
    assert v3["ctrl_Mb"].min == v3["ctrl_Mb"].max == v3["ctrl_Mb"].start
    kw = dict(stop_time=1.0, output_interval=0.005, start_values=STANDING, output=COMPARED)
    r2, r3 = simulate_fmu(str(b2.fmu), **kw), simulate_fmu(str(b3.fmu), **kw)
    assert r2.shape == r3.shape == (201,)
    for n in COMPARED:
        np.testing.assert_allclose(r3[n], r2[n], rtol=0, atol=FMI3_BOUND, err_msg=n)
    # not a trivial run: the MPC's plan changed the velocity reference at its samples (the
    # estimate stands still on these readings: measured 2.8 cm/s, then 1.3 cm/s)
    speed = np.hypot(r2["v_ref_used_x"], r2["v_ref_used_y"])
    assert np.max(speed) > 0.01 and np.unique(speed).size >= 3
    # the FMI 3.0 variant refuses a parameter the MPC was built from too (fmi3Error)
    logs: list[str] = []
    fmu = FMU3Slave(guid=b3.guid, unzipDirectory=str(b3.unzipped),
                    modelIdentifier=b3.model_identifier, instanceName="ctrl3")
    fmu.instantiate(loggingOn=True, logMessage=lambda env, status, category, message:
                    logs.append(message.decode()))
    fmu.enterInitializationMode(startTime=0.0)
    with pytest.raises(FMICallException) as exc:
        fmu.setFloat64([v3["ctrl_Mb"].valueReference], [1.1 * float(v3["ctrl_Mb"].start)])
    assert exc.value.status == 3  # fmi3Error
    assert any("'ctrl_Mb'" in m and "its build value" in m for m in logs), logs
    fmu.setFloat64([v3["ctrl_tau_max"].valueReference], [1.5])  # not in the model: free
    fmu.exitInitializationMode()
    fmu.terminate()
    fmu.freeInstance()


@pytest.mark.slow  # builds the FMI 3.0 plant, path controller and reference player
def test_the_fmi3_path_system_equals_the_mission_with_the_jacobi_delay():
    run = run_fmi3_jacobi(_scenario())
    log = sil_log(run).arrays
    ref = _mission(True)
    for key in ("state", "tau", "x_hat", "v_ref_used"):
        np.testing.assert_allclose(log[key], ref[key], rtol=0, atol=BOUND, err_msg=key)
    assert np.max(np.hypot(*log["state"][:, :2].T)) > 1.0  # it went somewhere

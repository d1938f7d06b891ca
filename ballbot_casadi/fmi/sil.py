"""Software in the loop: plant FMU + controller FMU as an SSP system, run by libcosim.

The system (:func:`sil_system`, written by :func:`write_sil_ssp`, ``make sil``):

* ``plant`` - ``BallbotPlant.fmu`` (or any FMU with its variable names) with the
  scenario's plant parameters, sensor parameters, noise switch and seed (a 32-bit signed
  Integer in the FMU), internal step ``Ts / n_sub`` and sensor period ``Ts``;
* ``controller`` - ``BallbotController.fmu`` (:mod:`~ballbot_casadi.fmi.controller`)
  with the scenario's controller and filter models, gains, tuning and state at power-on;
* ``reference`` - ``BallbotReference.fmu`` (:mod:`~ballbot_casadi.fmi.reference`),
  the scenario's per-period references and wheel-torque disturbance;
* connections ``plant.sensor_* -> controller.sensor_*``, ``controller.tau0..2 ->
  plant.tau0..2``, ``reference.<reference> -> controller.<reference>``,
  ``reference.tau_dist0..2 -> plant.tau_dist0..2``; one parameter set ``scenario``;
  the default experiment: the scenario's duration with a fixed 5 ms step
  (``osp:FixedStepAlgorithm``); the scenario itself as ``resources/scenario.json``.

Timing.  libcosim's fixed-step algorithm is a Jacobi master: every FMU steps from
``t_k`` on the inputs it was given at ``t_k``, and the outputs are transferred when all
have finished (its slave reads outputs only after a step).  The controller reads
sample ``k`` at ``t_k`` and its torque reaches the plant at ``t_k+1``: the SIL has one
period of actuation delay that the compiled mission (torque of period ``k`` acting on
``[t_k, t_k+1)``) does not have, and no ordering or delay elsewhere in a Jacobi master
can remove it (the torque that acts from ``t_k`` would have to be computed from the
state at ``t_k`` before the plant leaves ``t_k``).  Therefore:

* ``master="libcosim"`` (default; the SSP as any engine runs it) equals, bit for bit
  up to rounding, the compiled mission of the same scenario with that one-period delay
  (``run_scenario(..., actuation_delay=True)``, :mod:`ballbot_casadi.sim.steps`);
* ``master="gauss-seidel"`` (fmpy, the same SSP and FMUs) steps the controller first
  and the plant after it at every ``t_k``, which is the compiled mission itself.

Every connection is logged at every communication point (:attr:`SilRun.signals`,
``connections.csv``); :func:`sil_log` turns a run into a
:class:`~ballbot_casadi.sim.log.SimulationLog` with the mission's layout for the
metrics of :mod:`ballbot_casadi.analysis.metrics`.
"""

from __future__ import annotations

import json
import math
import shutil
import tempfile
import time
import zipfile
from ctypes import c_double, c_int, c_int64, c_size_t, c_uint32
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

from ballbot_casadi.control import BALANCE_DIAG_NAMES
from ballbot_casadi.core.layout import STATE
from ballbot_casadi.core.params import PARAM_NAMES
from ballbot_casadi.core.sensor_params import SENSOR_VECTOR_NAMES
from ballbot_casadi.errors import BallbotError, BuildError, CosimError, FileFormatError, ScenarioError
from ballbot_casadi.fmi.build import build_fmu
from ballbot_casadi.fmi.controller import (
    READING_NAMES,
    REFERENCE_NAMES,
    XHAT_NAMES,
    controller_spec,
    controller_values,
    embedded_function,
)
from ballbot_casadi.fmi.package import build_fmu_from_spec
from ballbot_casadi.fmi.plant import WHEEL_ANGLE_NAMES
from ballbot_casadi.fmi.reference import DISTURBANCE_NAMES, reference_spec
from ballbot_casadi.fmi.spec import INT32_MAX
from ballbot_casadi.fmi.ssp import SspComponent, SspConnection, write_ssp
from ballbot_casadi.fmi.ssp_check import MAX_STEPS, open_ssp
from ballbot_casadi.sim.embedded import MEAS
from ballbot_casadi.sim.log import SimulationLog
from ballbot_casadi.sim.scenario import Scenario

__all__ = [
    "PLANT",
    "CONTROLLER",
    "REFERENCE",
    "MASTERS",
    "SCENARIO_RESOURCE",
    "SilRun",
    "plant_parameters",
    "sil_connections",
    "sil_system",
    "write_sil_ssp",
    "read_scenario",
    "run_ssp",
    "sil_log",
]

PLANT, CONTROLLER, REFERENCE = "plant", "controller", "reference"
#: Masters of :func:`run_ssp`.
MASTERS = ("libcosim", "gauss-seidel")
SCENARIO_RESOURCE = "scenario.json"
_TORQUES = tuple(f"tau{i}" for i in range(3))
#: Controller outputs recorded besides the connections (the estimate and diagnostics).
_CONTROLLER_RECORDED = (
    *(f"tau_cmd{i}" for i in range(3)), *XHAT_NAMES, "roll_hat", "pitch_hat", "yaw_hat",
    *(f"omega_hat_{c}" for c in "xyz"),
    *(f"{w}_ref_used{i}" for w in ("q", "dq", "ddq") for i in range(4)),
    *(f"diag_{n}" for n in BALANCE_DIAG_NAMES), "nis_attitude", "nis_velocity", "repairs",
)


@dataclass
class SilRun:
    """A co-simulation of an SSP system.

    Attributes
    ----------
    time
        The communication points ``t_0 .. t_N`` (N + 1).
    signals
        ``{"<component>.<variable>": (N + 1,) array}``: every connection's source (the
        value transferred at each communication point), the plant's states and the
        controller's estimate and diagnostics, sampled at the communication points.
    connections
        The system's connections.
    master
        ``"libcosim"`` or ``"gauss-seidel"``.
    scenario
        The scenario the SSP was written for (``None`` if it carries none).
    specs
        The scenario file's ``[[spec]]`` rows (may be empty).
    wall_s
        Wall time of the co-simulation (s).
    """

    time: np.ndarray
    signals: dict[str, np.ndarray]
    connections: tuple[SspConnection, ...]
    master: str
    scenario: Scenario | None
    specs: tuple[Mapping[str, Any], ...]
    wall_s: float

    def write_connections(self, path: str | Path) -> Path:
        """Every logged signal as CSV (``time`` first, ``%.17g``: exact doubles)."""
        path = Path(path)
        names = list(self.signals)
        data = np.column_stack([self.time, *(self.signals[n] for n in names)])
        np.savetxt(path, data, delimiter=",", header=",".join(["time", *names]), comments="",
                   fmt="%.17g")
        return path


def plant_parameters(scenario: Scenario, variables: Sequence[str] | None = None
                     ) -> dict[str, float | int | bool]:
    """The plant FMU's parameter set for ``scenario``: model parameters (``load_params``
    names), ``h_internal = Ts / n_sub``, ``Ts_sensor = Ts``, sensor parameters,
    ``noise_on``, ``seed`` and the initial state (start values of the states).

    ``variables`` (the names a user's plant FMU has) drops the entries it lacks.

    Raises
    ------
    ScenarioError
        The seed does not fit the FMU's 32-bit signed Integer.
    """
    if not 0 <= scenario.seed <= INT32_MAX:
        raise ScenarioError(f"scenario {scenario.name!r}: seed {scenario.seed} does not fit the "
                            f"plant FMU's 32-bit signed Integer seed (0 .. {INT32_MAX})")
    sensors = scenario.sensor_params().to_vector()
    values: dict[str, float | int | bool] = {
        **dict(zip(PARAM_NAMES, (float(v) for v in scenario.plant_params().to_vector()))),
        "h_internal": scenario.Ts / scenario.n_sub,
        "Ts_sensor": float(scenario.Ts),
        **dict(zip(SENSOR_VECTOR_NAMES, (float(v) for v in sensors))),
        "noise_on": bool(scenario.noise),
        "seed": int(scenario.seed),
        **dict(zip(STATE.names, (float(v) for v in scenario.x0))),
    }
    if variables is not None:
        values = {k: v for k, v in values.items() if k in set(variables)}
    return values


def sil_connections(plant_variables: Sequence[str]) -> list[SspConnection]:
    """The SIL connections; the disturbance only if the plant has ``tau_dist0..2``."""
    cons = [SspConnection(PLANT, n, CONTROLLER, n) for n in READING_NAMES]
    cons += [SspConnection(CONTROLLER, n, PLANT, n) for n in _TORQUES]
    cons += [SspConnection(REFERENCE, n, CONTROLLER, n) for n in (*REFERENCE_NAMES, "balance_only")]
    if all(n in plant_variables for n in DISTURBANCE_NAMES):
        cons += [SspConnection(REFERENCE, n, PLANT, n) for n in DISTURBANCE_NAMES]
    return cons


def sil_system(scenario: Scenario, plant_fmu: str | Path | None = None,
               out: str | Path | None = None) -> tuple[list[SspComponent], list[SspConnection]]:
    """Build the controller and reference FMUs of ``scenario`` and describe the system.

    ``plant_fmu`` replaces ``BallbotPlant.fmu`` (it needs the inputs ``tau0..2`` and the
    outputs ``sensor_*`` of the package's plant; parameters it lacks are left out).
    ``out`` is the FMU build folder (default ``<build>/fmu``).

    Raises
    ------
    ScenarioError
        A scenario without an estimator, with pushes or sensor dropouts, or a seed beyond
        32 bits.
    BuildError
        The plant FMU lacks a variable the system connects.
    """
    if scenario.estimator == "true":
        raise ScenarioError(f"scenario {scenario.name!r}: the SIL runs the embedded software, "
                            "which reads sensors; set estimator = 'ukf' or 'ekf'")
    if scenario.sensor_dropouts:  # refused, never silently dropped
        raise ScenarioError(f"scenario {scenario.name!r} has [[sensor_dropout]] rows, which the "
                            "SSP cannot express (the FMUs have no dropout input); remove them "
                            "to write the SIL system")
    out = Path(out) if out is not None else None
    plant = Path(build_fmu(out).fmu if plant_fmu is None else plant_fmu)
    causality = {v.name: v.causality for v in read_model_description(str(plant)).modelVariables}
    names = list(causality)
    missing = [n for n in _TORQUES if causality.get(n) != "input"] + [
        n for n in READING_NAMES if causality.get(n) != "output"]
    if missing:
        raise BuildError(f"plant FMU {plant} lacks {', '.join(missing)}; a plant for the SIL needs "
                         "the inputs tau0..2 and the outputs sensor_acc_x .. sensor_enc2 (Real)")
    embedded = embedded_function(scenario.controller, scenario.estimator)
    ctrl = build_fmu_from_spec(controller_spec(scenario.controller, scenario.estimator), out)
    ref_dir = (out if out is not None else Path(ctrl.fmu).parent) / "reference" / scenario.name
    ref = build_fmu_from_spec(reference_spec(scenario), ref_dir)
    components = [
        SspComponent(PLANT, plant, plant_parameters(scenario, names)),
        SspComponent(CONTROLLER, ctrl.fmu, controller_values(scenario, embedded)),
        SspComponent(REFERENCE, ref.fmu, {"Ts": float(scenario.Ts)}),
    ]
    return components, sil_connections(names)


def write_sil_ssp(scenario: Scenario, path: str | Path, plant_fmu: str | Path | None = None,
                  specs: Sequence[Mapping[str, Any]] = (), out: str | Path | None = None,
                  source: str = "") -> Path:
    """Write the SIL system of ``scenario`` as an SSP archive (see the module docstring);
    ``specs`` (a scenario file's ``[[spec]]`` rows) travel with it for the metrics."""
    components, connections = sil_system(scenario, plant_fmu, out)
    meta = {"scenario": scenario.to_dict(), "specs": [dict(s) for s in specs], "source": source}
    return write_ssp(path, components, connections, name="BallbotSIL",
                     stop=scenario.n_periods * scenario.Ts, step=scenario.Ts,
                     description=f"ballbot software in the loop: scenario {scenario.name!r} "
                     f"({scenario.controller}, estimator {scenario.estimator}, seed "
                     f"{scenario.seed})",
                     resources={SCENARIO_RESOURCE: json.dumps(meta, indent=1).encode()})


def read_scenario(ssp: str | Path) -> tuple[Scenario | None, tuple[Mapping[str, Any], ...]]:
    """The scenario and specs an SSP written by :func:`write_sil_ssp` carries (or ``None``)."""
    with zipfile.ZipFile(ssp) as zf:
        try:
            meta = json.loads(zf.read(f"resources/{SCENARIO_RESOURCE}"))
        except KeyError:
            return None, ()
        except ValueError as exc:
            raise FileFormatError(f"{ssp}: resources/{SCENARIO_RESOURCE} is not valid JSON ({exc})") from None
    try:
        return Scenario.from_dict(meta["scenario"]), tuple(dict(s) for s in meta.get("specs", ()))
    except BallbotError as exc:
        raise FileFormatError(f"{ssp}: resources/{SCENARIO_RESOURCE}: {exc}") from None
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise FileFormatError(f"{ssp}: resources/{SCENARIO_RESOURCE} is malformed "
                              f"({type(exc).__name__}: {exc})") from None


# ------------------------------------------------------------------ running


def _recorded(system: Any, variables: Mapping[str, Mapping[str, Any]]) -> list[tuple[str, str]]:
    """``(component, variable)`` pairs to record: both ends of every connection, the
    plant's states and the controller's estimate and diagnostics (those the FMUs have)."""
    rec: list[tuple[str, str]] = []
    for c in system.connections:
        for pair in ((c.start_element, c.start_connector), (c.end_element, c.end_connector)):
            if pair not in rec:
                rec.append(pair)
    for comp, names in ((PLANT, (*STATE.names, *WHEEL_ANGLE_NAMES)),
                        (CONTROLLER, _CONTROLLER_RECORDED)):
        rec += [(comp, n) for n in names if comp in variables and n in variables[comp]
                and (comp, n) not in rec]
    return rec


def _run_libcosim(ssp: Path, system: Any, n: int, step: float, variables: Mapping[str, Any],
                  rec: Sequence[tuple[str, str]]) -> dict[str, np.ndarray]:
    from libcosimpy.CosimEnums import CosimVariableType
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    log_output_level(CosimLogLevel.ERROR)
    ex = CosimExecution.from_ssp_file(str(ssp))
    index = {c: ex.slave_index_from_instance_name(c) for c in system.components}
    # values the SSP binds but libcosim skips (start values of states): initial values
    for comp, params in system.parameters.items():
        for name, value in params.items():
            v = variables[comp][name]
            if v.causality in ("parameter", "input"):
                continue
            if v.type != "Real":
                raise BuildError(f"{comp}.{name}: cannot apply a {v.type} start value")
            if not ex.real_initial_value(index[comp], v.valueReference, float(value)):
                raise CosimError(f"libcosim refused the initial value of {comp}.{name}")
    obs = CosimObserver.create_time_series(buffer_size=n + 1)
    last = CosimObserver.create_last_value()
    ex.add_observer(obs)
    ex.add_observer(last)
    kinds = {"Real": CosimVariableType.REAL, "Integer": CosimVariableType.INTEGER}
    for comp, name in rec:
        v = variables[comp][name]
        if v.type in kinds:
            obs.start_time_series(index[comp], v.valueReference, kinds[v.type])
    if not ex.simulate_until(int(round(n * step * 1e9))):
        raise CosimError(f"libcosim stopped before t = {n * step:g} s (see the FMUs' log above)")
    out = {}
    for comp, name in rec:
        v = variables[comp][name]
        if v.type not in kinds:  # the time-series observer records Reals and Integers only
            out[f"{comp}.{name}"] = np.full(n + 1, float(last.last_boolean_values(
                index[comp], [v.valueReference])[0]))
            continue
        x = _samples(obs, index[comp], v, n)
        # libcosim reads an input after the step that used it: sample k + 1 is the value
        # the FMU held on [t_k, t_k+1)
        out[f"{comp}.{name}"] = np.append(x[1:], np.nan) if v.causality == "input" else x
    return out


def _samples(obs: Any, slave: int, var: Any, n: int) -> np.ndarray:
    """The n + 1 samples (steps 0 .. n) of a variable from a time series observer."""
    from libcosimpy._internal import libcosimc

    real = var.type == "Real"
    fn = (libcosimc().cosim_observer_slave_get_real_samples if real
          else libcosimc().cosim_observer_slave_get_integer_samples)
    vals = ((c_double if real else c_int) * (n + 1))()
    steps, times = (c_int64 * (n + 1))(), (c_int64 * (n + 1))()
    fn.restype = c_int64
    ptr = obs.ptr()
    fn.argtypes = [type(ptr), c_int, c_uint32, c_int64, c_size_t, type(vals), type(steps),
                   type(times)]
    got = fn(ptr, slave, var.valueReference, 0, n + 1, vals, steps, times)
    if got != n + 1 or list(steps) != list(range(n + 1)):
        raise CosimError(f"libcosim returned {got} samples of {var.name} (steps {steps[0]} .. "
                         f"{steps[max(got - 1, 0)]}), expected steps 0 .. {n}")
    return np.array(vals[:], dtype=float)


def _run_gauss_seidel(system: Any, unzipped: Mapping[str, Path], n: int, step: float,
                      variables: Mapping[str, Mapping[str, Any]],
                      rec: Sequence[tuple[str, str]]) -> dict[str, np.ndarray]:
    """Controller-first Gauss-Seidel: at t_k give the controller the plant's and the
    reference's outputs and step it, give the plant the controller's new torque and step
    it, then step the reference (it reads nothing)."""
    order = [c for c in (CONTROLLER, PLANT, REFERENCE) if c in system.components]
    order += [c for c in system.components if c not in order]
    slaves: dict[str, FMU2Slave] = {}
    for comp in order:
        md = read_model_description(str(unzipped[comp]))
        s = FMU2Slave(guid=md.guid, unzipDirectory=str(unzipped[comp]),
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName=comp)
        s.instantiate()
        slaves[comp] = s
    out = {f"{c}.{v}": np.zeros(n + 1) for c, v in rec}

    def get(comp: str, name: str) -> float:
        v = variables[comp][name]
        s = slaves[comp]
        if v.type == "Real":
            return s.getReal([v.valueReference])[0]
        if v.type == "Integer":
            return float(s.getInteger([v.valueReference])[0])
        return float(s.getBoolean([v.valueReference])[0])

    def put(comp: str, name: str, value: Any) -> None:
        v = variables[comp][name]
        s = slaves[comp]
        if v.type == "Real":
            s.setReal([v.valueReference], [float(value)])
        elif v.type == "Integer":
            s.setInteger([v.valueReference], [int(value)])
        else:
            s.setBoolean([v.valueReference], [bool(value)])

    def transfer(into: str) -> None:
        for c in system.connections:
            if c.end_element == into:
                put(into, c.end_connector, get(c.start_element, c.start_connector))

    try:
        for comp, s in slaves.items():
            s.setupExperiment(startTime=system.start_time)
            s.enterInitializationMode()
            for name, value in system.parameters.get(comp, {}).items():
                put(comp, name, value)
        for comp in order:  # outputs at the start time, in dependency order
            transfer(comp)
            slaves[comp].exitInitializationMode()
        t0 = system.start_time
        for k in range(n + 1):
            for key, (c, v) in zip(out, rec):  # outputs at t_k
                if variables[c][v].causality != "input":
                    out[key][k] = get(c, v)
            for comp in order:
                transfer(comp)
                for key, (c, v) in zip(out, rec):  # inputs held on [t_k, t_k+1)
                    if c == comp and variables[c][v].causality == "input":
                        out[key][k] = get(c, v) if k < n else np.nan
                if k < n:
                    slaves[comp].doStep(t0 + k * step, step)
    finally:
        for s in slaves.values():
            s.freeInstance()
    return out


def _steps(ssp: Path, system: Any, duration: float | None, allow_long: bool) -> int:
    """Number of fixed steps of the run: ``duration`` or the SSP's stop time, a whole
    number of steps, at most :data:`~ballbot_casadi.fmi.ssp_check.MAX_STEPS` unless
    ``duration`` is given or ``allow_long``."""
    if system.step is None:
        raise FileFormatError(f"{ssp}: the default experiment has no fixed step "
                              "(osp:FixedStepAlgorithm baseStepSize)")
    stop = duration if duration is not None else (system.stop_time or 0.0) - system.start_time
    n = int(round(stop / system.step)) if math.isfinite(stop) and stop < 1e15 * system.step else 0
    if n < 1 or abs(n * system.step - stop) > 1e-9 * max(1.0, stop):
        raise ScenarioError(f"duration {stop!r} s must be a positive multiple of the step "
                            f"{system.step!r} s")
    if n > MAX_STEPS and duration is None and not allow_long:
        raise ScenarioError(f"{ssp}: its stop time asks for {n} steps of {system.step:g} s "
                            f"({stop:g} s), more than {MAX_STEPS}; give --duration, or "
                            "--allow-long to run it all")
    return n


def run_ssp(ssp: str | Path, duration: float | None = None, master: str = "libcosim",
            allow_long: bool = False) -> SilRun:
    """Co-simulate an SSP archive for ``duration`` s (default: its stop time).

    Parameters
    ----------
    ssp
        The ``.ssp`` file (e.g. from :func:`write_sil_ssp`).
    duration
        Simulated time; a whole number of the system's fixed steps.
    master
        ``"libcosim"`` (``CosimExecution.from_ssp_file``, fixed-step Jacobi) or
        ``"gauss-seidel"`` (fmpy, controller before plant; see the module docstring).
    allow_long
        Run a stop time beyond :data:`~ballbot_casadi.fmi.ssp_check.MAX_STEPS` steps
        when ``duration`` is not given (refused otherwise).

    Raises
    ------
    ScenarioError
        Unknown master, a bad duration, a stop time beyond the cap.
    FileFormatError, StateError
        The SSP or an FMU in it is malformed, unsafe or truncated, or its start state is
        off the unit quaternion (:func:`~ballbot_casadi.fmi.ssp_check.open_ssp`).
    BuildError
        A step fails.
    """
    if master not in MASTERS:
        raise ScenarioError(f"unknown master {master!r}; allowed: {', '.join(MASTERS)}")
    ssp = Path(ssp)
    tmp = Path(tempfile.mkdtemp(prefix="ballbot-ssp-"))
    try:
        # members, FMUs (complete binaries), connections and start values checked here
        system, fmus, variables = open_ssp(ssp, tmp / "ssp")
        n = _steps(ssp, system, duration, allow_long)
        scenario, specs = read_scenario(ssp)
        unzipped = {c: Path(extract(str(f), unzipdir=str(tmp / "unzipped" / c)))
                    for c, f in fmus.items()}
        rec = _recorded(system, variables)
        t_wall = time.perf_counter()
        if master == "libcosim":
            signals = _run_libcosim(ssp, system, n, system.step, variables, rec)
        else:
            signals = _run_gauss_seidel(system, unzipped, n, system.step, variables, rec)
        wall = time.perf_counter() - t_wall
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return SilRun(system.start_time + np.arange(n + 1) * system.step, signals,
                  system.connections, master, scenario, specs, wall)


# ------------------------------------------------------------------ the log


def sil_log(run: SilRun, scenario: Scenario | None = None) -> SimulationLog:
    """The run in the layout of the compiled mission's log (:meth:`ClosedLoop.simulate`).

    Row ``k`` of the per-period arrays is period ``k`` (``[t_k, t_k+1)``): ``state`` and
    ``meas`` at ``t_k``, ``tau`` the torque acting on the plant in it (its inputs
    saturated at the plant's ``tau_max``, plus the disturbance), ``tau_cmd``, ``x_hat``,
    the references used, ``diag``, ``nis`` and ``repairs`` of the controller's period
    ``k`` (its outputs at ``t_k+1``).
    """
    sc = scenario if scenario is not None else run.scenario
    if sc is None:
        raise ScenarioError("the SSP carries no scenario; pass the scenario to sil_log")
    s = run.signals
    missing = [n for n in STATE.names if f"{PLANT}.{n}" not in s]
    if missing:
        raise ScenarioError(f"the plant FMU has no outputs {', '.join(missing)}: the log in the "
                            "mission's layout needs the state (the connections are logged anyway)")
    n = run.time.size - 1

    def cols(comp: str, names: Sequence[str]) -> np.ndarray:
        return np.column_stack([s[f"{comp}.{m}"] for m in names])

    params = sc.plant_params()
    tau_in = cols(PLANT, _TORQUES)[:n]
    dist = cols(PLANT, DISTURBANCE_NAMES)[:n] if f"{PLANT}.tau_dist0" in s else np.zeros((n, 3))
    tau = np.clip(tau_in, -params.tau_max, params.tau_max) + dist
    meas = cols(PLANT, READING_NAMES)[:n].copy()
    meas[0, MEAS["enc"]] = np.nan  # the controller takes the first encoder reading as missing
    ctrl = {k: cols(CONTROLLER, names)[1:] for k, names in (
        ("tau_cmd", [f"tau_cmd{i}" for i in range(3)]), ("x_hat", XHAT_NAMES),
        ("q_ref", [f"q_ref_used{i}" for i in range(4)]),
        ("dq_ref", [f"dq_ref_used{i}" for i in range(4)]),
        ("ddq_ref", [f"ddq_ref_used{i}" for i in range(4)]),
        ("diag", [f"diag_{m}" for m in BALANCE_DIAG_NAMES]),
        ("nis", ["nis_attitude", "nis_velocity"]), ("repairs", ["repairs"]))}
    inp_v = cols(CONTROLLER, REFERENCE_NAMES[12:15])[:n]
    w = np.zeros((n, 6))
    w[:, 3:6] = dist
    arrays = {"time": run.time - run.time[0], "state": cols(PLANT, STATE.names),
              "tau": tau, "meas": meas, "v_ref": inp_v, "w": w, **ctrl}
    if all(f"{PLANT}.{m}" in s for m in WHEEL_ANGLE_NAMES):
        arrays["phi"] = cols(PLANT, WHEEL_ANGLE_NAMES)
    return SimulationLog(arrays=arrays, scenario=sc.to_dict(), params=params,
                         ctrl_params=sc.controller_params(), diag_names=tuple(BALANCE_DIAG_NAMES),
                         extra={"master": run.master, "sil": True})

"""Software in the loop: plant FMU + controller FMU + reference player as an SSP system.

The system (:func:`sil_system`, written by :func:`write_sil_ssp`, ``make sil``):

* ``plant`` - ``BallbotPlant.fmu`` (or any FMU with its variable names) with the
  scenario's plant parameters, sensor parameters, noise switch, heading-sensor switch
  and seed (a 32-bit signed Integer in the FMU), internal step ``Ts / n_sub`` and sensor
  period ``Ts``;
* ``controller`` - ``BallbotController[_<ctrl>_<est>].fmu`` (the scenario's controller and
  estimator, :func:`~ballbot_casadi.fmi.controller.controller.model_identifier`;
  :mod:`~ballbot_casadi.fmi.controller.controller`) with the scenario's controller and filter models, gains, tuning and state at power-on;
  a scenario with a ``[path]`` (and ``[[obstacle]]`` rows) gets the path-following
  variant ``BallbotControllerPath[_<est>].fmu`` (built per scenario under ``<fmu>/path/<name>/``:
  its MPC predicts with the scenario's controller model) with the path table, the
  obstacles and ``path_s0`` in the parameter set (:mod:`~ballbot_casadi.fmi.controller.path`);
* ``reference`` - ``BallbotReference.fmu`` (:mod:`~ballbot_casadi.fmi.reference_player.player`),
  the scenario's per-period references and wheel-torque disturbance;
* connections ``plant.sensor_* -> controller.sensor_*`` (the readings the controller's
  estimator reads: with ``ukf_heading`` / ``ekf_heading`` also ``sensor_heading``, the
  plant's heading sensor, NaN between its low-rate samples), ``controller.tau0..2 ->
  plant.tau0..2``, ``reference.<reference> -> controller.<reference>``,
  ``reference.tau_dist0..2 -> plant.tau_dist0..2``; one parameter set ``scenario``;
  the default experiment: the scenario's duration with a fixed 5 ms step
  (``osp:FixedStepAlgorithm``); the scenario itself as ``resources/scenario.json``.

The masters that run it (libcosim's Jacobi algorithm, the controller-first Gauss-Seidel
master on fmpy) are in :mod:`ballbot_casadi.fmi.masters`
(:func:`~ballbot_casadi.fmi.masters.ssp_run.run_ssp`, which explains their timing); this
module only composes the system.

A run of the system is a :class:`SilRun` (every connection logged at every communication
point, plus :func:`recorded_signals`); :func:`~ballbot_casadi.fmi.system.sil_log.sil_log` turns it
into a :class:`~ballbot_casadi.sim.log.SimulationLog` in the mission's layout.
"""

from __future__ import annotations

import json
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
from fmpy import read_model_description

from ballbot_casadi.control import BALANCE_DIAG_NAMES
from ballbot_casadi.core.layout import STATE
from ballbot_casadi.core.params import PARAM_NAMES
from ballbot_casadi.core.sensor_params import SENSOR_VECTOR_NAMES
from ballbot_casadi.core.toolchain import build_root
from ballbot_casadi.errors import BallbotError, BuildError, FileFormatError, ScenarioError
from ballbot_casadi.fmi.build import build_fmu
from ballbot_casadi.fmi.controller.controller import (
    REFERENCE_NAMES,
    REJECTION_NAMES,
    V_REF_USED_NAMES,
    XHAT_NAMES,
    controller_spec,
    controller_values,
    embedded_function,
    path_embedded_function,
    reading_names,
)
from ballbot_casadi.fmi.controller.path import path_law
from ballbot_casadi.fmi.package import FmuBuild, build_fmu_from_spec
from ballbot_casadi.fmi.plant.plant import WHEEL_ANGLE_NAMES, X0_PREFIX
from ballbot_casadi.fmi.reference_player.player import DISTURBANCE_NAMES, reference_player_spec
from ballbot_casadi.fmi.spec import INT32_MAX
from ballbot_casadi.fmi.system.ssp import SspComponent, SspConnection, SspSystem, write_ssp
from ballbot_casadi.sim.embedded import DEFAULT_ESTIMATOR, ESTIMATOR_FILTERS
from ballbot_casadi.sim.scenario import Scenario

__all__ = [
    "PLANT",
    "CONTROLLER",
    "REFERENCE",
    "TORQUES",
    "CONTROLLER_RECORDED",
    "SCENARIO_RESOURCE",
    "SilRun",
    "recorded_signals",
    "plant_parameters",
    "sil_connections",
    "sil_controller",
    "sil_system",
    "write_sil_ssp",
    "read_scenario",
]

PLANT, CONTROLLER, REFERENCE = "plant", "controller", "reference"
SCENARIO_RESOURCE = "scenario.json"
#: The wheel torques the controller sends the plant.
TORQUES = tuple(f"tau{i}" for i in range(3))
#: Controller outputs recorded besides the connections (the estimate and diagnostics).
CONTROLLER_RECORDED = (
    *(f"tau_cmd{i}" for i in range(3)), *XHAT_NAMES, "roll_hat", "pitch_hat", "yaw_hat",
    *(f"omega_hat_{c}" for c in "xyz"),
    *(f"{w}_ref_used{i}" for w in ("q", "dq", "ddq") for i in range(4)),
    *(f"diag_{n}" for n in BALANCE_DIAG_NAMES), "nis_attitude", "nis_velocity", "repairs",
    *REJECTION_NAMES, *V_REF_USED_NAMES,
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
        The master that ran it (:data:`~ballbot_casadi.fmi.masters.ssp_run.MASTERS`).
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
    ``noise_on``, ``heading_sensor``, ``seed`` and the initial state (the parameters ``x0_<state>`` the
    plant's states start from).

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
        "heading_sensor": bool(scenario.heading_sensor),
        "seed": int(scenario.seed),
        **dict(zip((X0_PREFIX + n for n in STATE.names), (float(v) for v in scenario.x0))),
    }
    if variables is not None:
        values = {k: v for k, v in values.items() if k in set(variables)}
    return values


def sil_connections(plant_variables: Sequence[str], estimator: str = DEFAULT_ESTIMATOR
                    ) -> list[SspConnection]:
    """The SIL connections: the readings ``estimator`` reads
    (:func:`~ballbot_casadi.fmi.controller.controller.reading_names`), the torques, the
    references; the disturbance only if the plant has ``tau_dist0..2``."""
    cons = [SspConnection(PLANT, n, CONTROLLER, n) for n in reading_names(estimator)]
    cons += [SspConnection(CONTROLLER, n, PLANT, n) for n in TORQUES]
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
        A scenario without an estimator, with pushes, sensor dropouts or glitches, or a
        seed beyond 32 bits.
    BuildError
        The plant FMU lacks a variable the system connects.
    """
    if scenario.estimator == "true":
        raise ScenarioError(f"scenario {scenario.name!r}: the SIL runs the embedded software, "
                            f"which reads sensors; set estimator = one of {', '.join(ESTIMATOR_FILTERS)}")
    if scenario.sensor_dropouts:  # refused, never silently dropped
        raise ScenarioError(f"scenario {scenario.name!r} has [[sensor_dropout]] rows, which the "
                            "SSP cannot express (the FMUs have no dropout input); remove them "
                            "to write the SIL system")
    if scenario.sensor_glitches:  # the plant FMU draws its own noise: no way to inject them
        raise ScenarioError(f"scenario {scenario.name!r} has [[sensor_glitch]] rows, which the "
                            "SSP cannot express (the plant FMU draws its own sensor noise); "
                            "remove them to write the SIL system")
    out = Path(out) if out is not None else None
    plant = Path(build_fmu(out).fmu if plant_fmu is None else plant_fmu)
    causality = {v.name: v.causality for v in read_model_description(str(plant)).modelVariables}
    names = list(causality)
    readings = reading_names(scenario.estimator)
    missing = [n for n in TORQUES if causality.get(n) != "input"] + [
        n for n in readings if causality.get(n) != "output"]
    if missing:
        raise BuildError(f"plant FMU {plant} lacks {', '.join(missing)}; a plant for the SIL of "
                         f"estimator {scenario.estimator!r} needs the inputs tau0..2 and the "
                         f"outputs {', '.join(readings)} (Real)")
    ctrl, values = sil_controller(scenario, out)
    fmu_dir = out if out is not None else build_root() / "fmu"
    ref_dir = fmu_dir / "reference" / scenario.name
    ref = build_fmu_from_spec(reference_player_spec(scenario), ref_dir)
    components = [
        SspComponent(PLANT, plant, plant_parameters(scenario, names)),
        SspComponent(CONTROLLER, ctrl.fmu, values),
        SspComponent(REFERENCE, ref.fmu, {"Ts": float(scenario.Ts)}),
    ]
    return components, sil_connections(names, scenario.estimator)


def sil_controller(scenario: Scenario, out: str | Path | None = None, fmi_version: int = 2
                   ) -> tuple[FmuBuild, dict[str, float | bool]]:
    """The controller FMU of ``scenario``'s SIL system (built, FMI ``fmi_version``) and
    its parameter values.

    A scenario with a ``[path]`` gets the path-following variant, built per scenario under
    ``<out>/path/<name>/`` (its MPC predicts with this scenario's controller model and
    gains); the others the controller FMU of their controller and estimator in ``out``
    (default ``<build>/fmu``, FMI 3.0 ``<build>/fmu3``).
    """
    if scenario.route.build() is not None:
        law = path_law(scenario)
        embedded = path_embedded_function(law, scenario.estimator)
        root = Path(out) if out is not None else build_root() / ("fmu" if fmi_version == 2
                                                                  else "fmu3")
        ctrl = build_fmu_from_spec(controller_spec(path=scenario), root / "path" / scenario.name,
                                   fmi_version=fmi_version)
        return ctrl, controller_values(scenario, embedded, law)
    embedded = embedded_function(scenario.controller, scenario.estimator)
    ctrl = build_fmu_from_spec(controller_spec(scenario.controller, scenario.estimator), out,
                               fmi_version=fmi_version)
    return ctrl, controller_values(scenario, embedded)


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


def recorded_signals(system: SspSystem, variables: Mapping[str, Mapping[str, Any]]) -> list[tuple[str, str]]:
    """``(component, variable)`` pairs to record: both ends of every connection, the
    plant's states and the controller's estimate and diagnostics (those the FMUs have)."""
    rec: list[tuple[str, str]] = []
    for c in system.connections:
        for pair in ((c.start_element, c.start_connector), (c.end_element, c.end_connector)):
            if pair not in rec:
                rec.append(pair)
    for comp, names in ((PLANT, (*STATE.names, *WHEEL_ANGLE_NAMES)),
                        (CONTROLLER, CONTROLLER_RECORDED)):
        rec += [(comp, n) for n in names if comp in variables and n in variables[comp]
                and (comp, n) not in rec]
    return rec

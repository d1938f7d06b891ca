"""The SIL system as one FMU: a container of plant, controller and reference FMUs.

Tools without SSP support run the closed loop as a single Co-Simulation FMU built with
fmpy's container support (:mod:`fmpy.container_fmu`: a prebuilt container binary that
loads the component FMUs from its ``resources/`` and steps them at a fixed internal
step): :func:`build_container` turns an SSP archive of :mod:`ballbot_casadi.fmi.system.ssp`
(e.g. ``build/fmu/BallbotSIL.ssp``) into ``BallbotSILContainer.fmu`` with

* the same components and connections;
* every value of the SSP's parameter set as a container variable ``<component>.<name>``
  with that start value (parameters; the plant's states as outputs with exact start
  values), so ``fmpy.simulate_fmu(container)`` runs the scenario and ``start_values``
  change it;
* outputs ``<component>.<name>`` for the plant's states, wheel angles and readings and the
  controller's torques, estimate and diagnostics;
* the fixed internal step of the SSP's default experiment (5 ms).

The container steps every component from ``t_k`` and then updates the connections in
order (a Jacobi master, like libcosim), so its result equals the libcosim run of the
same SSP (:mod:`ballbot_casadi.fmi.masters.ssp_run`).
"""

from __future__ import annotations

import hashlib
import shutil
import tempfile
import uuid
from pathlib import Path

from fmpy import read_model_description
from fmpy.container_fmu.cli import create_container_fmu
from fmpy.container_fmu.config import Component, Configuration, Connection
from fmpy.model_description import (
    CoSimulation,
    DefaultExperiment,
    ModelDescription,
    ModelVariable,
    Unknown,
)

from ballbot_casadi.core.layout import STATE
from ballbot_casadi.errors import BuildError, FileFormatError
from ballbot_casadi.fmi.controller.controller import READING_NAMES, REJECTION_NAMES, XHAT_NAMES
from ballbot_casadi.fmi.plant.plant import WHEEL_ANGLE_NAMES
from ballbot_casadi.fmi.system.ssp_check import open_ssp

__all__ = ["CONTAINER_NAME", "OUTPUTS", "build_container"]

CONTAINER_NAME = "BallbotSILContainer"
_CONTAINER_TYPES = {"Real": "Float64", "Integer": "Int32"}
#: ``(component, variable)`` exposed as container outputs (when the component has them).
OUTPUTS = (
    *(("plant", n) for n in (*STATE.names, *WHEEL_ANGLE_NAMES, *READING_NAMES)),
    *(("controller", n) for n in (*(f"tau{i}" for i in range(3)),
                                  *(f"tau_cmd{i}" for i in range(3)), *XHAT_NAMES, "roll_hat",
                                  "pitch_hat", "yaw_hat", "nis_attitude", "nis_velocity",
                                  "repairs", *REJECTION_NAMES)),
)


def _text(v: float | int | bool) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    return str(v) if isinstance(v, int) else repr(float(v))


def build_container(ssp: str | Path, fmu: str | Path) -> Path:
    """Build the container FMU ``fmu`` of the SSP system ``ssp`` (see the module docstring).

    Raises
    ------
    FileFormatError, StateError
        The SSP or an FMU in it is malformed, unsafe or truncated, has two connections
        into one input or no fixed step (:func:`~ballbot_casadi.fmi.system.ssp_check.open_ssp`).
    BuildError
        A variable the container exports is missing.
    """
    ssp, fmu = Path(ssp), Path(fmu)
    tmp = Path(tempfile.mkdtemp(prefix="ballbot-container-"))
    try:
        # members, FMUs (complete binaries), one connection per input, start values
        system, fmus, variables = open_ssp(ssp, tmp / "ssp")
        if system.step is None:
            raise FileFormatError(f"{ssp}: the default experiment has no fixed step")
        components: dict[str, Component] = {}
        for name, path in fmus.items():
            md = read_model_description(str(path))
            components[name] = Component(name=name, filename=path, modelDescription=md)

        def var(comp: str, name: str) -> ModelVariable:
            try:
                return variables[comp][name]
            except KeyError:
                raise BuildError(f"{ssp}: {comp} has no variable {name!r}") from None

        def port(comp: str, name: str) -> ModelVariable:
            # the container's configuration names FMI 3 types (fmpy writes a connection's
            # type as given, so FMI 2 components' "Real" and "Integer" are translated here)
            v = var(comp, name)
            return ModelVariable(name=v.name, valueReference=v.valueReference,
                                 type=_CONTAINER_TYPES.get(v.type, v.type))

        connections = [Connection(components[c.start_element], [port(c.start_element,
                                                                     c.start_connector)],
                                  components[c.end_element], [port(c.end_element, c.end_connector)])
                       for c in system.connections]
        mappings: dict[ModelVariable, list] = {}
        outputs: list[ModelVariable] = []
        for comp, values in system.parameters.items():
            for name, value in values.items():
                v = var(comp, name)
                is_state = v.causality == "output"
                cv = ModelVariable(name=f"{comp}.{name}", type=v.type,
                                   causality="output" if is_state else "parameter",
                                   variability=v.variability if is_state else "fixed",
                                   initial="exact", start=_text(value),
                                   description=v.description)
                mappings[cv] = [(components[comp], v)]
                if is_state:
                    outputs.append(cv)
        taken = {cv.name for cv in mappings}
        for comp, name in OUTPUTS:
            if comp not in variables or name not in variables[comp] or f"{comp}.{name}" in taken:
                continue
            v = variables[comp][name]
            cv = ModelVariable(name=f"{comp}.{name}", type=v.type, causality="output",
                               variability=v.variability, initial="calculated",
                               description=v.description)
            mappings[cv] = [(components[comp], v)]
            outputs.append(cv)
        time = ModelVariable(name="time", type="Real", causality="independent",
                             variability="continuous")
        token = hashlib.sha256(ssp.read_bytes()).digest()[:16]
        md = ModelDescription(
            fmiVersion="2.0", modelName=CONTAINER_NAME,
            instantiationToken="{" + str(uuid.UUID(bytes=token)) + "}",
            description=f"ballbot software in the loop as one FMU (fmpy container of "
            f"{', '.join(system.components)}) from {ssp.name}",
            generationTool="ballbot-casadi + fmpy.container_fmu",
            defaultExperiment=DefaultExperiment(startTime=repr(system.start_time),
                                                stopTime=repr(system.stop_time),
                                                stepSize=repr(system.step)),
            coSimulation=CoSimulation(modelIdentifier=CONTAINER_NAME,
                                      fixedInternalStepSize=system.step),
            modelVariables=[time, *mappings],
        )
        md.outputs = [Unknown(variable=v) for v in outputs]
        md.initialUnknowns = [Unknown(variable=v) for v in outputs if v.initial == "calculated"]
        config = Configuration(parallelDoStep=False, modelDescription=md,
                               components=list(components.values()), connections=connections,
                               variableMappings=mappings)
        work = tmp / "container"
        work.mkdir()
        fmu.parent.mkdir(parents=True, exist_ok=True)
        part = tmp / fmu.name
        create_container_fmu(config, work, part)
        shutil.move(str(part), str(fmu))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return fmu

"""The software-in-the-loop system with the FMI 3.0 FMUs, run by an fmpy Jacobi master.

:func:`fmi3_system` builds the FMI 3.0 versions of the plant, controller and reference
FMUs of a scenario (the same specs, tables and per-model C as the FMI 2.0 ones, see
:func:`~ballbot_casadi.fmi.package.build_fmu_from_spec`) and takes the connections and
parameter sets of the FMI 2.0 system (:func:`~ballbot_casadi.fmi.system.sil.sil_system`): the
variable names and value references are the same in both versions.  A scenario with a
``[path]`` gets the FMI 3.0 path-following controller FMU
(:func:`~ballbot_casadi.fmi.system.sil.sil_controller`).

:func:`run_fmi3_jacobi` co-simulates it the way libcosim runs the FMI 2.0 SSP (libcosim
has no FMI 3.0): at every ``t_k`` every input is set from the outputs at ``t_k`` and
then every FMU steps by ``Ts``.  It therefore equals the compiled mission with the
one-period actuation delay (``run_scenario(..., actuation_delay=True)``).  No clocks:
the controller's period is the fixed communication step.
"""

from __future__ import annotations

import shutil
import tempfile
import time
from pathlib import Path
from typing import Any, Mapping

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi3 import FMU3Slave

from ballbot_casadi.core.toolchain import build_root
from ballbot_casadi.errors import CosimError
from ballbot_casadi.fmi.package import FmuBuild, build_fmu_from_spec
from ballbot_casadi.fmi.plant.plant import plant_spec
from ballbot_casadi.fmi.reference_player.player import reference_player_spec
from ballbot_casadi.fmi.system.sil import (
    CONTROLLER,
    PLANT,
    REFERENCE,
    SilRun,
    recorded_signals,
    sil_controller,
    sil_system,
)
from ballbot_casadi.fmi.system.ssp import SspComponent, SspConnection
from ballbot_casadi.sim.scenario import Scenario

__all__ = ["FMI3_MASTER", "fmi3_system", "run_fmi3_jacobi"]

#: :attr:`~ballbot_casadi.fmi.system.sil.SilRun.master` of :func:`run_fmi3_jacobi`.
FMI3_MASTER = "fmi3-jacobi"


def fmi3_system(scenario: Scenario, out: str | Path | None = None
                ) -> tuple[dict[str, FmuBuild], list[SspComponent], list[SspConnection]]:
    """The FMI 3.0 builds ``{component: build}`` and the SIL system's components
    (parameter sets) and connections.  ``out`` defaults to ``<build>/fmu3``."""
    out = Path(out) if out is not None else build_root() / "fmu3"
    components, connections = sil_system(scenario)
    builds = {
        PLANT: build_fmu_from_spec(plant_spec(), out, fmi_version=3),
        CONTROLLER: sil_controller(scenario, out, fmi_version=3)[0],
        REFERENCE: build_fmu_from_spec(reference_player_spec(scenario),
                                       out / "reference" / scenario.name, fmi_version=3),
    }
    return builds, components, connections


class _System:
    """What :func:`~ballbot_casadi.fmi.system.sil.recorded_signals` reads of a system."""

    def __init__(self, components: list[SspComponent], connections: list[SspConnection]):
        self.components = {c.name: c.fmu for c in components}
        self.connections = tuple(connections)


def run_fmi3_jacobi(scenario: Scenario, duration: float | None = None,
                    out: str | Path | None = None) -> SilRun:
    """Co-simulate the FMI 3.0 SIL system of ``scenario`` with a fixed-step Jacobi master.

    Returns a :class:`~ballbot_casadi.fmi.system.sil.SilRun` (master :data:`FMI3_MASTER`) with
    the signals :func:`~ballbot_casadi.fmi.system.sil_log.sil_log` reads.

    Raises
    ------
    CosimError
        An FMU call fails.
    """
    builds, components, connections = fmi3_system(scenario, out)
    n = scenario.n_periods if duration is None else int(round(duration / scenario.Ts))
    step, t0 = float(scenario.Ts), 0.0
    tmp = Path(tempfile.mkdtemp(prefix="ballbot-fmi3-"))
    slaves: dict[str, FMU3Slave] = {}
    try:
        unz = {c: extract(str(b.fmu), unzipdir=str(tmp / c)) for c, b in builds.items()}
        variables = {c: {v.name: v for v in read_model_description(d).modelVariables}
                     for c, d in unz.items()}
        system = _System(components, connections)
        rec = recorded_signals(system, variables)
        for c, b in builds.items():
            s = FMU3Slave(guid=b.guid, unzipDirectory=unz[c], modelIdentifier=b.model_identifier,
                          instanceName=c)
            s.instantiate()
            slaves[c] = s

        def get(comp: str, name: str) -> float:
            v, s = variables[comp][name], slaves[comp]
            if v.type == "Float64":
                return s.getFloat64([v.valueReference])[0]
            if v.type == "Int32":
                return float(s.getInt32([v.valueReference])[0])
            return float(s.getBoolean([v.valueReference])[0])

        def put(comp: str, name: str, value: Any) -> None:
            v, s = variables[comp][name], slaves[comp]
            if v.type == "Float64":
                s.setFloat64([v.valueReference], [float(value)])
            elif v.type == "Int32":
                s.setInt32([v.valueReference], [int(value)])
            else:
                s.setBoolean([v.valueReference], [bool(value)])

        params: Mapping[str, Mapping[str, Any]] = {c.name: c.parameters for c in components}
        t_wall = time.perf_counter()
        for comp, s in slaves.items():
            s.enterInitializationMode(startTime=t0)
            for name, value in params.get(comp, {}).items():
                put(comp, name, value)
            s.exitInitializationMode()
        signals = {f"{c}.{v}": np.zeros(n + 1) for c, v in rec}
        for k in range(n + 1):
            values = {(c.start_element, c.start_connector): get(c.start_element,
                                                                 c.start_connector)
                      for c in connections}  # every output at t_k, before any input is set
            for key, (c, v) in zip(signals, rec):
                if variables[c][v].causality != "input":
                    signals[key][k] = get(c, v)
            if k == n:
                break
            for con in connections:
                put(con.end_element, con.end_connector,
                    values[(con.start_element, con.start_connector)])
            for key, (c, v) in zip(signals, rec):
                if variables[c][v].causality == "input":
                    signals[key][k] = get(c, v)
            for s in slaves.values():
                s.doStep(t0 + k * step, step)
        for key, (c, v) in zip(signals, rec):
            if variables[c][v].causality == "input":
                signals[key][n] = np.nan
        wall = time.perf_counter() - t_wall
    except Exception as exc:  # fmpy raises plain exceptions for failed FMI calls
        raise CosimError(f"FMI 3.0 co-simulation of {scenario.name!r} failed: {exc}") from None
    finally:
        for s in slaves.values():
            s.freeInstance()
        shutil.rmtree(tmp, ignore_errors=True)
    return SilRun(t0 + np.arange(n + 1) * step, signals, tuple(connections), FMI3_MASTER,
                  scenario, (), wall)

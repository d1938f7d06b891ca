"""Shared helpers of the controller-FMU and SIL tests: cached builds, fmpy instances with
captured logs, the compiled embedded step of the mission library."""

from __future__ import annotations

import functools
from ctypes import c_double, c_int, c_void_p

import numpy as np

from ballbot_casadi.core.constants import N_SUB
from ballbot_casadi.core.toolchain import load_library
from ballbot_casadi.fmi.controller.controller import controller_spec, controller_values, default_scenario
from ballbot_casadi.fmi.package import FmuBuild, build_fmu_from_spec
from ballbot_casadi.sim.library import closed_loop_library


@functools.lru_cache(maxsize=None)
def controller_build(controller: str = "flc", estimator: str = "ukf") -> FmuBuild:
    """The controller FMU, built once per session (cached on disk by content hash)."""
    return build_fmu_from_spec(controller_spec(controller, estimator))


@functools.lru_cache(maxsize=None)
def compiled_embedded(controller: str = "flc", estimator: str = "ukf"):
    """``ballbot_embedded_<controller>_<estimator>`` from the compiled mission library."""
    lib, _, _ = closed_loop_library(N_SUB, None, estimator)
    name = f"ballbot_embedded_{controller}_{estimator}"
    return load_library(lib, [name])[name]


@functools.lru_cache(maxsize=None)
def default_values(controller: str = "flc", estimator: str = "ukf") -> dict:
    return controller_values(default_scenario(controller, estimator))


class Controller:
    """One fmpy Co-Simulation instance of a controller FMU with a logger recording every
    message."""

    def __init__(self, controller: str = "flc", estimator: str = "ukf", name: str = "ctrl"):
        from fmpy import calloc, free, read_model_description
        from fmpy.fmi2 import (
            FMU2Slave,
            fmi2CallbackAllocateMemoryTYPE,
            fmi2CallbackFreeMemoryTYPE,
            fmi2CallbackFunctions,
            fmi2CallbackLoggerTYPE,
        )

        b = controller_build(controller, estimator)
        md = read_model_description(str(b.unzipped))
        self.vars = {v.name: v for v in md.modelVariables}
        self.logs: list[tuple[int, str]] = []
        self.fmu = FMU2Slave(guid=b.guid, unzipDirectory=str(b.unzipped),
                             modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
        cb = fmi2CallbackFunctions()
        cb.logger = fmi2CallbackLoggerTYPE(self._log)
        cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        self._cb = cb
        self.fmu.instantiate(callbacks=cb)
        self.t = 0.0

    def _log(self, env, name, status, category, message):
        self.logs.append((int(status), message.decode()))

    def vr(self, *names: str) -> list[int]:
        return [self.vars[n].valueReference for n in names]

    def set(self, **values) -> None:
        for n, v in values.items():
            if isinstance(v, bool):
                self.fmu.setBoolean(self.vr(n), [v])
            else:
                self.fmu.setReal(self.vr(n), [float(v)])

    def set_many(self, names, values) -> None:
        self.fmu.setReal(self.vr(*names), [float(v) for v in values])

    def get(self, *names: str) -> np.ndarray:
        return np.array(self.fmu.getReal(self.vr(*names)))

    def init(self, values: dict | None = None) -> None:
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        for n, v in (values or {}).items():
            self.set(**{n: v})
        self.fmu.exitInitializationMode()
        self.t = 0.0

    def raw(self, fname: str, *args) -> int:
        f = getattr(self.fmu.dll, fname)
        f.restype = c_int
        return f(c_void_p(self.fmu.component), *args)

    def raw_step(self, h: float) -> int:
        return self.raw("fmi2DoStep", c_double(self.t), c_double(h), 1)

    def step(self, h: float = 0.005) -> None:
        self.fmu.doStep(self.t, h)
        self.t += h

    def errors(self) -> list[str]:
        return [m for s, m in self.logs if s >= 3]

    def free(self) -> None:
        self.fmu.freeInstance()

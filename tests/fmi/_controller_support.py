"""Shared helpers of the controller-FMU and SIL tests: cached builds, instances on the
masters' adapter with captured logs, the compiled embedded step of the mission library."""

from __future__ import annotations

import functools
from ctypes import c_double, c_int, c_void_p

import numpy as np

from ballbot_casadi.core.constants import N_SUB
from ballbot_casadi.core.toolchain import load_library
from ballbot_casadi.fmi.controller.controller import (
    controller_spec,
    controller_values,
    default_scenario,
)
from ballbot_casadi.fmi.masters.adapter import FmuSlave
from ballbot_casadi.fmi.package import FmuBuild, build_fmu_from_spec
from ballbot_casadi.sim.embedded import DEFAULT_ESTIMATOR
from ballbot_casadi.sim.library import closed_loop_library


@functools.lru_cache(maxsize=None)
def controller_build(controller: str = "flc", estimator: str = DEFAULT_ESTIMATOR) -> FmuBuild:
    """The controller FMU, built once per session (cached on disk by content hash)."""
    return build_fmu_from_spec(controller_spec(controller, estimator))


@functools.lru_cache(maxsize=None)
def compiled_embedded(controller: str = "flc", estimator: str = DEFAULT_ESTIMATOR):
    """``ballbot_embedded_<controller>_<estimator>`` from the compiled mission library."""
    lib, _, _ = closed_loop_library(N_SUB, None, estimator)
    name = f"ballbot_embedded_{controller}_{estimator}"
    return load_library(lib, [name])[name]


@functools.lru_cache(maxsize=None)
def default_values(controller: str = "flc", estimator: str = DEFAULT_ESTIMATOR) -> dict:
    return controller_values(default_scenario(controller, estimator))


class Controller:
    """One Co-Simulation instance of a controller FMU on the masters' adapter
    (:class:`~ballbot_casadi.fmi.masters.adapter.FmuSlave`) with a logger recording every
    message; ``fmu`` is the fmpy instance for raw calls."""

    def __init__(self, controller: str = "flc", estimator: str = DEFAULT_ESTIMATOR, name: str = "ctrl"):
        b = controller_build(controller, estimator)
        self.logs: list[tuple[int, str]] = []
        self.slave = FmuSlave(b.unzipped, name,
                              logger=lambda status, category, msg: self.logs.append((status, msg)))
        self.vars = self.slave.variables
        self.fmu = self.slave.fmu
        self.t = 0.0

    def vr(self, *names: str) -> list[int]:
        return self.slave.vr(*names)

    def set(self, **values) -> None:
        for n, v in values.items():
            self.slave.set(n, v)

    def set_many(self, names, values) -> None:
        self.slave.set_reals(names, values)

    def get(self, *names: str) -> np.ndarray:
        return self.slave.get_reals(names)

    def init(self, values: dict | None = None) -> None:
        self.slave.setup(0.0, values)
        self.slave.exit_initialization()
        self.t = 0.0

    def raw(self, fname: str, *args) -> int:
        f = getattr(self.fmu.dll, fname)
        f.restype = c_int
        return f(c_void_p(self.fmu.component), *args)

    def raw_step(self, h: float) -> int:
        return self.raw("fmi2DoStep", c_double(self.t), c_double(h), 1)

    def step(self, h: float = 0.005) -> None:
        self.slave.do_step(self.t, h)
        self.t += h

    def errors(self) -> list[str]:
        return [m for s, m in self.logs if s >= 3]

    def free(self) -> None:
        self.slave.free()

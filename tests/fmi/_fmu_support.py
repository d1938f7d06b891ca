"""Shared helpers of the plant-FMU tests: one cached build, fmpy instances with captured logs."""

from __future__ import annotations

import ctypes
import functools
import json
import subprocess
from ctypes import c_double, c_int, c_uint, c_void_p

import numpy as np

from ballbot_casadi.fmi.build import FmuBuild, build_fmu, build_tool, plant_variables

STATES = ("x", "y", "q0", "q1", "q2", "q3", "dx", "dy", "dq0", "dq1", "dq2", "dq3")
#: All continuous states of the FMU: the model states, then the wheel angles.
ALL_STATES = (*STATES, "phi0", "phi1", "phi2")
#: The parameters the model states start from (x0_<state>).
X0_NAMES = tuple(f"x0_{n}" for n in STATES)
NXW = len(ALL_STATES)
SENSORS = ("sensor_acc_x", "sensor_acc_y", "sensor_acc_z", "sensor_gyro_x", "sensor_gyro_y",
           "sensor_gyro_z", "sensor_enc0", "sensor_enc1", "sensor_enc2")


@functools.lru_cache(maxsize=None)
def plant_build() -> FmuBuild:
    """The plant FMU, built once per test session (cached on disk by content hash)."""
    return build_fmu()


def run_fuzz(build: FmuBuild, *args: str, cc: str | None = None, env: dict | None = None,
             timeout: float = 120) -> subprocess.CompletedProcess:
    """The C fuzzer of the FMI API (``fmu/tools/fuzz.c``) built for ``build`` and run with
    ``args`` (``{lib}`` and ``{guid}`` in an argument are the build's binary and GUID)."""
    exe = build_tool(build, "fuzz", cc=cc)
    return subprocess.run([str(exe), *[a.format(lib=build.binary, guid=build.guid) for a in args]],
                          capture_output=True, text=True, timeout=timeout, env=env)


def fuzz_counts(build: FmuBuild, n_calls: int, seed: int, timeout: float = 120) -> dict[str, int]:
    """The fuzzer's tallies of ``n_calls`` iterations from ``seed``; it must exit 0."""
    res = run_fuzz(build, "{lib}", "{guid}", str(n_calls), str(seed), timeout=timeout)
    assert res.returncode == 0, res.stderr[-2000:]
    return json.loads(res.stdout)


@functools.lru_cache(maxsize=None)
def vr_table() -> dict[str, int]:
    return {v.name: v.vr for v in plant_variables()}


def vrs_of_type(kind: str) -> list[int]:
    """Value references of every Real, Integer or Boolean variable."""
    return [v.vr for v in plant_variables() if v.type == kind]


def vrs(*names: str) -> list[int]:
    t = vr_table()
    return [t[n] for n in names]


def plant_dll() -> ctypes.CDLL:
    """The plant FMU's binary loaded with ctypes alone, for calls fmpy's handle would refuse
    (fmpy declares argument types there; these calls pass raw NULLs or make instances)."""
    return ctypes.CDLL(str(plant_build().binary))


def fmi2_callbacks(logger, allocate: bool = True, free: bool = True):
    """fmpy's FMI 2.0 callback struct: ``logger(env, name, status, category, message)`` and
    fmpy's ``calloc`` / ``free`` (either left out, NULL, when asked).  Keep the struct alive
    as long as the instance made with it."""
    from fmpy import calloc
    from fmpy import free as fmpy_free
    from fmpy.fmi2 import (
        fmi2CallbackAllocateMemoryTYPE,
        fmi2CallbackFreeMemoryTYPE,
        fmi2CallbackFunctions,
        fmi2CallbackLoggerTYPE,
    )

    cb = fmi2CallbackFunctions()
    cb.logger = fmi2CallbackLoggerTYPE(logger)
    if allocate:
        cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    if free:
        cb.freeMemory = fmi2CallbackFreeMemoryTYPE(fmpy_free)
    return cb


class Plant:
    """One fmpy instance of the plant with a logger that records every message."""

    def __init__(self, kind: str = "cs", name: str = "plant", guid: str | None = None,
                 logging_on: bool = False):
        from fmpy.fmi2 import FMU2Model, FMU2Slave

        b = plant_build()
        self.build = b
        self.kind = kind
        self.logs: list[tuple[int, str, str]] = []
        cls = FMU2Slave if kind == "cs" else FMU2Model
        self.fmu = cls(guid=guid or b.guid, unzipDirectory=str(b.unzipped),
                       modelIdentifier="BallbotPlant", instanceName=name)
        cb = fmi2_callbacks(self._log)
        self._cb = cb
        self.fmu.instantiate(callbacks=cb, loggingOn=logging_on)
        self.t = 0.0

    def _log(self, env, name, status, category, message):
        self.logs.append((int(status), category.decode(), message.decode()))

    # thin wrappers ------------------------------------------------------------------
    def set(self, **values: float) -> None:
        names = list(values)
        self.fmu.setReal(vrs(*names), [float(values[n]) for n in names])

    def get(self, *names: str) -> np.ndarray:
        return np.array(self.fmu.getReal(vrs(*names)))

    def state(self) -> np.ndarray:
        return self.get(*STATES)

    def set_int(self, **values: int) -> None:
        self.fmu.setInteger(vrs(*values), [int(v) for v in values.values()])

    def set_bool(self, **values: bool) -> None:
        self.fmu.setBoolean(vrs(*values), [bool(v) for v in values.values()])

    def get_int(self, *names: str) -> list[int]:
        return list(self.fmu.getInteger(vrs(*names)))

    def get_bool(self, *names: str) -> list[bool]:
        return [bool(b) for b in self.fmu.getBoolean(vrs(*names))]

    def snapshot(self) -> tuple[list[float], list[int], list[bool]]:
        """Every Real, Integer and Boolean value."""
        return (list(self.fmu.getReal(vrs_of_type("Real"))),
                list(self.fmu.getInteger(vrs_of_type("Integer"))),
                list(self.fmu.getBoolean(vrs_of_type("Boolean"))))

    def init(self, start_time: float = 0.0, **values: float) -> None:
        """Initialise: Reals by keyword (a state's name sets its start parameter
        ``x0_<name>``); ``noise_on`` (bool) and ``seed`` (int) as such."""
        values = {(f"x0_{k}" if k in ALL_STATES else k): v for k, v in values.items()}
        self.fmu.setupExperiment(startTime=start_time)
        self.fmu.enterInitializationMode()
        if "noise_on" in values:
            self.set_bool(noise_on=values.pop("noise_on"))
        if "seed" in values:
            self.set_int(seed=values.pop("seed"))
        if values:
            self.set(**values)
        self.fmu.exitInitializationMode()
        self.t = start_time
        if self.kind == "me":
            self.fmu.enterContinuousTimeMode()

    def step(self, h: float, n: int = 1) -> None:
        for _ in range(n):
            self.fmu.doStep(self.t, h)
            self.t += h

    def raw_set_real(self, vr: list[int], values: list[float]) -> int:
        """fmi2SetReal without fmpy's exception on error: returns the status."""
        f = getattr(self.fmu.dll, "fmi2SetReal")
        f.restype = c_int
        return f(c_void_p(self.fmu.component), (c_uint * len(vr))(*vr), len(vr),
                 (c_double * len(values))(*values))

    def raw(self, fname: str, *args) -> int:
        """Call an FMI function directly (first argument the component) and return the status."""
        f = getattr(self.fmu.dll, fname)
        f.restype = c_int
        return f(c_void_p(self.fmu.component), *args)

    def errors(self) -> list[str]:
        return [m for s, _, m in self.logs if s >= 2]

    def free(self) -> None:
        self.fmu.freeInstance()


def python_rk4(x0, tau, p, h_total: float, n_steps: int, h_int: float = 1e-3):
    """The Python model (CasADi RK4 Function) over n_steps communication steps."""
    rk4 = _rk4()
    x = np.asarray(x0, float).copy()
    sub = max(1, int(np.ceil(h_total / h_int * (1 - 1e-12))))
    hs = h_total / sub
    out = [x.copy()]
    for _ in range(n_steps):
        for _ in range(sub):
            x = np.asarray(rk4(x, tau, p, hs)).ravel()
        out.append(x.copy())
    return np.array(out)


@functools.lru_cache(maxsize=None)
def _rk4():
    from ballbot_casadi.model.dynamics import make_model_functions
    from ballbot_casadi.model.integrators import make_rk4

    return make_rk4(make_model_functions()["ode"])

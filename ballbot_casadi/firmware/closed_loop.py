"""The firmware's generated period, built for this PC, closed around the simulated robot.

The single-precision question of issue 21 (does the float build still meet the
complete-system specs?) needs the loop *closed*: the readings must come from a plant
driven by the float controller's torques, not from a recorded log.  This module

* compiles the firmware's generated period (the same ``ballbot_fw_cg.c`` the Cortex-M7
  build compiles, :func:`~ballbot_casadi.firmware.sources.generate_sources`, with
  ``casadi_real = float`` for ``"single"``) with the host ``gcc`` and the firmware's
  strict flags into a shared library, cached under ``<build>/firmware/host/`` by the
  hash of its source, flags and compiler (:func:`host_period_library`);
* wraps it as a CasADi :class:`~casadi.Callback` with the period's inputs and outputs
  (:class:`FirmwarePeriod`; the doubles are rounded to the library's real type on the
  way in and widened on the way out);
* puts that Callback in place of the embedded software in the package's own estimating
  step (:func:`~ballbot_casadi.sim.steps.make_estimating_step`: plant RK4, sensors with
  noise and drop-outs, the same ports) and runs a scenario through
  :func:`~ballbot_casadi.sim.closed_loop.run_scenario` (:func:`run_firmware_scenario`),
  so the log is a :class:`~ballbot_casadi.sim.log.SimulationLog` like any other.

With ``"double"`` the loop must equal the compiled mission (same Function, same inputs;
only the compilers' rounding differs), which validates the loop itself.
"""

from __future__ import annotations

import ctypes
import hashlib
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

from ballbot_casadi.control import balance_state_size
from ballbot_casadi.core.constants import N_SUB
from ballbot_casadi.core.toolchain import build_root, cached_file, compiler_command, run_tool
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.firmware.build import FW_CFLAGS, SINGLE_CFLAGS, default_scenario
from ballbot_casadi.firmware.sources import CG_NAME, firmware_function, generate_sources, scenario_values
from ballbot_casadi.firmware.toolchain import PRECISIONS, tool_version
from ballbot_casadi.model.dynamics import make_wheel_speeds
from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario
from ballbot_casadi.sim.embedded import DEFAULT_ESTIMATOR, ESTIMATOR_FILTERS, software_blocks
from ballbot_casadi.sim.library import MissionVariant
from ballbot_casadi.sim.log import SimulationLog
from ballbot_casadi.sim.scenario import Scenario
from ballbot_casadi.sim.steps import make_estimating_step

__all__ = ["host_period_library", "FirmwarePeriod", "firmware_step", "FirmwareLoop",
           "run_firmware_scenario"]

_CTYPE = {"double": (ctypes.c_double, np.float64), "single": (ctypes.c_float, np.float32)}


def host_period_library(controller: str = "flc", estimator: str = DEFAULT_ESTIMATOR,
                        precision: str = "double", root: Path | None = None) -> Path:
    """The firmware's generated period compiled for this PC as a shared library (cached).

    The source is the firmware build's ``ballbot_fw_cg.c`` for ``precision``; the flags
    are the firmware's (:data:`~ballbot_casadi.firmware.build.FW_CFLAGS`, plus
    :data:`~ballbot_casadi.firmware.build.SINGLE_CFLAGS` in single precision) and
    ``-fPIC -shared``.

    Raises
    ------
    ScenarioError
        Unknown controller, estimator or precision.
    BuildError
        The compiler failed.
    """
    if precision not in PRECISIONS:
        raise ScenarioError(f"unknown precision {precision!r}; allowed: {', '.join(PRECISIONS)}")
    f = firmware_function(controller, estimator)
    values = scenario_values(f, default_scenario(controller, estimator))
    src = generate_sources(f, precision, values)[f"{CG_NAME}.c"]
    cc = compiler_command()
    flags = [*FW_CFLAGS, *(SINGLE_CFLAGS if precision == "single" else ()), "-fPIC", "-shared"]
    digest = hashlib.sha256("\0".join([src, *cc, *flags, tool_version(cc[0])]).encode()).hexdigest()[:16]
    folder = (build_root() if root is None else Path(root)) / "firmware" / "host"
    folder.mkdir(parents=True, exist_ok=True)

    def make(target: Path) -> None:
        c_file = target.with_name(f"{CG_NAME}.c")
        c_file.write_text(src)
        run_tool([*cc, *flags, "-o", str(target), str(c_file), "-lm"],
                 f"compiling the {precision} firmware period for this PC")

    return cached_file(folder / f"{controller}_{estimator}_{precision}-{digest}.so", make, digest)


class FirmwarePeriod(ca.Callback):
    """The host-compiled firmware period as a CasADi Function with the period's ports.

    Inputs are rounded to the library's real type (``float`` in single precision), the
    outputs widened back to double; dense, column-major, as the generated C lays them out.
    """

    def __init__(self, controller: str = "flc", estimator: str = DEFAULT_ESTIMATOR,
                 precision: str = "double", root: Path | None = None) -> None:
        ca.Callback.__init__(self)
        self._f = firmware_function(controller, estimator)
        self.precision = precision
        self.path = host_period_library(controller, estimator, precision, root)
        self._lib = ctypes.CDLL(str(self.path))
        self._entry = getattr(self._lib, self._f.name())
        ctype, self._dtype = _CTYPE[precision]
        ptr = ctypes.POINTER(ctype)
        self._entry.argtypes = [ctypes.POINTER(ptr), ctypes.POINTER(ptr), ctypes.POINTER(ctypes.c_int),
                                ptr, ctypes.c_int]
        self._entry.restype = ctypes.c_int
        self._ptr = ptr
        f = self._f
        self._arg = (ptr * max(f.sz_arg(), 1))()
        self._res = (ptr * max(f.sz_res(), 1))()
        self._iw = (ctypes.c_int * max(f.sz_iw(), 1))()
        self._w = np.zeros(max(f.sz_w(), 1), self._dtype)
        self._out = [np.zeros(f.nnz_out(i), self._dtype) for i in range(f.n_out())]
        self.construct(f"{f.name()}_host_{precision}", {})

    def get_n_in(self) -> int:
        return self._f.n_in()

    def get_n_out(self) -> int:
        return self._f.n_out()

    def get_name_in(self, i: int) -> str:
        return self._f.name_in(i)

    def get_name_out(self, i: int) -> str:
        return self._f.name_out(i)

    def get_sparsity_in(self, i: int) -> ca.Sparsity:
        return self._f.sparsity_in(i)

    def get_sparsity_out(self, i: int) -> ca.Sparsity:
        return self._f.sparsity_out(i)

    def eval(self, arg: list[Any]) -> list[ca.DM]:
        f = self._f
        ins = []
        for i, a in enumerate(arg):
            v = np.ascontiguousarray(ca.DM(a).nonzeros(), dtype=self._dtype)
            if v.size != f.nnz_in(i):
                raise ScenarioError(f"{f.name()}: input {f.name_in(i)} has {v.size} entries, "
                                    f"expected {f.nnz_in(i)}")
            ins.append(v)
            self._arg[i] = v.ctypes.data_as(self._ptr)
        for i, o in enumerate(self._out):
            self._res[i] = o.ctypes.data_as(self._ptr)
        rc = self._entry(self._arg, self._res, self._iw, self._w.ctypes.data_as(self._ptr), 0)
        if rc != 0:
            raise ScenarioError(f"{f.name()} ({self.precision}, host) returned {rc}")
        return [ca.DM(f.sparsity_out(i), o.astype(float)) for i, o in enumerate(self._out)]


def firmware_step(period: FirmwarePeriod, controller: str = "flc",
                  estimator: str = DEFAULT_ESTIMATOR, n_sub: int = N_SUB) -> ca.Function:
    """The estimating step of the compiled mission with ``period`` as its embedded software."""
    blocks, est = software_blocks(controller, estimator)
    return make_estimating_step(blocks.balance, blocks.velocity, est.ode, make_wheel_speeds(), est,
                                n_sub, period)


class FirmwareLoop(ClosedLoop):
    """A :class:`~ballbot_casadi.sim.closed_loop.ClosedLoop` whose only mission is the
    estimating step with the host-compiled firmware period (evaluated by CasADi, the
    plant and sensors as CasADi Functions, the period through ctypes)."""

    def __init__(self, controller: str = "flc", estimator: str = DEFAULT_ESTIMATOR,
                 precision: str = "double", n_sub: int = N_SUB, root: Path | None = None) -> None:
        if balance_state_size(controller):
            raise ScenarioError(f"the firmware loop runs balance controllers without own state; "
                                f"{controller!r} has one")
        super().__init__(compiled=False, n_sub=n_sub, steps={}, root=root, use_driver=False)
        self.period = FirmwarePeriod(controller, estimator, precision, root)
        self._key = (int(n_sub), estimator, False)
        self._fw = MissionVariant({controller: firmware_step(self.period, controller, estimator,
                                                             n_sub)}, None, False)

    def _variant(self, n_sub: int, estimator: str = "true",
                 actuation_delay: bool = False) -> MissionVariant:
        if (int(n_sub), estimator, bool(actuation_delay)) != self._key:
            raise ScenarioError(f"this firmware loop runs n_sub = {self._key[0]}, estimator "
                                f"{self._key[1]!r}, no actuation delay; got n_sub = {n_sub}, "
                                f"estimator {estimator!r}, actuation_delay = {actuation_delay}")
        return self._fw


def run_firmware_scenario(scenario: Scenario, precision: str = "double",
                          root: Path | None = None) -> SimulationLog:
    """Run ``scenario`` (an estimator in the loop) with the host-compiled firmware period
    of ``precision`` as the embedded software (see the module docstring)."""
    if scenario.estimator == "true":
        raise ScenarioError(f"scenario {scenario.name!r}: the firmware loop needs an estimator "
                            f"(estimator = one of {', '.join(ESTIMATOR_FILTERS)})")
    loop = FirmwareLoop(scenario.controller, scenario.estimator, precision, scenario.n_sub, root)
    return run_scenario(scenario, loop)

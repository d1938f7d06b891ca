"""One FMI 2.0 Co-Simulation instance driven by variable name: the adapter every Python
master of the package steps FMUs through (fmpy's :class:`~fmpy.fmi2.FMU2Slave` underneath).

:class:`FmuSlave` reads the unzipped FMU's ``modelDescription.xml`` once, instantiates
it under an instance name and offers the calls a master needs - set up and initialise,
get and set by name (each value by its variable's type: Real, Integer or Boolean, or a
block of Reals in one call), ``fmi2DoStep``, terminate, free - so no master handles value
references or fmpy's per-type calls.  Values pass through unchanged (Python ``float`` to
``fmi2Real``), so a master on the adapter computes bit for bit what the same sequence of
raw fmpy calls computes.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable, Iterable, Mapping, Sequence

import numpy as np
from fmpy import calloc, free, read_model_description
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)

from ballbot_casadi.errors import CosimError

__all__ = ["FmuSlave"]

#: ``logger(status, category, message)``: receives every message the FMU logs.
Logger = Callable[[int, str, str], None]


class FmuSlave:
    """One Co-Simulation instance of the unzipped FMU ``unzipped``, driven by variable name.

    Parameters
    ----------
    unzipped
        The FMU's unzipped folder (``fmpy.extract``).
    instance_name
        The instance name (the component's name in a system).
    logger
        Optional ``logger(status, category, message)`` receiving every message of the
        FMU (default: fmpy's, which prints them).
    logging_on
        ``loggingOn`` of ``fmi2Instantiate``.

    Attributes
    ----------
    model_description
        fmpy's model description.
    variables
        ``{name: fmpy ScalarVariable}``.
    fmu
        The fmpy :class:`~fmpy.fmi2.FMU2Slave` (for raw calls a master does not need).
    """

    def __init__(self, unzipped: str | Path, instance_name: str,
                 logger: Logger | None = None, logging_on: bool = False):
        self.model_description = read_model_description(str(unzipped))
        md = self.model_description
        if md.coSimulation is None:
            raise CosimError(f"{md.modelName}: the FMU has no Co-Simulation interface")
        self.variables = {v.name: v for v in md.modelVariables}
        self.fmu = FMU2Slave(guid=md.guid, unzipDirectory=str(unzipped),
                             modelIdentifier=md.coSimulation.modelIdentifier,
                             instanceName=instance_name)
        self._callbacks = None
        if logger is None:
            self.fmu.instantiate(loggingOn=logging_on)
        else:
            cb = fmi2CallbackFunctions()
            cb.logger = fmi2CallbackLoggerTYPE(
                lambda env, name, status, category, message: logger(
                    int(status), category.decode(), message.decode()))
            cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
            cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
            self._callbacks = cb  # kept alive as long as the instance
            self.fmu.instantiate(callbacks=cb, loggingOn=logging_on)
        self._freed = False

    # ------------------------------------------------------------------ names
    def vr(self, *names: str) -> list[int]:
        """Value references of ``names``.

        Raises
        ------
        CosimError
            A name the FMU does not have.
        """
        try:
            return [self.variables[n].valueReference for n in names]
        except KeyError as e:
            raise CosimError(f"{self.model_description.modelName} has no variable {e.args[0]!r}"
                             ) from None

    def causality(self, name: str) -> str:
        """The variable's causality (``"input"``, ``"output"``, ``"parameter"``, ...)."""
        self.vr(name)
        return self.variables[name].causality

    # ------------------------------------------------------------------ life cycle
    def setup(self, start_time: float = 0.0, values: Mapping[str, Any] | None = None) -> None:
        """``fmi2SetupExperiment(start_time)``, ``fmi2EnterInitializationMode`` and the
        ``values`` (name -> value, in their order) set in initialisation mode."""
        self.fmu.setupExperiment(startTime=start_time)
        self.fmu.enterInitializationMode()
        for name, value in (values or {}).items():
            self.set(name, value)

    def exit_initialization(self) -> None:
        """``fmi2ExitInitializationMode``."""
        self.fmu.exitInitializationMode()

    def do_step(self, t: float, h: float) -> None:
        """``fmi2DoStep(t, h)`` (fmpy raises on an error status)."""
        self.fmu.doStep(t, h)

    def terminate(self) -> None:
        """``fmi2Terminate``."""
        self.fmu.terminate()

    def free(self) -> None:
        """``fmi2FreeInstance`` (once; later calls do nothing)."""
        if not self._freed:
            self._freed = True
            self.fmu.freeInstance()

    def __enter__(self) -> FmuSlave:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.free()

    # ------------------------------------------------------------------ values
    def get(self, name: str) -> float:
        """One variable's value as ``float`` (Integer and Boolean converted)."""
        vr = self.vr(name)
        v = self.variables[name]
        if v.type == "Real":
            return self.fmu.getReal(vr)[0]
        if v.type == "Integer":
            return float(self.fmu.getInteger(vr)[0])
        return float(self.fmu.getBoolean(vr)[0])

    def set(self, name: str, value: Any) -> None:
        """Set one variable by its type (Real: ``float``, Integer: ``int``, Boolean: ``bool``)."""
        vr = self.vr(name)
        kind = self.variables[name].type
        if kind == "Real":
            self.fmu.setReal(vr, [float(value)])
        elif kind == "Integer":
            self.fmu.setInteger(vr, [int(value)])
        else:
            self.fmu.setBoolean(vr, [bool(value)])

    def get_reals(self, names: Sequence[str]) -> np.ndarray:
        """The Real variables ``names`` in one ``fmi2GetReal``."""
        return np.array(self.fmu.getReal(self.vr(*names)))

    def set_reals(self, names: Sequence[str], values: Iterable[Any]) -> None:
        """The Real variables ``names`` in one ``fmi2SetReal``."""
        self.fmu.setReal(self.vr(*names), [float(v) for v in values])

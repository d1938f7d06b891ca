"""Run an SSP archive with one of the masters (:func:`run_ssp`, a
:class:`~ballbot_casadi.fmi.system.sil.SilRun`).

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

"""

from __future__ import annotations

import math
import shutil
import tempfile
import time
from pathlib import Path
from typing import Any, Sequence

import numpy as np
from fmpy import extract

from ballbot_casadi.errors import FileFormatError, ScenarioError
from ballbot_casadi.fmi.masters.gauss_seidel import run_gauss_seidel
from ballbot_casadi.fmi.masters.libcosim import run_libcosim
from ballbot_casadi.fmi.system.sil import (
    CONTROLLER,
    PLANT,
    REFERENCE,
    SilRun,
    read_scenario,
    recorded_signals,
)
from ballbot_casadi.fmi.system.ssp_check import MAX_STEPS, open_ssp

__all__ = ["MASTERS", "GAUSS_SEIDEL_ORDER", "run_ssp"]

#: Masters of :func:`run_ssp`.
MASTERS = ("libcosim", "gauss-seidel")
#: The Gauss-Seidel master's order: the controller first, then the plant on its new
#: torque, then the reference player (it reads nothing).
GAUSS_SEIDEL_ORDER = (CONTROLLER, PLANT, REFERENCE)


def _steps(ssp: Path, system: Any, duration: float | None, allow_long: bool) -> int:
    """Number of fixed steps of the run: ``duration`` or the SSP's stop time, a whole
    number of steps, at most :data:`~ballbot_casadi.fmi.system.ssp_check.MAX_STEPS` unless
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
            order: Sequence[str] | None = None, allow_long: bool = False) -> SilRun:
    """Co-simulate an SSP archive for ``duration`` s (default: its stop time).

    Parameters
    ----------
    ssp
        The ``.ssp`` file (e.g. from :func:`~ballbot_casadi.fmi.system.sil.write_sil_ssp`).
    duration
        Simulated time; a whole number of the system's fixed steps.
    master
        ``"libcosim"`` (``CosimExecution.from_ssp_file``, fixed-step Jacobi) or
        ``"gauss-seidel"`` (fmpy, controller before plant; see the module docstring).
    order
        Gauss-Seidel only: the components in the order they step at every ``t_k``
        (default :data:`GAUSS_SEIDEL_ORDER`).
    allow_long
        Run a stop time beyond :data:`~ballbot_casadi.fmi.system.ssp_check.MAX_STEPS` steps
        when ``duration`` is not given (refused otherwise).

    Raises
    ------
    ScenarioError
        Unknown master, a bad duration.
    BuildError
        The SSP cannot be loaded or a step fails.
    """
    if master not in MASTERS:
        raise ScenarioError(f"unknown master {master!r}; allowed: {', '.join(MASTERS)}")
    ssp = Path(ssp)
    tmp = Path(tempfile.mkdtemp(prefix="ballbot-ssp-"))
    try:
        # members, FMUs (complete binaries), connections and start values checked here
        system, fmus, variables = open_ssp(ssp, tmp / "ssp")
        if order is not None and (master != "gauss-seidel" or sorted(order) != sorted(
                system.components)):
            raise ScenarioError(f"order {tuple(order)!r}: only for master 'gauss-seidel', a "
                                f"permutation of {', '.join(system.components)}")
        n = _steps(ssp, system, duration, allow_long)
        scenario, specs = read_scenario(ssp)
        unzipped = {c: Path(extract(str(f), unzipdir=str(tmp / "unzipped" / c)))
                    for c, f in fmus.items()}
        rec = recorded_signals(system, variables)
        t_wall = time.perf_counter()
        if master == "libcosim":
            signals = run_libcosim(ssp, system, n, system.step, variables, rec)
        else:
            signals = run_gauss_seidel(system, unzipped, n, system.step, variables, rec,
                                       first=GAUSS_SEIDEL_ORDER if order is None else order)
        wall = time.perf_counter() - t_wall
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return SilRun(system.start_time + np.arange(n + 1) * system.step, signals,
                  system.connections, master, scenario, specs, wall)

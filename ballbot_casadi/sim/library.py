"""The compiled closed-loop library: every controller's step and chunk, built once per variant.

A variant of the mission is ``(n_sub, estimator, actuation_delay)``: RK4 sub-steps per
period, what the controllers read (``"true"`` state, or sensors and the embedded
software with ``"ukf"`` / ``"ekf"``), and the one-period actuation delay of a Jacobi
co-simulation master (:mod:`ballbot_casadi.sim.steps`).  :func:`closed_loop_library`
generates and compiles the steps and chunks of every balance controller (cached by the
hash of the generated C); :class:`MissionVariant` loads them, with the zero-copy C entry
point of :mod:`~ballbot_casadi.sim.driver`, and caches mission Functions.
"""

from __future__ import annotations

from pathlib import Path
from typing import Mapping

import casadi as ca
import numpy as np

from ballbot_casadi.control import BALANCE_CONTROLLERS, make_velocity_controller
from ballbot_casadi.core.constants import N_SUB
from ballbot_casadi.core.toolchain import Library, build_library, load_library
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.estimation.com_observer import make_com_observer
from ballbot_casadi.model.dynamics import make_affine, make_ode, make_wheel_speeds
from ballbot_casadi.sim.driver import MissionDriver
from ballbot_casadi.sim.embedded import embedded_software, software_blocks
from ballbot_casadi.sim.mission import CHUNK, compose_mission, make_chunk, make_mission
from ballbot_casadi.sim.ports import sequence_positions
from ballbot_casadi.sim.steps import make_closed_loop_step, make_estimating_step

__all__ = ["closed_loop_steps", "closed_loop_functions", "library_name", "closed_loop_library",
           "MissionVariant"]


def closed_loop_steps(n_sub: int = N_SUB, estimator: str = "true",
                      actuation_delay: bool = False) -> dict[str, ca.Function]:
    """Symbolic step Functions of every balance controller, each with the COM observer
    (``ballbot_com_observer``, switched by the ``com_observer`` input).

    Parameters
    ----------
    n_sub
        RK4 sub-steps per period.
    estimator
        ``"true"`` (controllers read the true state), ``"ukf"`` or ``"ekf"`` (noisy
        sensors and the embedded software :func:`~ballbot_casadi.sim.embedded.embedded_software`).
    actuation_delay
        With an estimator: the one-period actuation delay of a Jacobi master.
    """
    if actuation_delay and estimator == "true":
        raise ScenarioError("the actuation delay is an option of the missions with an estimator "
                            "('ukf' or 'ekf')")
    steps: dict[str, ca.Function] = {}
    if estimator == "true":
        ode, affine = make_ode(), make_affine()
        velocity, observer = make_velocity_controller(), make_com_observer()
        for name, builder in BALANCE_CONTROLLERS.items():
            steps[name] = make_closed_loop_step(builder(affine), velocity, ode, n_sub, observer)
        return steps
    for name in BALANCE_CONTROLLERS:
        blocks, est = software_blocks(name, estimator)
        # the plant's wheel-angle ODE has its own wheel-speed Function (as the generated C
        # always had: one copy for the plant, one inside the velocity filter)
        steps[name] = make_estimating_step(blocks.balance, blocks.velocity, est.ode,
                                           make_wheel_speeds(), est, n_sub,
                                           embedded_software(name, estimator),
                                           actuation_delay=actuation_delay)
    return steps


def closed_loop_functions(n_sub: int = N_SUB, estimator: str = "true",
                          actuation_delay: bool = False,
                          ) -> tuple[dict[str, ca.Function], list[ca.Function]]:
    """The steps of :func:`closed_loop_steps` and everything the library exports: each
    step, its chunk (:func:`~ballbot_casadi.sim.mission.make_chunk`) and, with an
    estimator, the embedded software ``ballbot_embedded_<ctrl>_<est>`` (the controller
    FMU's code)."""
    steps = closed_loop_steps(n_sub, estimator, actuation_delay)
    exported: list[ca.Function] = []
    for name, step in steps.items():
        exported += [step, make_chunk(step)]
        if estimator != "true":
            exported.append(embedded_software(name, estimator))
    return steps, exported


def library_name(n_sub: int, estimator: str = "true", actuation_delay: bool = False) -> str:
    """Name of the compiled closed-loop library of a variant."""
    name = "ballbot_closed_loop" if estimator == "true" else f"ballbot_closed_loop_{estimator}"
    name = f"{name}_delayed" if actuation_delay else name
    return name if n_sub == N_SUB else f"{name}_sub{n_sub}"


def closed_loop_library(n_sub: int = N_SUB, root: Path | None = None, estimator: str = "true",
                        actuation_delay: bool = False,
                        ) -> tuple[Library, dict[str, ca.Function], list[ca.Function]]:
    """Generate and compile the closed-loop library of a variant (steps, chunks, embedded
    software).

    Cached by the hash of the generated C (see :func:`~ballbot_casadi.core.toolchain.build_library`).

    Returns
    -------
    library, steps, exported
        The :class:`~ballbot_casadi.core.toolchain.Library`, the symbolic step Functions and
        every Function the library exports.
    """
    steps, exported = closed_loop_functions(n_sub, estimator, actuation_delay)
    return (build_library(library_name(n_sub, estimator, actuation_delay), exported, root),
            steps, exported)


class MissionVariant:
    """The step Functions of one ``n_sub`` (compiled or symbolic) and their missions."""

    def __init__(self, symbolic: Mapping[str, ca.Function], lib: Library | None, use_driver: bool,
                 exported: list[ca.Function] | None = None) -> None:
        self.library = lib
        self.exported = list(exported or [])
        self.symbolic = dict(symbolic)
        self.chunks: dict[str, ca.Function] = {}
        self.driver: MissionDriver | None = None
        self.missions: dict[tuple[str, int], ca.Function] = {}
        self.tags: dict[str, str] = {}
        if lib is None:
            self.steps = dict(symbolic)
            return
        names = [f.name() for f in symbolic.values()]
        chunk_names = [n.replace("ballbot_cl_step_", "ballbot_cl_chunk_") for n in names]
        ext = load_library(lib, names + chunk_names)
        self.steps = {k: ext[f.name()] for k, f in symbolic.items()}
        self.chunks = {k: ext[c] for k, c in zip(symbolic, chunk_names)}
        if use_driver:
            # the driver's entry points are named after the steps: ballbot_mission_<tag>
            self.tags = {k: f.name().removeprefix("ballbot_cl_step_") for k, f in symbolic.items()}
            first = next(iter(symbolic.values()))
            self.driver = MissionDriver(lib, {self.tags[k]: f for k, f in symbolic.items()}, CHUNK,
                                        sequence_positions(first))

    def run_driver(self, controller: str, n: int, args: list) -> list[np.ndarray]:
        """Run a mission through the C entry point."""
        return self.driver.run(self.tags[controller], n, args)

    def mission(self, controller: str, n_periods: int) -> ca.Function:
        key = (controller, int(n_periods))
        if key not in self.missions:
            step = self.steps[controller]
            if controller in self.chunks:
                self.missions[key] = compose_mission(step, self.chunks[controller], CHUNK, key[1])
            else:
                self.missions[key] = make_mission(step, key[1])
        return self.missions[key]

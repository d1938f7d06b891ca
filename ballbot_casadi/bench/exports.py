"""What the benchmarks time in C, in one place: the bench libraries' export lists.

The simulation library (:mod:`ballbot_casadi.sim.library`) exports what missions and the
controller FMU need; the benchmarks time single blocks as well, so they build their own
libraries (cached by hash like every compiled library):

* :func:`control_bench_library` - ``ballbot_bench_control``: the FLC step and chunk of
  the true-state mission and the controllers ``ballbot_flc``, ``ballbot_smc``,
  ``ballbot_velocity`` (``csrc/bench_control.c``);
* :func:`estimation_bench_library` - ``ballbot_bench_estimation_<est>``: the embedded
  software, the filters, the tilt correction and the COM observer, the very Functions
  the mission calls (``csrc/bench_function.c``).
"""

from __future__ import annotations

from pathlib import Path

import casadi as ca

from ballbot_casadi.control import BALANCE_CONTROLLERS, make_velocity_controller
from ballbot_casadi.core.constants import N_SUB
from ballbot_casadi.core.toolchain import Library, build_library
from ballbot_casadi.model.dynamics import make_affine
from ballbot_casadi.sim.embedded import embedded_software, software_blocks
from ballbot_casadi.sim.library import closed_loop_steps
from ballbot_casadi.sim.mission import make_chunk

__all__ = ["control_bench_functions", "control_bench_library", "estimation_bench_functions",
           "estimation_bench_library"]


def control_bench_functions() -> list[ca.Function]:
    """``ballbot_cl_step_flc``, ``ballbot_cl_chunk_flc``, the balance controllers and the
    velocity controller."""
    step = closed_loop_steps(N_SUB, "true")["flc"]
    affine = make_affine()
    return [step, make_chunk(step), *(b(affine) for b in BALANCE_CONTROLLERS.values()),
            make_velocity_controller()]


def control_bench_library(root: Path | None = None) -> tuple[Library, dict[str, ca.Function]]:
    """The compiled ``ballbot_bench_control`` library and its Functions by name."""
    fs = control_bench_functions()
    return build_library("ballbot_bench_control", fs, root), {f.name(): f for f in fs}


def estimation_bench_functions(controller: str, estimator: str) -> dict[str, ca.Function]:
    """The embedded software of ``controller`` with ``estimator`` and its parts, by name."""
    blocks, est = software_blocks(controller, estimator)
    fs = [embedded_software(controller, estimator), est.attitude, est.velocity,
          est.tilt_correction, blocks.observer]
    return {f.name(): f for f in fs}


def estimation_bench_library(controller: str, estimator: str, root: Path | None = None
                             ) -> tuple[Library, dict[str, ca.Function]]:
    """The compiled ``ballbot_bench_estimation_<controller>_<estimator>`` library and its
    Functions by name."""
    fs = estimation_bench_functions(controller, estimator)
    return build_library(f"ballbot_bench_estimation_{controller}_{estimator}", list(fs.values()),
                         root), fs

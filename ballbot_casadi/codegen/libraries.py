"""The C libraries of ``ballbot codegen``: which CasADi Functions each one exports.

``ballbot_model``: the model Functions (ODE, Jacobians, affine split, energy,
kinematics); ``ballbot_control``: the balance and velocity controllers built on the
symbolic model (the controllers call ``ballbot_affine``, generated into the same
library).  Generation, compilation and the hash-keyed cache are
:mod:`ballbot_casadi.core.toolchain`.
"""

from __future__ import annotations

from pathlib import Path
from types import MappingProxyType
from typing import Callable, Mapping

import casadi as ca

from ballbot_casadi.control import controller_functions_list
from ballbot_casadi.core.toolchain import Library, build_library, load_library
from ballbot_casadi.model.dynamics import make_affine, make_model_functions

__all__ = [
    "CODEGEN_LIBRARIES",
    "model_functions_list",
    "control_codegen_functions",
    "model_library",
    "load_model_library",
    "run_codegen",
]


def model_functions_list() -> list[ca.Function]:
    """The model Functions exported by the ``ballbot_model`` library."""
    return list(make_model_functions().values())


def control_codegen_functions() -> list[ca.Function]:
    """``[ballbot_flc, ballbot_smc, ballbot_velocity]`` built on the symbolic model."""
    return controller_functions_list(make_affine())


#: Libraries built by ``ballbot codegen``: name -> function returning the Functions to export.
CODEGEN_LIBRARIES: Mapping[str, Callable[[], list[ca.Function]]] = MappingProxyType({
    "ballbot_model": model_functions_list,
    "ballbot_control": control_codegen_functions,
})


def model_library(root: Path | None = None) -> Library:
    """Generate and compile the model library ``ballbot_model`` (ODE, Jacobians, ...)."""
    return build_library("ballbot_model", model_functions_list(), root)


def load_model_library(root: Path | None = None) -> dict[str, ca.Function]:
    """Compiled model Functions keyed like :func:`~ballbot_casadi.model.dynamics.make_model_functions`."""
    names = make_model_functions()
    lib = model_library(root)
    ext = load_library(lib, [f.name() for f in names.values()])
    return {key: ext[f.name()] for key, f in names.items()}


def run_codegen(root: Path | None = None) -> dict[str, Library]:
    """Generate and compile every library of :data:`CODEGEN_LIBRARIES`."""
    return {name: build_library(name, make(), root) for name, make in CODEGEN_LIBRARIES.items()}

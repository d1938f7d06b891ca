"""The ``ballbot_control`` C library: balance and velocity controllers for ``ballbot codegen``.

Sits at the code-generation layer (like :mod:`ballbot_casadi.codegen`), so unlike the
controllers themselves it may build the model Functions.  The controllers call the
model's ``ballbot_affine`` Function, which is generated into the same library.
"""

from __future__ import annotations

import casadi as ca

from .controllers import controller_functions_list

__all__ = ["control_codegen_functions"]


def control_codegen_functions() -> list[ca.Function]:
    """``[ballbot_flc, ballbot_smc, ballbot_velocity]`` built on the symbolic model."""
    from .model import make_affine

    return controller_functions_list(make_affine())

"""Closed-loop controllers of the ballbot (thesis ch. 7-8).

Balance controllers (inner loop), built from the model's control-affine Function
``affine(x, p) -> (f, g)`` and sharing one interface::
    ballbot_<name>(x[12], q_ref[4], dq_ref[4], ddq_ref[4], p[NP], k[NK]) -> (tau[3], diag[12])

* ``"flc"`` - feedback linearisation (thesis ch. 8), :mod:`.flc`;
* ``"smc"`` - sliding mode, the predecessor's baseline (thesis §8.3), :mod:`.smc`.

``p`` is the controller's *internal-model* parameter vector (may differ from the
plant's), ``k`` the gains (:func:`default_balance_gains`), ``tau`` is not saturated.
``diag`` entries are named by :data:`BALANCE_DIAG_NAMES`; entry 0, ``singular``, is 1.0
when the decoupling matrix E(x) was near-singular and the damped inverse was used.

Velocity controller (outer loop, thesis §7.3), :mod:`.velocity`::
    ballbot_velocity(x[12], v_ref[3], z[NZ], p[NP], k[NKV], Ts) -> (q_ref, dq_ref, ddq_ref, z_next)

Controllers never import the model; they receive its Functions.
"""

from __future__ import annotations

import math
from typing import Callable

import casadi as ca
import numpy as np

from ballbot_casadi.control.flc import (
    DIAG_NAMES,
    FLC_DEFAULT_GAINS,
    FLC_GAIN_NAMES,
    make_flc,
)
from ballbot_casadi.control.quaternion_error import (
    make_quaternion_error,
    quaternion_error,
    quaternion_error_accel,
    quaternion_error_rate,
    shortest_path_sign,
)
from ballbot_casadi.control.smc import SMC_DEFAULT_GAINS, SMC_GAIN_NAMES, make_smc
from ballbot_casadi.control.velocity import (
    VELOCITY_NKV,
    VELOCITY_NZ,
    check_velocity_gains,
    default_velocity_gains,
    design_velocity_lqr,
    make_velocity_controller,
    velocity_initial_state,
)
from ballbot_casadi.errors import ArgumentError

__all__ = [
    "BALANCE_CONTROLLERS",
    "BALANCE_DIAG_NAMES",
    "BALANCE_GAIN_NAMES",
    "default_balance_gains",
    "check_gains",
    "make_balance_controller",
    "make_flc",
    "make_smc",
    "make_velocity_controller",
    "design_velocity_lqr",
    "default_velocity_gains",
    "velocity_initial_state",
    "check_velocity_gains",
    "VELOCITY_NZ",
    "VELOCITY_NKV",
    "controller_functions_list",
    "saturate_torques",
    "make_quaternion_error",
    "quaternion_error",
    "quaternion_error_rate",
    "quaternion_error_accel",
    "shortest_path_sign",
]

#: Balance-controller builders ``make_<name>(affine) -> ca.Function``.
BALANCE_CONTROLLERS: dict[str, Callable[[ca.Function], ca.Function]] = {
    "flc": make_flc,
    "smc": make_smc,
}
#: Names of the ``diag`` output entries (same for every balance controller).
BALANCE_DIAG_NAMES: tuple[str, ...] = DIAG_NAMES
#: Names of the gain-vector entries per balance controller.
BALANCE_GAIN_NAMES: dict[str, tuple[str, ...]] = {"flc": FLC_GAIN_NAMES, "smc": SMC_GAIN_NAMES}
_DEFAULT_GAINS = {"flc": FLC_DEFAULT_GAINS, "smc": SMC_DEFAULT_GAINS}


def _check_name(name: str) -> str:
    if not isinstance(name, str) or name not in BALANCE_CONTROLLERS:
        raise ArgumentError(
            f"unknown balance controller {name!r}; allowed: {', '.join(sorted(BALANCE_CONTROLLERS))}"
        )
    return name


def default_balance_gains(name: str) -> np.ndarray:
    """Default gain vector ``k`` of balance controller ``name`` (``"flc"`` or ``"smc"``).

    Raises
    ------
    ArgumentError
        Unknown controller name (the message lists the allowed names).
    """
    return _DEFAULT_GAINS[_check_name(name)].copy()


def check_gains(name: str, k: object) -> np.ndarray:
    """Validate a gain vector for controller ``name``: right length, finite, positive.

    Raises
    ------
    ArgumentError
        Unknown controller, wrong length, non-finite or non-positive entries.
    """
    names = BALANCE_GAIN_NAMES[_check_name(name)]
    try:
        arr = np.asarray(k, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ArgumentError(f"{name} gains must be numbers, got {k!r}") from None
    if arr.size != len(names):
        raise ArgumentError(f"{name} gains need {len(names)} entries {names}, got {arr.size}")
    bad = [n for n, v in zip(names, arr) if not (math.isfinite(v) and v > 0)]
    if bad:
        raise ArgumentError(f"{name} gains must be finite and > 0; invalid: {', '.join(bad)}")
    return arr


def make_balance_controller(name: str, affine: ca.Function) -> ca.Function:
    """Build balance controller ``name`` from the model's ``affine`` Function."""
    return BALANCE_CONTROLLERS[_check_name(name)](affine)


def controller_functions_list(affine: ca.Function) -> list[ca.Function]:
    """``[ballbot_flc, ballbot_smc, ballbot_velocity]`` for code generation."""
    return [make_flc(affine), make_smc(affine), make_velocity_controller()]


def saturate_torques(tau: object, tau_max: object) -> object:
    """Direction-preserving torque limit: scale ``tau`` so that ``max |tau_i| <= tau_max``.

    Clipping each wheel separately changes the direction of the torque vector and so
    leaks tilt demand into yaw (on the thesis §8.4.1 test the heading swings by ~20 deg
    with clipping and ~0.1 deg with scaling); scaling keeps the decoupling.  Works on
    numpy arrays and on CasADi SX/MX (then ``tau_max`` may be symbolic); the closed loop
    applies it at the controller's internal ``tau_max`` before the plant's per-wheel
    saturation.
    """
    if isinstance(tau, (ca.SX, ca.MX)) or isinstance(tau_max, (ca.SX, ca.MX)):
        m = ca.mmax(ca.fabs(tau))
        return tau * ca.fmin(1, tau_max / ca.fmax(m, 1e-300))
    t = np.asarray(tau, dtype=float).reshape(-1)
    m = float(np.max(np.abs(t))) if t.size else 0.0
    return t * (float(tau_max) / m) if m > float(tau_max) else t.copy()

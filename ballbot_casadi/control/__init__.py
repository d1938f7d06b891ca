"""Closed-loop controllers of the ballbot (thesis ch. 7-8).

Balance controllers (inner loop), built from the model's control-affine Function
``affine(x, p) -> (f, g)`` and sharing one interface (:mod:`.balance_frame`)::
    ballbot_<name>(x[12], q_ref[4], dq_ref[4], ddq_ref[4], p[NP], k[NK]) -> (tau[3], diag[12])

* ``"flc"`` - feedback linearisation (thesis ch. 8), :mod:`.flc`;
* ``"smc"`` - sliding mode, the predecessor's baseline (thesis §8.3), :mod:`.smc`;
* ``"sta"`` - super-twisting sliding mode (thesis ch. 11 future work), :mod:`.super_twisting`;
* ``"lqr"`` - the predecessor's balance LQR (thesis §1.2), :mod:`.balance_lqr`;
* ``"flc_dob"`` - the FLC with a disturbance observer (thesis ch. 11 future work),
  :mod:`.disturbance_observer`.

A controller with a *balance-controller state* ``zb`` (``"sta"``: the integral term;
``"flc_dob"``: the disturbance estimate and its predictor)
takes it as a 7th input and returns its next value as a 3rd output
(:data:`BALANCE_STATE_SIZES`; the period carries it, :mod:`ballbot_casadi.sim.ports`).
A controller whose default gain is designed on the linearised model (``"lqr"``) needs
that model for :func:`default_balance_gains` (the caller linearises: controllers never
import the model).

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

from ballbot_casadi.control.disturbance_observer import (
    DOB_DEFAULT_GAINS,
    DOB_GAIN_NAMES,
    DOB_NZ,
    make_flc_dob,
)
from ballbot_casadi.control.balance_frame import DIAG_NAMES
from ballbot_casadi.control.flc import FLC_DEFAULT_GAINS, FLC_GAIN_NAMES, make_flc
from ballbot_casadi.control.quaternion_error import (
    make_quaternion_error,
    quaternion_error,
    quaternion_error_accel,
    quaternion_error_rate,
    shortest_path_sign,
)
from ballbot_casadi.control.balance_lqr import LQR_GAIN_NAMES, design_balance_lqr, make_balance_lqr
from ballbot_casadi.control.torque_limit import saturate_torques
from ballbot_casadi.control.smc import SMC_DEFAULT_GAINS, SMC_GAIN_NAMES, make_smc
from ballbot_casadi.control.super_twisting import (
    STA_DEFAULT_GAINS,
    STA_GAIN_NAMES,
    STA_NZ,
    make_super_twisting,
)
from ballbot_casadi.control.velocity import (
    VELOCITY_NKV,
    VELOCITY_NZ,
    check_velocity_gains,
    default_velocity_gains,
    design_velocity_lqr,
    make_velocity_controller,
    velocity_initial_state,
)
from ballbot_casadi.core.constants import TS_CONTROL
from ballbot_casadi.errors import ArgumentError

__all__ = [
    "BALANCE_CONTROLLERS",
    "BALANCE_DIAG_NAMES",
    "BALANCE_GAIN_NAMES",
    "BALANCE_STATE_SIZES",
    "LINEAR_DESIGNED",
    "balance_state_size",
    "default_balance_gains",
    "check_gains",
    "make_balance_controller",
    "make_flc",
    "make_smc",
    "make_super_twisting",
    "make_balance_lqr",
    "make_flc_dob",
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
    "sta": make_super_twisting,
    "lqr": make_balance_lqr,
    "flc_dob": make_flc_dob,
}
#: Names of the ``diag`` output entries (same for every balance controller).
BALANCE_DIAG_NAMES: tuple[str, ...] = DIAG_NAMES
#: Names of the gain-vector entries per balance controller.
BALANCE_GAIN_NAMES: dict[str, tuple[str, ...]] = {
    "flc": FLC_GAIN_NAMES, "smc": SMC_GAIN_NAMES, "sta": STA_GAIN_NAMES, "lqr": LQR_GAIN_NAMES,
    "flc_dob": DOB_GAIN_NAMES}
#: Size of the balance-controller state ``zb`` per controller (absent: stateless).
BALANCE_STATE_SIZES: dict[str, int] = {"sta": STA_NZ, "flc_dob": DOB_NZ}
#: Controllers whose default gain is designed on the linearised model (no positivity rule).
LINEAR_DESIGNED: tuple[str, ...] = ("lqr",)
_DEFAULT_GAINS = {"flc": FLC_DEFAULT_GAINS, "smc": SMC_DEFAULT_GAINS, "sta": STA_DEFAULT_GAINS,
                  "flc_dob": DOB_DEFAULT_GAINS}
#: Controllers whose last gain is the discretisation step ``h`` (set to the period ``Ts``).
_STEP_GAIN = {"sta": STA_GAIN_NAMES.index("h"), "flc_dob": DOB_GAIN_NAMES.index("h")}


def _check_name(name: str) -> str:
    if not isinstance(name, str) or name not in BALANCE_CONTROLLERS:
        raise ArgumentError(
            f"unknown balance controller {name!r}; allowed: {', '.join(sorted(BALANCE_CONTROLLERS))}"
        )
    return name


def default_balance_gains(name: str, linear: object = None, Ts: float = TS_CONTROL) -> np.ndarray:
    """Default gain vector ``k`` of balance controller ``name`` for the control period ``Ts``.

    ``linear`` is the :class:`~ballbot_casadi.model.linearization.LinearModel` of the
    controller's model at the balance point; only the controllers of
    :data:`LINEAR_DESIGNED` (``"lqr"``: :func:`~.balance_lqr.design_balance_lqr` for the
    period ``Ts``) need it.  The super-twisting and disturbance-observer step ``h`` is ``Ts``.

    Raises
    ------
    ArgumentError
        Unknown controller name (the message lists the allowed names), or a linearly
        designed controller without ``linear``.
    """
    name = _check_name(name)
    if name in LINEAR_DESIGNED:
        if linear is None:
            raise ArgumentError(f"the default {name} gain is designed on the linearised model; "
                                "pass linear=linearize(params)")
        return design_balance_lqr(linear, Ts).ravel()  # row-major, LQR_GAIN_NAMES
    k = _DEFAULT_GAINS[name].copy()
    if name in _STEP_GAIN:
        k[_STEP_GAIN[name]] = Ts
    return k


def balance_state_size(name: str) -> int:
    """Size of the balance-controller state ``zb`` of controller ``name`` (0: stateless)."""
    return BALANCE_STATE_SIZES.get(_check_name(name), 0)


def check_gains(name: str, k: object) -> np.ndarray:
    """Validate a gain vector for controller ``name``: right length, finite, positive
    (a linearly designed gain, :data:`LINEAR_DESIGNED`, may have any sign).

    Raises
    ------
    ArgumentError
        Unknown controller, wrong length, non-finite or non-positive entries.
    """
    names = BALANCE_GAIN_NAMES[_check_name(name)]
    try:
        arr = np.asarray(k, dtype=float).ravel()
    except (TypeError, ValueError):
        raise ArgumentError(f"{name} gains must be numbers, got {k!r}") from None
    if arr.size != len(names):
        raise ArgumentError(f"{name} gains need {len(names)} entries {names}, got {arr.size}")
    signed = name in LINEAR_DESIGNED
    bad = [n for n, v in zip(names, arr) if not (math.isfinite(v) and (signed or v > 0))]
    if bad:
        rule = "finite" if signed else "finite and > 0"
        raise ArgumentError(f"{name} gains must be {rule}; invalid: {', '.join(bad)}")
    return arr


def make_balance_controller(name: str, affine: ca.Function) -> ca.Function:
    """Build balance controller ``name`` from the model's ``affine`` Function."""
    return BALANCE_CONTROLLERS[_check_name(name)](affine)


def controller_functions_list(affine: ca.Function) -> list[ca.Function]:
    """Every balance controller of :data:`BALANCE_CONTROLLERS` and ``ballbot_velocity``
    for code generation."""
    return [*(b(affine) for b in BALANCE_CONTROLLERS.values()), make_velocity_controller()]

"""One control period of the closed loop, defined once (thesis Fig. 7.1 cascade, Fig. 8.1).

The sequence of one period ``[t_k, t_k + Ts)`` is

1. **push** - a disturbance jump of the plant attitude (thesis §8.4.3): ``q`` and ``dq``
   are rotated in {K} by the rotation vector ``w[push]``,
   ``q <- exp(w/2) o q``, ``dq <- exp(w/2) o dq`` (body rates unchanged);
2. (with sensors) **sensing and estimation**: what the controllers read
   (:mod:`ballbot_casadi.sim.embedded`);
3. **velocity controller** (outer loop, thesis §7.3) produces ``q_ref, dq_ref, ddq_ref``
   and its next state ``z``; with ``cascade = 0`` the references come from the input
   sequences instead (balance controller alone, thesis Fig. 8.1) and ``z`` is held;
4. **balance controller** (FLC thesis 8.26/8.44, or SMC) computes ``tau_cmd`` on its own
   internal-model parameters ``p_ctrl``; with ``feedforward = 0`` it gets the reference's
   second derivative as zero, as the thesis's FLC (8.44) and the predecessor's sliding
   mode controller did (``feedforward = 1``: the exact reference acceleration);
5. **torque limits** - a direction-preserving limit at the controller's ``tau_max``
   (:func:`~ballbot_casadi.control.saturate_torques`), then the plant's physical
   per-wheel saturation at the plant's ``tau_max``.  The limit is a switch
   (:data:`TORQUE_LIMIT_MODES`, a scenario's ``torque_limit``): ``"direction"`` (ours,
   default) scales all three torques together so the torque direction - and with it the
   decoupling of the FLC - survives saturation; ``"per-wheel"`` (the thesis's set-up,
   §9.1: each motor clips on its own, motor 0 first) lifts the controller's own limit
   (:func:`controller_torque_limit`) so only the per-wheel saturation acts;
6. **disturbance** - the wheel-torque disturbance ``w[tau_dist]`` is added *after* the
   saturation (it is an external torque on the wheel axes, not a motor command);
7. **plant** - the resulting torque is held over the period (zero-order hold) while the
   plant advances by ``Ts``.

:func:`control_period` is that sequence, written once; its inputs and outputs are the
ports of :mod:`ballbot_casadi.sim.ports`.  It evaluates on CasADi
symbols (the compiled mission's step Function, :mod:`ballbot_casadi.sim.closed_loop`)
and on numpy values (the FMU co-simulation master :mod:`ballbot_casadi.fmi.masters.plant_loop` and
the Python-loop benchmark), with the plant supplied by the caller: classical RK4 on the
model's ODE (:func:`rk4_plant`), or an FMU stepped by ``fmi2DoStep``.
"""

from __future__ import annotations

import math
from typing import Any, Callable, Mapping

import casadi as ca
import numpy as np

from ballbot_casadi.control import saturate_torques
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import DISTURBANCE, STATE
from ballbot_casadi.core.params import PARAM_NAMES
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.model.integrators import make_rk4_n
from ballbot_casadi.sim.ports import PeriodBlocks, controller_state

__all__ = [
    "apply_push",
    "actuate",
    "controller_part",
    "control_period",
    "rk4_plant",
    "TORQUE_LIMIT_MODES",
    "require_finite_controller_limit",
    "controller_torque_limit",
]

#: The torque-limit switch (module docstring, step 5): ours first (the default).
TORQUE_LIMIT_MODES = ("direction", "per-wheel")

_TAU_MAX = PARAM_NAMES.index("tau_max")
_SYMBOLIC = (ca.SX, ca.MX)


def _symbolic(*args: Any) -> bool:
    return any(isinstance(a, _SYMBOLIC) for a in args)


def _value(v: Any) -> Any:
    """Numeric results of a Function call as flat numpy arrays (symbols unchanged)."""
    return v if isinstance(v, _SYMBOLIC) else np.asarray(v, dtype=float).ravel()


def _select(on: Any, a: Any, b: Any) -> Any:
    """``a if on else b``; a CasADi ``if_else`` when ``on`` is symbolic."""
    if _symbolic(on):
        return ca.if_else(on, a, b)
    return a if bool(on) else b


def apply_push(x: Any, push: Any) -> Any:
    """Rotate the plant attitude ``q`` and its rate ``dq`` in {K} by the rotation vector ``push``.

    An exact identity for ``push = 0`` (thesis §8.4.3 attitude disturbance).  Entries of
    ``x`` beyond the 12-state (the wheel angles of a plant with sensors) are kept.
    """
    r = Q.from_rotation_vector(push)
    q, dq = x[STATE["q"]], x[STATE["dq"]]
    parts = [x[0:STATE["q"].start], Q.mul(r, q), x[STATE["q"].stop:STATE["dq"].start], Q.mul(r, dq)]
    n = x.numel() if _symbolic(x) else np.size(x)
    if n > STATE.size:  # further plant states (wheel angles) are not rotated
        parts.append(x[STATE.size:])
    return ca.vertcat(*parts) if _symbolic(x, push) else np.concatenate([np.ravel(p) for p in parts])


def controller_torque_limit(tau_max: float, mode: str) -> float:
    """The controller's own limit of step 5 for torque-limit ``mode``
    (:data:`TORQUE_LIMIT_MODES`): ``tau_max`` for ``"direction"``, ``+inf`` for
    ``"per-wheel"`` (no limit of its own, so only the plant's per-wheel saturation at its
    ``tau_max`` acts, thesis §9.1 Fig. 9.2)."""
    if mode not in TORQUE_LIMIT_MODES:
        raise ScenarioError(f"torque_limit {mode!r} unknown; allowed: {', '.join(TORQUE_LIMIT_MODES)}",
                            key="torque_limit")
    return float(tau_max) if mode == "direction" else math.inf


def require_finite_controller_limit(mode: str, scenario_name: str, consumer: str) -> None:
    """Refuse torque-limit ``mode`` for a ``consumer`` (the controller FMU, the firmware)
    that applies the direction-preserving limit at a finite ``ctrl_tau_max``: the
    ``"per-wheel"`` mode's controller limit is ``+inf`` (:func:`controller_torque_limit`),
    not a value of that parameter.

    Raises
    ------
    ScenarioError
        ``mode`` is not ``"direction"`` (one line naming ``torque_limit``).
    """
    if mode != TORQUE_LIMIT_MODES[0]:
        raise ScenarioError(f"scenario {scenario_name!r}: {consumer} limits its torques at its "
                            f"finite ctrl_tau_max (torque_limit = \"{TORQUE_LIMIT_MODES[0]}\"); "
                            f"torque_limit = {mode!r} lifts the controller's limit to +inf (the "
                            f"plant's per-wheel clipping only, thesis 9.1); allowed: "
                            f"{TORQUE_LIMIT_MODES[0]}", key="torque_limit")


def actuate(tau_lim: Any, tau_dist: Any, tau_max: Any) -> Any:
    """Torque acting on the plant: per-wheel saturation at the plant's ``tau_max``, plus the
    disturbance torque (added after the saturation)."""
    if _symbolic(tau_lim, tau_dist, tau_max):
        return ca.fmin(ca.fmax(tau_lim, -tau_max), tau_max) + tau_dist
    return np.clip(tau_lim, -tau_max, tau_max) + np.asarray(tau_dist, dtype=float)


def controller_part(
    blocks: PeriodBlocks,
    x_seen: Any,
    z: Any,
    seq: Mapping[str, Any],
    const: Mapping[str, Any],
) -> dict[str, Any]:
    """The robot's controllers for one period: guidance (if any), velocity controller,
    balance controller and the direction-preserving torque limit (steps 2-4 of the module
    docstring).

    ``x_seen`` is what the controllers read (the true state or an estimate); ``z`` the
    controllers' state, laid out by :func:`~ballbot_casadi.sim.ports.controller_state`
    (velocity controller ``z``, then the observer's ``obs``, then the guidance block's
    ``guide``, then the balance controller's own state ``bal``, advanced every period).  Returns ``z_next``, ``tau_cmd`` (balance controller output), ``tau_lim``
    (after the limit at the controller's ``tau_max``), the references used and ``diag``.

    With ``blocks.observer`` (``ballbot_com_observer``,
    :mod:`ballbot_casadi.estimation.com_observer`) ``const`` also holds ``k_obs``
    (observer gains) and ``com_observer`` (switch): the observer runs every period on
    ``x_seen`` and, with the switch on, both controllers use its internal model ``p_hat``
    (the estimated COM offset) instead of ``p_ctrl``; with the switch off they get
    ``p_ctrl`` itself, so the loop is exactly the one without an observer (the estimate
    still runs, unused).  The result then also has ``com_hat`` (the COM-offset estimate
    after this period's update) and ``com_meas`` (the observer's measurement).

    With ``blocks.guidance`` (``const`` holds ``k_guid``) the guidance block turns the
    period's ``v_ref`` into the velocity reference the velocity controller and the
    observer follow (output ``v_ref_used``); it reads ``x_seen`` and the velocity
    controller's state ``z`` at the start of the period.  A guidance block with three
    more outputs ``(q_ref, dq_ref, ddq_ref)`` (the balance feed,
    :mod:`ballbot_casadi.sim.balance_feed`) gives the balance controller its references
    itself: they replace the velocity controller's (which still runs and advances its
    state).
    """
    Z = controller_state(blocks, len(PARAM_NAMES))
    p_ctrl = const["p_ctrl"]
    observer, guidance = blocks.observer, blocks.guidance
    v_ref, extra = seq["v_ref"], {}
    z_vel = z if len(Z.fields) == 1 else z[Z["z"]]
    fed = None  # a balance-feed guidance block's (q_ref, dq_ref, ddq_ref)
    if guidance is not None:
        v_ref, g_next, *fed = (_value(v) for v in guidance(x_seen, v_ref, z[Z["guide"]], z_vel,
                                                           p_ctrl, const["k_guid"], const["Ts"]))
        extra["v_ref_used"] = v_ref
    if observer is not None:
        o_next, p_hat, com_hat, com_meas = (_value(v) for v in observer(
            x_seen, v_ref, z[Z["obs"]], p_ctrl, const["k_obs"], const["Ts"]))
        p_ctrl = _select(_on(const["com_observer"]), p_hat, p_ctrl)
        extra.update(com_hat=com_hat, com_meas=com_meas)
    qv, dqv, ddqv, zv = (_value(v) for v in blocks.velocity(x_seen, v_ref, z_vel, p_ctrl,
                                                            const["k_vel"], const["Ts"]))
    if fed:  # the guidance feeds the balance controller directly (the velocity LQR bypassed)
        qv, dqv, ddqv = fed
    on = _on(const["cascade"])
    qr = _select(on, qv, seq["q_ref"])
    dqr = _select(on, dqv, seq["dq_ref"])
    ddqr = _select(on, ddqv, seq["ddq_ref"])
    ddqr = ddqr * (const["feedforward"] if _symbolic(const["feedforward"]) else float(const["feedforward"]))
    z_next = _select(on, zv, z_vel)
    bal_args = (x_seen, qr, dqr, ddqr, p_ctrl, const["k_bal"])
    if blocks.balance_state:
        tau_cmd, diag, b_next = (_value(v) for v in blocks.balance(*bal_args, z[Z["bal"]]))
    else:
        tau_cmd, diag = (_value(v) for v in blocks.balance(*bal_args))
    parts = [z_next, *([o_next] if observer is not None else []),
             *([g_next] if guidance is not None else []),
             *([b_next] if blocks.balance_state else [])]
    if len(parts) > 1:
        z_next = (ca.vertcat(*parts) if _symbolic(*parts)
                  else np.concatenate([np.ravel(p) for p in parts]))
    tau_lim = saturate_torques(tau_cmd, const["p_ctrl"][_TAU_MAX])
    return {"z_next": z_next, "tau_cmd": tau_cmd, "tau_lim": tau_lim, "q_ref_used": qr,
            "dq_ref_used": dqr, "ddq_ref_used": ddqr, "diag": diag, **extra}


def _on(switch: Any) -> Any:
    """A 0/1 switch input as a condition (symbolic: ``> 0.5``)."""
    return switch > 0.5 if _symbolic(switch) else bool(switch)


def control_period(
    blocks: PeriodBlocks,
    x: Any,
    z: Any,
    seq: Mapping[str, Any],
    const: Mapping[str, Any],
    plant: Callable[[Any, Any, Any, Any], Any],
    controller: Callable[[Any, Any, Mapping[str, Any], Mapping[str, Any]], dict[str, Any]] | None = None,
) -> dict[str, Any]:
    """One control period (see the module docstring): symbolic or numeric.

    Parameters
    ----------
    blocks
        The controllers.
    x, z
        Plant state at ``t_k`` (before a push) and the controller's state.
    seq
        This period's :data:`~ballbot_casadi.sim.ports.PERIOD_SEQUENCES` (``q_ref``,
        ``dq_ref``, ``ddq_ref``, ``v_ref``, ``w``).
    const
        The :data:`~ballbot_casadi.sim.ports.PERIOD_CONSTANTS` (``p_plant``, ``p_ctrl``,
        ``k_bal``, ``k_vel``, ``Ts``, ``cascade``, ``feedforward``).
    plant
        ``plant(xk, tau, tau_lim, tau_dist) -> x_next``: advance the plant over the
        period from the pushed state ``xk``; ``tau`` is the torque acting on the plant
        (:func:`actuate`), ``tau_lim`` and ``tau_dist`` its two parts for a plant that
        saturates its motor torque itself (an FMU).
    controller
        ``controller(xk, z, seq, const) -> dict``: the robot between the pushed plant
        state and the limited torque command, returning at least the keys of
        :func:`controller_part`; default :func:`controller_part` on the true state.  The
        estimating loop passes its sensors and embedded software here
        (:mod:`ballbot_casadi.sim.embedded`).

    Returns
    -------
    dict
        ``x_next``, ``z_next`` and the :data:`~ballbot_casadi.sim.ports.PERIOD_OUTPUTS`: ``x`` (the pushed plant
        state at ``t_k``), ``tau_cmd`` (controller output), ``tau`` (torque acting on the
        plant), the references used and ``diag``, plus whatever else ``controller``
        returned.
    """
    w = seq["w"]
    xk = apply_push(x, w[DISTURBANCE["push"]])
    if controller is None:
        ctrl = controller_part(blocks, xk, z, seq, const)
    else:
        ctrl = controller(xk, z, seq, const)
    tau_dist = w[DISTURBANCE["tau_dist"]]
    tau = actuate(ctrl["tau_lim"], tau_dist, const["p_plant"][_TAU_MAX])
    x_next = plant(xk, tau, ctrl["tau_lim"], tau_dist)
    return {**ctrl, "x_next": x_next, "x": xk, "tau": tau}


def rk4_plant(ode: ca.Function, n_sub: int, p_plant: Any, Ts: Any) -> Callable[[Any, Any, Any, Any], Any]:
    """The plant of the simulation: ``n_sub`` classical RK4 steps of ``Ts / n_sub`` on ``ode``.

    Returns the ``plant`` callback of :func:`control_period`; the RK4 Function
    (:func:`~ballbot_casadi.model.integrators.make_rk4_n`) is built once and called.
    """
    rk4 = make_rk4_n(ode, n_sub)

    def plant(xk: Any, tau: Any, tau_lim: Any, tau_dist: Any) -> Any:
        return _value(rk4(xk, tau, p_plant, Ts))

    return plant

"""The control period as a CasADi Function: the step of a compiled mission.

One control period ``Ts`` (200 Hz, thesis §7.1) is the Function
``ballbot_cl_step_<ctrl>[_<est>]``: :func:`ballbot_casadi.sim.period.control_period`
(push, controllers, torque limits, disturbance torque, plant) on CasADi symbols made
from the period's ports (:func:`~ballbot_casadi.sim.ports.period_ports`), with
``n_sub`` classical RK4 steps of ``Ts / n_sub`` as the plant.  Every block is a
*called* Function (ODE inside RK4, RK4 and controllers inside the step), so the
generated C holds one copy of each.

Variants of the period (all from the same ports and the same ``control_period``):

* :func:`make_closed_loop_step` - the controllers read the true state;
* :func:`make_estimating_step` - the plant-side sensors and the embedded software
  (:mod:`ballbot_casadi.sim.embedded`, the controller FMU's Function) in the loop;
* ``make_estimating_step(..., actuation_delay=True)`` - the same with the torque of
  period ``k`` acting on ``[t_k+1, t_k+2)``: the loop a Jacobi co-simulation master
  (libcosim's fixed-step algorithm, fmpy's containers) runs with the plant and
  controller FMUs (:mod:`ballbot_casadi.fmi.system.sil`).
"""

from __future__ import annotations

from typing import Any, Mapping

import casadi as ca

from ballbot_casadi.core.constants import N_SUB
from ballbot_casadi.model.dynamics import NP
from ballbot_casadi.model.sensors import make_wheel_angle_ode
from ballbot_casadi.sim.embedded import (
    NOISE,
    SENSOR_STATE,
    VALID,
    EstimatorBlocks,
    make_embedded_step,
    software_layout,
    sense,
)
from ballbot_casadi.sim.period import control_period, rk4_plant
from ballbot_casadi.sim.ports import (
    EMBEDDED_INPUTS,
    REFERENCE_SEQUENCES,
    PeriodBlocks,
    PeriodPorts,
    period_ports,
)

__all__ = ["make_closed_loop_step", "make_estimating_step", "closed_loop_ports",
           "estimating_ports"]


def closed_loop_ports(blocks: PeriodBlocks) -> PeriodPorts:
    """The ports of the period whose controllers read the true state."""
    return period_ports(blocks, NP)


def make_closed_loop_step(
    balance: ca.Function,
    velocity: ca.Function,
    ode: ca.Function,
    n_sub: int = N_SUB,
    observer: ca.Function | None = None,
    guidance: ca.Function | None = None,
) -> ca.Function:
    """One control period of the closed loop as a Function, ``ballbot_cl_step_<ctrl>``.

    The period is :func:`ballbot_casadi.sim.period.control_period` evaluated on CasADi
    symbols with the RK4 plant (:func:`~ballbot_casadi.sim.period.rk4_plant`).

    Parameters
    ----------
    balance
        Balance controller ``(x, q_ref, dq_ref, ddq_ref, p, k) -> (tau, diag)``.
    velocity
        Velocity controller ``(x, v_ref, z, p, k, Ts) -> (q_ref, dq_ref, ddq_ref, z_next)``.
    ode
        Plant ``ballbot_ode(x, tau, p)``.
    n_sub
        RK4 sub-steps per control period (plant step ``Ts / n_sub``).
    observer
        Optional COM observer ``ballbot_com_observer``
        (:mod:`ballbot_casadi.estimation.com_observer`): the state then carries its
        state after ``z``, the constants end with ``com_observer`` (switch) and ``k_obs``
        (gains) and the outputs with ``com_hat``.
    guidance
        Optional block above the velocity controller (the slot of
        :class:`~ballbot_casadi.sim.ports.PeriodBlocks`).

    Returns
    -------
    casadi.Function
        Inputs and outputs are the ports of :func:`closed_loop_ports`: the state
        ``xz = [x; c]`` (accumulated; ``c`` the controllers' state), the per-period
        ``q_ref, dq_ref, ddq_ref`` (4 each, used when ``cascade = 0``), ``v_ref`` (3,
        used when ``cascade = 1``), ``w`` (6, :data:`~ballbot_casadi.core.layout.DISTURBANCE`),
        then the constants ``p_plant, p_ctrl, k_bal, k_vel, Ts, cascade, feedforward``.
        Outputs ``xz_next``, ``x`` (state the controllers saw, after the jump),
        ``tau_cmd`` (controller output), ``tau`` (torque acting on the plant: saturated,
        plus the disturbance), the references used and ``diag``.
    """
    blocks = PeriodBlocks(balance, velocity, observer, guidance)
    ports = closed_loop_ports(blocks)
    sym = ports.symbols()
    X = ports.state
    seq = {k: sym[k] for k in ports.sequences}
    const = {k: sym[k] for k in ports.constants}
    plant = rk4_plant(ode, n_sub, const["p_plant"], const["Ts"])
    xz = sym["xz"]
    out = control_period(blocks, xz[X["x"]], xz[X["c"]], seq, const, plant)
    out["xz_next"] = ca.vertcat(out["x_next"], out["z_next"])
    return ports.function(ports.name, sym, out)


def estimating_ports(blocks: PeriodBlocks, estimator: EstimatorBlocks, embedded: ca.Function,
                     actuation_delay: bool = False, n_guide: int = 0) -> PeriodPorts:
    """The ports of the period with sensors and the embedded software ``embedded`` (whose
    guidance block, if any, has a state of ``n_guide`` entries)."""
    return period_ports(blocks, NP, {
        "embedded": embedded, "c": software_layout(embedded, estimator.name, n_guide),
        "s": estimator.imu.size1_in(3), "sensor_state": SENSOR_STATE, "noise": NOISE,
        "valid": VALID, "name": estimator.name}, actuation_delay)


def make_estimating_step(
    balance: ca.Function,
    velocity: ca.Function,
    ode: ca.Function,
    wheel_speeds: ca.Function,
    estimator: EstimatorBlocks,
    n_sub: int = N_SUB,
    embedded: ca.Function | None = None,
    observer: ca.Function | None = None,
    actuation_delay: bool = False,
    guidance: ca.Function | None = None,
) -> ca.Function:
    """One control period with sensors and the embedded software, ``ballbot_cl_step_<ctrl>_<est>``.

    :func:`ballbot_casadi.sim.period.control_period` on CasADi symbols whose controller
    is the robot: the plant-side sensors (:func:`~ballbot_casadi.sim.embedded.sense`)
    and a call of the embedded software ``ballbot_embedded_<ctrl>_<est>``
    (:func:`~ballbot_casadi.sim.embedded.make_embedded_step`, the same Function the
    controller FMU runs); the plant carries the wheel angles (``ballbot_ode_wheel_angles``
    in RK4).

    With ``actuation_delay`` (``ballbot_cl_step_delayed_<ctrl>_<est>``) the torque that
    acts in period ``k`` is the command of period ``k-1``, held in the state field ``u``
    (zero before the first period): the loop of a Jacobi co-simulation master, in which
    the plant and the controller FMU step from ``t_k`` at the same time.

    Returns
    -------
    casadi.Function
        The ports of :func:`estimating_ports`: the state ``xz = [x (12); phi (3); c; s]``
        (``c`` the controller state of :func:`~ballbot_casadi.sim.embedded.software_layout`,
        ``s`` the sensor state :data:`~ballbot_casadi.sim.embedded.SENSOR_STATE`; ``u``
        last with the delay), the sequences of :func:`make_closed_loop_step` plus
        ``noise`` (:data:`~ballbot_casadi.sim.embedded.NOISE`, standard normal) and ``valid``
        (:data:`~ballbot_casadi.sim.embedded.VALID`), its constants plus ``s``
        (sensor parameters), ``p_est`` (the filters' model parameters) and the filter
        covariances ``Qa, Ra, Qv, Rv`` (column-major).  Outputs those of
        :func:`make_closed_loop_step` (``x`` the true 12-state) plus ``x_hat`` (what the
        controllers read), ``meas`` (the readings), ``nis``, ``repairs`` and
        ``rejections``.  With the
        COM observer (inside the embedded software, its state last in ``c``) the
        constants end with ``com_observer, k_obs`` and the outputs with ``com_hat``.
        With ``guidance`` (inside the embedded software, built here when ``embedded`` is
        not given) the constants end with ``k_guid`` and the outputs with ``v_ref_used``.
    """
    if embedded is None:
        embedded = make_embedded_step(balance, velocity, estimator, observer, guidance)
    blocks = PeriodBlocks(balance, velocity)
    n_guide = guidance.numel_in(2) if guidance is not None else 0
    ports = estimating_ports(blocks, estimator, embedded, actuation_delay, n_guide)
    X, C = ports.state, ports.state.part("c")
    sym = ports.symbols()
    seq = {k: sym[k] for k in ports.sequences}
    const = {k: sym[k] for k in ports.constants}
    ode_w = make_wheel_angle_ode(ode, wheel_speeds)
    embedded_constants = [k for k in embedded.name_in() if k not in (*EMBEDDED_INPUTS[:2],
                                                                      *REFERENCE_SEQUENCES)]
    nc = C.size

    def robot(xk: ca.MX, cs: ca.MX, sq: Mapping[str, Any], cn: Mapping[str, Any]) -> dict[str, Any]:
        # cs: the state after the plant's part, [c; s (; u)]
        c, s_state = cs[:nc], cs[nc:nc + SENSOR_STATE.size] if actuation_delay else cs[nc:]
        meas, s_mid = sense(estimator, xk, s_state, sq["noise"], sq["valid"], cn["p_plant"],
                            cn["s"], cn["Ts"])
        out = embedded.call({"c": c, "meas": meas, **{k: sq[k] for k in REFERENCE_SEQUENCES},
                             **{k: cn[k] for k in embedded_constants}})
        if not actuation_delay:
            return {**out, "z_next": ca.vertcat(out["c_next"], s_mid), "meas": meas}
        u = cs[nc + SENSOR_STATE.size:]
        return {**out, "tau_lim": u, "meas": meas,
                "z_next": ca.vertcat(out["c_next"], s_mid, out["tau_lim"])}

    xz = sym["xz"]
    plant = rk4_plant(ode_w, n_sub, const["p_plant"], const["Ts"])
    nxw = X.offset("c")
    out = control_period(blocks, xz[:nxw], xz[nxw:], seq, const, plant, controller=robot)
    # the sensor state starts with the torque that acted on the plant in this period
    zn = out["z_next"]
    out["xz_next"] = ca.vertcat(out["x_next"], ca.vertcat(zn[:nc], out["tau"], zn[nc:]))
    out["x"] = out["x"][X["x"]]
    return ports.function(ports.name, sym, out)


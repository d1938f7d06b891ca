"""Co-simulation of the plant FMU from Python: open loop and the closed-loop master.

The closed-loop master runs the package's controllers once per control period around
the FMU, through the one definition of a control period in
:mod:`ballbot_casadi.sim.period`.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi2 import FMU2Slave

from ballbot_casadi.control import (
    BALANCE_CONTROLLERS,
    make_velocity_controller,
    saturate_torques,
)
from ballbot_casadi.core.params import PARAM_NAMES
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.fmi.build import MODEL_IDENTIFIER, build_fmu
from ballbot_casadi.model.dynamics import STATE_NAMES, make_affine
from ballbot_casadi.sim.closed_loop import N_SUB_DEFAULT

__all__ = ["cosim_open_loop", "closed_loop_cosim"]


def cosim_open_loop(fmu: str | Path, tau: np.ndarray, stop_time: float, step: float = 5e-3,
                    start_values: dict | None = None):
    """One fmpy co-simulation of the plant with constant wheel torques.

    Returns the fmpy result record array (time, states, outputs).
    """

    sv = {f"tau{i}": float(t) for i, t in enumerate(tau)}
    sv.update(start_values or {})
    return simulate_fmu(str(fmu), fmi_type="CoSimulation", stop_time=stop_time,
                        output_interval=step, start_values=sv)


def closed_loop_cosim(scenario, fmu: str | Path | None = None, n_sub: int | None = None,
                      controllers: tuple | None = None) -> dict[str, np.ndarray]:
    """Closed-loop co-simulation: the plant FMU stepped by a Python master that runs the
    package's controllers once per control period (zero-order hold, as in
    :mod:`ballbot_casadi.simulation`).

    Per period ``k`` the master reads the plant state from the FMU, runs the velocity
    controller (cascade scenarios) and the balance controller on the controller's
    internal-model parameters, sets the wheel torques (the FMU saturates them at the
    plant's ``tau_max``) and calls ``fmi2DoStep(t_k, Ts)``; the FMU integrates with RK4
    sub-steps of ``Ts / n_sub`` (parameter ``h_internal``).  The plant FMU gets every
    plant parameter of the scenario.

    Parameters
    ----------
    scenario
        A :class:`~ballbot_casadi.scenarios.Scenario` without attitude pushes.
    fmu
        The plant FMU (default: build it).
    n_sub
        RK4 sub-steps per period (default that of :mod:`ballbot_casadi.simulation`).
    controllers
        Optional ``(balance, velocity)`` CasADi Functions (default: built from the
        symbolic model).

    Returns
    -------
    dict
        ``time`` (N+1), ``state`` (N+1, 12; row k the state at ``t_k``), ``tau_cmd``
        (N, 3) and ``tau`` (N, 3, as saturated inside the FMU).
    """

    n_sub = N_SUB_DEFAULT if n_sub is None else int(n_sub)
    if controllers is None:
        controllers = (BALANCE_CONTROLLERS[scenario.controller](make_affine()),
                       make_velocity_controller())
    balance, velocity = controllers
    inp = scenario.inputs()
    w = np.asarray(inp["w"], float)
    if np.any(w[:, :3] != 0.0):
        raise ScenarioError("closed_loop_cosim: attitude pushes cannot be applied through the "
                            "FMU's inputs; use a scenario without pushes")
    if fmu is None:
        unzipped = build_fmu().unzipped
    else:
        unzipped = Path(extract(str(fmu)))
    md = read_model_description(str(unzipped))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    sx = [vr[n] for n in STATE_NAMES]
    su = [vr[f"tau{i}"] for i in range(3)]
    Ts, cascade = float(inp["Ts"]), bool(inp["cascade"])
    n = w.shape[0]
    plant = FMU2Slave(guid=md.guid, unzipDirectory=str(unzipped),
                      modelIdentifier=MODEL_IDENTIFIER, instanceName="plant")
    plant.instantiate()
    try:
        plant.setupExperiment(startTime=0.0)
        plant.enterInitializationMode()
        plant.setReal([vr[p] for p in PARAM_NAMES], [float(v) for v in inp["p_plant"]])
        plant.setReal([vr["h_internal"]], [Ts / n_sub])
        plant.setReal(sx, [float(v) for v in inp["x0"]])
        plant.exitInitializationMode()
        z = np.asarray(inp["z0"], float)
        p_ctrl, k_bal, k_vel = inp["p_ctrl"], inp["k_bal"], inp["k_vel"]
        states = np.zeros((n + 1, len(sx)))
        tau_cmd = np.zeros((n, 3))
        tau = np.zeros((n, 3))
        for k in range(n):
            x = np.array(plant.getReal(sx))
            states[k] = x
            if cascade:
                qr, dqr, ddqr, z_next = velocity(x, inp["v_ref"][k], z, p_ctrl, k_vel, Ts)
                z = np.asarray(z_next, float).ravel()
            else:
                qr, dqr, ddqr = inp["q_ref"][k], inp["dq_ref"][k], inp["ddq_ref"][k]
            u, _ = balance(x, qr, dqr, ddqr, p_ctrl, k_bal)
            tau_cmd[k] = np.asarray(u, float).ravel()
            u_lim = saturate_torques(tau_cmd[k], p_ctrl[PARAM_NAMES.index("tau_max")])
            plant.setReal(su, (u_lim + w[k, 3:6]).tolist())
            plant.doStep(k * Ts, Ts)
            tmax = float(inp["p_plant"][PARAM_NAMES.index("tau_max")])
            tau[k] = np.clip(u_lim + w[k, 3:6], -tmax, tmax)
        states[n] = plant.getReal(sx)
        plant.terminate()
    finally:
        plant.freeInstance()
    return {"time": np.arange(n + 1) * Ts, "state": states, "tau_cmd": tau_cmd, "tau": tau}

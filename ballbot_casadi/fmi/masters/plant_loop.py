"""Co-simulation of the plant FMU from Python: open loop and the closed-loop master.

The closed-loop master runs the package's controllers once per control period around
the FMU, through the one definition of a control period in
:mod:`ballbot_casadi.sim.period`; the FMU runs on the one adapter
:class:`~ballbot_casadi.fmi.masters.adapter.FmuSlave`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from fmpy import extract, simulate_fmu

from ballbot_casadi.control import BALANCE_CONTROLLERS, make_velocity_controller
from ballbot_casadi.core.layout import DISTURBANCE, STATE
from ballbot_casadi.core.params import PARAM_NAMES
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.fmi.archive import verify_fmu
from ballbot_casadi.fmi.build import build_fmu
from ballbot_casadi.fmi.masters.adapter import FmuSlave
from ballbot_casadi.fmi.plant.plant import X0_PREFIX
from ballbot_casadi.model.dynamics import make_affine
from ballbot_casadi.sim.period import control_period
from ballbot_casadi.sim.ports import PERIOD_CONSTANTS, PERIOD_SEQUENCES, PeriodBlocks
from ballbot_casadi.sim.scenario import Scenario

__all__ = ["cosim_open_loop", "closed_loop_cosim"]


def cosim_open_loop(fmu: str | Path, tau: np.ndarray, stop_time: float, step: float = 5e-3,
                    start_values: dict | None = None):
    """One fmpy co-simulation of the plant with constant wheel torques.

    Returns the fmpy result record array (time, states, outputs).

    Raises
    ------
    FileFormatError
        ``fmu`` is not a complete FMU archive (:func:`~ballbot_casadi.fmi.archive.verify_fmu`).
    """

    verify_fmu(fmu, f"plant FMU {fmu}")  # before fmpy extracts it or loads its binary
    sv = {f"tau{i}": float(t) for i, t in enumerate(tau)}
    sv.update(start_values or {})
    return simulate_fmu(str(fmu), fmi_type="CoSimulation", stop_time=stop_time,
                        output_interval=step, start_values=sv)


def closed_loop_cosim(scenario: Scenario, fmu: str | Path | None = None, n_sub: int | None = None,
                      controllers: tuple | None = None) -> dict[str, np.ndarray]:
    """Closed-loop co-simulation: the plant FMU stepped by a Python master.

    Every control period is :func:`ballbot_casadi.sim.period.control_period` (the same
    definition as the compiled mission) evaluated on numpy values, with the plant FMU as
    the plant: the master reads the FMU's state, runs the velocity controller (cascade
    scenarios) and the balance controller on the controller's internal-model parameters
    and its torque limit, sets the FMU inputs ``tau0..2`` (the FMU saturates them at the
    plant's ``tau_max``) and ``tau_dist0..2`` (added after the saturation), and calls
    ``fmi2DoStep(t_k, Ts)``; the FMU integrates with RK4 sub-steps of ``Ts / n_sub``
    (parameter ``h_internal``).  The plant FMU gets every plant parameter of the scenario.

    Parameters
    ----------
    scenario
        A :class:`~ballbot_casadi.sim.scenario.Scenario` without attitude pushes (an FMU
        in co-simulation cannot have its state set between steps).
    fmu
        The plant FMU (default: build it).
    n_sub
        RK4 sub-steps per period (default: the scenario's).
    controllers
        Optional ``(balance, velocity)`` CasADi Functions (default: built from the
        symbolic model).

    Returns
    -------
    dict
        ``time`` (N+1), ``state`` (N+1, 12; row k the state at ``t_k``), ``z``
        (N+1, NZ), ``tau_cmd`` (N, 3) and ``tau`` (N, 3, the torque acting on the plant).

    Raises
    ------
    ScenarioError
        The scenario has attitude pushes.
    FileFormatError
        ``fmu`` is not a complete FMU archive, checked before it is extracted.
    """
    n_sub = scenario.n_sub if n_sub is None else int(n_sub)
    if controllers is None:
        controllers = (BALANCE_CONTROLLERS[scenario.controller](make_affine()),
                       make_velocity_controller())
    blocks = PeriodBlocks(*controllers)
    inp = scenario.inputs()
    w = np.asarray(inp["w"], float)
    if np.any(w[:, DISTURBANCE["push"]] != 0.0):
        raise ScenarioError("closed_loop_cosim: attitude pushes cannot be applied through the "
                            "FMU's inputs; use a scenario without pushes")
    if fmu is not None:  # a user's FMU is checked before it is extracted or loaded
        verify_fmu(fmu, f"plant FMU {fmu}")
    unzipped = build_fmu().unzipped if fmu is None else Path(extract(str(fmu)))
    torques = [f"tau{i}" for i in range(3)]
    dists = [f"tau_dist{i}" for i in range(3)]
    const = {k: inp[k] for k in PERIOD_CONSTANTS}
    Ts = float(const["Ts"])
    n = w.shape[0]
    plant = FmuSlave(unzipped, "plant")
    states = np.zeros((n + 1, STATE.size))
    zs = np.zeros((n + 1, np.size(inp["z0"])))
    tau_cmd = np.zeros((n, 3))
    tau = np.zeros((n, 3))
    try:
        plant.setup(0.0)
        plant.set_reals(PARAM_NAMES, inp["p_plant"])
        plant.set_reals(["h_internal"], [Ts / n_sub])
        plant.set_reals([X0_PREFIX + n for n in STATE.names], inp["x0"])  # the start state
        plant.exit_initialization()
        z = np.asarray(inp["z0"], float)
        zs[0] = z
        k = 0

        def fmu_plant(xk: np.ndarray, tau_k: np.ndarray, tau_lim: np.ndarray,
                      tau_dist: np.ndarray) -> np.ndarray:
            plant.set_reals(torques, tau_lim)
            plant.set_reals(dists, tau_dist)
            plant.do_step(k * Ts, Ts)
            return plant.get_reals(STATE.names)

        x = plant.get_reals(STATE.names)
        for k in range(n):
            seq = {key: inp[key][k] for key in PERIOD_SEQUENCES}
            out = control_period(blocks, x, z, seq, const, fmu_plant)
            states[k], tau_cmd[k], tau[k] = out["x"], out["tau_cmd"], out["tau"]
            x, z = out["x_next"], out["z_next"]
            zs[k + 1] = z
        states[n] = x
        plant.terminate()
    finally:
        plant.free()
    return {"time": np.arange(n + 1) * Ts, "state": states, "z": zs, "tau_cmd": tau_cmd, "tau": tau}

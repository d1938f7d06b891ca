"""A SIL run in the layout of the compiled mission's log, for the metrics of
:mod:`ballbot_casadi.analysis.metrics`: :func:`sil_log`."""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ballbot_casadi.control import BALANCE_DIAG_NAMES
from ballbot_casadi.core.layout import STATE
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.fmi.controller.controller import (
    REFERENCE_NAMES,
    REJECTION_NAMES,
    V_REF_USED_NAMES,
    XHAT_NAMES,
    reading_names,
)
from ballbot_casadi.fmi.plant.plant import WHEEL_ANGLE_NAMES
from ballbot_casadi.fmi.reference_player.player import DISTURBANCE_NAMES
from ballbot_casadi.fmi.system.sil import CONTROLLER, PLANT, TORQUES, SilRun
from ballbot_casadi.sim.embedded import MEAS
from ballbot_casadi.sim.log import SimulationLog
from ballbot_casadi.sim.scenario import Scenario

__all__ = ["sil_log"]


def sil_log(run: SilRun, scenario: Scenario | None = None) -> SimulationLog:
    """The run in the layout of the compiled mission's log (:meth:`ClosedLoop.simulate`).

    Row ``k`` of the per-period arrays is period ``k`` (``[t_k, t_k+1)``): ``state`` and
    ``meas`` at ``t_k``, ``tau`` the torque acting on the plant in it (its inputs
    saturated at the plant's ``tau_max``, plus the disturbance), ``tau_cmd``, ``x_hat``,
    the references used, ``diag``, ``nis``, ``repairs`` and ``rejections`` of the controller's period
    ``k`` (its outputs at ``t_k+1``; the path-following variant's ``v_ref_used`` too).
    """
    sc = scenario if scenario is not None else run.scenario
    if sc is None:
        raise ScenarioError("the SSP carries no scenario; pass the scenario to sil_log")
    s = run.signals
    missing = [n for n in STATE.names if f"{PLANT}.{n}" not in s]
    if missing:
        raise ScenarioError(f"the plant FMU has no outputs {', '.join(missing)}: the log in the "
                            "mission's layout needs the state (the connections are logged anyway)")
    n = run.time.size - 1

    def cols(comp: str, names: Sequence[str]) -> np.ndarray:
        return np.column_stack([s[f"{comp}.{m}"] for m in names])

    params = sc.plant_params()
    tau_in = cols(PLANT, TORQUES)[:n]
    dist = cols(PLANT, DISTURBANCE_NAMES)[:n] if f"{PLANT}.tau_dist0" in s else np.zeros((n, 3))
    tau = np.clip(tau_in, -params.tau_max, params.tau_max) + dist
    meas = cols(PLANT, reading_names(sc.estimator))[:n].copy()  # with the heading reading
    meas[0, MEAS["enc"]] = np.nan  # the controller takes the first encoder reading as missing
    ctrl = {k: cols(CONTROLLER, names)[1:] for k, names in (
        ("tau_cmd", [f"tau_cmd{i}" for i in range(3)]), ("x_hat", XHAT_NAMES),
        ("q_ref", [f"q_ref_used{i}" for i in range(4)]),
        ("dq_ref", [f"dq_ref_used{i}" for i in range(4)]),
        ("ddq_ref", [f"ddq_ref_used{i}" for i in range(4)]),
        ("diag", [f"diag_{m}" for m in BALANCE_DIAG_NAMES]),
        ("nis", ["nis_attitude", "nis_velocity"]), ("repairs", ["repairs"]),
        ("rejections", list(REJECTION_NAMES)))}
    inp_v = cols(CONTROLLER, REFERENCE_NAMES[12:15])[:n]
    w = np.zeros((n, 6))
    w[:, 3:6] = dist
    arrays = {"time": run.time - run.time[0], "state": cols(PLANT, STATE.names),
              "tau": tau, "meas": meas, "v_ref": inp_v, "w": w, **ctrl}
    if all(f"{CONTROLLER}.{m}" in s for m in V_REF_USED_NAMES):  # the path-following variant
        arrays["v_ref_used"] = cols(CONTROLLER, V_REF_USED_NAMES)[1:]
    if all(f"{PLANT}.{m}" in s for m in WHEEL_ANGLE_NAMES):
        arrays["phi"] = cols(PLANT, WHEEL_ANGLE_NAMES)
    return SimulationLog(arrays=arrays, scenario=sc.to_dict(), params=params,
                         ctrl_params=sc.controller_params(), diag_names=tuple(BALANCE_DIAG_NAMES),
                         extra={"master": run.master, "sil": True})

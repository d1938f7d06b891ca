"""The reference player: a scenario's references as an FMU, ``BallbotReference.fmu`` (FMI 2.0 CS).

The SIL system (:mod:`ballbot_casadi.fmi.system.ssp`) needs the scenario's references as
signals that any co-simulation engine can connect to the controller FMU.  This FMU plays
back the per-period rows the compiled mission uses (:meth:`Scenario.inputs
<ballbot_casadi.sim.scenario.Scenario.inputs>`: ``q_ref, dq_ref, ddq_ref`` of the
balance-only mode, ``v_ref = [vx, vy, yaw rate]``) and the wheel-torque disturbance
``tau_dist0..2`` (added by the plant after its saturation), so they are identical bit
for bit: the table is a CasADi linear interpolant on the grid ``0, 1, ..., N-1``
evaluated at whole row numbers (the stored row, exactly), generated into the FMU's C.
Row ``k`` is output from ``t_k = startTime + k Ts`` until the next row (the last row is
held after the end); ``balance_only`` is the scenario's mode (not ``cascade``).

The output names are the controller FMU's input names
(:data:`~ballbot_casadi.fmi.controller.controller.REFERENCE_NAMES`) and the plant FMU's
disturbance inputs (:data:`DISTURBANCE_NAMES`), so the SSP connects equal names.
Attitude pushes cannot enter an FMU's state through its inputs; scenarios with pushes
are refused.
One FMU per scenario (the table is compiled in), cached by content hash like every FMU
of the package; the per-model C file is ``fmu/reference/reference_model.c``.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from ballbot_casadi.core.layout import DISTURBANCE
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.fmi.controller.controller import REFERENCE_NAMES
from ballbot_casadi.fmi.spec import INT32_MAX, FmuBlock, FmuSpec, FmuVar, VarTable
from ballbot_casadi.sim.scenario import Scenario

__all__ = ["MODEL_IDENTIFIER", "GRID_TOL", "DISTURBANCE_NAMES", "OUTPUT_NAMES", "reference_table",
           "reference_player_variables", "reference_player_spec"]

MODEL_IDENTIFIER = "BallbotReference"
#: A time within GRID_TOL * Ts of a row's instant is at the instant.
GRID_TOL = 1e-6
#: The plant FMU's wheel-torque disturbance inputs (the table's last columns).
DISTURBANCE_NAMES = ("tau_dist0", "tau_dist1", "tau_dist2")
#: The table's columns: the controller's references, then the disturbance.
OUTPUT_NAMES = (*REFERENCE_NAMES, *DISTURBANCE_NAMES)

_UNITS = {"q": "1", "dq": "1/s", "ddq": "1/s2", "v_ref_x": "m/s", "v_ref_y": "m/s",
          "yaw_rate_ref": "rad/s", "tau_dist": "N.m"}


def reference_table(scenario: Scenario) -> np.ndarray:
    """The per-period inputs of ``scenario``: rows ``[q_ref, dq_ref, ddq_ref, v_ref,
    tau_dist]`` (N, 18, :data:`OUTPUT_NAMES`), as
    :meth:`~ballbot_casadi.sim.scenario.Scenario.inputs` gives them.

    Raises
    ------
    ScenarioError
        The scenario pushes the attitude (an FMU's state cannot jump through its inputs).
    """
    w = scenario.disturbance()
    if np.any(w[:, DISTURBANCE["push"]] != 0.0):
        raise ScenarioError(f"scenario {scenario.name!r} has attitude pushes, which cannot enter "
                            "the plant FMU through its inputs; use a scenario without pushes "
                            "(wheel-torque disturbances are fine)")
    q, dq, ddq = scenario.attitude_reference()
    table = np.hstack([q, dq, ddq, scenario.velocity_reference(), w[:, DISTURBANCE["tau_dist"]]])
    if table.shape[1] != len(OUTPUT_NAMES) or not np.all(np.isfinite(table)):
        raise ScenarioError(f"scenario {scenario.name!r}: the reference table must be finite with "
                            f"{len(OUTPUT_NAMES)} columns, got shape {table.shape}")
    return table


def _unit(name: str) -> str:
    return _UNITS.get(name, _UNITS.get(name.rstrip("0123").removesuffix("_ref"), "1"))



def reference_player_variables(Ts: float) -> tuple[FmuVar, ...]:
    """The variable table of the reference FMU (row period ``Ts`` as the start value)."""
    t = VarTable()
    for name in REFERENCE_NAMES:
        t.add(name, "discrete_output", f"reference {name} of the current period (the "
              "controller FMU's input of that name)", unit=_unit(name))
    for name in DISTURBANCE_NAMES:
        t.add(name, "discrete_output", f"wheel-torque disturbance {name} of the current period "
              "(the plant FMU's input of that name)", unit="N.m")
    t.add("Ts", "parameter", "period of the table's rows: row k is output from startTime + "
          "k Ts", start=float(Ts), unit="s", rule="pos")
    t.add("row", "local", "index of the row being output", type="Integer", bounds=(0, INT32_MAX))
    t.add("balance_only", "discrete_output", "the scenario's mode: true = attitude reference "
          "(balance controller alone), false = velocity cascade (the controller FMU's input of "
          "that name)", type="Boolean")
    return t.rows()


def reference_player_spec(scenario: Scenario) -> FmuSpec:
    """The reference FMU of ``scenario`` (Co-Simulation only)."""
    table = reference_table(scenario)
    if table.shape[0] == 1:  # an interpolant needs two grid points
        table = np.vstack([table, table])
    n = table.shape[0]
    k = ca.MX.sym("k")
    interp = ca.interpolant("ballbot_reference_interp", "linear", [np.arange(n, dtype=float)],
                            table.ravel(order="C"))
    f = ca.Function("ballbot_reference_table", [k], [interp(k)], ["k"], ["row"])
    rows = reference_player_variables(scenario.Ts)
    defines = {"NROWS": n, "BALANCE_ONLY": int(not scenario.cascade), "GRID_TOL": repr(GRID_TOL)}
    return FmuSpec(
        model_identifier=MODEL_IDENTIFIER,
        description=f"references of scenario {scenario.name!r} ({n} periods of "
        f"{scenario.Ts:g} s): attitude reference and its derivatives, velocity and heading-rate "
        "references and the mode, played back from the table the compiled mission uses",
        prefix="ref",
        variables=rows,
        functions=(f,),
        model_source="reference/reference_model.c",
        cg_name="ballbot_reference_cg",
        interfaces=("cs",),
        defines=tuple((k_, str(v)) for k_, v in defines.items()),
        blocks=(FmuBlock("out", None, OUTPUT_NAMES),),
        default_experiment=(0.0, n * scenario.Ts, scenario.Ts),
    )

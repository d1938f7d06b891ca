"""The Gauss-Seidel master: the FMUs of an SSP system stepped one after the other (fmpy).

At every communication point ``t_k`` each component in turn gets its inputs from the
connections (the outputs its predecessors have just computed) and steps; for the SIL,
controller first, then the plant on the controller's new torque, then the reference
player (it reads nothing): the loop of the compiled mission (torque of period ``k``
computed from sample ``k`` and acting on ``[t_k, t_k+1)``).  Every FMU runs on the one
adapter :class:`~ballbot_casadi.fmi.masters.adapter.FmuSlave`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ballbot_casadi.fmi.masters.adapter import FmuSlave
from ballbot_casadi.fmi.system.ssp import SspSystem

__all__ = ["run_gauss_seidel"]


def run_gauss_seidel(system: SspSystem, unzipped: Mapping[str, Path], n: int, step: float,
                     variables: Mapping[str, Mapping[str, Any]],
                     rec: Sequence[tuple[str, str]], first: Sequence[str] = ()
                     ) -> dict[str, np.ndarray]:
    """Run ``system`` for ``n`` steps of ``step`` s, the components in the order ``first``
    (those the system has) and then the others in the system's order.

    Parameters
    ----------
    system
        The SSP system (:func:`~ballbot_casadi.fmi.system.ssp.read_ssp`): its parameter
        sets are set in initialisation mode, its connections transferred before each
        component's step.
    unzipped
        ``{component: unzipped FMU folder}``.
    n, step
        Number and size of the communication steps.
    variables
        ``{component: {name: fmpy ScalarVariable}}``.
    rec
        ``(component, variable)`` pairs to record.
    first
        Components stepped first, in this order.

    Returns
    -------
    dict
        ``{"<component>.<variable>": (n + 1,) array}``: outputs at ``t_k``, inputs as
        held on ``[t_k, t_k+1)`` (NaN at ``t_n``).
    """
    order = [c for c in first if c in system.components]
    order += [c for c in system.components if c not in order]
    slaves: dict[str, FmuSlave] = {}
    out = {f"{c}.{v}": np.zeros(n + 1) for c, v in rec}

    def transfer(into: str) -> None:
        for c in system.connections:
            if c.end_element == into:
                slaves[into].set(c.end_connector,
                                 slaves[c.start_element].get(c.start_connector))

    try:
        for comp in order:
            slaves[comp] = FmuSlave(unzipped[comp], comp)
        for comp, s in slaves.items():
            s.setup(system.start_time, system.parameters.get(comp, {}))
        for comp in order:  # outputs at the start time, in dependency order
            transfer(comp)
            slaves[comp].exit_initialization()
        t0 = system.start_time
        for k in range(n + 1):
            for key, (c, v) in zip(out, rec):  # outputs at t_k
                if variables[c][v].causality != "input":
                    out[key][k] = slaves[c].get(v)
            for comp in order:
                transfer(comp)
                for key, (c, v) in zip(out, rec):  # inputs held on [t_k, t_k+1)
                    if c == comp and variables[c][v].causality == "input":
                        out[key][k] = slaves[c].get(v) if k < n else np.nan
                if k < n:
                    slaves[comp].do_step(t0 + k * step, step)
    finally:
        for s in slaves.values():
            s.free()
    return out

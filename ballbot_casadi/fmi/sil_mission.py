"""The compiled mission as a Jacobi co-simulation master runs the SIL system.

In a Jacobi master (libcosim's fixed-step algorithm, fmpy's containers) the plant and
the controller FMU step from ``t_k`` at the same time, so the torque the embedded
software computes in period ``k`` (from sample ``k``) reaches the plant at ``t_k+1``
and acts on ``[t_k+1, t_k+2)``; the torque of period 0 is the controller's output
before its first step, zero (:mod:`ballbot_casadi.fmi.sil`).  This module builds that
loop the way :func:`~ballbot_casadi.sim.closed_loop.make_estimating_step` builds the
mission's period, from the same Functions (the plant-side sensors
:func:`~ballbot_casadi.sim.embedded.sense`, the embedded software
``ballbot_embedded_<ctrl>_<est>`` the controller FMU runs, the period of
:func:`~ballbot_casadi.sim.period.control_period` with the RK4 plant) with one
difference: the torque that acts in period ``k`` is the command held from period
``k-1`` (an extra state ``u``).  Compiled like the mission (cached by hash) and run as
one ``mapaccum`` call, it is the reference the libcosim run is checked against.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping

import casadi as ca
import numpy as np

from ballbot_casadi.core.layout import DISTURBANCE
from ballbot_casadi.core.toolchain import build_library, load_library
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.fmi.controller import (
    controller_state_layout,
    embedded_function,
    initial_controller_state,
)
from ballbot_casadi.model.dynamics import NP, NX, make_ode, make_wheel_speeds
from ballbot_casadi.model.sensors import make_wheel_angle_ode
from ballbot_casadi.sim.closed_loop import make_mission
from ballbot_casadi.sim.embedded import (
    N_WHEEL,
    NOISE,
    SENSOR_STATE,
    VALID,
    estimator_blocks,
    sense,
)
from ballbot_casadi.sim.period import PERIOD_OUTPUTS, control_period, rk4_plant
from ballbot_casadi.sim.scenario import Scenario

__all__ = ["make_jacobi_step", "jacobi_mission"]

_SEQUENCES = ("q_ref", "dq_ref", "ddq_ref", "v_ref", "w", "noise", "valid")
_OUTPUTS = (*PERIOD_OUTPUTS, "x_hat", "meas", "nis", "repairs")


def make_jacobi_step(embedded: ca.Function, estimator: str, n_sub: int) -> ca.Function:
    """One period of the SIL loop under a Jacobi master, ``ballbot_sil_jacobi_<ctrl>_<est>``.

    Inputs ``xz = [x (15, with the wheel angles); c; s; u]`` (``s``
    :data:`~ballbot_casadi.sim.embedded.SENSOR_STATE`, ``u`` the held torque command),
    the sequences ``q_ref, dq_ref, ddq_ref, v_ref, w, noise, valid`` and the constants
    of :func:`~ballbot_casadi.sim.closed_loop.make_estimating_step` (the embedded
    Function's parameters by name).  Outputs ``xz_next`` and, per period, ``x``,
    ``tau_cmd``, ``tau`` (acting: the held command saturated, plus the disturbance),
    the references used, ``diag``, ``x_hat``, ``meas``, ``nis``, ``repairs``.
    """
    ode = make_ode()
    ws = make_wheel_speeds()
    est = estimator_blocks(estimator, ode, ws)
    nc = embedded.size1_in(0)
    nxw = NX + N_WHEEL
    MX = ca.MX.sym
    xz = MX("xz", nxw + nc + SENSOR_STATE.size + 3)
    seq = {"q_ref": MX("q_ref", 4), "dq_ref": MX("dq_ref", 4), "ddq_ref": MX("ddq_ref", 4),
           "v_ref": MX("v_ref", 3), "w": MX("w", DISTURBANCE.size),
           "noise": MX("noise", NOISE.size), "valid": MX("valid", VALID.size)}
    params = [n for n in embedded.name_in() if n not in ("c", "meas", *seq)]
    const = {"p_plant": MX("p_plant", NP), "s": MX("s", est.imu.size1_in(3)),
             **{n: MX(n, embedded.size1_in(embedded.index_in(n))) for n in params}}

    def robot(xk: ca.MX, cs: ca.MX, sq: Mapping[str, Any], cn: Mapping[str, Any]) -> dict[str, Any]:
        c, s_state, u = cs[:nc], cs[nc:nc + SENSOR_STATE.size], cs[nc + SENSOR_STATE.size:]
        meas, s_mid = sense(est, xk, s_state, sq["noise"], sq["valid"], cn["p_plant"], cn["s"],
                            cn["Ts"])
        out = embedded.call({"c": c, "meas": meas,
                             **{k: sq[k] for k in ("q_ref", "dq_ref", "ddq_ref", "v_ref")},
                             **{k: cn[k] for k in params}})
        return {**out, "tau_lim": u, "meas": meas,
                "z_next": ca.vertcat(out["c_next"], s_mid, out["tau_lim"])}

    plant = rk4_plant(make_wheel_angle_ode(ode, ws), n_sub, const["p_plant"], const["Ts"])
    out = control_period(None, xz[:nxw], xz[nxw:], seq, const, plant, controller=robot)
    zn = out["z_next"]
    z_next = ca.vertcat(zn[:nc], out["tau"], zn[nc:])
    out["x"] = out["x"][:NX]
    name = embedded.name().replace("ballbot_embedded_", "ballbot_sil_jacobi_")
    return ca.Function(name, [xz, *seq.values(), *const.values()],
                       [ca.vertcat(out["x_next"], z_next), *(out[k] for k in _OUTPUTS)],
                       ["xz", *seq, *const], ["xz_next", *_OUTPUTS])


def jacobi_mission(scenario: Scenario, root: Path | None = None) -> dict[str, np.ndarray]:
    """Run ``scenario`` as the SIL loop under a Jacobi master (compiled, one call).

    Returns the arrays of :meth:`ClosedLoop.simulate <ballbot_casadi.sim.closed_loop.
    ClosedLoop.simulate>`'s log that the SIL is compared on: ``time``, ``state``
    (N + 1, 12), ``tau``, ``tau_cmd``, ``x_hat``, ``meas``, ``q_ref``, ``diag``,
    ``nis``, ``repairs``.

    Raises
    ------
    ScenarioError
        A scenario without an estimator.
    """
    if scenario.estimator == "true":
        raise ScenarioError(f"scenario {scenario.name!r}: the SIL needs an estimator in the loop")
    embedded = embedded_function(scenario.controller, scenario.estimator)
    step = make_jacobi_step(embedded, scenario.estimator, scenario.n_sub)
    lib = build_library(f"ballbot_sil_jacobi_{scenario.estimator}_sub{scenario.n_sub}", [step],
                        root)
    compiled = load_library(lib, [step.name()])[step.name()]
    inp = scenario.inputs()
    est = inp["estimation"]
    layout = controller_state_layout(embedded, scenario.estimator)
    n = scenario.n_periods
    xz0 = np.concatenate([inp["x0"], np.zeros(N_WHEEL), initial_controller_state(inp, layout),
                          est["s0"], np.zeros(3)])
    values = {"q_ref": inp["q_ref"], "dq_ref": inp["dq_ref"], "ddq_ref": inp["ddq_ref"],
              "v_ref": inp["v_ref"], "w": inp["w"], "noise": est["noise"], "valid": est["valid"],
              "p_plant": inp["p_plant"], "s": est["s"], "p_ctrl": inp["p_ctrl"],
              "p_est": est["p_est"], "k_bal": inp["k_bal"], "k_vel": inp["k_vel"],
              "Ts": inp["Ts"], "cascade": float(inp["cascade"]),
              "feedforward": float(inp["feedforward"]),
              **{k: np.asarray(est[k], float).ravel(order="F") for k in ("Qa", "Ra", "Qv", "Rv")},
              "com_observer": float(inp.get("com_observer", False)), "k_obs": inp.get("k_obs")}
    args = [xz0]
    for i in range(1, step.n_in()):
        name = step.name_in(i)
        a = np.asarray(values[name], float)
        args.append(a.T if name in _SEQUENCES else a.reshape(-1))
    res = dict(zip(step.name_out(), make_mission(compiled, n)(*args)))
    res = {k: np.asarray(v).T for k, v in res.items()}
    final = res["xz_next"][-1, :NX]
    return {"time": np.arange(n + 1) * scenario.Ts, "state": np.vstack([res["x"], final]),
            "tau": res["tau"], "tau_cmd": res["tau_cmd"], "x_hat": res["x_hat"],
            "meas": res["meas"], "q_ref": res["q_ref_used"], "diag": res["diag"],
            "nis": res["nis"], "repairs": res["repairs"]}

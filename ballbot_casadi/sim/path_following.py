"""Guidance above the compiled mission, driven from Python: the reference driver.

The product runs the guidance *inside* the control period (the guidance slot,
:mod:`ballbot_casadi.sim.guided`, one compiled mission); this driver is kept as its
independent reference (the tests compare the two, equal to ~1e-7 m) and for the MPC
benchmark, which times the solver's calls from Python.

A guidance law (the MPC of :mod:`ballbot_casadi.guidance.mpc` or the pure-pursuit
baseline) runs every ``guidance_period`` (default 0.1 s = 20 control periods, 10 Hz): it
reads the true state of the plant and the velocity controller's state, returns a velocity
reference, and the compiled closed loop (FLC cascade with the velocity LQR,
:class:`~ballbot_casadi.sim.closed_loop.ClosedLoop`) then runs one guidance period with
that reference held, continuing from the previous segment's final state (segments of a
compiled mission equal the single-call run bit for bit).

Everything that ties the guidance layer to the model and controllers is here: the
prediction model of the closed velocity loop (:func:`velocity_loop_model`, from the
velocity LQR's design model and gain) and the map from the plant and controller state to
that model's state (:func:`loop_state`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Protocol

import casadi as ca
import numpy as np

from ballbot_casadi.control.velocity import VELOCITY_LIMIT_NAMES, VELOCITY_NKV, design_model, measured_tilt
from ballbot_casadi.core.constants import TS_CONTROL
from ballbot_casadi.core.layout import STATE, STATE_DXY, STATE_XY
from ballbot_casadi.core.layout import VELOCITY_CONTROLLER_STATE as Z
from ballbot_casadi.core.params import PARAM_NAMES
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.guidance.paths import Path
from ballbot_casadi.guidance.prediction import LoopModel, closed_velocity_loop
from ballbot_casadi.model.dynamics import make_jacobians
from ballbot_casadi.sim.closed_loop import ClosedLoop
from ballbot_casadi.sim.ports import PERIOD_SEQUENCES
from ballbot_casadi.sim.scenario import Scenario

__all__ = ["Guidance", "simulate_chunk", "chunks_log", "velocity_loop_model", "make_loop_state", "run_path", "PathRun",
           "path_scenario", "FLC_CANCELLED", "LOOP_GAIN_ENTRIES", "LoopDependencies",
           "velocity_loop_dependencies"]

#: Entries of ``k_vel`` that are the velocity LQR's gain ``K`` (2 x 12, row-major); the
#: rest are the limits (``VELOCITY_LIMIT_NAMES``), which the linear loop model does not read.
LOOP_GAIN_ENTRIES = VELOCITY_NKV - len(VELOCITY_LIMIT_NAMES)
#: Model parameters that enter the plant's Jacobians at the upright equilibrium but not
#: the loop model :func:`velocity_loop_model` builds from them: the balance controller's
#: FLC inverts the torque-to-tilt-acceleration map ``E`` (thesis (8.26), (8.44)), which
#: cancels the wheel geometry, inertia and motor friction (``rw``, ``alpha``, ``gamma``,
#: ``Jw``, ``Bvm``), and the heading inertia ``Jbz`` and the quaternion stabilisation
#: ``beta`` act on the heading row only, which the FLC decouples from the tilt.
FLC_CANCELLED = ("Jbz", "Jw", "rw", "alpha", "gamma", "Bvm", "beta")


class Guidance(Protocol):
    """A guidance law: ``step(x_loop) -> v_ref (2)`` once per guidance period."""

    def step(self, x_loop: np.ndarray) -> np.ndarray: ...


def path_scenario(path: Path, duration: float, controller: str = "flc") -> Scenario:
    """The cascade scenario the guidance runs above: standing upright at the path's start."""
    s0 = 0.0
    x0 = np.zeros(12)
    x0[STATE["q"].start] = 1.0
    x0[STATE_XY] = path.point(s0)
    return Scenario("path", controller, duration, tuple(x0.tolist()), cascade=True)


def velocity_loop_model(p_ctrl: np.ndarray, k_vel: np.ndarray, dt: float,
                        Ts: float = TS_CONTROL) -> LoopModel:
    """Linear model of the closed velocity loop (gain ``k_vel``) at the MPC step ``dt``."""
    Ac, Bc, _, _ = design_model(make_jacobians(), p_ctrl, Ts)
    # row-major, as the controller reads it
    K = np.asarray(k_vel, float)[:LOOP_GAIN_ENTRIES].reshape(2, LOOP_GAIN_ENTRIES // 2)
    return closed_velocity_loop(Ac, Bc, K, Ts, dt)


@dataclass(frozen=True)
class LoopDependencies:
    """What :func:`velocity_loop_model` reads: ``params`` (``load_params`` names of
    ``p_ctrl``), ``gains`` (indices into ``k_vel``) and the control period ``Ts``."""

    params: tuple[str, ...]
    gains: tuple[int, ...]
    period: bool = True


def velocity_loop_dependencies(jac: ca.Function | None = None) -> LoopDependencies:
    """The inputs :func:`velocity_loop_model` is built from, declared, not probed.

    The model parameters are those the Jacobians ``jac(x, tau, p)`` (default the model's,
    :func:`~ballbot_casadi.model.dynamics.make_jacobians`) depend on structurally
    (``casadi.depends_on``) at the upright equilibrium the design model linearises at,
    less :data:`FLC_CANCELLED`; the gains are the ``K`` entries of ``k_vel``
    (:data:`LOOP_GAIN_ENTRIES`); the loop is discretised at ``Ts``.  The set does not
    depend on the parameter values.
    """
    jac = make_jacobians() if jac is None else jac
    x0 = np.zeros(12)
    x0[STATE["q"].start] = 1.0
    p = ca.SX.sym("p", len(PARAM_NAMES))
    A, B = jac(ca.DM(x0), ca.DM.zeros(jac.size1_in(1)), p)
    AB = ca.vertcat(ca.vec(A), ca.vec(B))
    read = [n for i, n in enumerate(PARAM_NAMES) if ca.depends_on(AB, p[i])]
    return LoopDependencies(tuple(n for n in read if n not in FLC_CANCELLED),
                            tuple(range(LOOP_GAIN_ENTRIES)))


def make_loop_state() -> ca.Function:
    """``ballbot_loop_state(x[12], z[8]) -> X[14]``: the loop model's state of plant + controller."""
    x = ca.SX.sym("x", 12)
    z = ca.SX.sym("z", Z.size)
    q, dq = x[STATE["q"]], x[STATE["dq"]]
    th = measured_tilt(q)
    dth = ca.jtimes(th, q, dq)
    X = ca.vertcat(x[STATE_DXY], th, dth, z[Z["theta_r"]], z[Z["dtheta_r"]], z[Z["p_e"]],
                   x[STATE_XY])
    return ca.Function("ballbot_loop_state", [x, z], [X], ["x", "z"], ["X"])


@dataclass
class PathRun:
    """Log of a guided run: the mission log arrays plus the guidance samples."""

    log: dict[str, np.ndarray]
    t_guidance: np.ndarray
    v_ref: np.ndarray
    solve_s: np.ndarray
    progress: np.ndarray
    predictions: list


def run_path(path: Path, guidance: Guidance, duration: float, guidance_period: float = 0.1,
             sim: ClosedLoop | None = None, controller: str = "flc") -> PathRun:
    """Run ``guidance`` above the compiled cascade for ``duration`` s (true-state feedback).

    Returns the concatenated mission log (``state`` (n+1, 12), ``z``, ``tau``, ``q_ref``,
    ... of :meth:`ClosedLoop.simulate`) and per guidance sample: time, ``v_ref``, the
    wall-clock time of the guidance call, progress and predicted positions (if the
    guidance has them).
    """
    m = int(round(guidance_period / TS_CONTROL))
    if m < 1 or abs(m * TS_CONTROL - guidance_period) > 1e-9:
        raise ScenarioError(f"guidance_period must be a multiple of {TS_CONTROL} s, got "
                            f"{guidance_period!r}")
    n_seg = int(round(duration / guidance_period))
    sim = ClosedLoop() if sim is None else sim
    sc = path_scenario(path, guidance_period, controller)
    inp = sc.inputs()
    for key in ("com_observer", "k_obs", "estimator"):
        inp.pop(key, None)
    loop_state = make_loop_state()
    x, z = inp["x0"], inp["z0"]
    xz = None
    parts: dict[str, list[np.ndarray]] = {}
    t_g, v_log, solve, prog, preds = [], [], [], [], []
    for i in range(n_seg):
        X = np.asarray(loop_state(x, z), float).ravel()
        t0 = time.perf_counter()
        v = np.asarray(guidance.step(X), float).reshape(2)
        solve.append(time.perf_counter() - t0)
        t_g.append(i * guidance_period)
        v_log.append(v)
        prog.append(getattr(guidance, "progress", lambda: np.nan)())
        if hasattr(guidance, "prediction"):
            preds.append(guidance.prediction())
        seq = dict(inp)
        seq["v_ref"] = np.tile([v[0], v[1], 0.0], (m, 1))
        for key in PERIOD_SEQUENCES:
            if key != "v_ref":
                seq[key] = inp[key][:m]
        xz, x, z = simulate_chunk(sim, controller, seq, xz, parts)
    log = chunks_log(parts, x, z)
    return PathRun(log, np.array(t_g), np.array(v_log), np.array(solve), np.array(prog), preds)


def simulate_chunk(sim: ClosedLoop, controller: str, seq: dict, xz, parts: dict) -> tuple:
    """Simulate one guidance sample's periods from ``xz`` with the sequences ``seq`` and
    append the log's rows to ``parts`` (the last row of time, state and z is the next
    chunk's first, so it is left out); the next ``xz`` and the last state and z."""
    out = sim.simulate(controller, **seq, xz0=xz)
    xz = out.pop("xz_final")
    for key, val in out.items():
        parts.setdefault(key, []).append(val[:-1] if key in ("time", "state", "z") else val)
    return xz, out["state"][-1], out["z"][-1]


def chunks_log(parts: dict, x: np.ndarray, z: np.ndarray, Ts: float = TS_CONTROL) -> dict:
    """The log of the chunks in ``parts`` (:func:`simulate_chunk`), closed with the last
    state ``x`` and velocity-controller state ``z``, time on the control period ``Ts``."""
    log = {k: np.concatenate(v) for k, v in parts.items()}
    log["state"] = np.vstack([log["state"], x])
    log["z"] = np.vstack([log["z"], z])
    log["time"] = np.arange(log["state"].shape[0]) * Ts
    return log

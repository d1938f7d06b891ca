"""Closed-loop simulation: plant, sampled controllers and the whole mission as CasADi Functions.

Structure (thesis Fig. 7.1 cascade, Fig. 8.1 balance-only)
----------------------------------------------------------
One control period ``Ts`` (200 Hz, thesis §7.1) is the Function
``ballbot_cl_step_<ctrl>``:

1. a disturbance jump of the plant attitude (a push, thesis §8.4.3): the attitude is
   rotated in {K} by the rotation vector ``w[0:3]``, ``q <- exp(w/2) o q`` and
   ``dq <- exp(w/2) o dq`` (body rates unchanged);
2. the velocity controller ``ballbot_velocity`` (outer loop, thesis §7.3) runs once per
   period and produces ``q_ref, dq_ref, ddq_ref``; with ``cascade = 0`` the references
   come from the input sequences instead (balance controller alone, thesis Fig. 8.1);
3. the balance controller (``ballbot_flc`` thesis 8.26/8.44 or ``ballbot_smc``) computes
   the wheel torques on its *own* internal-model parameters ``p_ctrl``;
4. the torques are limited without changing their direction at ``tau_max`` of the
   controller parameters ``p_ctrl`` and then saturated per wheel at ``+-tau_max`` of the
   *plant* parameters ``p_plant``,
   an input disturbance torque ``w[3:6]`` is added, and the result is held (zero-order
   hold) over the period while the plant is integrated with ``n_sub`` classical RK4 steps
   of size ``Ts / n_sub`` (:func:`~ballbot_casadi.integrators.make_rk4_n`).

Every block is a *called* Function (ODE inside RK4, RK4 and controllers inside the
step), so the generated C holds one copy of each.  The mission over ``N`` periods is
``step.mapaccum(N)`` (CasADi nests it in log-depth folds): one call runs a whole
mission.  The compiled variant (:func:`closed_loop_library`, built once, cached by hash)
holds the step and a chunk of :data:`CHUNK` periods (``ballbot_cl_chunk_<ctrl>``, the
step's ``mapaccum`` in C); a mission of any length chains compiled chunks and runs the
remainder through the compiled step's ``mapaccum``, composed into one Function, so
missions run as a single call without regenerating C.  By default the same chain runs
through the zero-copy C entry point of :mod:`~ballbot_casadi.mission_driver` (one C
call per mission, numpy buffers in place; identical results).

Log layout: ``state[k]`` (k < N) is the state the controllers saw at ``t_k = k Ts`` (after
a push), ``state[N]`` the final state; torques and references of period k apply on
``[t_k, t_k+1)``.

Plant and controller parameters are separate inputs, so robustness runs (thesis §8.4)
need no regeneration.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import casadi as ca
import numpy as np

from ballbot_casadi.control import (
    BALANCE_CONTROLLERS,
    make_velocity_controller,
    saturate_torques,
)
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.params import PARAM_NAMES, Params
from ballbot_casadi.core.toolchain import build_library, load_library
from ballbot_casadi.errors import ScenarioError, ShapeError
from ballbot_casadi.model.dynamics import NP, NU, NX, STATE_NAMES, make_affine, make_ode
from ballbot_casadi.model.integrators import make_rk4_n
from ballbot_casadi.sim.driver import MissionDriver
from ballbot_casadi.sim.scenarios import Scenario

__all__ = [
    "TS_DEFAULT",
    "N_SUB_DEFAULT",
    "ND_W",
    "make_closed_loop_step",
    "make_mission",
    "make_chunk",
    "CHUNK",
    "closed_loop_functions",
    "closed_loop_library",
    "ClosedLoop",
    "SimulationLog",
    "save_log",
    "load_log",
    "run_scenario",
]

#: Control period (s): 200 Hz, thesis §7.1.
TS_DEFAULT = 0.005
#: RK4 sub-steps per control period: 1 ms plant step by default.
N_SUB_DEFAULT = 5
#: Size of the per-period disturbance input ``w = [attitude jump (3), torque (3)]``.
ND_W = 6
#: Control periods per compiled chunk (1 s at 200 Hz).
CHUNK = 200
#: Step inputs that are per-period sequences (the others are constants).
_SEQ_INPUTS = (1, 2, 3, 4, 5)

_TAU_MAX = PARAM_NAMES.index("tau_max")


def _sizes(balance: ca.Function, velocity: ca.Function) -> dict[str, int]:
    """Check the controller signatures of the interface contract and return the sizes."""
    if not isinstance(balance, ca.Function) or balance.n_in() != 6 or balance.n_out() != 2:
        raise ScenarioError(
            "balance controller must be a CasADi Function "
            "(x, q_ref, dq_ref, ddq_ref, p, k) -> (tau, diag)"
        )
    if not isinstance(velocity, ca.Function) or velocity.n_in() != 6 or velocity.n_out() != 4:
        raise ScenarioError(
            "velocity controller must be a CasADi Function "
            "(x, v_ref, z, p, k, Ts) -> (q_ref, dq_ref, ddq_ref, z_next)"
        )
    want_b = [NX, 4, 4, 4, NP]
    got_b = [balance.numel_in(i) for i in range(5)]
    if got_b != want_b or balance.numel_out(0) != NU:
        raise ScenarioError(f"balance controller input sizes {got_b} (expected {want_b} + gains)")
    nz = velocity.numel_in(2)
    want_v = [NX, 3, nz, NP]
    got_v = [velocity.numel_in(i) for i in range(4)]
    if got_v != want_v or [velocity.numel_out(i) for i in range(4)] != [4, 4, 4, nz]:
        raise ScenarioError(f"velocity controller sizes {got_v} do not match {want_v}")
    return {
        "nk": balance.numel_in(5),
        "nd": balance.numel_out(1),
        "nz": nz,
        "nkv": velocity.numel_in(4),
    }


def _block_name(balance: ca.Function) -> str:
    return balance.name().removeprefix("ballbot_")


def make_closed_loop_step(
    balance: ca.Function,
    velocity: ca.Function,
    ode: ca.Function,
    n_sub: int = N_SUB_DEFAULT,
) -> ca.Function:
    """One control period of the closed loop, ``ballbot_cl_step_<ctrl>``.

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

    Returns
    -------
    casadi.Function
        Inputs ``xz = [x; z]`` (accumulated), per-period ``q_ref, dq_ref, ddq_ref``
        (4 each, used when ``cascade = 0``), ``v_ref`` (3, used when ``cascade = 1``),
        ``w`` (6: attitude jump rotation vector in {K}, wheel-torque disturbance),
        then the constants ``p_plant, p_ctrl, k_bal, k_vel, Ts, cascade``.  Outputs
        ``xz_next``, ``x`` (state the controllers saw, after the jump), ``tau_cmd``
        (controller output), ``tau`` (saturated), the references used and ``diag``.
    """
    s = _sizes(balance, velocity)
    rk4 = make_rk4_n(ode, n_sub)
    MX = ca.MX.sym
    xz = MX("xz", NX + s["nz"])
    q_ref, dq_ref, ddq_ref = MX("q_ref", 4), MX("dq_ref", 4), MX("ddq_ref", 4)
    v_ref, w = MX("v_ref", 3), MX("w", ND_W)
    p_plant, p_ctrl = MX("p_plant", NP), MX("p_ctrl", NP)
    k_bal, k_vel = MX("k_bal", s["nk"]), MX("k_vel", s["nkv"])
    Ts, cascade = MX("Ts"), MX("cascade")

    x, z = xz[:NX], xz[NX:]
    r = Q.from_rotation_vector(w[0:3])  # push (thesis §8.4.3): exact identity for w = 0
    xk = ca.vertcat(x[0:2], Q.mul(r, x[2:6]), x[6:8], Q.mul(r, x[8:12]))

    qv, dqv, ddqv, z_next = velocity(xk, v_ref, z, p_ctrl, k_vel, Ts)
    on = cascade > 0.5
    qr = ca.if_else(on, qv, q_ref)
    dqr = ca.if_else(on, dqv, dq_ref)
    ddqr = ca.if_else(on, ddqv, ddq_ref)
    z_next = ca.if_else(on, z_next, z)

    tau_cmd, diag = balance(xk, qr, dqr, ddqr, p_ctrl, k_bal)
    # Direction-preserving limit at the controller's own tau_max, then the plant's
    # physical per-wheel saturation (a no-op unless the plant's limit is lower).
    tau_lim = saturate_torques(tau_cmd, p_ctrl[_TAU_MAX])
    tau_max = p_plant[_TAU_MAX]
    tau = ca.fmin(ca.fmax(tau_lim, -tau_max), tau_max)
    x_next = rk4(xk, tau + w[3:6], p_plant, Ts)
    return ca.Function(
        f"ballbot_cl_step_{_block_name(balance)}",
        [xz, q_ref, dq_ref, ddq_ref, v_ref, w, p_plant, p_ctrl, k_bal, k_vel, Ts, cascade],
        [ca.vertcat(x_next, z_next), xk, tau_cmd, tau, qr, dqr, ddqr, diag],
        ["xz", "q_ref", "dq_ref", "ddq_ref", "v_ref", "w",
         "p_plant", "p_ctrl", "k_bal", "k_vel", "Ts", "cascade"],
        ["xz_next", "x", "tau_cmd", "tau", "q_ref_used", "dq_ref_used", "ddq_ref_used", "diag"],
    )


def make_mission(step: ca.Function, n_periods: int) -> ca.Function:
    """The closed loop over ``n_periods`` control periods as one Function (``mapaccum``).

    Sequence inputs are ``(size, n_periods)`` matrices (one column per period);
    constants (parameters, gains, ``Ts``, ``cascade``) may be single columns.
    """
    if not isinstance(n_periods, (int, np.integer)) or n_periods < 1:
        raise ScenarioError(f"number of control periods must be an int >= 1, got {n_periods!r}")
    name = step.name().replace("ballbot_cl_step_", "ballbot_mission_")
    return step.mapaccum(name, int(n_periods))


def make_chunk(step: ca.Function, n_periods: int = CHUNK) -> ca.Function:
    """``n_periods`` steps as one Function whose first output is the *last* ``xz``.

    ``ballbot_cl_chunk_<ctrl>(xz, sequences..., constants...) -> (xz_last, xz_next,
    x, tau_cmd, tau, q_ref_used, dq_ref_used, ddq_ref_used, diag)``: the shape of the
    accumulated input equals that of the first output, so chunks chain with
    ``mapaccum`` themselves (see :meth:`ClosedLoop.mission`).
    """
    inner = make_mission(step, n_periods)
    # constants (parameters, gains, Ts, cascade) are single columns, broadcast inside
    args = [ca.MX.sym(inner.name_in(i), inner.size1_in(i), n_periods if i in _SEQ_INPUTS else 1)
            for i in range(inner.n_in())]
    args[0] = ca.MX.sym(inner.name_in(0), inner.sparsity_in(0))
    outs = inner(*[a if i == 0 or i in _SEQ_INPUTS else ca.repmat(a, 1, n_periods)
                   for i, a in enumerate(args)])
    return ca.Function(
        step.name().replace("ballbot_cl_step_", "ballbot_cl_chunk_"),
        args,
        [outs[0][:, -1], *outs],
        inner.name_in(),
        ["xz_last", *inner.name_out()],
    )


def _compose_mission(step: ca.Function, chunk: ca.Function, n_chunk: int, n_periods: int) -> ca.Function:
    """Mission of ``n_periods``: a chain of ``chunk`` calls + ``step.mapaccum`` for the rest.

    Same inputs and outputs as ``make_mission(step, n_periods)``.  The chunks are chained
    by explicit calls (one call node per chunk, each running ``n_chunk`` periods in
    compiled C); building ``chunk.mapaccum`` instead is two orders of magnitude slower to
    construct (seconds for a 100 s mission) and no faster to run.
    """
    if not isinstance(n_periods, (int, np.integer)) or n_periods < 1:
        raise ScenarioError(f"number of control periods must be an int >= 1, got {n_periods!r}")
    n_c, rem = divmod(int(n_periods), n_chunk)
    args = [ca.MX.sym(step.name_in(i), step.size1_in(i), n_periods if i in _SEQ_INPUTS else 1)
            for i in range(step.n_in())]
    parts: list[list[ca.MX]] = []
    xz = args[0]
    for c in range(n_c):
        cols = slice(c * n_chunk, (c + 1) * n_chunk)
        a = [xz] + [args[i][:, cols] if i in _SEQ_INPUTS else args[i] for i in range(1, len(args))]
        outs = chunk(*a)
        xz = outs[0]
        parts.append(list(outs[1:]))
    if rem:
        start = n_c * n_chunk
        a = [xz] + [args[i][:, start:] if i in _SEQ_INPUTS else args[i] for i in range(1, len(args))]
        parts.append(list(step.mapaccum(f"{step.name()}_x{rem}", rem)(*a)))
    outs = [ca.horzcat(*[p[j] for p in parts]) for j in range(step.n_out())]
    name = step.name().replace("ballbot_cl_step_", "ballbot_mission_")
    return ca.Function(name, args, outs, step.name_in(), step.name_out())


def closed_loop_functions(n_sub: int = N_SUB_DEFAULT) -> tuple[dict[str, ca.Function], list[ca.Function]]:
    """Symbolic step Functions of every balance controller, and everything to export in C.

    Returns
    -------
    steps
        ``{"flc": ballbot_cl_step_flc, "smc": ballbot_cl_step_smc}``.
    exported
        The step and chunk (:func:`make_chunk`) Functions plus the controllers
        ``ballbot_flc``, ``ballbot_smc``, ``ballbot_velocity`` (for the C benchmark).
    """

    ode, affine = make_ode(), make_affine()
    velocity = make_velocity_controller()
    steps: dict[str, ca.Function] = {}
    exported: list[ca.Function] = []
    for name, builder in BALANCE_CONTROLLERS.items():
        bal = builder(affine)
        steps[name] = make_closed_loop_step(bal, velocity, ode, n_sub)
        exported += [steps[name], make_chunk(steps[name]), bal]
    exported.append(velocity)
    return steps, exported


def closed_loop_library(n_sub: int = N_SUB_DEFAULT, root: Path | None = None):
    """Generate and compile ``ballbot_closed_loop`` (steps, chunks and controllers).

    Cached by the hash of the generated C (see :func:`~ballbot_casadi.codegen.build_library`).

    Returns
    -------
    library, steps
        The :class:`~ballbot_casadi.codegen.Library` and the symbolic step Functions.
    """

    steps, exported = closed_loop_functions(n_sub)
    return build_library("ballbot_closed_loop", exported, root), steps


class ClosedLoop:
    """Closed-loop missions for every balance controller, compiled or symbolic.

    Parameters
    ----------
    compiled
        Run the generated C (default) or the symbolic Functions.
    n_sub
        RK4 sub-steps per control period.
    steps
        Optional ``{controller name: step Function}`` to use instead of the package's
        controllers (e.g. a stand-in in tests); with ``compiled`` those are compiled
        (library ``ballbot_closed_loop_custom``).
    root
        Build root (default :func:`~ballbot_casadi.codegen.build_root`).
    use_driver
        With ``compiled``: run missions through the zero-copy C entry point of
        :mod:`~ballbot_casadi.mission_driver` (same generated chunk and step code, no
        numpy <-> DM conversion); otherwise call the CasADi mission Function.

    Notes
    -----
    Mission Functions are cached per ``(controller, N)`` on the instance, so reuse one
    instance for many runs.
    """

    def __init__(
        self,
        compiled: bool = True,
        n_sub: int = N_SUB_DEFAULT,
        steps: Mapping[str, ca.Function] | None = None,
        root: Path | None = None,
        use_driver: bool = True,
    ) -> None:
        self.n_sub = int(n_sub)
        self.compiled = bool(compiled)
        lib = None
        if steps is None:
            if compiled:
                lib, symbolic = closed_loop_library(self.n_sub, root)
            else:
                symbolic, _ = closed_loop_functions(self.n_sub)
        else:
            symbolic = dict(steps)
            if compiled:
                funcs = [g for f in symbolic.values() for g in (f, make_chunk(f))]
                lib = build_library("ballbot_closed_loop_custom", funcs, root)
        self.library = lib
        self.symbolic_steps = symbolic
        self.chunks: dict[str, ca.Function] = {}
        if lib is not None:
            names = [f.name() for f in symbolic.values()]
            chunk_names = [n.replace("ballbot_cl_step_", "ballbot_cl_chunk_") for n in names]
            ext = load_library(lib, names + chunk_names)
            self.steps = {k: ext[f.name()] for k, f in symbolic.items()}
            self.chunks = {k: ext[c] for k, c in zip(symbolic, chunk_names)}
        else:
            self.steps = dict(symbolic)
        self._missions: dict[tuple[str, int], ca.Function] = {}
        self.driver = None
        if lib is not None and use_driver:
            self.driver = MissionDriver(lib, symbolic, CHUNK, _SEQ_INPUTS)

    @property
    def controllers(self) -> tuple[str, ...]:
        """Names of the available balance controllers."""
        return tuple(self.steps)

    def step(self, controller: str) -> ca.Function:
        """The step Function of ``controller`` (compiled or symbolic)."""
        try:
            return self.steps[controller]
        except KeyError:
            raise ScenarioError(
                f"unknown controller {controller!r}; allowed: {', '.join(self.steps)}"
            ) from None

    def mission(self, controller: str, n_periods: int) -> ca.Function:
        """The ``n_periods`` mission Function of ``controller`` (cached)."""
        key = (controller, int(n_periods))
        if key not in self._missions:
            step = self.step(controller)
            if controller in self.chunks:
                self._missions[key] = _compose_mission(step, self.chunks[controller], CHUNK, key[1])
            else:
                self._missions[key] = make_mission(step, key[1])
        return self._missions[key]

    def simulate(
        self,
        controller: str,
        x0: np.ndarray,
        *,
        p_plant: np.ndarray,
        p_ctrl: np.ndarray,
        k_bal: np.ndarray,
        k_vel: np.ndarray,
        z0: np.ndarray,
        q_ref: np.ndarray,
        dq_ref: np.ndarray,
        ddq_ref: np.ndarray,
        v_ref: np.ndarray,
        w: np.ndarray,
        Ts: float = TS_DEFAULT,
        cascade: bool = False,
    ) -> dict[str, np.ndarray]:
        """Run one mission in a single Function call.

        Sequences are ``(N, size)`` arrays (one row per control period).  Returns the
        named arrays of the log: ``time`` (N+1), ``state`` (N+1, 12; row k < N is the
        state the controllers saw at ``t_k``, the last row the final state),
        ``z`` (N+1, NZ), ``tau_cmd``, ``tau`` (N, 3), ``q_ref``, ``dq_ref``,
        ``ddq_ref`` (N, 4, the references used), ``v_ref`` (N, 3), ``w`` (N, 6),
        ``diag`` (N, ND).
        """
        seqs = {"q_ref": q_ref, "dq_ref": dq_ref, "ddq_ref": ddq_ref, "v_ref": v_ref, "w": w}
        n = None
        for key, val in seqs.items():
            arr = np.asarray(val, dtype=float)
            width = 3 if key == "v_ref" else ND_W if key == "w" else 4
            if arr.ndim != 2 or arr.shape[1] != width:
                raise ShapeError(f"{key} must have shape (N, {width}), got {arr.shape}")
            if not np.all(np.isfinite(arr)):
                raise ScenarioError(f"{key} contains NaN or Inf; references must be finite")
            n = arr.shape[0] if n is None else n
            if arr.shape[0] != n:
                raise ShapeError(f"{key} has {arr.shape[0]} rows, the other sequences {n}")
            seqs[key] = arr
        xz0 = np.concatenate([np.asarray(x0, float).reshape(NX), np.asarray(z0, float).reshape(-1)])
        args = [xz0, seqs["q_ref"], seqs["dq_ref"], seqs["ddq_ref"], seqs["v_ref"], seqs["w"],
                np.asarray(p_plant, float), np.asarray(p_ctrl, float), np.asarray(k_bal, float),
                np.asarray(k_vel, float), float(Ts), 1.0 if cascade else 0.0]
        step = self.step(controller)
        for i, a in enumerate(args[6:], start=6):
            if np.size(a) != step.size1_in(i):
                raise ShapeError(f"{step.name_in(i)} has {np.size(a)} entries, expected {step.size1_in(i)}")
        if self.driver is not None and controller in self.chunks:
            res = self.driver.run(controller, n, args)
        else:
            mission = self.mission(controller, n)
            res = [np.asarray(r).T for r in mission(*[a.T if i in _SEQ_INPUTS else a
                                                       for i, a in enumerate(args)])]
        xz_next, xs, tau_cmd, tau, qr, dqr, ddqr, diag = res
        state = np.vstack([xs, xz_next[-1:, :NX]])
        z = np.vstack([xz0[None, NX:], xz_next[:, NX:]])
        return {
            "time": np.arange(n + 1) * float(Ts),
            "state": state,
            "z": z,
            "tau_cmd": tau_cmd,
            "tau": tau,
            "q_ref": qr,
            "dq_ref": dqr,
            "ddq_ref": ddqr,
            "v_ref": seqs["v_ref"],
            "w": seqs["w"],
            "diag": diag,
        }


@dataclass
class SimulationLog:
    """Result of a closed-loop run: named numpy arrays plus the run's metadata.

    Attributes
    ----------
    arrays
        ``time``, ``state``, ``z``, ``tau_cmd``, ``tau``, ``q_ref``, ``dq_ref``,
        ``ddq_ref``, ``v_ref``, ``w``, ``diag`` (see :meth:`ClosedLoop.simulate`).
    scenario
        The scenario as a JSON-compatible dict.
    params, ctrl_params
        Plant and controller internal-model parameter sets.
    diag_names
        Names of the ``diag`` columns.
    """

    arrays: dict[str, np.ndarray]
    scenario: dict[str, Any]
    params: Params
    ctrl_params: Params
    diag_names: tuple[str, ...] = ()
    extra: dict[str, Any] = field(default_factory=dict)

    def __getitem__(self, key: str) -> np.ndarray:
        return self.arrays[key]

    def __contains__(self, key: object) -> bool:
        return key in self.arrays

    def keys(self):
        """Names of the logged arrays."""
        return self.arrays.keys()

    def save(self, path: str | Path) -> Path:
        """Write the log to ``path`` (``.npz``); see :func:`save_log`."""
        return save_log(self, path)


def save_log(log: SimulationLog, path: str | Path) -> Path:
    """Save a log to ``.npz``: the arrays plus parameters and scenario as a JSON string."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    meta = {
        "scenario": log.scenario,
        "params": log.params.as_dict(),
        "ctrl_params": log.ctrl_params.as_dict(),
        "diag_names": list(log.diag_names),
        "state_names": list(STATE_NAMES),
        "extra": log.extra,
    }
    np.savez_compressed(path, **log.arrays, meta_json=np.array(json.dumps(meta)))
    return path if path.suffix == ".npz" else path.with_name(path.name + ".npz")


def load_log(path: str | Path) -> SimulationLog:
    """Load a log written by :func:`save_log`."""
    with np.load(Path(path), allow_pickle=False) as data:
        arrays = {k: np.array(data[k]) for k in data.files if k != "meta_json"}
        if "meta_json" not in data.files:
            raise ScenarioError(f"{path}: not a ballbot simulation log (no meta_json entry)")
        meta = json.loads(str(data["meta_json"]))
    return SimulationLog(
        arrays=arrays,
        scenario=meta["scenario"],
        params=Params(**meta["params"]),
        ctrl_params=Params(**meta["ctrl_params"]),
        diag_names=tuple(meta.get("diag_names", ())),
        extra=meta.get("extra", {}),
    )


def run_scenario(scenario: Any, sim: ClosedLoop | None = None) -> SimulationLog:
    """Run a :class:`~ballbot_casadi.scenarios.Scenario` and return its log.

    Parameters
    ----------
    scenario
        The scenario (validated on construction).
    sim
        A :class:`ClosedLoop` to reuse (compiled C by default); ``None`` builds one.
    """

    if not isinstance(scenario, Scenario):
        raise ScenarioError(f"run_scenario needs a Scenario, got {type(scenario).__name__}")
    sim = ClosedLoop() if sim is None else sim
    inputs = scenario.inputs()
    arrays = sim.simulate(scenario.controller, **inputs)
    return SimulationLog(
        arrays=arrays,
        scenario=scenario.to_dict(),
        params=scenario.plant_params(),
        ctrl_params=scenario.controller_params(),
        diag_names=scenario.diag_names(),
    )

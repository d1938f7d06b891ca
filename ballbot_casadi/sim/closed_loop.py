"""Closed-loop missions: the control period as a Function, chained over a whole mission.

One control period ``Ts`` (200 Hz, thesis §7.1) is the Function
``ballbot_cl_step_<ctrl>``: :func:`ballbot_casadi.sim.period.control_period` (push,
velocity controller, balance controller, torque limits, disturbance torque, plant) on
CasADi symbols, with ``n_sub`` classical RK4 steps of ``Ts / n_sub`` as the plant.

Every block is a *called* Function (ODE inside RK4, RK4 and controllers inside the
step), so the generated C holds one copy of each.  The mission over ``N`` periods is
``step.mapaccum(N)`` (CasADi nests it in log-depth folds): one call runs a whole
mission.  The compiled variant (:func:`closed_loop_library`, built once per ``n_sub``,
cached by hash) holds the step and a chunk of :data:`CHUNK` periods
(``ballbot_cl_chunk_<ctrl>``, the step's ``mapaccum`` in C); a mission of any length
chains compiled chunks and runs the remainder through the compiled step's ``mapaccum``,
composed into one Function, so missions run as a single call without regenerating C.
By default the same chain runs through the zero-copy C entry point of
:mod:`~ballbot_casadi.sim.driver` (one C call per mission, numpy buffers in place;
identical results).

Log layout: ``state[k]`` (k < N) is the state the controllers saw at ``t_k = k Ts`` (after
a push), ``state[N]`` the final state; torques and references of period k apply on
``[t_k, t_k+1)``.

Plant and controller parameters are separate inputs, so robustness runs (thesis §8.4)
need no regeneration.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping

import casadi as ca
import numpy as np

from ballbot_casadi.control import BALANCE_CONTROLLERS, make_velocity_controller
from ballbot_casadi.core.constants import N_SUB, TS_CONTROL
from ballbot_casadi.core.layout import DISTURBANCE
from ballbot_casadi.core.toolchain import Library, build_library, load_library
from ballbot_casadi.errors import ScenarioError, ShapeError
from ballbot_casadi.estimation.com_observer import (
    COM_OBSERVER_DEFAULT_GAINS,
    check_com_observer_gains,
    com_observer_initial_state,
    make_com_observer,
)
from ballbot_casadi.model.dynamics import (
    NP,
    NX,
    make_affine,
    make_ode,
    make_wheel_speeds,
)
from ballbot_casadi.model.sensors import (
    make_wheel_angle_ode,
)
from ballbot_casadi.sim.driver import MissionDriver
from ballbot_casadi.sim.embedded import (
    EMBEDDED_INPUTS,
    ESTIMATOR_FILTERS,
    N_WHEEL,
    NOISE,
    OBSERVER_INPUTS,
    SENSOR_STATE,
    VALID,
    EstimatorBlocks,
    estimator_blocks,
    make_embedded_step,
    sense,
)
from ballbot_casadi.sim.log import SimulationLog, load_log, save_log
from ballbot_casadi.sim.period import (
    PERIOD_OUTPUTS,
    SEQUENCE_INPUTS,
    PeriodBlocks,
    check_blocks,
    control_period,
    controller_part,
    rk4_plant,
)
from ballbot_casadi.sim.scenario import Scenario

__all__ = [
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

#: Control periods per compiled chunk (1 s at 200 Hz).
CHUNK = 200
#: Per-period inputs of the steps with sensors and estimators (besides SEQUENCE_INPUTS).
ESTIMATION_SEQUENCES = ("noise", "valid")
#: Constant inputs of the steps with sensors and estimators (besides CONSTANT_INPUTS).
ESTIMATION_CONSTANTS = ("s", "p_est", "Qa", "Ra", "Qv", "Rv")
#: Outputs of the steps with sensors and estimators (besides the PERIOD_OUTPUTS).
ESTIMATION_OUTPUTS = ("x_hat", "meas", "nis", "repairs")
#: Outputs of the steps with the COM observer (last).
OBSERVER_OUTPUTS = ("com_hat",)


def seq_inputs(step: ca.Function) -> tuple[int, ...]:
    """Positions of the step inputs that are per-period sequences (the others are constants)."""
    names = set(SEQUENCE_INPUTS) | set(ESTIMATION_SEQUENCES)
    return tuple(i for i in range(step.n_in()) if step.name_in(i) in names)


def make_closed_loop_step(
    balance: ca.Function,
    velocity: ca.Function,
    ode: ca.Function,
    n_sub: int = N_SUB,
    observer: ca.Function | None = None,
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
        (:mod:`ballbot_casadi.estimation.com_observer`): the step then carries its state
        after ``z``, takes the constants ``com_observer`` (switch) and ``k_obs`` (gains)
        last and outputs ``com_hat`` last (see
        :func:`~ballbot_casadi.sim.period.controller_part`).

    Returns
    -------
    casadi.Function
        Inputs ``xz = [x; z]`` (accumulated), per-period ``q_ref, dq_ref, ddq_ref``
        (4 each, used when ``cascade = 0``), ``v_ref`` (3, used when ``cascade = 1``),
        ``w`` (6, :data:`~ballbot_casadi.core.layout.DISTURBANCE`: attitude jump rotation
        vector in {K}, wheel-torque disturbance), then the constants ``p_plant, p_ctrl,
        k_bal, k_vel, Ts, cascade, feedforward``.  Outputs ``xz_next``, ``x`` (state the controllers
        saw, after the jump), ``tau_cmd`` (controller output), ``tau`` (torque acting on
        the plant: saturated, plus the disturbance), the references used and ``diag``.
    """
    blocks = PeriodBlocks(balance, velocity)
    s = check_blocks(blocks, NP)
    n_obs = observer.numel_in(2) if observer is not None else 0
    MX = ca.MX.sym
    xz = MX("xz", NX + s["nz"] + n_obs)
    seq = {"q_ref": MX("q_ref", 4), "dq_ref": MX("dq_ref", 4), "ddq_ref": MX("ddq_ref", 4),
           "v_ref": MX("v_ref", 3), "w": MX("w", DISTURBANCE.size)}
    const = {"p_plant": MX("p_plant", NP), "p_ctrl": MX("p_ctrl", NP), "k_bal": MX("k_bal", s["nk"]),
             "k_vel": MX("k_vel", s["nkv"]), "Ts": MX("Ts"), "cascade": MX("cascade"),
             "feedforward": MX("feedforward")}
    outputs = list(PERIOD_OUTPUTS)
    controller = None
    if observer is not None:
        const.update({"com_observer": MX("com_observer"), "k_obs": MX("k_obs", observer.numel_in(4))})
        outputs += OBSERVER_OUTPUTS

        def controller(xk: ca.MX, z: ca.MX, sq: Mapping[str, Any], cn: Mapping[str, Any]) -> dict[str, Any]:
            return controller_part(blocks, xk, z, sq, cn, observer)

    plant = rk4_plant(ode, n_sub, const["p_plant"], const["Ts"])
    out = control_period(blocks, xz[:NX], xz[NX:], seq, const, plant, controller)
    return ca.Function(
        f"ballbot_cl_step_{blocks.name}",
        [xz, *seq.values(), *const.values()],
        [ca.vertcat(out["x_next"], out["z_next"]), *(out[k] for k in outputs)],
        ["xz", *SEQUENCE_INPUTS, *const],
        ["xz_next", *outputs],
    )


def make_estimating_step(
    balance: ca.Function,
    velocity: ca.Function,
    ode: ca.Function,
    wheel_speeds: ca.Function,
    estimator: EstimatorBlocks,
    n_sub: int = N_SUB,
    embedded: ca.Function | None = None,
    observer: ca.Function | None = None,
) -> ca.Function:
    """One control period with sensors and the embedded software, ``ballbot_cl_step_<ctrl>_<est>``.

    :func:`ballbot_casadi.sim.period.control_period` on CasADi symbols whose controller
    is the robot: the plant-side sensors (:func:`~ballbot_casadi.sim.embedded.sense`)
    and a call of the embedded software ``ballbot_embedded_<ctrl>_<est>``
    (:func:`~ballbot_casadi.sim.embedded.make_embedded_step`, the same Function the
    controller FMU runs); the plant carries the wheel angles (``ballbot_ode_wheel_angles``
    in RK4).

    Returns
    -------
    casadi.Function
        Inputs ``xz = [x (15, with the wheel angles); c; s]`` (accumulated; ``c`` the
        controller state of :func:`~ballbot_casadi.sim.embedded.controller_layout`, ``s``
        the sensor state :data:`~ballbot_casadi.sim.embedded.SENSOR_STATE`), the
        sequences of :func:`make_closed_loop_step` plus ``noise`` (9, standard normal)
        and ``valid`` (3), the constants of :func:`make_closed_loop_step` plus ``s``
        (sensor parameters), ``p_est`` (the filters' model parameters) and the filter
        covariances ``Qa, Ra, Qv, Rv`` (column-major).  Outputs those of
        :func:`make_closed_loop_step` (``x`` the true 12-state) plus ``x_hat`` (what the
        controllers read), ``meas`` (the readings), ``nis`` and ``repairs``.  With the
        COM ``observer`` (inside the embedded software, its state last in ``c``) the
        constants end with ``com_observer, k_obs`` and the outputs with ``com_hat``.
    """
    blocks = PeriodBlocks(balance, velocity)
    sz = check_blocks(blocks, NP)
    if embedded is None:
        embedded = make_embedded_step(balance, velocity, estimator, observer)
    with_obs = OBSERVER_INPUTS[0] in embedded.name_in()
    nc = embedded.size1_in(0)
    nxw = NX + N_WHEEL
    ode_w = make_wheel_angle_ode(ode, wheel_speeds)
    MX = ca.MX.sym
    xz = MX("xz", nxw + nc + SENSOR_STATE.size)
    seq = {"q_ref": MX("q_ref", 4), "dq_ref": MX("dq_ref", 4), "ddq_ref": MX("ddq_ref", 4),
           "v_ref": MX("v_ref", 3), "w": MX("w", DISTURBANCE.size),
           "noise": MX("noise", NOISE.size), "valid": MX("valid", VALID.size)}
    const = {"p_plant": MX("p_plant", NP), "p_ctrl": MX("p_ctrl", NP), "k_bal": MX("k_bal", sz["nk"]),
             "k_vel": MX("k_vel", sz["nkv"]), "Ts": MX("Ts"), "cascade": MX("cascade"),
             "feedforward": MX("feedforward"), "s": MX("s", estimator.imu.size1_in(3)),
             "p_est": MX("p_est", NP), "Qa": MX("Qa", embedded.size1_in(13)),
             "Ra": MX("Ra", embedded.size1_in(14)), "Qv": MX("Qv", embedded.size1_in(15)),
             "Rv": MX("Rv", embedded.size1_in(16))}
    outputs = [*PERIOD_OUTPUTS, *ESTIMATION_OUTPUTS]
    if with_obs:
        const.update({k: MX(k, embedded.size1_in(embedded.index_in(k))) for k in OBSERVER_INPUTS})
        outputs += OBSERVER_OUTPUTS

    def robot(xk: ca.MX, cs: ca.MX, sq: Mapping[str, Any], cn: Mapping[str, Any]) -> dict[str, Any]:
        c, s_state = cs[:nc], cs[nc:]
        meas, s_mid = sense(estimator, xk, s_state, sq["noise"], sq["valid"], cn["p_plant"], cn["s"],
                            cn["Ts"])
        out = embedded.call({"c": c, "meas": meas, **{k: sq[k] for k in ("q_ref", "dq_ref", "ddq_ref", "v_ref")},
                             **{k: cn[k] for k in EMBEDDED_INPUTS[6:]},
                             **({k: cn[k] for k in OBSERVER_INPUTS} if with_obs else {})})
        return {**out, "z_next": ca.vertcat(out["c_next"], s_mid), "meas": meas}

    plant = rk4_plant(ode_w, n_sub, const["p_plant"], const["Ts"])
    out = control_period(blocks, xz[:nxw], xz[nxw:], seq, const, plant, controller=robot)
    # the sensor state starts with the torque that acted on the plant in this period
    z_next = ca.vertcat(out["z_next"][:nc], out["tau"], out["z_next"][nc:])
    out["x"] = out["x"][:NX]
    return ca.Function(
        f"ballbot_cl_step_{blocks.name}_{estimator.name}",
        [xz, *seq.values(), *const.values()],
        [ca.vertcat(out["x_next"], z_next), *(out[k] for k in outputs)],
        ["xz", *seq, *const],
        ["xz_next", *outputs],
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
    seq = seq_inputs(step)
    # constants (parameters, gains, Ts, cascade) are single columns, broadcast inside
    args = [ca.MX.sym(inner.name_in(i), inner.size1_in(i), n_periods if i in seq else 1)
            for i in range(inner.n_in())]
    args[0] = ca.MX.sym(inner.name_in(0), inner.sparsity_in(0))
    outs = inner(*[a if i == 0 or i in seq else ca.repmat(a, 1, n_periods)
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
    seq = seq_inputs(step)
    args = [ca.MX.sym(step.name_in(i), step.size1_in(i), n_periods if i in seq else 1)
            for i in range(step.n_in())]
    parts: list[list[ca.MX]] = []
    xz = args[0]
    for c in range(n_c):
        cols = slice(c * n_chunk, (c + 1) * n_chunk)
        a = [xz] + [args[i][:, cols] if i in seq else args[i] for i in range(1, len(args))]
        outs = chunk(*a)
        xz = outs[0]
        parts.append(list(outs[1:]))
    if rem:
        start = n_c * n_chunk
        a = [xz] + [args[i][:, start:] if i in seq else args[i] for i in range(1, len(args))]
        parts.append(list(step.mapaccum(f"{step.name()}_x{rem}", rem)(*a)))
    outs = [ca.horzcat(*[p[j] for p in parts]) for j in range(step.n_out())]
    name = step.name().replace("ballbot_cl_step_", "ballbot_mission_")
    return ca.Function(name, args, outs, step.name_in(), step.name_out())


def closed_loop_functions(n_sub: int = N_SUB, estimator: str = "true",
                          ) -> tuple[dict[str, ca.Function], list[ca.Function]]:
    """Symbolic step Functions of every balance controller, and everything to export in C.

    Parameters
    ----------
    n_sub
        RK4 sub-steps per period.
    estimator
        ``"true"`` (controllers read the true state), ``"ukf"`` or ``"ekf"`` (noisy
        sensors and estimators, :func:`make_estimating_step`).

    Returns
    -------
    steps
        ``{"flc": ballbot_cl_step_flc..., "smc": ballbot_cl_step_smc...}``, each with the
        COM observer (``ballbot_com_observer``, switched by the ``com_observer`` input).
    exported
        The step and chunk (:func:`make_chunk`) Functions plus, for ``"true"``, the
        controllers ``ballbot_flc``, ``ballbot_smc``, ``ballbot_velocity`` (for the C
        benchmark), otherwise the embedded software ``ballbot_embedded_<ctrl>_<est>`` (the
        controller FMU's code), the filters and the tilt correction (for the estimator
        benchmark), and the COM observer.
    """
    ode, affine = make_ode(), make_affine()
    velocity = make_velocity_controller()
    observer = make_com_observer()
    est = None if estimator == "true" else estimator_blocks(estimator, ode, make_wheel_speeds())
    steps: dict[str, ca.Function] = {}
    exported: list[ca.Function] = []
    for name, builder in BALANCE_CONTROLLERS.items():
        bal = builder(affine)
        if est is None:
            steps[name] = make_closed_loop_step(bal, velocity, ode, n_sub, observer)
            exported += [steps[name], make_chunk(steps[name]), bal]
        else:
            embedded = make_embedded_step(bal, velocity, est, observer)
            steps[name] = make_estimating_step(bal, velocity, ode, make_wheel_speeds(), est, n_sub,
                                               embedded)
            exported += [steps[name], make_chunk(steps[name]), embedded]
    exported += [velocity] if est is None else [est.attitude, est.velocity, est.tilt_correction]
    return steps, exported + [observer]


def library_name(n_sub: int, estimator: str = "true") -> str:
    """Name of the compiled closed-loop library for ``n_sub`` RK4 sub-steps and an estimator."""
    name = "ballbot_closed_loop" if estimator == "true" else f"ballbot_closed_loop_{estimator}"
    return name if n_sub == N_SUB else f"{name}_sub{n_sub}"


def closed_loop_library(n_sub: int = N_SUB, root: Path | None = None, estimator: str = "true",
                        ) -> tuple[Library, dict[str, ca.Function], list[ca.Function]]:
    """Generate and compile the closed-loop library (steps, chunks and controllers).

    Cached by the hash of the generated C (see :func:`~ballbot_casadi.core.toolchain.build_library`).

    Returns
    -------
    library, steps, exported
        The :class:`~ballbot_casadi.core.toolchain.Library`, the symbolic step Functions and
        every Function the library exports.
    """
    steps, exported = closed_loop_functions(n_sub, estimator)
    return build_library(library_name(n_sub, estimator), exported, root), steps, exported


class _Variant:
    """The step Functions of one ``n_sub`` (compiled or symbolic) and their missions."""

    def __init__(self, symbolic: Mapping[str, ca.Function], lib: Library | None, use_driver: bool,
                 exported: list[ca.Function] | None = None) -> None:
        self.library = lib
        self.exported = list(exported or [])
        self.symbolic = dict(symbolic)
        self.chunks: dict[str, ca.Function] = {}
        self.driver: MissionDriver | None = None
        self.missions: dict[tuple[str, int], ca.Function] = {}
        self.tags: dict[str, str] = {}
        if lib is None:
            self.steps = dict(symbolic)
            return
        names = [f.name() for f in symbolic.values()]
        chunk_names = [n.replace("ballbot_cl_step_", "ballbot_cl_chunk_") for n in names]
        ext = load_library(lib, names + chunk_names)
        self.steps = {k: ext[f.name()] for k, f in symbolic.items()}
        self.chunks = {k: ext[c] for k, c in zip(symbolic, chunk_names)}
        if use_driver:
            # the driver's entry points are named after the steps: ballbot_mission_<tag>
            self.tags = {k: f.name().removeprefix("ballbot_cl_step_") for k, f in symbolic.items()}
            first = next(iter(symbolic.values()))
            self.driver = MissionDriver(lib, {self.tags[k]: f for k, f in symbolic.items()}, CHUNK,
                                        seq_inputs(first))

    def run_driver(self, controller: str, n: int, args: list) -> list[np.ndarray]:
        """Run a mission through the C entry point."""
        return self.driver.run(self.tags[controller], n, args)

    def mission(self, controller: str, n_periods: int) -> ca.Function:
        key = (controller, int(n_periods))
        if key not in self.missions:
            step = self.steps[controller]
            if controller in self.chunks:
                self.missions[key] = _compose_mission(step, self.chunks[controller], CHUNK, key[1])
            else:
                self.missions[key] = make_mission(step, key[1])
        return self.missions[key]


class ClosedLoop:
    """Closed-loop missions for every balance controller, compiled or symbolic.

    Parameters
    ----------
    compiled
        Run the generated C (default) or the symbolic Functions.
    n_sub
        Default RK4 sub-steps per control period; a mission may ask for another
        (:meth:`simulate`), whose library is then built (cached by hash) on first use.
    steps
        Optional ``{controller name: step Function}`` to use instead of the package's
        controllers (e.g. a stand-in in tests); with ``compiled`` those are compiled
        (library ``ballbot_closed_loop_custom``).  Such steps have a fixed ``n_sub``.
    root
        Build root (default :func:`~ballbot_casadi.core.toolchain.build_root`).
    use_driver
        With ``compiled``: run missions through the zero-copy C entry point of
        :mod:`~ballbot_casadi.sim.driver` (same generated chunk and step code, no
        numpy <-> DM conversion); otherwise call the CasADi mission Function.

    Notes
    -----
    Mission Functions are cached per ``(n_sub, controller, N)`` on the instance, so reuse
    one instance for many runs.
    """

    def __init__(
        self,
        compiled: bool = True,
        n_sub: int = N_SUB,
        steps: Mapping[str, ca.Function] | None = None,
        root: Path | None = None,
        use_driver: bool = True,
    ) -> None:
        if not isinstance(n_sub, (int, np.integer)) or isinstance(n_sub, bool) or n_sub < 1:
            raise ScenarioError(f"n_sub must be an int >= 1, got {n_sub!r}")
        self.n_sub = int(n_sub)
        self.compiled = bool(compiled)
        self.root = root
        self.use_driver = bool(use_driver)
        self._custom = steps is not None
        self._variants: dict[tuple[int, str], _Variant] = {}
        if steps is not None:
            lib = None
            if compiled:
                funcs = [g for f in steps.values() for g in (f, make_chunk(f))]
                lib = build_library("ballbot_closed_loop_custom", funcs, root)
            self._variants[(self.n_sub, "true")] = _Variant(steps, lib, self.use_driver)
        else:
            self._variant(self.n_sub)

    def _variant(self, n_sub: int, estimator: str = "true") -> _Variant:
        key = (int(n_sub), estimator)
        if key not in self._variants:
            if self._custom:
                raise ScenarioError(
                    f"these custom steps integrate with n_sub = {self.n_sub} and the true state; "
                    f"n_sub = {n_sub}, estimator = {estimator!r} needs steps built for it"
                )
            if estimator not in ("true", *ESTIMATOR_FILTERS):
                raise ScenarioError(f"unknown estimator {estimator!r}; allowed: true, "
                                    f"{', '.join(ESTIMATOR_FILTERS)}")
            if self.compiled:
                lib, symbolic, exported = closed_loop_library(key[0], self.root, estimator)
            else:
                lib, (symbolic, exported) = None, closed_loop_functions(key[0], estimator)
            self._variants[key] = _Variant(symbolic, lib, self.use_driver, exported)
        return self._variants[key]

    @property
    def library(self) -> Library | None:
        """The compiled library of the default ``n_sub`` (``None`` when symbolic)."""
        return self._variant(self.n_sub).library

    @property
    def driver(self) -> MissionDriver | None:
        """The zero-copy C mission entry point of the default ``n_sub`` (if any)."""
        return self._variant(self.n_sub).driver

    @property
    def symbolic_steps(self) -> dict[str, ca.Function]:
        """The symbolic step Functions of the default ``n_sub``."""
        return self._variant(self.n_sub).symbolic

    @property
    def controllers(self) -> tuple[str, ...]:
        """Names of the available balance controllers."""
        return tuple(self._variant(self.n_sub).steps)

    def step(self, controller: str, n_sub: int | None = None, estimator: str = "true") -> ca.Function:
        """The step Function of ``controller`` (compiled or symbolic)."""
        steps = self._variant(self.n_sub if n_sub is None else int(n_sub), estimator).steps
        try:
            return steps[controller]
        except KeyError:
            raise ScenarioError(
                f"unknown controller {controller!r}; allowed: {', '.join(steps)}"
            ) from None

    def mission(self, controller: str, n_periods: int, n_sub: int | None = None,
                estimator: str = "true") -> ca.Function:
        """The ``n_periods`` mission Function of ``controller`` (cached)."""
        self.step(controller, n_sub, estimator)  # validates the name
        n_sub = self.n_sub if n_sub is None else int(n_sub)
        return self._variant(n_sub, estimator).mission(controller, n_periods)

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
        Ts: float = TS_CONTROL,
        cascade: bool = False,
        feedforward: bool = True,
        n_sub: int | None = None,
        estimator: str = "true",
        estimation: Mapping[str, Any] | None = None,
        xz0: np.ndarray | None = None,
        com_observer: bool = False,
        k_obs: np.ndarray | None = None,
        o0: np.ndarray | None = None,
    ) -> dict[str, np.ndarray]:
        """Run one mission in a single Function call.

        Sequences are ``(N, size)`` arrays (one row per control period).  ``n_sub``
        (default: the instance's) sets the RK4 sub-steps per period; ``feedforward =
        False`` gives the balance controller a zero reference acceleration (thesis
        mode, see :mod:`~ballbot_casadi.sim.period`).  With ``estimator`` ``"ukf"`` or
        ``"ekf"`` the controllers read estimates from noisy sensors
        (:func:`make_estimating_step`); ``estimation`` then holds ``noise`` (N, 9),
        ``valid`` (N, 3), ``s``, ``p_est``, ``Qa``, ``Ra``, ``Qv``, ``Rv``, ``e0`` (the
        filters' initial state) and ``s0`` (the initial sensor state).  ``xz0``
        (optional) replaces the whole initial accumulated state built from those (a
        segment of a long run continues from the previous segment's ``xz_final``).
        Steps with the COM observer (the package's) also take ``com_observer`` (the
        controllers use the estimate), ``k_obs`` (gains, default
        :data:`~ballbot_casadi.estimation.com_observer.COM_OBSERVER_DEFAULT_GAINS`) and
        ``o0`` (its initial state, default: the controller model's COM, see
        :func:`~ballbot_casadi.estimation.com_observer.com_observer_initial_state`); the
        observer's state is the last part of the controller state.

        Returns the named arrays of the log: ``time`` (N+1), ``state`` (N+1, 12; row
        k < N is the plant state at ``t_k`` after a push, the last row the final
        state), ``z`` (N+1, NZ), ``tau_cmd``, ``tau`` (N, 3; ``tau`` acts on the plant:
        saturated plus the disturbance), ``q_ref``, ``dq_ref``, ``ddq_ref`` (N, 4, the
        references used), ``v_ref`` (N, 3), ``w`` (N, 6), ``diag`` (N, ND); with an
        estimator also ``x_hat`` (N, 12, what the controllers read), ``meas`` (N, 9),
        ``nis`` (N, 2), ``repairs`` (N, 1), ``noise``, ``valid``, ``phi`` (N+1, 3, wheel
        angles) and ``c_final`` (the embedded software's final state); with the
        observer ``com_hat`` (N, 2: the estimate after each period's update).
        """
        n_sub = self.n_sub if n_sub is None else n_sub
        if not isinstance(n_sub, (int, np.integer)) or isinstance(n_sub, bool) or n_sub < 1:
            raise ScenarioError(f"n_sub must be an int >= 1, got {n_sub!r}")
        step = self.step(controller, n_sub, estimator)
        est = estimator != "true"
        if est and estimation is None:
            raise ScenarioError(f"estimator {estimator!r} needs the estimation inputs (noise, ...)")
        extra = dict(estimation or {}) if est else {}
        seqs = {"q_ref": q_ref, "dq_ref": dq_ref, "ddq_ref": ddq_ref, "v_ref": v_ref, "w": w,
                **{k: extra.get(k) for k in (ESTIMATION_SEQUENCES if est else ())}}
        n = None
        for key, val in seqs.items():
            width = step.size1_in(step.name_in().index(key))
            arr = np.asarray(val, dtype=float)
            if arr.ndim != 2 or arr.shape[1] != width:
                raise ShapeError(f"{key} must have shape (N, {width}), got {arr.shape}")
            if not np.all(np.isfinite(arr)):
                raise ScenarioError(f"{key} contains NaN or Inf; inputs must be finite")
            n = arr.shape[0] if n is None else n
            if arr.shape[0] != n:
                raise ShapeError(f"{key} has {arr.shape[0]} rows, the other sequences {n}")
            seqs[key] = arr
        x0 = np.asarray(x0, float).reshape(NX)
        with_obs = "k_obs" in step.name_in()
        if com_observer and not with_obs:
            raise ScenarioError("com_observer = true needs steps with the COM observer "
                                "(these custom steps have none)")
        obs: list[np.ndarray] = []
        if with_obs:
            k_obs = check_com_observer_gains(COM_OBSERVER_DEFAULT_GAINS if k_obs is None else k_obs)
            obs = [com_observer_initial_state(x0, p_ctrl) if o0 is None else np.asarray(o0, float).reshape(-1)]
        parts = [x0, np.zeros(N_WHEEL)] if est else [x0]
        parts += [np.asarray(z0, float).reshape(-1)]
        if est:
            parts += [np.asarray(extra["e0"], float).reshape(-1), *obs, np.asarray(extra["s0"], float).reshape(-1)]
        else:
            parts += obs
        xz0 = np.concatenate(parts) if xz0 is None else np.asarray(xz0, float).reshape(-1)
        const = {"p_plant": p_plant, "p_ctrl": p_ctrl, "k_bal": k_bal, "k_vel": k_vel, "Ts": Ts,
                 "cascade": 1.0 if cascade else 0.0, "feedforward": 1.0 if feedforward else 0.0,
                 **{k: np.asarray(extra[k], float).ravel(order="F")
                    for k in (ESTIMATION_CONSTANTS if est else ())},
                 **({"com_observer": 1.0 if com_observer else 0.0, "k_obs": k_obs} if with_obs else {})}
        args = [xz0]
        for i in range(1, step.n_in()):
            name = step.name_in(i)
            a = seqs[name] if name in seqs else np.asarray(const[name], float).reshape(-1)
            if name not in seqs and a.size != step.size1_in(i):
                raise ShapeError(f"{name} has {a.size} entries, expected {step.size1_in(i)}")
            args.append(a)
        if xz0.size != step.size1_in(0):
            raise ShapeError(f"initial state has {xz0.size} entries, expected {step.size1_in(0)}")
        variant = self._variant(int(n_sub), estimator)
        seq_idx = seq_inputs(step)
        if variant.driver is not None and controller in variant.chunks:
            res = variant.run_driver(controller, n, args)
        else:
            mission = variant.mission(controller, n)
            res = [np.asarray(r).T for r in mission(*[a.T if i in seq_idx else a
                                                       for i, a in enumerate(args)])]
        out = dict(zip(step.name_out(), res))
        xz_next = out["xz_next"]
        nxw = NX + (N_WHEEL if est else 0)
        nz = np.size(z0)
        log = {
            "time": np.arange(n + 1) * float(Ts),
            "state": np.vstack([out["x"], xz_next[-1:, :NX]]),
            "z": np.vstack([xz0[None, nxw:nxw + nz], xz_next[:, nxw:nxw + nz]]),
            "tau_cmd": out["tau_cmd"],
            "tau": out["tau"],
            "q_ref": out["q_ref_used"],
            "dq_ref": out["dq_ref_used"],
            "ddq_ref": out["ddq_ref_used"],
            "v_ref": seqs["v_ref"],
            "w": seqs["w"],
            "diag": out["diag"],
            "xz_final": xz_next[-1].copy(),
        }
        if with_obs:
            log.update({k: out[k] for k in OBSERVER_OUTPUTS})
        if est:
            log.update({k: out[k] for k in ESTIMATION_OUTPUTS})
            log.update({k: seqs[k] for k in ESTIMATION_SEQUENCES})
            log["phi"] = np.vstack([xz0[None, NX:nxw], xz_next[:, NX:nxw]])
            log["c_final"] = xz_next[-1, nxw:xz_next.shape[1] - SENSOR_STATE.size]
        return log


def run_scenario(scenario: Any, sim: ClosedLoop | None = None, log_every: int = 1,
                 segment_periods: int | None = None) -> SimulationLog:
    """Run a :class:`~ballbot_casadi.sim.scenario.Scenario` and return its log.

    Parameters
    ----------
    scenario
        The scenario (validated on construction); its ``Ts`` and ``n_sub`` are used.
    sim
        A :class:`ClosedLoop` to reuse (compiled C by default); ``None`` builds one.
    log_every
        Keep every ``log_every``-th period in the log (decimated logging; the final state
        is always kept).  Metrics that need every period (lags, total variation) are
        then computed on the decimated log.
    segment_periods
        Run the mission in segments of this many periods, each one compiled call
        continuing from the previous one's final state, with the inputs of each segment
        built just before it: memory then grows only with the decimated log, not with
        the run's length (default: one segment, or 12000 periods = 60 s when decimating).
        The result equals the single-call run bit for bit (same inputs, same code).
    """
    if not isinstance(scenario, Scenario):
        raise ScenarioError(f"run_scenario needs a Scenario, got {type(scenario).__name__}")
    for name, v in (("log_every", log_every), ("segment_periods", segment_periods)):
        if v is not None and (not isinstance(v, (int, np.integer)) or isinstance(v, bool) or v < 1):
            raise ScenarioError(f"{name} must be an int >= 1, got {v!r}")
    sim = ClosedLoop() if sim is None else sim
    n = scenario.n_periods
    seg = segment_periods or (n if log_every == 1 else min(n, 12000))
    arrays: dict[str, list[np.ndarray]] = {}
    xz = None
    for k0 in range(0, n, seg):
        k1 = min(n, k0 + seg)
        inp = scenario.inputs(periods=(k0, k1))
        part = sim.simulate(scenario.controller, **inp, n_sub=scenario.n_sub, xz0=xz)
        xz = part.pop("xz_final")
        final = {k: part[k][-1:] for k in ("time", "state", "z", "phi") if k in part}
        keep = np.arange(0, k1 - k0)
        keep = keep[(keep + k0) % log_every == 0]
        for key, val in part.items():
            if key in ("c_final",):
                arrays[key] = [val]
                continue
            rows = val[:k1 - k0] if val.shape[0] > k1 - k0 else val
            arrays.setdefault(key, []).append(rows[keep])
    # time, state, z and phi carry one more row: the final state
    for key, val in final.items():
        arrays[key].append(val)
    out = {k: np.concatenate(v) if k != "c_final" else v[0] for k, v in arrays.items()}
    out["time"] = np.concatenate([np.arange(n)[np.arange(n) % log_every == 0], [n]]) * float(scenario.Ts)
    extra = {"log_every": int(log_every)} if log_every != 1 else {}
    return SimulationLog(
        arrays=out,
        scenario=scenario.to_dict(),
        params=scenario.plant_params(),
        ctrl_params=scenario.controller_params(),
        diag_names=scenario.diag_names(),
        extra=extra,
    )

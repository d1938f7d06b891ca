"""Path following inside the compiled mission: the guidance laws in the period's guidance slot.

The guidance law runs in the control period itself (the slot of
:class:`~ballbot_casadi.sim.ports.PeriodBlocks`), on what the controllers read (the true
state, or the estimate of the UKFs with noisy sensors), every ``m``-th period (default
``m = 20``: 10 Hz at 200 Hz): ``ballbot_guidance_<law>(x, v_ref, g, z, p, k_guid, Ts) ->
(v_ref_out, g_next)``.  Its state ``g = [count, sample state]`` counts the periods since
the last sample; a ``Function.conditional`` on ``count`` calls the law's sample
(:mod:`ballbot_casadi.guidance.blocks`; the MPC's real-time iteration or pure pursuit) at
``count = 0`` and otherwise only holds the last velocity reference, so the other
``m - 1`` periods do not pay for it (the generated C evaluates one branch).  The sample
reads the loop-model state from the plant state and the velocity controller's state
(:func:`~ballbot_casadi.sim.path_following.make_loop_state`); the period's own
``v_ref`` input gives the yaw-rate reference (its third entry) and is otherwise unused.

Latency (issue 18, a switch of the mission: :func:`mpc_law` ``latency = L``, default 0):
the sample of period ``k`` gives the reference of periods ``k + L`` on (the cold first
sample: :func:`first_sample_latency`), the previous sample's reference holding until
then, as a firmware whose sample runs in a background task applies it; the block's state
then ends with ``v_prev`` and ``due`` (:func:`latency_layout`).  ``L = 0`` is the block
without latency, unchanged.  The firmware's interrupt step runs the same block with
``split`` (no sample; a snapshot of the loop state for the background task).

The path and its obstacles are the parameter ``k_guid`` (the table of
:mod:`ballbot_casadi.guidance.path_table`), so one compiled mission follows any path.
:func:`run_guided` runs a path with true state or with noise and the UKFs and returns
the log (``v_ref_used``: the references, ``guide``: the laws' state, from which
:func:`predictions` reads the MPC's predicted horizons).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache, partial
from typing import Callable

import casadi as ca
import numpy as np

from ballbot_casadi.core.constants import N_SUB, TS_CONTROL
from ballbot_casadi.core.layout import Layout
from ballbot_casadi.core.toolchain import Library, linked_function
from ballbot_casadi.errors import BuildError, ScenarioError, SolverError
from ballbot_casadi.guidance.blocks import (
    make_mpc_sample,
    make_pursuit_sample,
    mpc_state_layout,
    pursuit_parameters,
    pursuit_state_layout,
)
from ballbot_casadi.guidance.condensed import Condensed
from ballbot_casadi.guidance.mpc import MpcConfig, MpcLayout, make_mpc_parts
from ballbot_casadi.guidance.path_table import PATH_SAMPLES, pack_path
from ballbot_casadi.guidance.paths import Path
from ballbot_casadi.guidance.prediction import NXL
from ballbot_casadi.guidance.shape_model import shape_model
from ballbot_casadi.model.dynamics import NP, make_ode, make_wheel_speeds
from ballbot_casadi.sim.balance_feed import (
    BALANCE_FEED_CONFIG,
    balance_initial_function,
    balance_state_layout,
    make_balance_guidance,
    shape_gains,
)
from ballbot_casadi.sim.closed_loop import ClosedLoop, power_on_inputs
from ballbot_casadi.sim.embedded import (
    DEFAULT_ESTIMATOR,
    ESTIMATOR_FILTERS,
    controller_blocks,
    embedded_software,
    software_blocks,
)
from ballbot_casadi.sim.log import PATH_KEY, SimulationLog
from ballbot_casadi.sim.path_following import make_loop_state, path_scenario, velocity_loop_model
from ballbot_casadi.sim.scenario import Scenario
from ballbot_casadi.sim.steps import make_closed_loop_step, make_estimating_step

__all__ = ["GUIDANCE_LAWS", "GuidanceLaw", "make_guidance", "latency_layout",
           "first_sample_latency", "mpc_law", "pursuit_law", "mpc_balance_law",
           "guided_software", "guided_simulator", "run_guided", "run_path_scenario",
           "scenario_law", "predictions", "GUIDANCE_EVERY", "PURSUIT_GAINS", "path_metadata",
           "PATH_LOG_SPACING"]

#: The guidance laws of the slot.
GUIDANCE_LAWS = ("mpc", "pursuit")
#: Control periods per guidance sample (0.1 s at 200 Hz: 10 Hz).
GUIDANCE_EVERY = 20
#: Spacing (m) of the path's points kept in a path run's log (:func:`path_metadata`).
PATH_LOG_SPACING = 0.02


def latency_layout(latency: int, split: bool = False) -> Layout:
    """The guidance block's state after ``[count, sample state]`` (module docstring,
    Latency): none at ``latency = 0``; else ``v_prev`` (2, the reference applied until the
    last sample's result is due) and ``due`` (1, the count at which it is applied); with
    ``split`` also ``snap`` (:data:`~ballbot_casadi.guidance.prediction.NXL`, the loop
    state the sample reads, taken at its sample period for a background task)."""
    fields = [] if latency == 0 else [("v_prev", 2), ("due", 1)]
    return Layout("guidance latency state", fields + ([("snap", NXL)] if split else []))


def make_guidance(name: str, sample: ca.Function, every: int = GUIDANCE_EVERY,
                  latency: int = 0, first_latency: int | None = None,
                  first_index: int | None = None, split: bool = False) -> ca.Function:
    """The period's guidance block ``ballbot_guidance_<name>`` around a sample Function
    ``(X, g, k) -> (v, g_next)`` (module docstring); the sample's state must start with
    the held velocity reference ``v`` (2).

    ``latency`` ``L`` (periods, ``0 <= L < every``): the sample of period ``k`` takes effect
    at period ``k + L`` (``first_latency`` for the sample whose state has ``first`` set,
    entry ``first_index`` of the sample state; default ``L``); until then the previous
    sample's reference holds.  ``L = 0`` is the block without latency (the result applied
    in its own period).  ``split`` (``L > 0``): the block of a firmware's interrupt step,
    which does not run the sample: it keeps the sample state, stores the loop state of
    the sample period in ``snap`` (:func:`latency_layout`) and applies whatever sample
    state it finds at the due count; the firmware's background task runs ``sample`` on
    the snapshot and writes its result into the state before the step of the due period.
    """
    if not (isinstance(every, int) and every >= 1):
        raise ScenarioError(f"guidance every must be an int >= 1 periods, got {every!r}")
    first_latency = latency if first_latency is None else first_latency
    for what, lat in (("latency", latency), ("first_latency", first_latency)):
        if not (isinstance(lat, int) and 0 <= lat < every):
            raise ScenarioError(f"guidance {what} must be an int in 0..{every - 1} periods "
                                f"(less than a sample interval), got {lat!r}")
    if split and latency == 0:
        raise ScenarioError("a split guidance block (background sample) needs latency >= 1")
    ns = sample.numel_in(1)
    X, gs, k = (ca.MX.sym(n, sample.numel_in(i)) for i, n in enumerate(("X", "gs", "k")))
    hold = ca.Function(f"ballbot_guidance_{name}_hold", [X, gs, k], [gs[0:2], gs],
                       ["X", "g", "k"], ["v", "g_next"])
    E = latency_layout(latency, split)
    loop_state = make_loop_state()
    x, v_ref, g, z = (ca.MX.sym(n, m) for n, m in (("x", 12), ("v_ref", 3),
                                                    ("g", ns + 1 + E.size),
                                                    ("z", loop_state.numel_in(1))))
    p, kg, Ts = ca.MX.sym("p", NP), ca.MX.sym("k_guid", k.numel()), ca.MX.sym("Ts")
    count, gs_now, tail = g[0], g[1:ns + 1], g[ns + 1:]
    X_now = loop_state(x, z)
    if split:  # the interrupt step: no sample; the background task runs it on the snapshot
        v, g_next = gs_now[0:2], gs_now
    else:
        branch = ca.Function.conditional(f"ballbot_guidance_{name}_branch", [sample], hold)
        v, g_next = branch(count, X_now, gs_now, kg)
    sampling = count == 0
    count_next = ca.if_else(count + 1 >= every, 0.0, count + 1)
    tail_next = []
    if latency:
        first = gs_now[first_index] > 0.5 if first_index is not None else ca.DM(0.0)
        due = ca.if_else(sampling, ca.if_else(first, first_latency, latency), tail[E["due"]])
        v_prev = ca.if_else(sampling, gs_now[0:2], tail[E["v_prev"]])
        v = ca.if_else(count >= due, v, v_prev)
        tail_next = [v_prev, due]
    if split:
        tail_next.append(ca.if_else(sampling, X_now, tail[E["snap"]]))
    suffix = "" if latency == 0 else f"_l{latency}{'_split' if split else ''}"
    return ca.Function(f"ballbot_guidance_{name}{suffix}", [x, v_ref, g, z, p, kg, Ts],
                       [ca.vertcat(v, v_ref[2]), ca.vertcat(count_next, g_next, *tail_next)],
                       ["x", "v_ref", "g", "z", "p", "k_guid", "Ts"], ["v_ref_out", "g_next"])


@dataclass(frozen=True)
class GuidanceLaw:
    """A guidance block for the slot and how to start it on a path.

    Attributes
    ----------
    name
        ``mpc``, ``pursuit`` or ``mpc_balance`` (the MPC feeding the balance controller,
        :mod:`ballbot_casadi.sim.balance_feed`).
    function
        The period's block (:func:`make_guidance`).
    state
        Layout of the sample's state (after the period counter).
    mpc_layout
        The MPC's decision-vector layout (MPC only).
    config
        The MPC configuration (MPC only).
    cond
        The MPC's condensed prediction (MPC only: predicted positions from the state).
    initial
        The block's own initial-state Function (:meth:`initial_function`), if it has one.
    sample
        The sample Function ``(X, g, k) -> (v, g_next)`` the block calls (a firmware's
        background task runs it alone).
    latency, first_latency, split
        As :func:`make_guidance` built ``function`` (``0, 0, False``: no latency).
    relink
        ``relink(f)``: the block built around ``f`` in place of :attr:`sample` (same
        ports); the host's compiled missions build it on the separately compiled sample
        (:func:`~ballbot_casadi.core.toolchain.linked_function`), so every variant links
        the one compiled MPC instead of generating it again (``None``: compiled whole).
    """

    name: str
    function: ca.Function
    state: Layout
    mpc_layout: MpcLayout | None = None
    config: MpcConfig | None = None
    options: tuple = ()
    cond: Condensed | None = None
    initial: ca.Function | None = None
    sample: ca.Function | None = None
    latency: int = 0
    first_latency: int = 0
    split: bool = False
    relink: Callable[[ca.Function], ca.Function] | None = None

    @property
    def tail(self) -> Layout:
        """The block's state after ``[count, sample state]`` (:func:`latency_layout`)."""
        return latency_layout(self.latency, self.split)

    @property
    def block_size(self) -> int:
        """Entries of the block's state ``g``: counter, sample state, :attr:`tail`."""
        return 1 + self.state.size + self.tail.size

    def parameters(self, path: Path) -> np.ndarray:
        """``k_guid`` of ``path``."""
        if self.config is not None:
            return pack_path(path, self.config.n_obstacles)
        return pursuit_parameters(path, **dict(self.options))

    def initial_state(self, path: Path, x0: np.ndarray, z0: np.ndarray) -> np.ndarray:
        """``g0``: period counter 0 and the sample's initial state at ``x0``, ``z0``
        (:meth:`initial_function` at the projection of the position onto ``path``)."""
        X0 = np.asarray(make_loop_state()(x0, z0), float).reshape(NXL)
        s0 = path.project(X0[12:14])
        g0 = np.asarray(self.initial_function()(x0, z0, s0), float).ravel()
        if g0.size != self.state.size + 1:
            raise BuildError(f"{self.name} guidance: initial state of {g0.size} entries, the "
                             f"sample's state has {self.state.size} + 1")
        # with latency: no previous reference (0), nothing due, no snapshot yet
        return np.concatenate([g0, np.zeros(self.tail.size)])

    def initial_function(self) -> ca.Function:
        """``ballbot_guidance_<name>_initial(x0[12], z0, s0) -> g0``: the block's state
        before the first period (counter 0; no velocity reference yet; the MPC: ``first =
        1`` and its state at the loop state of ``x0``, ``z0`` with progress ``s0``, the
        rest zero; pure pursuit: the projection ``s0``), from the robot's state at power-on
        ``x0``, the velocity controller's state ``z0`` and ``s0``, the arc length of the
        path point nearest the start (:meth:`Path.project
        <ballbot_casadi.guidance.paths.Path.project>`).  The compiled mission and the
        path-following controller FMU start from it.  A law with its own ``initial``
        Function (the balance feed) returns that."""
        if self.initial is not None:
            return self.initial
        return _initial_function(self.name, self.state)


class _Key:
    """An MPC configuration as a cache key (by its repr: it holds dicts)."""

    def __init__(self, config: MpcConfig) -> None:
        self.config, self.text = config, repr(config)

    def __hash__(self) -> int:
        return hash(self.text)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, _Key) and other.text == self.text


@lru_cache(maxsize=None)
def _mpc_parts(p_ctrl: tuple, k_vel: tuple, key: _Key) -> tuple:
    config = key.config
    model = velocity_loop_model(np.array(p_ctrl), np.array(k_vel), config.dt)
    f, L, parts = make_mpc_parts(model, config)
    return make_mpc_sample(f, L, parts, config, PATH_SAMPLES), L, parts


@lru_cache(maxsize=None)
def _mpc_law(p_ctrl: tuple, k_vel: tuple, key: _Key, latency: int, split: bool) -> GuidanceLaw:
    config = key.config
    sample, L, parts = _mpc_parts(p_ctrl, k_vel, key)
    every = int(round(config.dt / TS_CONTROL))
    S = mpc_state_layout(L)
    first = first_sample_latency(every) if latency else 0
    block = make_guidance("mpc", sample, every, latency, first, S.offset("first"), split)
    # the split block (a firmware's interrupt step) does not call the sample: nothing to link
    relink = None if split else partial(make_guidance, "mpc", every=every, latency=latency,
                                        first_latency=first, first_index=S.offset("first"))
    return GuidanceLaw("mpc", block, S, L, config, cond=parts["cond"], sample=sample,
                       latency=latency, first_latency=first, split=split, relink=relink)


def first_sample_latency(every: int = GUIDANCE_EVERY) -> int:
    """Latency (periods) of the MPC's cold first sample when its samples have a latency:
    ``every - 1``, the longest a sample interval allows (the first sample re-linearises
    :data:`~ballbot_casadi.guidance.mpc.FIRST_SAMPLE_QPS` times: several warm samples' work)."""
    return every - 1


def mpc_law(p_ctrl: np.ndarray, k_vel: np.ndarray, config: MpcConfig = MpcConfig(),
            latency: int = 0, split: bool = False) -> GuidanceLaw:
    """The path-following MPC in the slot, predicting the velocity loop of ``p_ctrl``,
    ``k_vel`` (built once per process and arguments); ``latency`` periods from a sample
    to its reference (the cold first sample: :func:`first_sample_latency`), ``split``:
    the block of a firmware interrupt step (:func:`make_guidance`)."""
    if abs(round(config.dt / TS_CONTROL) * TS_CONTROL - config.dt) > 1e-9:
        raise ScenarioError(f"MPC dt must be a multiple of {TS_CONTROL} s, got {config.dt!r}")
    return _mpc_law(tuple(np.asarray(p_ctrl, float).ravel()),
                    tuple(np.asarray(k_vel, float).ravel()), _Key(config), latency, bool(split))


@lru_cache(maxsize=None)
def _mpc_balance_law(p_ctrl: tuple, key: _Key) -> GuidanceLaw:
    config = key.config
    model = shape_model(shape_gains(np.array(p_ctrl)), config.dt)
    f, L, parts = make_mpc_parts(model, config)
    sample = make_mpc_sample(f, L, parts, config, PATH_SAMPLES)
    every = int(round(config.dt / TS_CONTROL))
    state = balance_state_layout(L)
    return GuidanceLaw("mpc_balance", make_balance_guidance(sample, L, every), state, L, config,
                       cond=parts["cond"], initial=balance_initial_function(state), sample=sample,
                       relink=partial(make_balance_guidance, L=L, every=every))


def mpc_balance_law(p_ctrl: np.ndarray, config: MpcConfig = BALANCE_FEED_CONFIG) -> GuidanceLaw:
    """The path-following MPC feeding the balance controller directly (Kugle's arrangement,
    :mod:`ballbot_casadi.sim.balance_feed`): the shape-accelerated model of ``p_ctrl``'s
    linearisation (built once per process and arguments)."""
    if abs(round(config.dt / TS_CONTROL) * TS_CONTROL - config.dt) > 1e-9:
        raise ScenarioError(f"MPC dt must be a multiple of {TS_CONTROL} s, got {config.dt!r}")
    return _mpc_balance_law(tuple(np.asarray(p_ctrl, float).ravel()), _Key(config))


#: Look-ahead (m) and lateral gain (1/s) of the pure-pursuit baseline in the slot: the
#: best of a 3 x 3 sweep (0.3 / 0.6 / 1.0 m x 0, 0.5, 1 1/s) on the figure-eight at
#: 0.5 m/s (the study's report); the class's own default 0.3 m lags the velocity loop.
PURSUIT_GAINS = (0.6, 1.0)


@lru_cache(maxsize=None)
def pursuit_law(lookahead: float = PURSUIT_GAINS[0], k_lat: float = PURSUIT_GAINS[1]) -> GuidanceLaw:
    """Pure pursuit in the slot (10 Hz)."""
    sample = make_pursuit_sample()
    return GuidanceLaw("pursuit", make_guidance("pursuit", sample), pursuit_state_layout(),
                       options=(("lookahead", lookahead), ("k_lat", k_lat)), sample=sample)


@lru_cache(maxsize=None)
def _initial_function(name: str, state: Layout) -> ca.Function:
    x0, s0 = ca.SX.sym("x0", 12), ca.SX.sym("s0")
    loop_state = make_loop_state()
    z0 = ca.SX.sym("z0", loop_state.numel_in(1))
    X0 = loop_state(x0, z0)
    if name == "mpc":
        parts = {"first": ca.DM(1.0), "x0": ca.vertcat(X0, s0, 0.0)}
    else:
        parts = {"s": s0}
    g = ca.vertcat(*(parts.get(f, ca.DM.zeros(state.size_of(f))) for f in state.fields))
    return ca.Function(f"ballbot_guidance_{name}_initial", [x0, z0, s0], [ca.vertcat(0.0, g)],
                       ["x0", "z0", "s0"], ["g0"])


def guided_software(law: GuidanceLaw, estimator: str = DEFAULT_ESTIMATOR) -> ca.Function:
    """The embedded software with ``law`` in its guidance slot,
    ``ballbot_embedded_<...>_<estimator>`` (inputs end with ``k_guid``, outputs with
    ``v_ref_used``, its state ``c`` carries ``guide``), built once per process: the
    compiled guided mission calls this Function and the path-following controller FMU
    is generated from it.

    Raises
    ------
    ScenarioError
        ``estimator`` is not one the embedded software runs (a key of
        :data:`~ballbot_casadi.sim.embedded.ESTIMATOR_FILTERS`).
    """
    if estimator not in ESTIMATOR_FILTERS:
        raise ScenarioError(f"the embedded software with guidance reads sensors: estimator "
                            f"{estimator!r} not allowed; allowed: {', '.join(ESTIMATOR_FILTERS)}")
    return embedded_software("flc", estimator, guidance=law.function)


@lru_cache(maxsize=None)
def _simulator(function: ca.Function, estimator: str, actuation_delay: bool = False,
               sample: ca.Function | None = None,
               relink: Callable[[ca.Function], ca.Function] | None = None) -> ClosedLoop:
    links: tuple[Library, ...] = ()
    if sample is not None and relink is not None:  # the sample compiled once, linked
        library, compiled_sample = linked_function(sample)
        function, links = relink(compiled_sample), (library,)
    if estimator == "true":
        blocks = controller_blocks("flc")
        step = make_closed_loop_step(blocks.balance, blocks.velocity, make_ode(), N_SUB,
                                     blocks.observer, function)
    else:  # the embedded software with the guidance block: the firmware's Function too
        blocks, est = software_blocks("flc", estimator)
        step = make_estimating_step(blocks.balance, blocks.velocity, est.ode, make_wheel_speeds(),
                                    est, N_SUB,
                                    embedded=embedded_software("flc", estimator, guidance=function),
                                    observer=blocks.observer, guidance=function,
                                    actuation_delay=actuation_delay)
    name = f"{function.name()}_{estimator}{'_delayed' if actuation_delay else ''}"
    return ClosedLoop(steps={"flc": step}, estimator=estimator, library=name,
                      actuation_delay=actuation_delay, links=links)


def guided_simulator(law: GuidanceLaw, estimator: str = "true",
                     actuation_delay: bool = False) -> ClosedLoop:
    """The compiled closed loop (FLC cascade, the guidance block in the period) reading
    the true state or, with an ``estimator`` of
    :data:`~ballbot_casadi.sim.embedded.ESTIMATOR_FILTERS`, the embedded software's
    estimate (:func:`guided_software`; built and compiled once per process, cached by
    hash on disk; an MPC's sample is compiled on its own and linked,
    :attr:`GuidanceLaw.relink`).  ``actuation_delay`` (an estimator only): the torque of
    period ``k`` acts in period ``k + 1`` (the loop of a Jacobi co-simulation master)."""
    if estimator != "true" and estimator not in ESTIMATOR_FILTERS:
        raise ScenarioError(f"unknown estimator {estimator!r}; allowed: true, "
                            f"{', '.join(ESTIMATOR_FILTERS)}")
    if actuation_delay and estimator == "true":
        raise ScenarioError("actuation_delay needs an estimator (the loop of the controller "
                            f"FMU): {', '.join(ESTIMATOR_FILTERS)}")
    return _simulator(law.function, estimator, bool(actuation_delay), law.sample, law.relink)


def run_guided(path: Path, law: GuidanceLaw, duration: float, estimator: str = "true",
               seed: int = 0, sim: ClosedLoop | None = None,
               scenario: Scenario | None = None,
               actuation_delay: bool = False) -> dict[str, np.ndarray]:
    """Follow ``path`` for ``duration`` s in one compiled mission (standing at its start,
    or as ``scenario`` says: its initial state, disturbances, estimator, seed, ...).

    Returns the log of :meth:`ClosedLoop.simulate` (``state``, ``v_ref_used``, ``guide``,
    with an estimator ``x_hat``, ...).

    Raises
    ------
    SolverError
        The guidance's QP failed in the generated C (the mission stops there).
    """
    sc = path_scenario(path, duration) if scenario is None else scenario
    if scenario is None and estimator != "true":
        sc = sc.replace(estimator=estimator, seed=seed)
    if sc.controller != "flc" or not sc.cascade:
        raise ScenarioError("path following runs the FLC cascade (controller 'flc', cascade = "
                            f"true), got controller {sc.controller!r}, cascade = {sc.cascade}")
    inp = sc.inputs()
    if sc.estimator != "true":
        inp = power_on_inputs(sc.estimator, inp)
    sim = guided_simulator(law, sc.estimator, actuation_delay) if sim is None else sim
    g0 = law.initial_state(path, inp["x0"], inp["z0"])
    try:
        return sim.simulate("flc", **inp, n_sub=sc.n_sub, k_guid=law.parameters(path), g0=g0,
                            actuation_delay=actuation_delay)
    except BuildError as exc:
        raise SolverError(f"path following stopped: a {law.name} guidance sample failed in "
                          f"the generated C (a QP that did not converge): {exc}") from None


def scenario_law(scenario: Scenario, latency: int | None = None, split: bool = False
                 ) -> GuidanceLaw:
    """The guidance law a scenario with a path asks for (its own controller model); the
    MPC with ``latency`` periods from a sample to its reference (:func:`mpc_law`; default
    the scenario's ``guidance_latency``)."""
    latency = scenario.guidance_latency if latency is None else latency
    if scenario.guidance == "pursuit":
        if latency or split:
            raise ScenarioError("guidance latency is an option of the MPC, not of pursuit")
        return pursuit_law()
    inp = scenario.inputs(periods=(0, 1))
    if scenario.guidance == "mpc_balance":
        if latency or split:
            raise ScenarioError("guidance latency is an option of the velocity-feed MPC "
                                "(guidance = \"mpc\"), not of mpc_balance")
        return mpc_balance_law(inp["p_ctrl"])
    return mpc_law(inp["p_ctrl"], inp["k_vel"], latency=latency, split=split)


def run_path_scenario(scenario: Scenario, sim: ClosedLoop | None = None,
                      actuation_delay: bool = False) -> SimulationLog:
    """Run a scenario with a ``[path]`` (:mod:`~ballbot_casadi.sim.scenario.path_section`)
    as a :class:`~ballbot_casadi.sim.log.SimulationLog` (arrays of :func:`run_guided`;
    ``actuation_delay``: the torque held one period, as under a Jacobi co-simulation
    master)."""
    path = scenario.route.build()
    if path is None:
        raise ScenarioError(f"scenario {scenario.name!r} has no [path] to follow", key="path")
    log = run_guided(path, scenario_law(scenario), scenario.duration, sim=sim, scenario=scenario,
                     actuation_delay=actuation_delay)
    log.pop("xz_final", None)
    return SimulationLog(arrays=log, scenario=scenario.to_dict(), params=scenario.plant_params(),
                         ctrl_params=scenario.controller_params(),
                         diag_names=scenario.diag_names(), extra={PATH_KEY: path_metadata(path)})


def path_metadata(path: Path, spacing: float = PATH_LOG_SPACING) -> dict[str, list]:
    """The followed path as a log keeps it (:data:`~ballbot_casadi.sim.log.PATH_KEY`):
    ``xy`` the path at arc lengths ``0, spacing, ..., length`` (both ends included) and
    ``obstacles`` as ``[x, y, r]`` rows, so a viewer draws it without the path code."""
    n = max(2, int(np.ceil(path.length / spacing)) + 1)
    xy = np.asarray(path.point(np.linspace(0.0, path.length, n)), float)
    return {"xy": xy.tolist(),
            "obstacles": [[float(o.center[0]), float(o.center[1]), float(o.radius)]
                          for o in path.obstacles]}


def predictions(law: GuidanceLaw, log: dict[str, np.ndarray], every: int = GUIDANCE_EVERY
                ) -> tuple[np.ndarray, np.ndarray]:
    """The MPC's predicted positions at each guidance sample: sample indices (periods)
    and positions (n_samples, N+1, 2), from the logged guidance state."""
    if law.mpc_layout is None:
        raise ScenarioError("predictions: only the MPC predicts")
    g = log["guide"][1::every, 1:]  # the state after each sample's period
    S = law.state
    pos = np.stack([law.cond.states(x0, u)[:, 12:14] for x0, u in zip(g[:, S["x0"]], g[:, S["u"]])])
    return np.arange(0, g.shape[0] * every, every), pos


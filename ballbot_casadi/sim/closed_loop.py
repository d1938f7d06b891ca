"""Running closed-loop missions: :class:`ClosedLoop` (one call per mission) and
:func:`run_scenario` (a scenario, optionally in segments, as a log).

The missions are those of :mod:`ballbot_casadi.sim.mission` over the steps of
:mod:`ballbot_casadi.sim.steps`, compiled by :mod:`ballbot_casadi.sim.library` (by
default run through the zero-copy C entry point of :mod:`~ballbot_casadi.sim.driver`;
identical results).  Inputs are packed and the log unpacked by the period's port names
and the mission state's layout (:mod:`ballbot_casadi.sim.ports`).

Log layout: ``state[k]`` (k < N) is the state the controllers saw at ``t_k = k Ts`` (after
a push), ``state[N]`` the final state; torques and references of period k apply on
``[t_k, t_k+1)``.

Plant and controller parameters are separate inputs, so robustness runs (thesis §8.4)
need no regeneration.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping, Sequence

import casadi as ca
import numpy as np

from ballbot_casadi.control import balance_state_size
from ballbot_casadi.control.velocity import VELOCITY_NZ
from ballbot_casadi.core.constants import N_SUB, TS_CONTROL
from ballbot_casadi.core.toolchain import Library, build_library
from ballbot_casadi.errors import ScenarioError, ShapeError
from ballbot_casadi.estimation.com_observer import (
    COM_OBSERVER_DEFAULT_GAINS,
    COM_OBSERVER_STATE,
    check_com_observer_gains,
    com_observer_initial_state,
)
from ballbot_casadi.model.dynamics import NX
from ballbot_casadi.sim.driver import MissionDriver
from ballbot_casadi.sim.embedded import (
    ESTIMATOR_FILTERS,
    SENSOR_STATE,
    controller_layout,
    estimator_layout,
    initial_controller_state,
)
from ballbot_casadi.sim.library import MissionVariant, closed_loop_functions, closed_loop_library
from ballbot_casadi.sim.log import SimulationLog
from ballbot_casadi.sim.mission import make_chunk
from ballbot_casadi.sim.ports import (
    ESTIMATION_OUTPUTS,
    FILTER_CONSTANTS,
    GUIDANCE_CONSTANTS,
    GUIDANCE_OUTPUTS,
    N_WHEEL,
    OBSERVER_CONSTANTS,
    OBSERVER_OUTPUTS,
    SENSOR_CONSTANTS,
    SENSOR_SEQUENCES,
    controller_state_of,
    mission_state,
    sequence_positions,
)
from ballbot_casadi.sim.scenario import Scenario

__all__ = ["ClosedLoop", "run_scenario", "power_on_inputs", "DECIMATED_SEGMENT_PERIODS"]

#: Periods per segment of a decimated run (60 s at 200 Hz): memory grows with the
#: decimated log only.
DECIMATED_SEGMENT_PERIODS = 12000


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
        controllers (e.g. a stand-in in tests, or steps with a guidance block); with
        ``compiled`` those are compiled (library ``ballbot_closed_loop_custom``, or
        ``library`` if given).  Such steps have a fixed ``n_sub`` and ``estimator``.
    root
        Build root (default :func:`~ballbot_casadi.core.toolchain.build_root`).
    use_driver
        With ``compiled``: run missions through the zero-copy C entry point of
        :mod:`~ballbot_casadi.sim.driver` (same generated chunk and step code, no
        numpy <-> DM conversion); otherwise call the CasADi mission Function.
    estimator
        What custom ``steps`` read: ``"true"`` (default) or the estimator their embedded
        software runs (``"ukf"``, ``"ekf"``).
    library
        Name of the compiled library of custom ``steps``.
    actuation_delay
        Custom ``steps`` hold the torque one period (built with ``actuation_delay``,
        :func:`~ballbot_casadi.sim.steps.make_estimating_step`): missions of them are run
        with ``actuation_delay=True``.
    links
        Libraries whose Functions custom ``steps`` call as externals (e.g. the guided
        mission's separately compiled MPC, :func:`~ballbot_casadi.core.toolchain.linked_function`),
        linked into their library (:func:`~ballbot_casadi.core.toolchain.build_library`).

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
        estimator: str = "true",
        library: str = "ballbot_closed_loop_custom",
        actuation_delay: bool = False,
        links: Sequence[Library] = (),
    ) -> None:
        if not isinstance(n_sub, (int, np.integer)) or isinstance(n_sub, bool) or n_sub < 1:
            raise ScenarioError(f"n_sub must be an int >= 1, got {n_sub!r}")
        self.n_sub = int(n_sub)
        self.compiled = bool(compiled)
        self.root = root
        self.use_driver = bool(use_driver)
        self._custom = steps is not None
        self._variants: dict[tuple[int, str, bool], MissionVariant] = {}
        if steps is not None:
            lib = None
            if compiled:
                funcs = [g for f in steps.values() for g in (f, make_chunk(f))]
                lib = build_library(library, funcs, root, links=links)
            self._variants[(self.n_sub, estimator, bool(actuation_delay))] = MissionVariant(
                steps, lib, self.use_driver)
        else:
            self._variant(self.n_sub)

    def _variant(self, n_sub: int, estimator: str = "true",
                 actuation_delay: bool = False) -> MissionVariant:
        key = (int(n_sub), estimator, bool(actuation_delay))
        if key not in self._variants:
            if self._custom:
                have = next(iter(self._variants))
                raise ScenarioError(
                    f"these custom steps integrate with n_sub = {have[0]} and estimator "
                    f"{have[1]!r}; n_sub = {n_sub}, estimator = {estimator!r} needs steps built "
                    "for it"
                )
            if estimator not in ("true", *ESTIMATOR_FILTERS):
                raise ScenarioError(f"unknown estimator {estimator!r}; allowed: true, "
                                    f"{', '.join(ESTIMATOR_FILTERS)}")
            if self.compiled:
                lib, symbolic, exported = closed_loop_library(key[0], self.root, estimator, key[2])
            else:
                lib, (symbolic, exported) = None, closed_loop_functions(key[0], estimator, key[2])
            self._variants[key] = MissionVariant(symbolic, lib, self.use_driver, exported)
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

    def step(self, controller: str, n_sub: int | None = None, estimator: str = "true",
             actuation_delay: bool = False) -> ca.Function:
        """The step Function of ``controller`` (compiled or symbolic)."""
        steps = self._variant(self.n_sub if n_sub is None else int(n_sub), estimator,
                              actuation_delay).steps
        try:
            return steps[controller]
        except KeyError:
            raise ScenarioError(
                f"unknown controller {controller!r}; allowed: {', '.join(steps)}"
            ) from None

    def mission(self, controller: str, n_periods: int, n_sub: int | None = None,
                estimator: str = "true", actuation_delay: bool = False) -> ca.Function:
        """The ``n_periods`` mission Function of ``controller`` (cached)."""
        self.step(controller, n_sub, estimator, actuation_delay)  # validates the name
        n_sub = self.n_sub if n_sub is None else int(n_sub)
        return self._variant(n_sub, estimator, actuation_delay).mission(controller, n_periods)

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
        actuation_delay: bool = False,
        k_guid: np.ndarray | None = None,
        g0: np.ndarray | None = None,
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
        ``o0`` (its initial state, default: the controller model's COM, from the power-on
        Function :func:`~ballbot_casadi.sim.embedded.initial_controller_state_function`
        with an estimator, else
        :func:`~ballbot_casadi.estimation.com_observer.com_observer_initial_state`); the
        observer's state is the last part of the controller state.  With
        ``actuation_delay`` (an estimator only) the torque of period ``k`` acts on
        ``[t_k+1, t_k+2)`` (zero in period 0): the loop of a Jacobi co-simulation master
        (:mod:`ballbot_casadi.sim.steps`).  Steps with a guidance block
        (:mod:`ballbot_casadi.sim.guided`) take its parameters ``k_guid`` and its
        initial state ``g0`` (the controller state's field ``guide``).

        Returns the named arrays of the log: ``time`` (N+1), ``state`` (N+1, 12; row
        k < N is the plant state at ``t_k`` after a push, the last row the final
        state), ``z`` (N+1, NZ), ``tau_cmd``, ``tau`` (N, 3; ``tau`` acts on the plant:
        saturated plus the disturbance), ``q_ref``, ``dq_ref``, ``ddq_ref`` (N, 4, the
        references used), ``v_ref`` (N, 3), ``w`` (N, 6), ``diag`` (N, ND); with an
        estimator also ``x_hat`` (N, 12, what the controllers read), ``meas`` (N, 9),
        ``nis`` (N, 2), ``repairs`` (N, 1), ``rejections`` (N, 4, the innovation gates'
        rejections per :data:`~ballbot_casadi.sim.embedded.GATE_GROUPS`), ``noise``,
        ``valid``, ``phi`` (N+1, 3, wheel
        angles) and ``c_final`` (the embedded software's final state); with the
        observer ``com_hat`` (N, 2: the estimate after each period's update); with
        guidance ``v_ref_used`` (N, 3: the reference the velocity controller followed)
        and ``guide`` (N+1, NG: the guidance block's state).
        """
        n_sub = self.n_sub if n_sub is None else n_sub
        if not isinstance(n_sub, (int, np.integer)) or isinstance(n_sub, bool) or n_sub < 1:
            raise ScenarioError(f"n_sub must be an int >= 1, got {n_sub!r}")
        step = self.step(controller, n_sub, estimator, actuation_delay)
        est = estimator != "true"
        if est and estimation is None:
            raise ScenarioError(f"estimator {estimator!r} needs the estimation inputs (noise, ...)")
        extra = dict(estimation or {}) if est else {}
        seqs = {"q_ref": q_ref, "dq_ref": dq_ref, "ddq_ref": ddq_ref, "v_ref": v_ref, "w": w,
                **{k: extra.get(k) for k in (SENSOR_SEQUENCES if est else ())}}
        n = None
        for key, val in seqs.items():
            width = step.size1_in(step.index_in(key))
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
        z0 = np.asarray(z0, float).ravel()
        with_obs = OBSERVER_CONSTANTS[1] in step.name_in()
        if com_observer and not with_obs:
            raise ScenarioError("com_observer = true needs steps with the COM observer "
                                "(these custom steps have none)")
        parts: dict[str, Any] = {"x": x0, "c.z": z0}
        if with_obs:
            k_obs = check_com_observer_gains(COM_OBSERVER_DEFAULT_GAINS if k_obs is None else k_obs)
            if o0 is not None:
                parts["c.obs"] = np.asarray(o0, float).ravel()
            elif est:  # the embedded software's power-on state, as the controller FMU's
                c0 = initial_controller_state(estimator, x0, p_ctrl, observer=True)
                parts["c.obs"] = c0[controller_layout(estimator, VELOCITY_NZ,
                                                      COM_OBSERVER_STATE.size)["obs"]]
            else:
                parts["c.obs"] = com_observer_initial_state(x0, p_ctrl)
        n_obs = np.size(parts["c.obs"]) if with_obs else 0
        with_guide = GUIDANCE_CONSTANTS[0] in step.name_in()
        if with_guide and (g0 is None or k_guid is None):
            raise ScenarioError("steps with a guidance block need its parameters k_guid and "
                                "initial state g0")
        n_guide = np.size(g0) if with_guide else 0
        if with_guide:
            parts["c.guide"] = np.asarray(g0, float).ravel()
        n_bal = 0 if self._custom else balance_state_size(controller)
        if n_bal:
            parts["c.bal"] = np.zeros(n_bal)  # the balance controller's own state starts at rest
        if est:
            X = mission_state(controller_layout(estimator, z0.size, n_obs, n_guide, n_bal=n_bal),
                              SENSOR_STATE, actuation_delay)
            E = estimator_layout(estimator)
            e0 = np.asarray(extra["e0"], float).ravel()
            if e0.size != E.size:
                raise ShapeError(f"e0 has {e0.size} entries, expected {E.size}")
            parts.update({"phi": np.zeros(N_WHEEL), "s": extra["s0"],
                          **{f"c.{f}": e0[E[f]] for f in E.fields}})
            if actuation_delay:
                parts["u"] = np.zeros(X.size_of("u"))
        else:
            X = mission_state(controller_state_of(z0.size, n_obs, n_guide, n_bal=n_bal), None,
                              actuation_delay)
        variant = self._variant(int(n_sub), estimator, actuation_delay)
        ports_state_size = step.size1_in(0)
        if xz0 is None:
            if X.size != ports_state_size:
                raise ShapeError(f"initial state has {X.size} entries, expected {ports_state_size}")
            try:
                xz0 = X.pack(parts)
            except ValueError as e:
                raise ShapeError(f"initial state: {e}") from None
        xz0 = np.asarray(xz0, float).ravel()
        const = {"p_plant": p_plant, "p_ctrl": p_ctrl, "k_bal": k_bal, "k_vel": k_vel, "Ts": Ts,
                 "cascade": 1.0 if cascade else 0.0, "feedforward": 1.0 if feedforward else 0.0,
                 **{k: extra[k] for k in ((*SENSOR_CONSTANTS, *FILTER_CONSTANTS) if est else ())},
                 **({"com_observer": 1.0 if com_observer else 0.0, "k_obs": k_obs} if with_obs else {}),
                 **({"k_guid": k_guid} if with_guide else {})}
        args = [xz0]
        for i in range(1, step.n_in()):
            name = step.name_in(i)
            a = seqs[name] if name in seqs else np.asarray(const[name], float).ravel(order="F")
            if name not in seqs and a.size != step.size1_in(i):
                raise ShapeError(f"{name} has {a.size} entries, expected {step.size1_in(i)}")
            args.append(a)
        if xz0.size != step.size1_in(0):
            raise ShapeError(f"initial state has {xz0.size} entries, expected {step.size1_in(0)}")
        seq_idx = sequence_positions(step)
        if variant.driver is not None and controller in variant.chunks:
            res = variant.run_driver(controller, n, args)
        else:
            mission = variant.mission(controller, n)
            res = [np.asarray(r).T for r in mission(*[a.T if i in seq_idx else a
                                                       for i, a in enumerate(args)])]
        out = dict(zip(step.name_out(), res))
        xz_next = out["xz_next"]
        log = {
            "time": np.arange(n + 1) * float(Ts),
            "state": np.vstack([out["x"], xz_next[-1:, X["x"]]]),
            "z": np.vstack([xz0[None, X["c.z"]], xz_next[:, X["c.z"]]]),
            "tau_cmd": out["tau_cmd"],
            "tau": out["tau"],
            "q_ref": out["q_ref_used"],
            "dq_ref": out["dq_ref_used"],
            "ddq_ref": out["ddq_ref_used"],
            "v_ref": seqs["v_ref"],
            "w": seqs["w"],
            "diag": out["diag"],
            "xz_final": xz_next[-1, :].copy(),
        }
        if with_obs:
            log.update({k: out[k] for k in OBSERVER_OUTPUTS})
        if with_guide:
            log.update({k: out[k] for k in GUIDANCE_OUTPUTS})
            log["guide"] = np.vstack([xz0[None, X["c.guide"]], xz_next[:, X["c.guide"]]])
        if est:
            log.update({k: out[k] for k in ESTIMATION_OUTPUTS})
            log.update({k: seqs[k] for k in SENSOR_SEQUENCES})
            log["phi"] = np.vstack([xz0[None, X["phi"]], xz_next[:, X["phi"]]])
            log["c_final"] = xz_next[-1, X["c"]]
        return log


def power_on_inputs(estimator: str, inp: Mapping[str, Any]) -> dict[str, Any]:
    """``inp`` (:meth:`Scenario.inputs <ballbot_casadi.sim.scenario.Scenario.inputs>`) with
    the embedded software's state at power-on (``z0``, the filters' ``e0``, the observer's
    ``o0``) from :func:`~ballbot_casadi.sim.embedded.initial_controller_state_function`,
    the Function the controller FMU evaluates in its initialisation."""
    c0 = initial_controller_state(estimator, inp["x0"], inp["p_ctrl"], observer=True)
    L = controller_layout(estimator, VELOCITY_NZ, COM_OBSERVER_STATE.size)
    e0 = np.concatenate([c0[L[f]] for f in estimator_layout(estimator).fields])
    return {**inp, "z0": c0[L["z"]], "o0": c0[L["obs"]],
            "estimation": {**inp["estimation"], "e0": e0}}


def run_scenario(scenario: Any, sim: ClosedLoop | None = None, log_every: int = 1,
                 segment_periods: int | None = None, actuation_delay: bool = False
                 ) -> SimulationLog:
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
        the run's length (default: one segment, or :data:`DECIMATED_SEGMENT_PERIODS` when
        decimating).
        The result equals the single-call run bit for bit (same inputs, same code).
    actuation_delay
        Run the loop of a Jacobi co-simulation master: the torque of period ``k`` acts on
        ``[t_k+1, t_k+2)`` (scenarios with an estimator; :mod:`ballbot_casadi.sim.steps`).
    """
    if not isinstance(scenario, Scenario):
        raise ScenarioError(f"run_scenario needs a Scenario, got {type(scenario).__name__}")
    if scenario.path:
        raise ScenarioError(f"scenario {scenario.name!r} follows a [path]: run it with "
                            "ballbot_casadi.sim.guided.run_path_scenario", key="path")
    for name, v in (("log_every", log_every), ("segment_periods", segment_periods)):
        if v is not None and (not isinstance(v, (int, np.integer)) or isinstance(v, bool) or v < 1):
            raise ScenarioError(f"{name} must be an int >= 1, got {v!r}")
    sim = ClosedLoop() if sim is None else sim
    n = scenario.n_periods
    seg = segment_periods or (n if log_every == 1 else min(n, DECIMATED_SEGMENT_PERIODS))
    arrays: dict[str, list[np.ndarray]] = {}
    xz = None
    for k0 in range(0, n, seg):
        k1 = min(n, k0 + seg)
        inp = scenario.inputs(periods=(k0, k1))
        if xz is None and scenario.estimator != "true":
            inp = power_on_inputs(scenario.estimator, inp)
        part = sim.simulate(scenario.controller, **inp, n_sub=scenario.n_sub, xz0=xz,
                            actuation_delay=actuation_delay)
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

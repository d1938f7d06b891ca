"""Closed-loop scenarios: a validated, JSON-serialisable description of one simulation run.

A :class:`Scenario` says which balance controller runs (``flc`` thesis ch. 8, ``smc``
the V2019 baseline of thesis §8.3), whether the velocity loop closes the cascade
(thesis Fig. 7.1) or the balance controller follows an attitude reference alone
(thesis Fig. 8.1), the initial state, the references, pushes, and how the plant and
the controller's internal model deviate from the nominal parameters (thesis §8.4).
It is composed of the sections of :mod:`~ballbot_casadi.sim.scenario.sections` (one per
part of a scenario file, each owning its keys, units, validation and TOML round trip).
:meth:`Scenario.inputs` turns it into the input sequences of
:meth:`ballbot_casadi.sim.closed_loop.ClosedLoop.simulate`.

The thesis experiments built from scenarios are the studies of
:mod:`ballbot_casadi.studies.registry`.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

from ballbot_casadi.control import (
    BALANCE_DIAG_NAMES,
    LINEAR_DESIGNED,
    VELOCITY_NKV,
    default_balance_gains,
    default_velocity_gains,
    velocity_initial_state,
)
from ballbot_casadi.control.velocity import VELOCITY_DEFAULT_LIMITS
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import DISTURBANCE
from ballbot_casadi.core.params import PARAM_NAMES, Params, load_params
from ballbot_casadi.core.rng import NoiseStream
from ballbot_casadi.core.sensor_params import SensorParams, load_sensor_params
from ballbot_casadi.core.validation import plain_json
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.estimation import DEFAULT_TUNING
from ballbot_casadi.estimation.com_observer import COM_OBSERVER_DEFAULT_GAINS
from ballbot_casadi.estimation.velocity import MATCHED_ACC_PROCESS_VAR
from ballbot_casadi.model.dynamics import make_jacobians, make_model_functions
from ballbot_casadi.model.linearization import linearize
from ballbot_casadi.model.sensors import NOISE_STREAMS, heading_schedule
from ballbot_casadi.sim import references as R
from ballbot_casadi.sim.period import TORQUE_LIMIT_MODES, controller_torque_limit
from ballbot_casadi.sim.embedded import (
    ESTIMATOR_FILTERS,
    MATCHED_VELOCITY,
    NOISE,
    VALID,
    initial_estimator_state,
)
from ballbot_casadi.sim.scenario.path_section import PathSection
from ballbot_casadi.sim.scenario.sections import (
    CONTROLLER_CHANGES,
    ESTIMATOR_CHANGES,
    ESTIMATOR_CHOICES,
    ESTIMATOR_TUNING_KEYS,
    ESTIMATOR_TUNING_TARGETS,
    FEEDFORWARD_MODES,
    GLITCH_AXES,
    PLANT_CHANGES,
    SCENARIO_SECTIONS,
    SENSOR_CHANGES,
    DisturbancesSection,
    EstimationSection,
    GainsSection,
    InitialSection,
    ModelSection,
    ObserverSection,
    ReferencesSection,
    RunSection,
    SensorsSection,
    initial_state,
)
from ballbot_casadi.sim.scenario.signals import attitude_reference

__all__ = [
    "Scenario",
    "SCENARIO_FIELDS",
    "FEEDFORWARD_MODES",
    "TORQUE_LIMIT_MODES",
    "ESTIMATOR_CHOICES",
    "ESTIMATOR_TUNING_KEYS",
    "ESTIMATOR_TUNING_TARGETS",
    "initial_state",
    "PLANT_CHANGES",
    "CONTROLLER_CHANGES",
    "ESTIMATOR_CHANGES",
    "SENSOR_CHANGES",
]

#: The attributes of a :class:`Scenario`, in the order of :meth:`Scenario.to_dict`.
SCENARIO_FIELDS = (
    "name", "controller", "duration", "x0", "cascade", "attitude", "velocity_keyframes", "pushes",
    "torque_disturbances", "plant_changes", "ctrl_changes", "k_bal", "k_vel", "Ts", "n_sub",
    "feedforward", "torque_limit", "estimator", "seed", "noise", "sensor_changes", "est_changes", "estimator_tuning",
    "sensor_dropouts", "sensor_glitches", "com_observer", "k_obs", "study", "description",
    "heading_sensor", "path", "obstacles", "guidance", "guidance_latency",
)
#: Attribute -> the section holding it.
#: Position of the torque limit in the parameter vector.
_TAU_MAX = PARAM_NAMES.index("tau_max")
_SECTION_OF = {f: name for name, cls in SCENARIO_SECTIONS for f in cls.FIELDS}


class Scenario:
    """One closed-loop run, composed of the sections of a scenario file.

    ``Scenario(name, **fields)`` takes the attributes below (each a keyword with its
    default); they are held by the sections of
    :mod:`~ballbot_casadi.sim.scenario.sections` (``run``, ``initial``, ``references``,
    ``disturbances``, ``models``, ``sensors``, ``estimation``, ``observer``, ``gains``),
    each validating its own fields, and read back as plain attributes.  Immutable.

    Attributes
    ----------
    name
        Identifier (also the study name for the acceptance scenarios).
    controller
        Balance controller: a key of ``controllers.BALANCE_CONTROLLERS`` (``flc``, ``smc``).
    duration
        Simulated time (s); the run has ``round(duration / Ts)`` control periods.
    x0
        Initial plant state (12 numbers, unit quaternion).
    cascade
        Close the velocity loop (thesis Fig. 7.1); otherwise the balance controller
        follows ``attitude`` alone (thesis Fig. 8.1).
    attitude
        ``{"roll": sig, "pitch": sig, "yaw": sig}`` with ``sig`` a dict: ``{"type":
        "const", "value_deg"}``, ``{"type": "sine", "amplitude_deg", "frequency_hz"}``,
        ``{"type": "step", "amplitude_deg", "t_step", "rise_time"}`` or ``{"type":
        "chirp", "amplitude_deg", "f0_hz", "f1_hz", "duration"}``; missing axes are 0.
    velocity_keyframes
        Rows ``(t_start, vx, vy, yaw_rate)`` of :func:`~ballbot_casadi.sim.references.velocity_profile`
        (cascade only; empty = stand still).
    pushes
        Rows ``(t, roll_deg, pitch_deg, yaw_deg)``: at the control instant nearest ``t``
        the plant attitude is rotated (in {K}) by that rotation (thesis §8.4.3).
    torque_disturbances
        Rows ``(t_start, t_end, tau0, tau1, tau2)`` in s and N m: a wheel-torque
        disturbance acting on the plant over the control periods that start in
        ``[t_start, t_end)``, added after the motor saturation (overlapping rows add).
    plant_changes, ctrl_changes
        ``{param: [op, value]}`` with op ``set``/``scale``/``add``, applied to the nominal
        parameters for the plant and for the controller's internal model.
    k_bal, k_vel
        Gain vectors; empty = the controller package's defaults.
    Ts, n_sub
        Control period (s, 200 Hz) and RK4 sub-steps per period (plant step Ts/n_sub).
    feedforward
        ``"exact"`` (default): the balance controller gets the reference's second
        derivative; ``"none"``: it gets zero, as the thesis's FLC (8.44) and the
        predecessor's sliding mode did.
    estimator
        What the controllers read: ``"true"`` (the true state, default), ``"ukf"``
        (noisy sensors, QUKF + VUKF, thesis ch. 4-5) or ``"ekf"`` (noisy sensors, the
        predecessor's EKFs) or ``"ukf_heading"`` (the QUKF with the heading reading and
        the z gyro bias as a state, :mod:`~ballbot_casadi.estimation.heading`, + VUKF) or
        ``"ekf_heading"`` (the predecessor's QEKF with heading correction and gyro-bias
        states, :mod:`~ballbot_casadi.estimation.predecessor`, + VEKF; thesis §6).
    seed
        Seed of the sensor-noise generator (int >= 0; runs with the same seed are
        identical bit for bit).
    noise
        With an estimator: draw sensor noise (default) or run the sensors noise-free
        (biases, scale factors and encoder quantisation stay).
    sensor_changes
        ``{sensor parameter: [op, value]}`` applied to the sensor parameters
        (:mod:`ballbot_casadi.core.sensor_params`; vector parameters take a list value
        with ``set``).
    est_changes
        ``{param: [op, value]}`` applied to the nominal parameters for the estimators'
        internal model.
    estimator_tuning
        Changes to the filters' default (thesis) tuning: ``rate_process_var`` (the
        attitude filter's body-rate process noise per period, (rad/s)^2, thesis 4.39:
        1e-5), ``encoder_var`` (the velocity filter's encoder noise, ticks^2, thesis
        5.27: 1/9), ``acc_process_var`` (the velocity filter's acceleration random walk per
        period, (m/s^2)^2, the predecessor's 1e-5; ``acc_process_var_x``, ``acc_process_var_y``
        set one axis, applied after it; the matched filter of ``ukf_consistent`` starts
        from its calibrated pair,
        :data:`~ballbot_casadi.estimation.velocity.MATCHED_ACC_PROCESS_VAR`, instead, and
        ``ukf_adaptive`` takes it as the prior of its online estimate) and
        ``acc_bias_process_var`` (the velocity
        filter's accelerometer-bias
        process noise per period, (m/s^2)^2, the predecessor's 1e-9; it sets how fast
        the velocity-aided tilt correction follows the attitude filter's slow error,
        :mod:`~ballbot_casadi.estimation.tilt_aiding`).
    sensor_dropouts
        Rows ``(t_start, t_end, sensor)`` with sensor ``"acc"``, ``"gyro"`` or ``"enc"``:
        that sensor's readings are missing (NaN) in the periods starting in
        ``[t_start, t_end)``; the filters predict only for it (also ``"heading"``).
    heading_sensor
        The robot carries the heading sensor (an absolute yaw reading at the sensor
        parameter ``heading_rate``, :func:`~ballbot_casadi.model.sensors.make_heading_sensor`).
        Off (default): its reading is always missing.  Only ``ukf_heading`` and
        ``ekf_heading`` read it.
    sensor_glitches
        Rows ``(t, sensor, axis, value)`` with sensor ``"acc"`` or ``"gyro"`` and axis
        ``"x"``, ``"y"`` or ``"z"``: at the control instant nearest ``t`` that reading is
        off by ``value`` (m/s^2, rad/s), added to its noise sample (so the sensor's noise
        variance on that axis must be positive); the filters' innovation gates should
        reject it.  Needs an estimator in the loop.
    com_observer
        The controllers use the online estimate of the COM offset
        (:mod:`ballbot_casadi.estimation.com_observer`) as their internal model: the
        balance controller's model and the velocity controller's balance point (position
        hold at standstill).  Off (default): the loop of thesis §7.3, bit for bit.
    k_obs
        COM observer gains ``[t_obs, t_com, t_diff, c_max]``; empty = the defaults.
    study
        Which study the scenario belongs to (:mod:`ballbot_casadi.studies.registry`).
    """

    __slots__ = tuple(name for name, _ in SCENARIO_SECTIONS)

    run: RunSection
    initial: InitialSection
    references: ReferencesSection
    disturbances: DisturbancesSection
    models: ModelSection
    sensors: SensorsSection
    estimation: EstimationSection
    observer: ObserverSection
    gains: GainsSection
    route: PathSection

    def __init__(self, *args: Any, **fields: Any) -> None:
        if len(args) > len(SCENARIO_FIELDS):
            raise TypeError(f"Scenario() takes at most {len(SCENARIO_FIELDS)} positional arguments")
        twice = sorted(set(SCENARIO_FIELDS[:len(args)]) & set(fields))
        unknown = sorted(set(fields) - set(SCENARIO_FIELDS))
        if twice or unknown:
            raise TypeError(f"Scenario() got field(s) {twice} twice or unknown field(s) {unknown}; "
                            f"allowed: {list(SCENARIO_FIELDS)}")
        fields.update(zip(SCENARIO_FIELDS, args))
        if "name" not in fields:
            raise TypeError("Scenario() needs a name")
        by_section: dict[str, dict[str, Any]] = {s: {} for s, _ in SCENARIO_SECTIONS}
        for f, v in fields.items():
            by_section[_SECTION_OF[f]][f] = v
        self._assign({s: cls(**by_section[s]) for s, cls in SCENARIO_SECTIONS})

    @classmethod
    def from_sections(cls, **sections: Any) -> "Scenario":
        """A scenario of section objects (every section of ``SCENARIO_SECTIONS``; missing
        ones are the defaults), validated."""
        unknown = sorted(set(sections) - {s for s, _ in SCENARIO_SECTIONS})
        if unknown:
            raise TypeError(f"unknown scenario section(s) {unknown}")
        self = cls.__new__(cls)
        self._assign({s: sections.get(s, c()) for s, c in SCENARIO_SECTIONS})
        return self

    def _assign(self, sections: Mapping[str, Any]) -> None:
        for s, _ in SCENARIO_SECTIONS:
            object.__setattr__(self, s, sections[s])
        try:
            for s, _ in SCENARIO_SECTIONS:
                sections[s].check(self.run)
            if self.sensor_glitches and self.estimator == "true":
                raise ScenarioError("sensor_glitch rows need sensors in the loop: set estimator "
                                    "= 'ukf' or 'ekf'", key="sensor_glitch[0]")
        except ScenarioError as exc:
            raise exc.within(f"scenario {self.name!r}") from None

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError(f"Scenario is immutable; use replace({name}=...)")

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Scenario):
            return NotImplemented
        return all(getattr(self, s) == getattr(other, s) for s, _ in SCENARIO_SECTIONS)

    __hash__ = None  # type: ignore[assignment]  (mutable mappings inside, as before)

    def __reduce__(self) -> tuple:
        """Pickle and copy by sections (the instance refuses attribute assignment)."""
        return (_from_sections, ({s: getattr(self, s) for s, _ in SCENARIO_SECTIONS},))

    def __repr__(self) -> str:
        return "Scenario(" + ", ".join(f"{f}={getattr(self, f)!r}" for f in SCENARIO_FIELDS) + ")"

    # -- derived quantities ------------------------------------------------------------
    @property
    def n_periods(self) -> int:
        """Number of control periods."""
        return self.run.n_periods

    def window(self, periods: tuple[int, int] | None = None) -> tuple[int, int]:
        """Validated period range ``[k0, k1)`` (default: the whole run)."""
        if periods is None:
            return 0, self.n_periods
        k0, k1 = (int(v) for v in periods)
        if not 0 <= k0 < k1 <= self.n_periods:
            raise ScenarioError(f"scenario {self.name!r}: periods [{k0}, {k1}) outside [0, {self.n_periods})")
        return k0, k1

    def time(self, periods: tuple[int, int] | None = None) -> np.ndarray:
        """Control instants ``t_k = k Ts``, k = 0..N-1 (or ``k`` in ``periods``)."""
        k0, k1 = self.window(periods)
        return np.arange(k0, k1) * self.Ts

    def plant_params(self, base: Params | None = None) -> Params:
        """Plant parameters: ``base`` (default thesis App. A) with :attr:`plant_changes`."""
        return PLANT_CHANGES.apply(base or load_params(), self.plant_changes)

    def controller_params(self, base: Params | None = None) -> Params:
        """Controller internal-model parameters (``base`` with :attr:`ctrl_changes`)."""
        return CONTROLLER_CHANGES.apply(base or load_params(), self.ctrl_changes)

    def attitude_reference(self, periods: tuple[int, int] | None = None
                           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``q, dq, ddq`` (N, 4) sampled at the control instants (analytic derivatives)."""
        t = self.time(periods)
        return attitude_reference(self.attitude, t)

    def velocity_reference(self, periods: tuple[int, int] | None = None) -> np.ndarray:
        """``[vx, vy, yaw_rate]`` (N, 3) at the control instants."""
        t = self.time(periods)
        if not self.velocity_keyframes:
            return np.zeros((t.size, 3))
        return R.velocity_profile(t, self.velocity_keyframes).value

    def disturbance(self, periods: tuple[int, int] | None = None) -> np.ndarray:
        """Per-period disturbance ``w`` (N, 6, :data:`~ballbot_casadi.core.layout.DISTURBANCE`):
        attitude jumps (rotation vectors) and wheel-torque disturbances."""
        k0, k1 = self.window(periods)
        w = np.zeros((k1 - k0, DISTURBANCE.size))
        for t, roll, pitch, yaw in self.pushes:
            k = min(int(round(t / self.Ts)), self.n_periods - 1)
            if k0 <= k < k1:
                q = Q.from_rpy(math.radians(roll), math.radians(pitch), math.radians(yaw))
                w[k - k0, DISTURBANCE["push"]] += Q.to_rotation_vector(q)
        t = self.time(periods)
        for t0, t1, *tau in self.torque_disturbances:
            w[(t >= t0 - 1e-12) & (t < t1 - 1e-12), DISTURBANCE["tau_dist"]] += tau
        return w

    def default_k_bal(self, p_ctrl: np.ndarray) -> np.ndarray:
        """The balance controller's default gains for this scenario's period (the balance
        LQR designed on the controller model ``p_ctrl`` linearised at the balance point)."""
        linear = None
        if self.controller in LINEAR_DESIGNED:
            linear = linearize(Params.from_vector(p_ctrl), functions=make_model_functions())
        return default_balance_gains(self.controller, linear, self.Ts)

    def diag_names(self) -> tuple[str, ...]:
        """Names of the balance controller's diagnostic outputs."""
        return tuple(BALANCE_DIAG_NAMES)

    def inputs(self, base: Params | None = None, periods: tuple[int, int] | None = None) -> dict[str, Any]:
        """Keyword arguments of :meth:`~ballbot_casadi.sim.closed_loop.ClosedLoop.simulate`.

        ``periods = (k0, k1)`` gives the sequences of that window only (a long run is
        simulated in segments; the initial values still describe ``t = 0``).
        """

        p_plant = self.plant_params(base).to_vector()
        p_ctrl = self.controller_params(base).to_vector()
        k_bal = np.asarray(self.k_bal, float) if self.k_bal else self.default_k_bal(p_ctrl)
        if self.k_vel:
            k_vel = np.asarray(self.k_vel, float)
        elif self.cascade:
            k_vel = default_velocity_gains(make_jacobians(), p_ctrl, Ts=self.Ts)
        else:  # balance controller alone: the velocity loop is open, no LQR design needed
            k_vel = np.concatenate([np.zeros(VELOCITY_NKV - VELOCITY_DEFAULT_LIMITS.size),
                                    VELOCITY_DEFAULT_LIMITS])
        q, dq, ddq = self.attitude_reference(periods)
        if self.feedforward == "no-rate":
            dq, ddq = np.zeros_like(dq), np.zeros_like(ddq)
        for key, arr in (("q_ref", q), ("dq_ref", dq), ("ddq_ref", ddq)):
            if not np.all(np.isfinite(arr)):
                raise ScenarioError(f"scenario {self.name!r}: {key} contains NaN or Inf")
        x0 = np.asarray(self.x0, float)
        p_ctrl = p_ctrl.copy()  # the limit of the balance loop only, after the gain design
        p_ctrl[_TAU_MAX] = controller_torque_limit(p_ctrl[_TAU_MAX], self.torque_limit)
        return {
            "x0": x0,
            "p_plant": p_plant,
            "p_ctrl": p_ctrl,
            "k_bal": np.asarray(k_bal, float).ravel(),
            "k_vel": np.asarray(k_vel, float).ravel(),
            "z0": np.asarray(velocity_initial_state(x0), float).ravel(),
            "q_ref": q,
            "dq_ref": dq,
            "ddq_ref": ddq,
            "v_ref": self.velocity_reference(periods),
            "w": self.disturbance(periods),
            "Ts": self.Ts,
            "cascade": self.cascade,
            "feedforward": self.feedforward == "exact",
            "com_observer": self.com_observer,
            "k_obs": np.asarray(self.k_obs if self.k_obs else COM_OBSERVER_DEFAULT_GAINS, float),
            "estimator": self.estimator,
            **({"estimation": self.estimation_inputs(base, periods)} if self.estimator != "true" else {}),
        }

    def estimator_params(self, base: Params | None = None) -> Params:
        """The estimators' internal-model parameters (``base`` with :attr:`est_changes`)."""
        return ESTIMATOR_CHANGES.apply(base or load_params(), self.est_changes)

    def sensor_params(self) -> SensorParams:
        """The plant's sensor parameters (defaults with :attr:`sensor_changes`)."""
        return SENSOR_CHANGES.apply(load_sensor_params(), self.sensor_changes)

    def estimation_inputs(self, base: Params | None = None, periods: tuple[int, int] | None = None
                          ) -> dict[str, Any]:
        """The ``estimation`` inputs of :meth:`~ballbot_casadi.sim.closed_loop.ClosedLoop.simulate`.

        Noise rows ``k`` are ``[n_acc, n_gyro, n_rw]`` drawn from the counter-based
        generator of :mod:`ballbot_casadi.core.rng` with this scenario's seed (streams
        :data:`~ballbot_casadi.model.sensors.NOISE_STREAMS`, row = period index), so a
        chunked or restarted run draws the same numbers.
        """
        if self.estimator == "true":
            raise ScenarioError(f"scenario {self.name!r} has no estimator in the loop")
        k0, k1 = self.window(periods)
        n = k1 - k0
        if self.noise:  # the heading sensor's noise has a stream of its own
            rng = NoiseStream(self.seed)
            noise = np.hstack([rng.normal(NOISE_STREAMS[k], n, m, start=k0)
                               for k, m in (("acc", 3), ("gyro", 3), ("gyro_bias_rw", 3),
                                            ("heading", 1))])
        else:
            noise = np.zeros((n, NOISE.size))
        valid = np.ones((n, VALID.size))
        sp = self.sensor_params()
        valid[:, VALID.index("heading")] = (
            heading_schedule(k0, k1, self.Ts, sp.heading_rate[0]) if self.heading_sensor else 0.0)
        if k0 == 0:
            valid[0, VALID.index("enc")] = 0.0  # no previous count to difference at the first sample
        t = self.time(periods)
        for t0, t1, sensor in self.sensor_dropouts:
            valid[(t >= t0 - 1e-12) & (t < t1 - 1e-12), VALID.index(sensor)] = 0.0
        self._add_glitches(noise, sp, k0, k1)
        att, vel = (DEFAULT_TUNING[f] for f in ESTIMATOR_FILTERS[self.estimator])
        cov = {"Qa": np.array(att.Q, float), "Ra": np.array(att.R, float),
               "Qv": np.array(vel.Q, float), "Rv": np.array(vel.R, float)}
        if self.estimator in MATCHED_VELOCITY:  # its calibration; the file's keys set theirs over it
            name, block = ESTIMATOR_TUNING_TARGETS["acc_process_var"]
            cov[name][block, block] = np.diag(MATCHED_ACC_PROCESS_VAR)
        for key in sorted(self.estimator_tuning, key=list(ESTIMATOR_TUNING_TARGETS).index):
            val = self.estimator_tuning[key]  # in the targets' order: per-axis after both axes
            name, block = ESTIMATOR_TUNING_TARGETS[key]
            n = block.stop - block.start
            cov[name][block, block] = np.eye(n) * float(val)
        return {
            "noise": noise,
            "valid": valid,
            "s": sp.to_vector(),
            "p_est": self.estimator_params(base).to_vector(),
            **cov,
            "e0": initial_estimator_state(self.estimator, np.asarray(self.x0, float)),
            "s0": np.concatenate([np.zeros(3), np.asarray(sp.gyro_bias0, float), np.zeros(3)]),
        }

    def _add_glitches(self, noise: np.ndarray, sp: Any, k0: int, k1: int) -> None:
        """Add :attr:`sensor_glitches` to the noise rows of periods ``[k0, k1)`` in place:
        ``value / sqrt(var)`` on the sensor's axis at the period nearest ``t``."""
        for i, (t, sensor, axis, value) in enumerate(self.sensor_glitches):
            k = int(round(t / self.Ts))
            if not k0 <= k < k1:
                continue
            a = GLITCH_AXES.index(axis)
            var = float(np.asarray(getattr(sp, f"{sensor}_noise_var"), float).ravel()[a])
            if not var > 0.0:
                raise ScenarioError(f"scenario {self.name!r}: a {sensor} glitch enters through the "
                                    f"noise input, but {sensor}_noise_var of axis {axis} is "
                                    f"{var:g}; make it positive", key=f"sensor_glitch[{i}]")
            noise[k - k0, NOISE[sensor].start + a] += value / np.sqrt(var)

    # -- serialisation -----------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """JSON-compatible dict of the attributes (round-trips through :meth:`from_dict`)."""
        d = {f: getattr(self, f) for f in SCENARIO_FIELDS}
        return plain_json(d, f"scenario {self.name!r}")

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> "Scenario":
        """Inverse of :meth:`to_dict`."""
        unknown = sorted(set(data) - set(SCENARIO_FIELDS))
        if unknown:
            raise ScenarioError(f"unknown scenario field(s) {unknown}; allowed: {sorted(SCENARIO_FIELDS)}")
        return cls(**dict(data))

    def replace(self, **changes: Any) -> "Scenario":
        """Copy with some fields changed (validated)."""
        return Scenario.from_dict({**self.to_dict(), **changes})

    def to_file(self) -> dict[str, Any]:
        """The scenario as a scenario-file table (friendly units, defaults omitted; read back
        by :func:`~ballbot_casadi.sim.scenario.file.parse_scenario` into an equal scenario)."""
        out: dict[str, Any] = {}
        for s, _ in SCENARIO_SECTIONS:
            out.update(getattr(self, s).to_file())
        return out


def _from_sections(sections: Mapping[str, Any]) -> Scenario:
    return Scenario.from_sections(**sections)


def _section_property(field_name: str) -> property:
    section = _SECTION_OF[field_name]
    return property(lambda self: getattr(getattr(self, section), field_name),
                     doc=f"``{section}.{field_name}`` (see the class docstring).")


for _f in SCENARIO_FIELDS:
    setattr(Scenario, _f, _section_property(_f))
del _f

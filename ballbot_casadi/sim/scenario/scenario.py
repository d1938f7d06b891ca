"""Closed-loop scenarios: a validated, JSON-serialisable description of one simulation run.

A :class:`Scenario` says which balance controller runs (``flc`` thesis ch. 8, ``smc``
the V2019 baseline of thesis §8.3), whether the velocity loop closes the cascade
(thesis Fig. 7.1) or the balance controller follows an attitude reference alone
(thesis Fig. 8.1), the initial state, the references, pushes, and how the plant and
the controller's internal model deviate from the nominal parameters (thesis §8.4).
:meth:`Scenario.inputs` turns it into the input sequences of
:meth:`ballbot_casadi.sim.closed_loop.ClosedLoop.simulate`.

The thesis experiments built from scenarios are the studies of
:mod:`ballbot_casadi.studies.registry`.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from types import MappingProxyType
from typing import Any, Mapping

import numpy as np

from ballbot_casadi.control import (
    BALANCE_CONTROLLERS,
    BALANCE_DIAG_NAMES,
    VELOCITY_NKV,
    LINEAR_DESIGNED,
    check_gains,
    default_balance_gains,
    default_velocity_gains,
    velocity_initial_state,
)
from ballbot_casadi.control.velocity import VELOCITY_DEFAULT_LIMITS
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.constants import N_SUB, TS_CONTROL
from ballbot_casadi.core.layout import DISTURBANCE
from ballbot_casadi.core.params import Params, load_params
from ballbot_casadi.core.rng import NoiseStream
from ballbot_casadi.core.sensor_params import SensorParams, load_sensor_params
from ballbot_casadi.core.validation import check_state
from ballbot_casadi.errors import ArgumentError, ScenarioError
from ballbot_casadi.estimation import DEFAULT_TUNING
from ballbot_casadi.estimation.com_observer import COM_OBSERVER_DEFAULT_GAINS, check_com_observer_gains
from ballbot_casadi.model.dynamics import make_jacobians, make_model_functions
from ballbot_casadi.model.linearization import linearize
from ballbot_casadi.model.sensors import NOISE_STREAMS
from ballbot_casadi.sim import references as R
from ballbot_casadi.sim.scenario.changes import ParamChanges
from ballbot_casadi.sim.scenario.signals import attitude_reference, check_attitude
from ballbot_casadi.sim.embedded import (
    ESTIMATOR_FILTERS,
    NOISE,
    VALID,
    initial_estimator_state,
)

__all__ = [
    "Scenario",
    "FEEDFORWARD_MODES",
    "ESTIMATOR_CHOICES",
    "ESTIMATOR_TUNING_KEYS",
    "ESTIMATOR_TUNING_TARGETS",
    "initial_state",
    "PLANT_CHANGES",
    "CONTROLLER_CHANGES",
    "ESTIMATOR_CHANGES",
    "SENSOR_CHANGES",
]

#: Balance-controller feed-forward of the reference acceleration: exact, or none (thesis mode).
FEEDFORWARD_MODES = ("exact", "none")
#: What the controllers read: the true state, or estimates from noisy sensors.
ESTIMATOR_CHOICES = ("true", "ukf", "ekf")
#: Scenario.estimator_tuning keys (changes to the filters' default tuning): the covariance
#: input each sets and the diagonal block of it (the value times the identity).
ESTIMATOR_TUNING_TARGETS: Mapping[str, tuple[str, slice]] = MappingProxyType({
    "rate_process_var": ("Qa", slice(3, 6)),      # QUKF body rate (tangent [rotation, omega])
    "encoder_var": ("Rv", slice(0, 3)),           # VUKF encoder ticks
    "acc_process_var": ("Qv", slice(2, 4)),       # VUKF ball acceleration
    "acc_bias_process_var": ("Qv", slice(4, 7)),  # VUKF accelerometer bias
})
#: Keys of Scenario.estimator_tuning.
ESTIMATOR_TUNING_KEYS = tuple(ESTIMATOR_TUNING_TARGETS)


#: The four parameter-change sections of a scenario (file table names as error keys).
PLANT_CHANGES = ParamChanges("plant")
CONTROLLER_CHANGES = ParamChanges("controller_model")
ESTIMATOR_CHANGES = ParamChanges("estimator_model")
SENSOR_CHANGES = ParamChanges("sensors", sensors=True)


def initial_state(roll_deg: float = 0.0, pitch_deg: float = 0.0, yaw_deg: float = 0.0) -> tuple:
    """Upright-at-rest state rotated by ZYX angles in degrees, as a 12-tuple."""
    q = Q.from_rpy(math.radians(roll_deg), math.radians(pitch_deg), math.radians(yaw_deg))
    return tuple(float(v) for v in np.concatenate([[0.0, 0.0], q, np.zeros(6)]))


@dataclass(frozen=True)
class Scenario:
    """One closed-loop run.

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
        predecessor's EKFs).
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
        period, (m/s^2)^2, the predecessor's 1e-5) and ``acc_bias_process_var`` (the velocity
        filter's accelerometer-bias
        process noise per period, (m/s^2)^2, the predecessor's 1e-9; it sets how fast
        the velocity-aided tilt correction follows the attitude filter's slow error,
        :mod:`~ballbot_casadi.estimation.tilt_aiding`).
    sensor_dropouts
        Rows ``(t_start, t_end, sensor)`` with sensor ``"acc"``, ``"gyro"`` or ``"enc"``:
        that sensor's readings are missing (NaN) in the periods starting in
        ``[t_start, t_end)``; the filters predict only for it.
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

    name: str
    controller: str = "flc"
    duration: float = 5.0
    x0: tuple = field(default_factory=initial_state)
    cascade: bool = False
    attitude: Mapping[str, Any] = field(default_factory=dict)
    velocity_keyframes: tuple = ()
    pushes: tuple = ()
    torque_disturbances: tuple = ()
    plant_changes: Mapping[str, Any] = field(default_factory=dict)
    ctrl_changes: Mapping[str, Any] = field(default_factory=dict)
    k_bal: tuple = ()
    k_vel: tuple = ()
    Ts: float = TS_CONTROL
    n_sub: int = N_SUB
    feedforward: str = "exact"
    estimator: str = "true"
    seed: int = 0
    noise: bool = True
    sensor_changes: Mapping[str, Any] = field(default_factory=dict)
    est_changes: Mapping[str, Any] = field(default_factory=dict)
    estimator_tuning: Mapping[str, Any] = field(default_factory=dict)
    sensor_dropouts: tuple = ()
    com_observer: bool = False
    k_obs: tuple = ()
    study: str = ""
    description: str = ""

    def __post_init__(self) -> None:
        try:
            self._validate()
        except ScenarioError as exc:
            raise exc.within(f"scenario {self.name!r}") from None

    def _validate(self) -> None:
        """Check every field; each error is a :class:`ScenarioError` keyed by the file key."""
        if self.controller not in BALANCE_CONTROLLERS:
            raise ScenarioError(f"unknown controller {self.controller!r}; allowed: "
                                f"{', '.join(BALANCE_CONTROLLERS)}", key="controller")
        if self.k_bal:
            _argument(check_gains, "gains.k_bal", self.controller, self.k_bal)
        if self.k_vel and len(self.k_vel) != VELOCITY_NKV:
            raise ScenarioError(f"k_vel needs {VELOCITY_NKV} entries, got {len(self.k_vel)}", key="gains.k_vel")
        for name, key in (("duration", "duration_s"), ("Ts", "control_period_s")):
            v = getattr(self, name)
            if not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise ScenarioError(f"{name} must be a finite number > 0, got {v!r}", key=key)
        if round(self.duration / self.Ts) < 1:
            raise ScenarioError(f"duration shorter than one control period ({self.Ts:g} s)", key="duration_s")
        if not _is_int(self.n_sub) or self.n_sub < 1:
            raise ScenarioError(f"n_sub must be an int >= 1, got {self.n_sub!r}", key="rk4_substeps")
        for name, allowed in (("feedforward", FEEDFORWARD_MODES), ("estimator", ESTIMATOR_CHOICES)):
            if getattr(self, name) not in allowed:
                raise ScenarioError(f"{name} {getattr(self, name)!r} unknown; allowed: {', '.join(allowed)}",
                                    key=name)
        if not _is_int(self.seed) or not 0 <= self.seed < 2**32:
            raise ScenarioError(f"seed must be an int in [0, 2^32), got {self.seed!r}", key="seed")
        for name in ("noise", "com_observer", "cascade"):
            if not isinstance(getattr(self, name), bool):
                raise ScenarioError(f"{name} must be true or false, got {getattr(self, name)!r}", key=name)
        if self.k_obs:
            _argument(check_com_observer_gains, "gains.k_obs", self.k_obs)
        drops = []
        for i, row in enumerate(self.sensor_dropouts):
            ok = (isinstance(row, (list, tuple)) and len(row) == 3 and row[2] in VALID.fields
                  and all(isinstance(v, (int, float)) and math.isfinite(v) for v in row[:2])
                  and 0 <= row[0] < row[1])
            if not ok:
                raise ScenarioError(f"sensor dropout {row!r} must be (t_start, t_end, sensor) "
                                    f"with 0 <= t_start < t_end and sensor in {VALID.fields}",
                                    key=f"sensor_dropout[{i}]")
            drops.append((float(row[0]), float(row[1]), str(row[2])))
        object.__setattr__(self, "sensor_dropouts", tuple(drops))
        for key, val in self.estimator_tuning.items():
            if key not in ESTIMATOR_TUNING_KEYS:
                raise ScenarioError(f"estimator_tuning key {key!r} unknown; allowed: "
                                    f"{', '.join(ESTIMATOR_TUNING_KEYS)}", key=f"estimator_tuning.{key}")
            if not isinstance(val, (int, float)) or isinstance(val, bool) or not math.isfinite(val) or val <= 0:
                raise ScenarioError(f"estimator_tuning {key} must be a finite number > 0, got {val!r}",
                                    key=f"estimator_tuning.{key}")
        SENSOR_CHANGES.check(self.sensor_changes)
        object.__setattr__(self, "x0", tuple(float(v) for v in check_state(self.x0, "initial state x0")))
        check_attitude(self.attitude, self.Ts)
        for name, key in (("velocity_keyframes", "velocity"), ("pushes", "push"),
                          ("torque_disturbances", "torque_disturbance"), ("k_bal", "gains.k_bal"),
                          ("k_vel", "gains.k_vel"), ("k_obs", "gains.k_obs")):
            arr = np.asarray(getattr(self, name), dtype=float)
            if not np.all(np.isfinite(arr)):
                raise ScenarioError(f"{name} contains NaN or Inf", key=key)
            object.__setattr__(self, name, _freeze(getattr(self, name)))
        for i, row in enumerate(self.pushes):
            if len(row) != 4 or not 0 <= row[0] < self.duration:
                raise ScenarioError(f"push {row!r} must be (t, roll_deg, pitch_deg, yaw_deg) with "
                                    f"0 <= t < duration", key=f"push[{i}]")
        for i, row in enumerate(self.torque_disturbances):
            if len(row) != 5 or not 0 <= row[0] < row[1]:
                raise ScenarioError(f"torque disturbance {row!r} must be (t_start, t_end, tau0, tau1, "
                                    f"tau2) with 0 <= t_start < t_end", key=f"torque_disturbance[{i}]")
        if self.velocity_keyframes:
            _argument(R.velocity_profile, "velocity", np.zeros(1), self.velocity_keyframes)
        PLANT_CHANGES.check(self.plant_changes)
        CONTROLLER_CHANGES.check(self.ctrl_changes)
        ESTIMATOR_CHANGES.check(self.est_changes)

    # -- derived quantities ------------------------------------------------------------
    @property
    def n_periods(self) -> int:
        """Number of control periods."""
        return int(round(self.duration / self.Ts))

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
        for key, arr in (("q_ref", q), ("dq_ref", dq), ("ddq_ref", ddq)):
            if not np.all(np.isfinite(arr)):
                raise ScenarioError(f"scenario {self.name!r}: {key} contains NaN or Inf")
        x0 = np.asarray(self.x0, float)
        return {
            "x0": x0,
            "p_plant": p_plant,
            "p_ctrl": p_ctrl,
            "k_bal": np.asarray(k_bal, float).reshape(-1),
            "k_vel": np.asarray(k_vel, float).reshape(-1),
            "z0": np.asarray(velocity_initial_state(x0), float).reshape(-1),
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
        if self.noise:
            rng = NoiseStream(self.seed)
            noise = np.hstack([rng.normal(NOISE_STREAMS[k], n, 3, start=k0)
                               for k in ("acc", "gyro", "gyro_bias_rw")])
        else:
            noise = np.zeros((n, NOISE.size))
        valid = np.ones((n, VALID.size))
        if k0 == 0:
            valid[0, VALID.index("enc")] = 0.0  # no previous count to difference at the first sample
        t = self.time(periods)
        for t0, t1, sensor in self.sensor_dropouts:
            valid[(t >= t0 - 1e-12) & (t < t1 - 1e-12), VALID.index(sensor)] = 0.0
        sp = self.sensor_params()
        att, vel = (DEFAULT_TUNING[f] for f in ESTIMATOR_FILTERS[self.estimator])
        cov = {"Qa": np.array(att.Q, float), "Ra": np.array(att.R, float),
               "Qv": np.array(vel.Q, float), "Rv": np.array(vel.R, float)}
        for key, val in self.estimator_tuning.items():
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

    # -- serialisation -----------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """JSON-compatible dict (round-trips through :meth:`from_dict`)."""
        d = asdict(self)
        return json.loads(json.dumps(d, default=_jsonable))

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> "Scenario":
        """Inverse of :meth:`to_dict`."""
        allowed = {f for f in cls.__dataclass_fields__}
        unknown = sorted(set(data) - allowed)
        if unknown:
            raise ScenarioError(f"unknown scenario field(s) {unknown}; allowed: {sorted(allowed)}")
        return cls(**dict(data))

    def replace(self, **changes: Any) -> "Scenario":
        """Copy with some fields changed (validated)."""
        return Scenario.from_dict({**self.to_dict(), **changes})


def _is_int(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _argument(check: Any, key: str, *args: Any) -> Any:
    """``check(*args)``; a library's :class:`ArgumentError` becomes a keyed :class:`ScenarioError`."""
    try:
        return check(*args)
    except ScenarioError as exc:
        raise ScenarioError(str(exc), key=exc.key or key, reason=exc.reason) from None
    except ArgumentError as exc:
        raise ScenarioError(str(exc), key=key) from None


def _freeze(value: Any) -> Any:
    if isinstance(value, (list, tuple, np.ndarray)):
        return tuple(_freeze(v) for v in value)
    return float(value)


def _jsonable(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    if isinstance(obj, Mapping):
        return dict(obj)
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")

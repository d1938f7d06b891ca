"""The sections of a scenario, mirroring the scenario file: each owns its keys once.

A :class:`~ballbot_casadi.sim.scenario.scenario.Scenario` is composed of these sections;
a scenario file (:mod:`ballbot_casadi.sim.scenario.file`) is read and written through
them.  Each section owns

* its fields in the scenario's units (:attr:`FIELDS`, the names of the ``Scenario``
  attributes it holds) and the file keys they come from (:attr:`TABLE_KEYS`, friendly
  units in the key names);
* its validation in scenario units (:meth:`check`, a :class:`ScenarioError` keyed by the
  file key), given the run section for the quantities every section may need (control
  period, duration, controller);
* its TOML round trip: ``from_file(checker, table, ...)`` reads the section's part of a
  file table (a :class:`ScenarioFileError` naming the file and key), ``to_file()`` writes
  it back (defaults omitted), so ``from_file(to_file(s)) == s``.

Sections: :class:`RunSection` (the top-level keys), :class:`InitialSection`,
:class:`ReferencesSection`, :class:`DisturbancesSection`, :class:`ModelSection`
(plant and controller model changes), :class:`SensorsSection`,
:class:`EstimationSection`, :class:`ObserverSection`, :class:`GainsSection`; the file's
``[[spec]]`` rows are :class:`SpecsSection` and its ``[montecarlo]`` table is
:class:`~ballbot_casadi.sim.scenario.dispersions.DispersionsSection`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Callable, Mapping

import numpy as np

from ballbot_casadi.control import BALANCE_CONTROLLERS, VELOCITY_NKV, check_gains
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.constants import N_SUB, TS_CONTROL
from ballbot_casadi.core.layout import VELOCITY_FILTER_STATE as XV
from ballbot_casadi.core.params import PARAM_NAMES
from ballbot_casadi.core.safe_paths import name_problem
from ballbot_casadi.core.specs import SPEC_OPS
from ballbot_casadi.core.validation import check_state
from ballbot_casadi.errors import ArgumentError, ScenarioError
from ballbot_casadi.estimation.attitude import ATTITUDE_NOISE
from ballbot_casadi.estimation.com_observer import check_com_observer_gains
from ballbot_casadi.estimation.velocity import VELOCITY_MEAS
from ballbot_casadi.sim import references as R
from ballbot_casadi.sim.embedded import VALID
from ballbot_casadi.sim.period import TORQUE_LIMIT_MODES
from ballbot_casadi.sim.ports import GAIN_CONSTANTS
from ballbot_casadi.sim.scenario.changes import ParamChanges
from ballbot_casadi.sim.scenario.checker import FileChecker
from ballbot_casadi.sim.scenario.path_section import PathSection
from ballbot_casadi.sim.scenario.signals import (
    attitude_reference,
    check_attitude,
    signal_from_file,
    signal_to_file,
)

__all__ = [
    "MAX_PERIODS", "TORQUE_DISTURBANCE_MAX_NM", "FEEDFORWARD_MODES", "ESTIMATOR_CHOICES", "ESTIMATOR_TUNING_TARGETS", "ESTIMATOR_TUNING_KEYS",
    "PLANT_CHANGES", "CONTROLLER_CHANGES", "ESTIMATOR_CHANGES", "SENSOR_CHANGES",
    "initial_state", "RunSection", "InitialSection", "ReferencesSection", "DisturbancesSection",
    "GLITCH_AXES", "GLITCH_SENSORS", "ModelSection", "SensorsSection", "EstimationSection", "ObserverSection", "GainsSection",
    "SpecsSection", "DispersionsSection", "DISPERSION_TARGETS", "SCENARIO_SECTIONS",
]

#: Balance-controller feed-forward of the reference acceleration: exact, or none (thesis mode).
FEEDFORWARD_MODES = ("exact", "none", "no-rate")
#: What the controllers read: the true state, or estimates from noisy sensors.
ESTIMATOR_CHOICES = ("true", "ukf", "ekf", "ukf_heading", "ekf_heading", "ukf_consistent",
                     "ukf_adaptive")
#: Scenario.estimator_tuning keys (changes to the filters' default tuning): the covariance
#: input each sets and the diagonal block of it (the value times the identity).
ESTIMATOR_TUNING_TARGETS: Mapping[str, tuple[str, slice]] = MappingProxyType({
    "rate_process_var": ("Qa", ATTITUDE_NOISE["omega"]),   # QUKF body rate
    "encoder_var": ("Rv", VELOCITY_MEAS["enc"]),           # VUKF encoder ticks
    "acc_process_var": ("Qv", XV["a"]),                    # VUKF ball acceleration
    "acc_process_var_x": ("Qv", slice(XV["a"].start, XV["a"].start + 1)),  # x only
    "acc_process_var_y": ("Qv", slice(XV["a"].start + 1, XV["a"].stop)),   # y only
    "acc_bias_process_var": ("Qv", XV["b_acc"]),           # VUKF accelerometer bias
})
#: Keys of Scenario.estimator_tuning.
ESTIMATOR_TUNING_KEYS = tuple(ESTIMATOR_TUNING_TARGETS)

#: The four parameter-change tables of a scenario (file table names as error keys).
PLANT_CHANGES = ParamChanges("plant")
CONTROLLER_CHANGES = ParamChanges("controller_model")
ESTIMATOR_CHANGES = ParamChanges("estimator_model")
SENSOR_CHANGES = ParamChanges("sensors", sensors=True)

_INITIAL = ("roll_deg", "pitch_deg", "yaw_deg", "x_m", "y_m", "vx_mps", "vy_mps", "on_reference")
_SPEC_KEYS = ("metric", "op", "threshold", "source", "thesis")
#: Initial-state quantities a Monte Carlo dispersion may target (besides ``plant.<name>``).
DISPERSION_TARGETS = ("initial.roll_deg", "initial.pitch_deg", "initial.yaw_deg", "initial.x_m",
                      "initial.y_m", "path.waypoint_y_m", "obstacle.x_m", "obstacle.y_m")
_DISTS = ("normal", "uniform")


def initial_state(roll_deg: float = 0.0, pitch_deg: float = 0.0, yaw_deg: float = 0.0) -> tuple:
    """Upright-at-rest state rotated by ZYX angles in degrees, as a 12-tuple."""
    q = Q.from_rpy(math.radians(roll_deg), math.radians(pitch_deg), math.radians(yaw_deg))
    return tuple(float(v) for v in np.concatenate([[0.0, 0.0], q, np.zeros(6)]))


def _is_int(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _argument(check: Callable[..., Any], key: str, *args: Any) -> Any:
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


def _frozen(section: Any, name: str, key: str) -> None:
    """Check a numeric field for NaN/Inf and store it as nested tuples of floats (rows may
    differ in length: each section checks its own rows)."""
    value = getattr(section, name)
    try:
        frozen = _freeze(value)
    except (TypeError, ValueError):
        raise ScenarioError(f"{name} must hold numbers only, got {value!r}", key=key) from None
    if not np.all(np.isfinite(np.asarray(_flat(frozen), dtype=float))):
        raise ScenarioError(f"{name} contains NaN or Inf", key=key)
    object.__setattr__(section, name, frozen)


def _flat(value: Any) -> list[float]:
    return [w for v in value for w in _flat(v)] if isinstance(value, tuple) else [value]


def _set(section: Any, name: str, value: Any) -> None:
    object.__setattr__(section, name, value)


#: Most control periods one run may have (``duration_s / control_period_s``): one hour at
#: the thesis's 5 ms period, whose log is held in memory.
MAX_PERIODS = 720_000
#: Largest wheel torque disturbance (N m) a scenario may add: ten times the motors'
#: maximum torque (``tau_max`` = 1.98 N m, default_params.toml).
TORQUE_DISTURBANCE_MAX_NM = 20.0


# --------------------------------------------------------------------------- the run


@dataclass(frozen=True)
class RunSection:
    """The run: its name, controller structure, length and time steps (top-level keys).

    ``duration`` and ``Ts`` in s (file ``duration_s``, ``control_period_s``), ``n_sub``
    RK4 sub-steps per period (``rk4_substeps``); ``cascade`` closes the velocity loop
    (thesis Fig. 7.1); ``feedforward`` ``exact``, ``none`` (thesis mode: zero reference
    acceleration) or ``no-rate`` (neither rate nor acceleration, thesis §7.2 item 5);
    ``torque_limit`` ``direction`` (ours: the controller scales its three torques together
    at its ``tau_max``) or ``per-wheel`` (the thesis's set-up, §9.1: only the motors'
    per-wheel saturation), :mod:`~ballbot_casadi.sim.period` step 5.
    """

    name: str = "scenario"
    controller: str = "flc"
    duration: float = 5.0
    cascade: bool = False
    Ts: float = TS_CONTROL
    n_sub: int = N_SUB
    feedforward: str = "exact"
    torque_limit: str = "direction"
    study: str = ""
    description: str = ""

    FIELDS = ("name", "controller", "duration", "cascade", "Ts", "n_sub", "feedforward",
              "torque_limit", "study", "description")
    #: Field -> file key.
    FILE = MappingProxyType({"name": "name", "description": "description", "study": "study",
                             "controller": "controller", "duration": "duration_s", "cascade": "cascade",
                             "feedforward": "feedforward", "torque_limit": "torque_limit",
                             "Ts": "control_period_s",
                             "n_sub": "rk4_substeps"})
    TABLE_KEYS = tuple(FILE.values())

    @property
    def n_periods(self) -> int:
        """Number of control periods."""
        return int(round(self.duration / self.Ts))

    def check(self, run: "RunSection") -> None:
        if self.controller not in BALANCE_CONTROLLERS:
            raise ScenarioError(f"unknown controller {self.controller!r}; allowed: "
                                f"{', '.join(BALANCE_CONTROLLERS)}", key="controller")
        for name, key in (("duration", "duration_s"), ("Ts", "control_period_s")):
            v = getattr(self, name)
            if not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise ScenarioError(f"{name} must be a finite number > 0, got {v!r}", key=key)
        if round(self.duration / self.Ts) < 1:
            raise ScenarioError(f"duration shorter than one control period ({self.Ts:g} s)", key="duration_s")
        if not _is_int(self.n_sub) or self.n_sub < 1:
            raise ScenarioError(f"n_sub must be an int >= 1, got {self.n_sub!r}", key="rk4_substeps")
        if self.feedforward not in FEEDFORWARD_MODES:
            raise ScenarioError(f"feedforward {self.feedforward!r} unknown; allowed: "
                                f"{', '.join(FEEDFORWARD_MODES)}", key="feedforward")
        if self.torque_limit not in TORQUE_LIMIT_MODES:
            raise ScenarioError(f"torque_limit {self.torque_limit!r} unknown; allowed: "
                                f"{', '.join(TORQUE_LIMIT_MODES)}", key="torque_limit")
        if not isinstance(self.cascade, bool):
            raise ScenarioError(f"cascade must be true or false, got {self.cascade!r}", key="cascade")

    @classmethod
    def from_file(cls, c: FileChecker, table: Mapping[str, Any], default_name: str) -> "RunSection":
        name = c.text(table, "name", "name", default_name) or default_name
        if (problem := name_problem(name)) is not None:  # the name becomes file names (montecarlo worst/)
            raise c.fail("name", problem)
        Ts = c.num(table, "control_period_s", "control_period_s", 0.005, lo=0.0, lo_open=True, hi=0.1)
        duration = c.num(table, "duration_s", "duration_s", lo=0.0, lo_open=True, hi=3600.0)
        if round(duration / Ts) < 1:
            raise c.fail("duration_s", f"shorter than one control period ({Ts:g} s)")
        if round(duration / Ts) > MAX_PERIODS:  # the log of every period is held in memory
            raise c.fail("duration_s", f"{duration:g} s at control_period_s = {Ts:g} s is "
                         f"{round(duration / Ts)} periods, more than {MAX_PERIODS}; shorten the run "
                         "or lengthen the period")
        n_sub = c.integer(table, "rk4_substeps", "rk4_substeps", 5, 1)
        if n_sub > 100:
            raise c.fail("rk4_substeps", f"at most 100, got {n_sub}")
        return cls(name=name, duration=duration, Ts=Ts, n_sub=n_sub,
                   controller=c.choice(table, "controller", "controller", "flc", tuple(BALANCE_CONTROLLERS)),
                   cascade=c.boolean(table, "cascade", "cascade", False),
                   feedforward=c.choice(table, "feedforward", "feedforward", "exact", FEEDFORWARD_MODES),
                   torque_limit=c.choice(table, "torque_limit", "torque_limit", "direction",
                                         TORQUE_LIMIT_MODES),
                   study=c.text(table, "study", "study"),
                   description=c.text(table, "description", "description"))

    def to_file(self) -> dict[str, Any]:
        out = {}
        for name, key in self.FILE.items():
            value = getattr(self, name)
            if name in ("name", "duration") or value != self.__dataclass_fields__[name].default:
                out[key] = value
        return out


# --------------------------------------------------------------------------- initial state


@dataclass(frozen=True)
class InitialSection:
    """The initial plant state ``x0`` (12 numbers, unit quaternion); file ``[initial]``:
    ZYX Euler angles in degrees, ball position (m) and velocity (m/s), or
    ``on_reference`` (start on the attitude reference's angle and rate at t = 0).

    ``written`` is the ``[initial]`` table the state was read from (written back as
    read); a state set in code is written as angles, position and velocity (at rest:
    body rates other than zero cannot be written).
    """

    x0: tuple = field(default_factory=initial_state)
    written: Mapping[str, Any] | None = field(default=None, compare=False, repr=False)

    FIELDS = ("x0",)
    TABLE_KEYS = ("initial",)

    def check(self, run: RunSection) -> None:
        _set(self, "x0", tuple(float(v) for v in check_state(self.x0, "initial state x0")))

    @classmethod
    def from_file(cls, c: FileChecker, table: Mapping[str, Any], attitude: Mapping[str, Any]) -> "InitialSection":
        written = c.keys(table.get("initial", {}), "initial", _INITIAL)
        ang = {k: c.num(written, k, f"initial.{k}", 0.0, lo=-180.0, hi=180.0)
               for k in ("roll_deg", "pitch_deg", "yaw_deg")}
        if abs(ang["pitch_deg"]) >= 90.0:
            raise c.fail("initial.pitch_deg", "must be within (-90, 90) deg (ZYX Euler angles)")
        pos = {k: c.num(written, k, f"initial.{k}", 0.0) for k in ("x_m", "y_m", "vx_mps", "vy_mps")}
        for k in ("vx_mps", "vy_mps"):
            if abs(pos[k]) > 10.0:
                raise c.fail(f"initial.{k}", f"{pos[k]:g} m/s is not a ballbot speed (|v| <= 10 m/s)")
        on_ref = c.boolean(written, "on_reference", "initial.on_reference", False)
        x0 = np.array(initial_state(ang["roll_deg"], ang["pitch_deg"], ang["yaw_deg"]))
        if on_ref:
            q, dq, _ = attitude_reference(attitude, np.zeros(1))
            x0[2:6], x0[8:12] = q[0], dq[0]
        x0[0], x0[1], x0[6], x0[7] = pos["x_m"], pos["y_m"], pos["vx_mps"], pos["vy_mps"]
        return cls(tuple(float(v) for v in x0), written)

    def to_file(self) -> dict[str, Any]:
        if self.written is not None:
            return {"initial": dict(self.written)} if self.written else {}
        x = self.x0
        if any(x[8:12]):
            raise ScenarioError("an initial state with body rates cannot be written to a file "
                                "(only through [initial] on_reference)", key="initial")
        rpy = np.degrees(Q.to_rpy(np.array(x[2:6])))
        values = dict(zip(_INITIAL[:7], (*(float(v) for v in rpy), x[0], x[1], x[6], x[7])))
        table = {k: v for k, v in values.items() if v != 0.0}
        return {"initial": table} if table else {}


# --------------------------------------------------------------------------- references


@dataclass(frozen=True)
class ReferencesSection:
    """The references: ``attitude`` ``{axis: signal}`` (angles in degrees, file
    ``[attitude.<axis>]``, :mod:`~ballbot_casadi.sim.scenario.signals`) and
    ``velocity_keyframes`` rows ``(t_start, vx, vy, yaw_rate[, accel])`` in s, m/s, rad/s,
    m/s^2 (file ``[[velocity]]``, cascade only)."""

    attitude: Mapping[str, Any] = field(default_factory=dict)
    velocity_keyframes: tuple = ()

    FIELDS = ("attitude", "velocity_keyframes")
    TABLE_KEYS = ("attitude", "velocity")
    _VELOCITY = ("t_s", "vx_mps", "vy_mps", "yaw_rate_rps", "accel_mps2")

    def check(self, run: RunSection) -> None:
        check_attitude(self.attitude, run.Ts)
        if run.cascade and self.attitude:
            axis = sorted(self.attitude)[0]
            raise ScenarioError("an attitude reference is ignored with cascade = true (the velocity "
                                "controller makes the attitude reference); drop it or set cascade = "
                                "false", key=f"attitude.{axis}")
        _frozen(self, "velocity_keyframes", "velocity")
        if self.velocity_keyframes:
            _argument(R.velocity_profile, "velocity", np.zeros(1), self.velocity_keyframes)

    @classmethod
    def from_file(cls, c: FileChecker, table: Mapping[str, Any], run: RunSection) -> "ReferencesSection":
        att_table = c.keys(table.get("attitude", {}), "attitude", ("roll", "pitch", "yaw"))
        attitude = {ax: c.keyed(signal_from_file, ax, spec, run.Ts) for ax, spec in att_table.items()}
        keyframes = []
        for i, row in enumerate(c.rows(table, "velocity")):
            key = f"velocity[{i}]"
            c.keys(row, key, cls._VELOCITY, ("t_s",))
            kf = [c.num(row, "t_s", f"{key}.t_s", lo=0.0), c.num(row, "vx_mps", f"{key}.vx_mps", 0.0),
                  c.num(row, "vy_mps", f"{key}.vy_mps", 0.0),
                  c.num(row, "yaw_rate_rps", f"{key}.yaw_rate_rps", 0.0)]
            if "accel_mps2" in row:
                kf.append(c.num(row, "accel_mps2", f"{key}.accel_mps2", lo=0.0, lo_open=True))
            keyframes.append(tuple(kf))
        if keyframes:
            try:
                R.velocity_profile(np.zeros(1), keyframes)
            except ScenarioError as exc:
                raise c.fail("velocity", str(exc)) from None
        return cls(attitude, tuple(keyframes))

    def to_file(self) -> dict[str, Any]:
        out: dict[str, Any] = {}
        if self.attitude:
            out["attitude"] = {ax: signal_to_file(sig) for ax, sig in self.attitude.items()}
        if self.velocity_keyframes:
            out["velocity"] = [dict(zip(self._VELOCITY, row)) for row in self.velocity_keyframes]
        return out


# --------------------------------------------------------------------------- disturbances


@dataclass(frozen=True)
class DisturbancesSection:
    """Disturbances of the plant: ``pushes`` rows ``(t, roll_deg, pitch_deg, yaw_deg)``
    (attitude jumps, thesis §8.4.3; file ``[[push]]``) and ``torque_disturbances`` rows
    ``(t_start, t_end, tau0, tau1, tau2)`` in s and N m (file ``[[torque_disturbance]]``)."""

    pushes: tuple = ()
    torque_disturbances: tuple = ()

    FIELDS = ("pushes", "torque_disturbances")
    TABLE_KEYS = ("push", "torque_disturbance")
    _PUSH = ("t_s", "roll_deg", "pitch_deg", "yaw_deg")

    def check(self, run: RunSection) -> None:
        _frozen(self, "pushes", "push")
        _frozen(self, "torque_disturbances", "torque_disturbance")
        for i, row in enumerate(self.pushes):
            if len(row) != 4 or not 0 <= row[0] < run.duration:
                raise ScenarioError(f"push {row!r} must be (t, roll_deg, pitch_deg, yaw_deg) with "
                                    f"0 <= t < duration", key=f"push[{i}]")
        for i, row in enumerate(self.torque_disturbances):
            if len(row) != 5 or not 0 <= row[0] < row[1]:
                raise ScenarioError(f"torque disturbance {row!r} must be (t_start, t_end, tau0, tau1, "
                                    f"tau2) with 0 <= t_start < t_end", key=f"torque_disturbance[{i}]")

    @classmethod
    def from_file(cls, c: FileChecker, table: Mapping[str, Any], run: RunSection) -> "DisturbancesSection":
        pushes = []
        for i, row in enumerate(c.rows(table, "push")):
            key = f"push[{i}]"
            c.keys(row, key, cls._PUSH, ("t_s",))
            t = c.num(row, "t_s", f"{key}.t_s", lo=0.0)
            if t >= run.duration:
                raise c.fail(f"{key}.t_s", f"must be before the end of the run ({run.duration:g} s), got {t:g}")
            pushes.append((t, *(c.num(row, k, f"{key}.{k}", 0.0, lo=-90.0, hi=90.0) for k in cls._PUSH[1:])))
        dists = []
        for i, row in enumerate(c.rows(table, "torque_disturbance")):
            key = f"torque_disturbance[{i}]"
            t0, t1 = c.interval(row, key, "tau_nm")
            tau = c.vector(row, "tau_nm", f"{key}.tau_nm", 3)
            if max(map(abs, tau)) > TORQUE_DISTURBANCE_MAX_NM:
                raise c.fail(f"{key}.tau_nm", f"each torque must be within "
                             f"+-{TORQUE_DISTURBANCE_MAX_NM:g} N m (10x the motors' maximum), "
                             f"got {list(tau)}")
            dists.append((t0, t1, *tau))
        return cls(tuple(pushes), tuple(dists))

    def to_file(self) -> dict[str, Any]:
        out: dict[str, Any] = {}
        if self.pushes:
            out["push"] = [{k: v for j, (k, v) in enumerate(zip(self._PUSH, row)) if j == 0 or v != 0.0}
                           for row in self.pushes]
        if self.torque_disturbances:
            out["torque_disturbance"] = [{"t_start_s": r[0], "t_end_s": r[1], "tau_nm": list(r[2:])}
                                         for r in self.torque_disturbances]
        return out


# --------------------------------------------------------------------------- model changes


def _changes_from_file(c: FileChecker, table: Mapping[str, Any], changes: ParamChanges) -> dict[str, list]:
    return c.keyed(changes.parse, table.get(changes.section, {}))


def _changes_to_file(changes: ParamChanges, values: Mapping[str, Any]) -> dict[str, Any]:
    """``{name: [op, v]}`` as a file table: ``name = v`` for ``set``, else ``{ op = v }``."""
    if not values:
        return {}
    return {changes.section: {k: (v if op == "set" else {op: v}) for k, (op, v) in values.items()}}


@dataclass(frozen=True)
class ModelSection:
    """How the plant (``plant_changes``, file ``[plant]``) and the controller's internal
    model (``ctrl_changes``, file ``[controller_model]``) deviate from the nominal
    parameters (thesis §8.4): ``{param: [op, value]}``, op ``set``/``scale``/``add``."""

    plant_changes: Mapping[str, Any] = field(default_factory=dict)
    ctrl_changes: Mapping[str, Any] = field(default_factory=dict)

    FIELDS = ("plant_changes", "ctrl_changes")
    TABLE_KEYS = ("plant", "controller_model")

    def check(self, run: RunSection) -> None:
        PLANT_CHANGES.check(self.plant_changes)
        CONTROLLER_CHANGES.check(self.ctrl_changes)

    @classmethod
    def from_file(cls, c: FileChecker, table: Mapping[str, Any]) -> "ModelSection":
        return cls(_changes_from_file(c, table, PLANT_CHANGES), _changes_from_file(c, table, CONTROLLER_CHANGES))

    def to_file(self) -> dict[str, Any]:
        return {**_changes_to_file(PLANT_CHANGES, self.plant_changes),
                **_changes_to_file(CONTROLLER_CHANGES, self.ctrl_changes)}


# --------------------------------------------------------------------------- sensors

#: Sensors a ``[[sensor_glitch]]`` row can corrupt: those with a noise input, through which
#: the glitch enters (the encoders count quantised wheel angles and have none).
GLITCH_SENSORS = ("acc", "gyro")
#: Axes of a glitch (IMU frame).
GLITCH_AXES = ("x", "y", "z")


@dataclass(frozen=True)
class SensorsSection:
    """The robot's sensors: parameter changes (``sensor_changes``, file ``[sensors]``,
    vector values allowed), the noise ``seed`` (int in [0, 2^32)) and whether ``noise`` is
    drawn, ``sensor_dropouts`` rows ``(t_start, t_end, sensor)`` in s with sensor
    ``acc``/``gyro``/``enc``/``heading`` (file ``[[sensor_dropout]]``), whether the
    robot carries the heading sensor (``heading_sensor``, off by default: it samples at
    the sensor parameter ``heading_rate``, :func:`~ballbot_casadi.model.sensors.heading_schedule`;
    only ``ukf_heading`` and ``ekf_heading`` read it) and ``sensor_glitches`` rows
    ``(t, sensor, axis, value)``: at the control instant nearest ``t`` (s, in ``[0,
    duration)``) the ``sensor`` (:data:`GLITCH_SENSORS`) reading of ``axis`` (``x``/``y``/``z``
    of the IMU) is off by ``value`` (m/s^2, rad/s; any finite number) - one glitch sample,
    injected through the sensor's noise input (file ``[[sensor_glitch]]``)."""

    sensor_changes: Mapping[str, Any] = field(default_factory=dict)
    seed: int = 0
    noise: bool = True
    sensor_dropouts: tuple = ()
    heading_sensor: bool = False
    sensor_glitches: tuple = ()

    FIELDS = ("sensor_changes", "seed", "noise", "sensor_dropouts", "heading_sensor",
              "sensor_glitches")
    TABLE_KEYS = ("sensors", "seed", "noise", "sensor_dropout", "heading_sensor", "sensor_glitch")

    def check(self, run: RunSection) -> None:
        if not _is_int(self.seed) or not 0 <= self.seed < 2**32:
            raise ScenarioError(f"seed must be an int in [0, 2^32), got {self.seed!r}", key="seed")
        if not isinstance(self.noise, bool):
            raise ScenarioError(f"noise must be true or false, got {self.noise!r}", key="noise")
        if not isinstance(self.heading_sensor, bool):
            raise ScenarioError(f"heading_sensor must be true or false, got "
                                f"{self.heading_sensor!r}", key="heading_sensor")
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
        _set(self, "sensor_dropouts", tuple(drops))
        glitches = []
        for i, row in enumerate(self.sensor_glitches):
            ok = (isinstance(row, (list, tuple)) and len(row) == 4 and row[1] in GLITCH_SENSORS
                  and row[2] in GLITCH_AXES
                  and all(isinstance(row[j], (int, float)) and not isinstance(row[j], bool)
                          and math.isfinite(row[j]) for j in (0, 3))
                  and 0 <= row[0] < run.duration)
            if not ok:
                raise ScenarioError(f"sensor glitch {row!r} must be (t, sensor, axis, value) with "
                                    f"0 <= t < duration ({run.duration:g} s), sensor in "
                                    f"{GLITCH_SENSORS}, axis in {GLITCH_AXES} and a finite value",
                                    key=f"sensor_glitch[{i}]")
            glitches.append((float(row[0]), str(row[1]), str(row[2]), float(row[3])))
        _set(self, "sensor_glitches", tuple(glitches))
        SENSOR_CHANGES.check(self.sensor_changes)

    @classmethod
    def from_file(cls, c: FileChecker, table: Mapping[str, Any]) -> "SensorsSection":
        seed = c.integer(table, "seed", "seed", 0, 0)
        if seed >= 2**32:
            raise c.fail("seed", f"must be below 2^32, got {seed}")
        drops = []
        for i, row in enumerate(c.rows(table, "sensor_dropout")):
            key = f"sensor_dropout[{i}]"
            t0, t1 = c.interval(row, key, "sensor")
            drops.append((t0, t1, c.choice(row, "sensor", f"{key}.sensor", "", VALID.fields)))
        glitches = []
        for i, row in enumerate(c.rows(table, "sensor_glitch")):
            key = f"sensor_glitch[{i}]"
            c.keys(row, key, ("t_s", "sensor", "axis", "value"), ("t_s", "sensor", "value"))
            glitches.append((c.num(row, "t_s", f"{key}.t_s", lo=0.0),
                             c.choice(row, "sensor", f"{key}.sensor", "", GLITCH_SENSORS),
                             c.choice(row, "axis", f"{key}.axis", "x", GLITCH_AXES),
                             c.num(row, "value", f"{key}.value")))
        return cls(_changes_from_file(c, table, SENSOR_CHANGES), seed,
                   c.boolean(table, "noise", "noise", True), tuple(drops),
                   c.boolean(table, "heading_sensor", "heading_sensor", False), tuple(glitches))

    def to_file(self) -> dict[str, Any]:
        out = _changes_to_file(SENSOR_CHANGES, self.sensor_changes)
        if self.seed != 0:
            out["seed"] = self.seed
        if not self.noise:
            out["noise"] = False
        if self.sensor_dropouts:
            out["sensor_dropout"] = [{"t_start_s": t0, "t_end_s": t1, "sensor": s}
                                     for t0, t1, s in self.sensor_dropouts]
        if self.heading_sensor:
            out["heading_sensor"] = True
        if self.sensor_glitches:
            out["sensor_glitch"] = [{"t_s": t, "sensor": s, "axis": a, "value": v}
                                    for t, s, a, v in self.sensor_glitches]
        return out


# --------------------------------------------------------------------------- estimation


@dataclass(frozen=True)
class EstimationSection:
    """What the controllers read: ``estimator`` ``true``/``ukf``/``ekf``/``ukf_heading``/
    ``ekf_heading``/``ukf_consistent`` (the QUKF with the matched velocity filter,
    :data:`~ballbot_casadi.sim.embedded.MATCHED_VELOCITY`)/``ukf_adaptive`` (the same with
    its acceleration random walk adapted online,
    :data:`~ballbot_casadi.sim.embedded.ADAPTIVE_VELOCITY`), the estimators' internal model
    (``est_changes``, file ``[estimator_model]``) and changes to the
    filters' thesis tuning (``estimator_tuning``: variances per period, file
    ``[estimator_tuning]``)."""

    estimator: str = "true"
    est_changes: Mapping[str, Any] = field(default_factory=dict)
    estimator_tuning: Mapping[str, Any] = field(default_factory=dict)

    FIELDS = ("estimator", "est_changes", "estimator_tuning")
    TABLE_KEYS = ("estimator", "estimator_model", "estimator_tuning")

    def check(self, run: RunSection) -> None:
        if self.estimator not in ESTIMATOR_CHOICES:
            raise ScenarioError(f"estimator {self.estimator!r} unknown; allowed: "
                                f"{', '.join(ESTIMATOR_CHOICES)}", key="estimator")
        for key, val in self.estimator_tuning.items():
            if key not in ESTIMATOR_TUNING_KEYS:
                raise ScenarioError(f"estimator_tuning key {key!r} unknown; allowed: "
                                    f"{', '.join(ESTIMATOR_TUNING_KEYS)}", key=f"estimator_tuning.{key}")
            if not isinstance(val, (int, float)) or isinstance(val, bool) or not math.isfinite(val) or val <= 0:
                raise ScenarioError(f"estimator_tuning {key} must be a finite number > 0, got {val!r}",
                                    key=f"estimator_tuning.{key}")
        ESTIMATOR_CHANGES.check(self.est_changes)

    @classmethod
    def from_file(cls, c: FileChecker, table: Mapping[str, Any]) -> "EstimationSection":
        estimator = c.choice(table, "estimator", "estimator", "true", ESTIMATOR_CHOICES)
        est_changes = _changes_from_file(c, table, ESTIMATOR_CHANGES)
        tuning = c.keys(table.get("estimator_tuning", {}), "estimator_tuning", ESTIMATOR_TUNING_KEYS)
        return cls(estimator, est_changes,
                   {k: c.num(tuning, k, f"estimator_tuning.{k}", lo=0.0, lo_open=True) for k in tuning})

    def to_file(self) -> dict[str, Any]:
        out: dict[str, Any] = {}
        if self.estimator != "true":
            out["estimator"] = self.estimator
        out.update(_changes_to_file(ESTIMATOR_CHANGES, self.est_changes))
        if self.estimator_tuning:
            out["estimator_tuning"] = dict(self.estimator_tuning)
        return out


# --------------------------------------------------------------------------- observer


@dataclass(frozen=True)
class ObserverSection:
    """Whether the controllers use the online COM-offset estimate
    (:mod:`ballbot_casadi.estimation.com_observer`) as their internal model (file
    ``com_observer``; its gains are in :class:`GainsSection`)."""

    com_observer: bool = False

    FIELDS = ("com_observer",)
    TABLE_KEYS = ("com_observer",)

    def check(self, run: RunSection) -> None:
        if not isinstance(self.com_observer, bool):
            raise ScenarioError(f"com_observer must be true or false, got {self.com_observer!r}",
                                key="com_observer")

    @classmethod
    def from_file(cls, c: FileChecker, table: Mapping[str, Any]) -> "ObserverSection":
        return cls(c.boolean(table, "com_observer", "com_observer", False))

    def to_file(self) -> dict[str, Any]:
        return {"com_observer": True} if self.com_observer else {}


# --------------------------------------------------------------------------- gains


@dataclass(frozen=True)
class GainsSection:
    """Gain vectors (file ``[gains]``; empty = the defaults): ``k_bal`` of the balance
    controller, ``k_vel`` of the velocity LQR (thesis §7.3), ``k_obs`` of the COM
    observer (``t_obs, t_com, t_diff`` in s, ``c_max`` in m)."""

    k_bal: tuple = ()
    k_vel: tuple = ()
    k_obs: tuple = ()

    FIELDS = GAIN_CONSTANTS
    TABLE_KEYS = ("gains",)

    def check(self, run: RunSection) -> None:
        if self.k_bal:
            _argument(check_gains, "gains.k_bal", run.controller, self.k_bal)
        if self.k_vel and len(self.k_vel) != VELOCITY_NKV:
            raise ScenarioError(f"k_vel needs {VELOCITY_NKV} entries, got {len(self.k_vel)}", key="gains.k_vel")
        if self.k_obs:
            _argument(check_com_observer_gains, "gains.k_obs", self.k_obs)
        for name in self.FIELDS:
            _frozen(self, name, f"gains.{name}")

    @classmethod
    def from_file(cls, c: FileChecker, table: Mapping[str, Any]) -> "GainsSection":
        gains = c.keys(table.get("gains", {}), "gains", GAIN_CONSTANTS)
        return cls(*(c.vector(gains, name, f"gains.{name}") for name in cls.FIELDS))

    def to_file(self) -> dict[str, Any]:
        gains = {name: list(getattr(self, name)) for name in self.FIELDS if getattr(self, name)}
        return {"gains": gains} if gains else {}


#: The sections of a :class:`~ballbot_casadi.sim.scenario.scenario.Scenario`: attribute
#: name and class, in file order.
SCENARIO_SECTIONS: tuple[tuple[str, type], ...] = (
    ("run", RunSection), ("initial", InitialSection), ("references", ReferencesSection),
    ("disturbances", DisturbancesSection), ("models", ModelSection), ("sensors", SensorsSection),
    ("estimation", EstimationSection), ("observer", ObserverSection), ("gains", GainsSection),
    ("route", PathSection),
)


# --------------------------------------------------------------------------- specs


@dataclass(frozen=True)
class SpecsSection:
    """A file's ``[[spec]]`` rows: dicts ``metric, op, threshold, source, thesis``
    (:mod:`ballbot_casadi.core.specs`)."""

    rows: tuple[Mapping[str, Any], ...] = ()

    TABLE_KEYS = ("spec",)

    @classmethod
    def from_file(cls, c: FileChecker, table: Mapping[str, Any]) -> "SpecsSection":
        out = []
        for i, row in enumerate(c.rows(table, "spec")):
            key = f"spec[{i}]"
            c.keys(row, key, _SPEC_KEYS, ("metric", "op", "threshold"))
            thr = row["threshold"]
            if not (isinstance(thr, bool) or (isinstance(thr, (int, float)) and math.isfinite(thr))):
                raise c.fail(f"{key}.threshold", f"expected a finite number or true/false, got {thr!r}")
            out.append({"metric": c.text(row, "metric", f"{key}.metric"),
                        "op": c.choice(row, "op", f"{key}.op", "", SPEC_OPS),
                        "threshold": thr,
                        "source": c.text(row, "source", f"{key}.source", "scenario file"),
                        "thesis": c.text(row, "thesis", f"{key}.thesis", "")})
        return cls(tuple(out))

    def to_file(self) -> dict[str, Any]:
        return {"spec": [{k: v for k, v in row.items() if not (k == "thesis" and v == "")}
                         for row in self.rows]} if self.rows else {}


# --------------------------------------------------------------------------- dispersions


@dataclass(frozen=True)
class DispersionsSection:
    """A file's ``[montecarlo]`` table: the set's ``seed`` and ``dispersion`` rows
    (``param`` a :data:`DISPERSION_TARGETS` entry or ``plant.<name>``; ``dist`` ``normal``
    with ``sd`` or ``uniform`` with ``low``, ``high``; ``relative``: fractions of the
    nominal value).  ``table`` is ``None`` for a file without the table
    (:mod:`ballbot_casadi.sim.scenario.dispersions` then uses its defaults)."""

    table: Mapping[str, Any] | None = None

    TABLE_KEYS = ("montecarlo",)

    @classmethod
    def from_file(cls, c: FileChecker, table: Mapping[str, Any]) -> "DispersionsSection":
        if "montecarlo" not in table:
            return cls(None)
        mc = c.keys(table["montecarlo"], "montecarlo", ("seed", "dispersion", "description"))
        seed = c.integer(mc, "seed", "montecarlo.seed", 0, 0)
        rows = []
        for i, row in enumerate(c.rows(mc, "dispersion")):
            key = f"montecarlo.dispersion[{i}]"
            c.keys(row, key, ("param", "dist", "sd", "low", "high", "relative"), ("param", "dist"))
            param = c.text(row, "param", f"{key}.param")
            if not (param in DISPERSION_TARGETS or (param.startswith("plant.") and param[6:] in PARAM_NAMES)):
                raise c.fail(f"{key}.param", f"unknown target {param!r}; allowed: plant.<parameter> "
                                             f"({', '.join(PARAM_NAMES)}) or {', '.join(DISPERSION_TARGETS)}")
            dist = c.choice(row, "dist", f"{key}.dist", "", _DISTS)
            d = {"param": param, "dist": dist, "relative": c.boolean(row, "relative", f"{key}.relative", False)}
            if dist == "normal":
                c.keys(row, key, ("param", "dist", "sd", "relative"), ("sd",))
                d["sd"] = c.num(row, "sd", f"{key}.sd", lo=0.0)
            else:
                c.keys(row, key, ("param", "dist", "low", "high", "relative"), ("low", "high"))
                d["low"] = c.num(row, "low", f"{key}.low")
                d["high"] = c.num(row, "high", f"{key}.high")
                if d["high"] < d["low"]:
                    raise c.fail(f"{key}.high", f"must be >= low ({d['low']:g}), got {d['high']:g}")
            rows.append(d)
        return cls({"seed": seed, "dispersion": rows})

    def to_file(self) -> dict[str, Any]:
        if self.table is None:
            return {}
        return {"montecarlo": {"seed": self.table["seed"],
                               "dispersion": [dict(d) for d in self.table["dispersion"]]}}

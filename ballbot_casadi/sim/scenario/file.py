"""Scenario files: one TOML file describes one closed-loop run, in friendly units.

``ballbot simulate FILE`` runs such a file, ``ballbot montecarlo FILE`` disperses it and
the shipped studies (``ballbot study --list``) are such files, so a user copies one and
edits it.  Every key is checked: an unknown key, a wrong type or an impossible value is
a :class:`ScenarioFileError` naming the file, the key and the reason.

Format (every key optional unless marked; units in the names)::

    name = "my_run"                 # default: the file name without .toml
    description = "what this run is"
    study = ""                      # the study it belongs to (informational)
    controller = "flc"              # flc | smc
    duration_s = 10.0               # required, > 0
    cascade = false                 # close the velocity loop (thesis Fig. 7.1)
    feedforward = "exact"           # exact | none (thesis mode: zero reference acceleration)
    estimator = "true"              # true | ukf | ekf (noisy sensors + QUKF/VUKF or QEKF/VEKF)
    seed = 0                        # sensor-noise seed, int >= 0
    noise = true                    # with an estimator: draw sensor noise (false: noise-free sensors)
    com_observer = false            # controllers use the online COM-offset estimate (position hold)
    control_period_s = 0.005        # 200 Hz (thesis §7.1)
    rk4_substeps = 5                # plant RK4 steps per control period

    [initial]                       # initial state (default: upright at rest at the origin)
    roll_deg = 0.0                  # ZYX Euler angles of the body
    pitch_deg = 0.0
    yaw_deg = 0.0
    x_m = 0.0                       # ball position and velocity
    y_m = 0.0
    vx_mps = 0.0
    vy_mps = 0.0
    on_reference = false            # start on the attitude reference (angle and rate at t = 0)

    [attitude.roll]                 # also attitude.pitch, attitude.yaw; default 0
    type = "sine"                   # const | sine | step | chirp
    amplitude_deg = 3.0             # sine, step, chirp
    frequency_hz = 0.5              # sine (below the 100 Hz Nyquist frequency)
    # phase_rad, offset_deg; step: t_step_s, rise_time_s; chirp: f0_hz, f1_hz, sweep_s;
    # const: value_deg

    [[velocity]]                    # velocity-profile keyframes (cascade only)
    t_s = 1.0
    vx_mps = 0.3
    vy_mps = 0.0
    yaw_rate_rps = 0.0
    accel_mps2 = 0.25               # optional ramp acceleration (<= 1 m/s^2)

    [[push]]                        # attitude jump of the plant (thesis §8.4.3)
    t_s = 1.0
    roll_deg = 4.0                  # pitch_deg, yaw_deg

    [[torque_disturbance]]          # wheel torques added after the motor saturation
    t_start_s = 1.0
    t_end_s = 1.5
    tau_nm = [0.5, 0.0, 0.0]

    [plant]                         # plant parameter overrides (names of default_params.toml)
    Mb = { scale = 1.1 }            # { set = v } | { scale = f } | { add = d } | plain number (= set)
    com_x = -0.02

    [controller_model]              # the controller's internal model (mismatch), same form

    [estimator_model]               # the estimators' internal model, same form

    [sensors]                       # sensor parameter overrides (names of the [sensors] table
    acc_bias = [0.05, 0.0, 0.0]     # of default_params.toml): a list or a number (= set), or
    gyro_noise_var = { scale = 2 }  # { set = v } | { scale = f } | { add = d }

    [estimator_tuning]              # changes to the filters' thesis tuning
    rate_process_var = 3e-5         # QUKF body-rate process noise per period, (rad/s)^2 (thesis 1e-5)
    encoder_var = 0.1111            # VUKF encoder noise, ticks^2 (thesis 1/9)
    acc_process_var = 1e-2          # VUKF acceleration random walk, (m/s^2)^2 per period (predecessor 1e-5)
    acc_bias_process_var = 2e-8     # VUKF accelerometer-bias process noise, (m/s^2)^2 (predecessor 1e-9)

    [[sensor_dropout]]              # readings missing (NaN) in [t_start_s, t_end_s)
    t_start_s = 2.0
    t_end_s = 2.5
    sensor = "enc"                  # acc | gyro | enc

    [gains]
    k_bal = [...]                   # balance gains (default: the controller's)
    k_vel = [...]                   # velocity gains (default: LQR of thesis §7.3)
    k_obs = [0.3, 2.0, 0.1, 0.1]   # COM observer: t_obs, t_com, t_diff (s), c_max (m)

    [[spec]]                        # pass/fail criteria on the run's metrics
    metric = "max_tilt_deg"
    op = "<="                       # < <= > >= == abs<=
    threshold = 5.0
    source = "why this number"
    thesis = "the thesis's value, shown beside ours"

    [montecarlo]                    # used by `ballbot montecarlo` (see montecarlo docs)
    seed = 1
    [[montecarlo.dispersion]]
    param = "plant.Mb"              # plant.<name> | initial.roll_deg | initial.pitch_deg | initial.yaw_deg
    dist = "normal"                 # normal (sd) | uniform (low, high)
    sd = 0.05
    relative = true                 # sd/low/high as fractions of the nominal value

:func:`load_scenario_file` reads and validates a file into a :class:`ScenarioFile`
(the validated table, the :class:`~ballbot_casadi.sim.scenario.Scenario`, specs and
dispersions); :func:`dump_toml` writes such a table back (e.g. a Monte Carlo run's
scenario, rerunnable alone with ``ballbot simulate``).
"""

from __future__ import annotations

import copy
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from ballbot_casadi.control import BALANCE_CONTROLLERS
from ballbot_casadi.core.params import PARAM_NAMES
from ballbot_casadi.core.safe_paths import name_problem
from ballbot_casadi.core.specs import SPEC_OPS
from ballbot_casadi.errors import ScenarioError, ScenarioFileError
from ballbot_casadi.sim import references as R
from ballbot_casadi.sim.ports import GAIN_CONSTANTS
from ballbot_casadi.sim.scenario.scenario import (
    CONTROLLER_CHANGES,
    ESTIMATOR_CHANGES,
    ESTIMATOR_CHOICES,
    ESTIMATOR_TUNING_KEYS,
    FEEDFORWARD_MODES,
    PLANT_CHANGES,
    SENSOR_CHANGES,
    Scenario,
    initial_state,
)
from ballbot_casadi.sim.scenario.signals import attitude_reference, signal_from_file

__all__ = [
    "ScenarioFileError",
    "ScenarioFile",
    "DISPERSION_TARGETS",
    "load_scenario_file",
    "parse_scenario",
]

#: Most control periods one run may have (``duration_s / control_period_s``): one hour at
#: the thesis's 5 ms period, whose log is held in memory.
MAX_PERIODS = 720_000
#: Largest wheel torque disturbance (N m) a scenario may add: ten times the motors'
#: maximum torque (``tau_max`` = 1.98 N m, default_params.toml).
TORQUE_DISTURBANCE_MAX_NM = 20.0

#: Initial-state quantities a Monte Carlo dispersion may target (besides ``plant.<name>``).
DISPERSION_TARGETS = ("initial.roll_deg", "initial.pitch_deg", "initial.yaw_deg")
_DISTS = ("normal", "uniform")

_NUM = (int, float)


@dataclass(frozen=True)
class ScenarioFile:
    """A validated scenario file.

    Attributes
    ----------
    path
        Where it was read from (``"<text>"`` for a string).
    table
        The validated TOML table (friendly units), as written in the file.
    scenario
        The run it describes.
    specs
        ``[[spec]]`` rows: dicts ``metric, op, threshold, source, thesis``.
    montecarlo
        The ``[montecarlo]`` table (``seed``, ``dispersion`` rows) or ``None``.
    """

    path: str
    table: Mapping[str, Any]
    scenario: Scenario
    specs: tuple[Mapping[str, Any], ...]
    montecarlo: Mapping[str, Any] | None


class _Checker:
    """Key-by-key validation with messages ``FILE: key 'a.b': reason``."""

    def __init__(self, where: str) -> None:
        self.where = where

    def fail(self, key: str, reason: str) -> ScenarioFileError:
        return ScenarioFileError(f"{self.where}: key '{key}': {reason}")

    def keys(self, table: Any, key: str, allowed: tuple[str, ...], required: tuple[str, ...] = ()) -> dict:
        if not isinstance(table, Mapping):
            raise self.fail(key, f"expected a table, got {type(table).__name__}")
        for k in table:
            if k not in allowed:
                raise self.fail(f"{key}.{k}" if key else k,
                                f"unknown key; allowed here: {', '.join(allowed)}")
        for k in required:
            if k not in table:
                raise self.fail(f"{key}.{k}" if key else k, "missing (required)")
        return dict(table)

    def num(self, table: Mapping, key: str, full: str, default: Any = None, *, lo: float | None = None,
            hi: float | None = None, lo_open: bool = False) -> Any:
        if key not in table:
            return default
        v = table[key]
        if not isinstance(v, _NUM) or isinstance(v, bool):
            raise self.fail(full, f"expected a number, got {v!r} ({type(v).__name__})")
        if not math.isfinite(v):
            raise self.fail(full, f"must be finite, got {v!r}")
        if lo is not None and (v <= lo if lo_open else v < lo):
            raise self.fail(full, f"must be {'>' if lo_open else '>='} {lo:g}, got {v!r}")
        if hi is not None and v > hi:
            raise self.fail(full, f"must be <= {hi:g}, got {v!r}")
        return float(v)

    def integer(self, table: Mapping, key: str, full: str, default: int, lo: int) -> int:
        if key not in table:
            return default
        v = table[key]
        if not isinstance(v, int) or isinstance(v, bool) or v < lo:
            raise self.fail(full, f"expected an integer >= {lo}, got {v!r}")
        return int(v)

    def choice(self, table: Mapping, key: str, full: str, default: str, allowed: tuple[str, ...]) -> str:
        if key not in table:
            return default
        v = table[key]
        if not isinstance(v, str) or v not in allowed:
            raise self.fail(full, f"allowed: {', '.join(allowed)}; got {v!r}")
        return v

    def text(self, table: Mapping, key: str, full: str, default: str = "") -> str:
        if key not in table:
            return default
        v = table[key]
        if not isinstance(v, str):
            raise self.fail(full, f"expected a string, got {v!r}")
        return v

    def boolean(self, table: Mapping, key: str, full: str, default: bool) -> bool:
        if key not in table:
            return default
        v = table[key]
        if not isinstance(v, bool):
            raise self.fail(full, f"expected true or false, got {v!r}")
        return v

    def rows(self, table: Mapping, key: str) -> list:
        v = table.get(key, [])
        if not isinstance(v, list) or not all(isinstance(r, Mapping) for r in v):
            raise self.fail(key, f"expected an array of tables ([[{key}]]), got {type(v).__name__}")
        return v

    def vector(self, table: Mapping, key: str, full: str, n: int | None = None) -> tuple[float, ...]:
        v = table.get(key, [])
        if not isinstance(v, list) or any(not isinstance(e, _NUM) or isinstance(e, bool) for e in v):
            raise self.fail(full, f"expected an array of numbers, got {v!r}")
        if n is not None and len(v) != n:
            raise self.fail(full, f"expected {n} numbers, got {len(v)}")
        if not all(math.isfinite(e) for e in v):
            raise self.fail(full, "numbers must be finite")
        return tuple(float(e) for e in v)


_TOP = ("name", "description", "study", "controller", "duration_s", "cascade", "feedforward",
        "estimator", "seed", "control_period_s", "rk4_substeps", "initial", "attitude", "velocity",
        "push", "torque_disturbance", "plant", "controller_model", "gains", "spec", "montecarlo",
        "noise", "estimator_model", "sensors", "sensor_dropout", "estimator_tuning", "com_observer")
_INITIAL = ("roll_deg", "pitch_deg", "yaw_deg", "x_m", "y_m", "vx_mps", "vy_mps", "on_reference")
def _section(c: _Checker, parse: Any, *args: Any) -> Any:
    """``parse(*args)`` of a section; its keyed :class:`ScenarioError` becomes a file error."""
    try:
        return parse(*args)
    except ScenarioError as exc:
        raise c.fail(exc.key or "scenario", exc.reason) from None


def _interval(c: _Checker, row: Any, key: str, field: str) -> tuple[float, float]:
    """``(t_start_s, t_end_s)`` of a row that also requires ``field``; end after start."""
    c.keys(row, key, ("t_start_s", "t_end_s", field), ("t_start_s", "t_end_s", field))
    t0 = c.num(row, "t_start_s", f"{key}.t_start_s", lo=0.0)
    t1 = c.num(row, "t_end_s", f"{key}.t_end_s")
    if t1 <= t0:
        raise c.fail(f"{key}.t_end_s", f"must be after t_start_s ({t0:g}), got {t1:g}")
    return t0, t1


def _dropouts(c: _Checker, table: Mapping[str, Any]) -> list[tuple]:
    rows = []
    for i, row in enumerate(c.rows(table, "sensor_dropout")):
        key = f"sensor_dropout[{i}]"
        t0, t1 = _interval(c, row, key, "sensor")
        rows.append((t0, t1, c.choice(row, "sensor", f"{key}.sensor", "", ("acc", "gyro", "enc"))))
    return rows


def _initial(c: _Checker, table: Any, attitude: Mapping[str, Any], Ts: float) -> tuple:
    table = c.keys(table, "initial", _INITIAL)
    ang = {k: c.num(table, k, f"initial.{k}", 0.0, lo=-180.0, hi=180.0)
           for k in ("roll_deg", "pitch_deg", "yaw_deg")}
    if abs(ang["pitch_deg"]) >= 90.0:
        raise c.fail("initial.pitch_deg", "must be within (-90, 90) deg (ZYX Euler angles)")
    pos = {k: c.num(table, k, f"initial.{k}", 0.0) for k in ("x_m", "y_m", "vx_mps", "vy_mps")}
    for k in ("vx_mps", "vy_mps"):
        if abs(pos[k]) > 10.0:
            raise c.fail(f"initial.{k}", f"{pos[k]:g} m/s is not a ballbot speed (|v| <= 10 m/s)")
    on_ref = c.boolean(table, "on_reference", "initial.on_reference", False)
    x0 = np.array(initial_state(ang["roll_deg"], ang["pitch_deg"], ang["yaw_deg"]))
    if on_ref:
        q, dq, _ = attitude_reference(attitude, np.zeros(1))
        x0[2:6], x0[8:12] = q[0], dq[0]
    x0[0], x0[1], x0[6], x0[7] = pos["x_m"], pos["y_m"], pos["vx_mps"], pos["vy_mps"]
    return tuple(float(v) for v in x0)


def _specs(c: _Checker, rows: list) -> tuple[dict[str, Any], ...]:
    out = []
    for i, row in enumerate(rows):
        key = f"spec[{i}]"
        c.keys(row, key, ("metric", "op", "threshold", "source", "thesis"), ("metric", "op", "threshold"))
        thr = row["threshold"]
        if not (isinstance(thr, bool) or (isinstance(thr, _NUM) and math.isfinite(thr))):
            raise c.fail(f"{key}.threshold", f"expected a finite number or true/false, got {thr!r}")
        out.append({"metric": c.text(row, "metric", f"{key}.metric"),
                    "op": c.choice(row, "op", f"{key}.op", "", SPEC_OPS),
                    "threshold": thr,
                    "source": c.text(row, "source", f"{key}.source", "scenario file"),
                    "thesis": c.text(row, "thesis", f"{key}.thesis", "")})
    return tuple(out)


def _montecarlo(c: _Checker, table: Any) -> dict[str, Any]:
    table = c.keys(table, "montecarlo", ("seed", "dispersion", "description"))
    seed = c.integer(table, "seed", "montecarlo.seed", 0, 0)
    rows = []
    for i, row in enumerate(c.rows(table, "dispersion")):
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
    return {"seed": seed, "dispersion": rows}


def parse_scenario(table: Mapping[str, Any], where: str = "<text>", default_name: str = "scenario") -> ScenarioFile:
    """Validate a scenario table (as read from TOML) into a :class:`ScenarioFile`."""
    c = _Checker(where)
    table = c.keys(table, "", _TOP, ("duration_s",))
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
    att_table = c.keys(table.get("attitude", {}), "attitude", ("roll", "pitch", "yaw"))
    attitude = {ax: _section(c, signal_from_file, ax, spec, Ts) for ax, spec in att_table.items()}
    x0 = _initial(c, table.get("initial", {}), attitude, Ts)
    keyframes = []
    for i, row in enumerate(c.rows(table, "velocity")):
        key = f"velocity[{i}]"
        c.keys(row, key, ("t_s", "vx_mps", "vy_mps", "yaw_rate_rps", "accel_mps2"), ("t_s",))
        kf = [c.num(row, "t_s", f"{key}.t_s", lo=0.0), c.num(row, "vx_mps", f"{key}.vx_mps", 0.0),
              c.num(row, "vy_mps", f"{key}.vy_mps", 0.0), c.num(row, "yaw_rate_rps", f"{key}.yaw_rate_rps", 0.0)]
        if "accel_mps2" in row:
            kf.append(c.num(row, "accel_mps2", f"{key}.accel_mps2", lo=0.0, lo_open=True))
        keyframes.append(tuple(kf))
    if keyframes:
        try:
            R.velocity_profile(np.zeros(1), keyframes)
        except ScenarioError as exc:
            raise c.fail("velocity", str(exc)) from None
    pushes = []
    for i, row in enumerate(c.rows(table, "push")):
        key = f"push[{i}]"
        c.keys(row, key, ("t_s", "roll_deg", "pitch_deg", "yaw_deg"), ("t_s",))
        t = c.num(row, "t_s", f"{key}.t_s", lo=0.0)
        if t >= duration:
            raise c.fail(f"{key}.t_s", f"must be before the end of the run ({duration:g} s), got {t:g}")
        pushes.append((t, *(c.num(row, k, f"{key}.{k}", 0.0, lo=-90.0, hi=90.0)
                            for k in ("roll_deg", "pitch_deg", "yaw_deg"))))
    dists = []
    for i, row in enumerate(c.rows(table, "torque_disturbance")):
        key = f"torque_disturbance[{i}]"
        t0, t1 = _interval(c, row, key, "tau_nm")
        tau = c.vector(row, "tau_nm", f"{key}.tau_nm", 3)
        if max(map(abs, tau)) > TORQUE_DISTURBANCE_MAX_NM:
            raise c.fail(f"{key}.tau_nm", f"each torque must be within +-{TORQUE_DISTURBANCE_MAX_NM:g} "
                         f"N m (10x the motors' maximum), got {list(tau)}")
        dists.append((t0, t1, *tau))
    gains = c.keys(table.get("gains", {}), "gains", GAIN_CONSTANTS)
    fields = dict(
        name=name,
        controller=c.choice(table, "controller", "controller", "flc", tuple(BALANCE_CONTROLLERS)),
        duration=duration, x0=x0,
        cascade=c.boolean(table, "cascade", "cascade", False),
        attitude=attitude, velocity_keyframes=tuple(keyframes), pushes=tuple(pushes),
        torque_disturbances=tuple(dists),
        plant_changes=_section(c, PLANT_CHANGES.parse, table.get("plant", {})),
        ctrl_changes=_section(c, CONTROLLER_CHANGES.parse, table.get("controller_model", {})),
        k_bal=c.vector(gains, "k_bal", "gains.k_bal"), k_vel=c.vector(gains, "k_vel", "gains.k_vel"),
        com_observer=c.boolean(table, "com_observer", "com_observer", False),
        k_obs=c.vector(gains, "k_obs", "gains.k_obs"),
        Ts=Ts, n_sub=c.integer(table, "rk4_substeps", "rk4_substeps", 5, 1),
        feedforward=c.choice(table, "feedforward", "feedforward", "exact", FEEDFORWARD_MODES),
        estimator=c.choice(table, "estimator", "estimator", "true", ESTIMATOR_CHOICES),
        seed=c.integer(table, "seed", "seed", 0, 0),
        noise=c.boolean(table, "noise", "noise", True),
        est_changes=_section(c, ESTIMATOR_CHANGES.parse, table.get("estimator_model", {})),
        sensor_changes=_section(c, SENSOR_CHANGES.parse, table.get("sensors", {})),
        sensor_dropouts=tuple(_dropouts(c, table)),
        estimator_tuning={k: c.num(table["estimator_tuning"], k, f"estimator_tuning.{k}", lo=0.0, lo_open=True)
                          for k in c.keys(table.get("estimator_tuning", {}), "estimator_tuning",
                                          ESTIMATOR_TUNING_KEYS)},
        study=c.text(table, "study", "study"), description=c.text(table, "description", "description"),
    )
    if fields["seed"] >= 2**32:
        raise c.fail("seed", f"must be below 2^32, got {fields['seed']}")
    if fields["n_sub"] > 100:
        raise c.fail("rk4_substeps", f"at most 100, got {fields['n_sub']}")
    scenario = _scenario(c, fields)
    specs = _specs(c, c.rows(table, "spec"))
    mc = _montecarlo(c, table["montecarlo"]) if "montecarlo" in table else None
    return ScenarioFile(where, copy.deepcopy(table), scenario, specs, mc)


def _scenario(c: _Checker, fields: Mapping[str, Any]) -> Scenario:
    """The :class:`Scenario` of the checked fields (checks only the whole run can make, e.g.
    the gain count of the chosen controller, fail here under their own key)."""
    try:
        return Scenario(**fields)
    except ScenarioError as exc:
        raise c.fail(exc.key or "scenario", exc.reason) from None


def load_scenario_file(path: str | Path) -> ScenarioFile:
    """Read and validate a scenario file (see the module docstring).

    Raises
    ------
    ScenarioFileError
        Unreadable file, TOML syntax error, unknown key, wrong type or impossible value;
        the one-line message names the file and the key.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioFileError(f"{path}: cannot read the scenario file ({exc})") from None
    try:
        table = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioFileError(f"{path}: not valid TOML ({exc})") from None
    except RecursionError:
        raise ScenarioFileError(f"{path}: not a scenario file (arrays or tables nested too "
                                "deeply to read)") from None
    return parse_scenario(table, str(path), path.stem)

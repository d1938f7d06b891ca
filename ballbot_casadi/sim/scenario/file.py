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
                                    # | no-rate (neither rate nor acceleration, thesis §7.2 item 5)
    torque_limit = "direction"      # direction (ours) | per-wheel (the thesis's clipping, §9.1)
    estimator = "true"              # true | ukf | ekf | ukf_heading | ekf_heading | ukf_consistent | ukf_adaptive
                                    # (noisy sensors + QUKF/VUKF, QEKF/VEKF, the heading-aided QUKF
                                    # with its z gyro bias + VUKF, the predecessor's QEKF with
                                    # heading + VEKF, or the QUKF with the matched velocity filter)
    heading_sensor = false          # the robot carries the heading sensor ([sensors] heading_rate)
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
    type = "sine"                   # const | sine | step | ramp | chirp (not with cascade = true)
    amplitude_deg = 3.0             # sine, step, chirp
    frequency_hz = 0.5              # sine (below the 100 Hz Nyquist frequency)
    # phase_rad, offset_deg; step: t_step_s, rise_time_s; ramp: t_start_s, rate_deg_s;
    # chirp: f0_hz, f1_hz, sweep_s;
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
    acc_process_var_x = 1e-2        # the same for x alone (and _y): after acc_process_var if both
                                    # (ukf_consistent, none set: its calibrated x/y pair;
                                    # ukf_adaptive: the prior its online estimate starts from)
    acc_bias_process_var = 2e-8     # VUKF accelerometer-bias process noise, (m/s^2)^2 (predecessor 1e-9)

    [[sensor_dropout]]              # readings missing (NaN) in [t_start_s, t_end_s)
    t_start_s = 2.0
    t_end_s = 2.5
    sensor = "enc"                  # acc | gyro | enc

    [[sensor_glitch]]               # one glitch sample at the control instant nearest t_s
    t_s = 3.0
    sensor = "gyro"                 # acc | gyro (through the sensor's noise input)
    axis = "x"                      # x | y | z (IMU frame; default x)
    value = 1000.0                  # added to that reading, m/s^2 | rad/s

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
scenario, rerunnable alone with ``ballbot simulate``).  Each part of the file is read,
checked and written by its section (:mod:`ballbot_casadi.sim.scenario.sections`).
"""

from __future__ import annotations

import copy
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

from ballbot_casadi.errors import ScenarioError, ScenarioFileError
from ballbot_casadi.sim.scenario.checker import FileChecker
from ballbot_casadi.sim.scenario.scenario import Scenario
from ballbot_casadi.sim.scenario.sections import (
    DISPERSION_TARGETS,
    MAX_PERIODS,
    SCENARIO_SECTIONS,
    PathSection,
    TORQUE_DISTURBANCE_MAX_NM,
    DispersionsSection,
    DisturbancesSection,
    EstimationSection,
    GainsSection,
    InitialSection,
    ModelSection,
    ObserverSection,
    ReferencesSection,
    RunSection,
    SensorsSection,
    SpecsSection,
)

__all__ = [
    "ScenarioFileError",
    "ScenarioFile",
    "DISPERSION_TARGETS",
    "MAX_PERIODS",
    "TORQUE_DISTURBANCE_MAX_NM",
    "load_scenario_file",
    "parse_scenario",
]

#: Every top-level key of a scenario file: the keys of its sections.
_TOP = tuple(k for _, cls in SCENARIO_SECTIONS for k in cls.TABLE_KEYS) + SpecsSection.TABLE_KEYS \
    + DispersionsSection.TABLE_KEYS


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

    def to_file(self) -> dict[str, Any]:
        """The file's table written by its sections (defaults omitted): read back by
        :func:`parse_scenario`, it gives an equal scenario, specs and dispersions."""
        return {**self.scenario.to_file(), **SpecsSection(self.specs).to_file(),
                **DispersionsSection(self.montecarlo).to_file()}


def parse_scenario(table: Mapping[str, Any], where: str = "<text>", default_name: str = "scenario") -> ScenarioFile:
    """Validate a scenario table (as read from TOML) into a :class:`ScenarioFile`."""
    c = FileChecker(where)
    table = c.keys(table, "", _TOP, ("duration_s",))
    run = RunSection.from_file(c, table, default_name)
    references = ReferencesSection.from_file(c, table, run)
    sections = dict(
        run=run, references=references,
        initial=InitialSection.from_file(c, table, references.attitude),
        disturbances=DisturbancesSection.from_file(c, table, run),
        models=ModelSection.from_file(c, table),
        gains=GainsSection.from_file(c, table),
        observer=ObserverSection.from_file(c, table),
        estimation=EstimationSection.from_file(c, table),
        sensors=SensorsSection.from_file(c, table),
        route=PathSection.from_file(c, table),
    )
    scenario = _scenario(c, sections)
    specs = SpecsSection.from_file(c, table).rows
    mc = DispersionsSection.from_file(c, table).table
    return ScenarioFile(where, copy.deepcopy(table), scenario, specs, mc)


def _scenario(c: FileChecker, sections: Mapping[str, Any]) -> Scenario:
    """The :class:`Scenario` of the checked sections (checks only the whole run can make,
    e.g. the gain count of the chosen controller, fail here under their own key)."""
    try:
        return Scenario.from_sections(**sections)
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
        return parse_scenario(table, str(path), path.stem)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioFileError(f"{path}: not valid TOML ({exc})") from None
    except RecursionError:
        raise ScenarioFileError(f"{path}: not a scenario file (arrays or tables nested too "
                                "deeply to read)") from None

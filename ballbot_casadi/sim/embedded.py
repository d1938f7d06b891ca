"""The robot's sensors and embedded software: what the controllers read (thesis Fig. 9.8).

With an estimator in the loop the plant carries the three wheel angles as well
(``[x; phi]``, 15 entries, integrated with the plant) and every control period is

1. **sensors** at ``t_k`` (after a push), thesis §3.1, on the plant side
   (:func:`sense`): the IMU (``ballbot_imu``: specific force at the IMU including the
   body's own acceleration, scale, bias, misalignment, noise) with the torque that acted
   on the plant just before ``t_k``; the gyroscope bias ``b_k`` (random walk,
   ``ballbot_gyro_bias_step``); the encoders (``ballbot_encoders``: wheel angles
   quantised to ``n_ticks`` per revolution, differenced over the period, in ticks/s).
   Standard-normal noise enters as the per-period input ``noise = [n_acc, n_gyro,
   n_rw]``; the per-period input ``valid = [acc, gyro, enc]`` (1 available, 0 missing)
   turns missing readings into NaN;
2. the **embedded software**, one Function ``ballbot_embedded_<ctrl>_<est>``
   (:func:`make_embedded_step`) that the controller FMU runs too: the attitude filter
   (QUKF thesis ch. 4, or the predecessor's QEKF) on ``[acc, gyro]``, its accelerometer
   prediction compensated by the velocity filter's last estimate of the ball's
   acceleration (the thesis's model (4.29) takes the accelerometer as measuring gravity
   only, which tilts the estimate by ``atan(a/g)`` whenever the ball accelerates), the
   velocity filter (VUKF ch. 5, or VEKF) on the encoder tick increments (predicted at
   the period's middle) and the accelerometer, the velocity-aided tilt correction
   (``ballbot_tilt_correction``: the velocity filter's horizontal accelerometer bias is
   the attitude filter's slow tilt error, :mod:`~ballbot_casadi.estimation.tilt_aiding`),
   the estimate ``x_hat = [pos, q_c, v, dq]`` (``q_c`` the corrected attitude,
   ``dq = 1/2 q_c o [0, omega]``; the position integrates the velocity estimate: the
   robot has no position sensor), then the controllers and the torque limit of
   :func:`~ballbot_casadi.sim.period.controller_part` on ``x_hat``.  A NaN reading makes
   its filter predict only for that sensor.  With a heading-reading estimator
   (``ukf_heading``: the QUKF with the z gyro bias, ``ekf_heading``: the predecessor's
   QEKF with heading correction and gyro biases) the readings end with the heading
   (:data:`MEAS_HEADING`, the heading sensor of ``heading_sensor`` scenarios, NaN between
   its samples) and the attitude filter reads it.

The controller state ``c = [z, xa, vec(Pa), xv, vec(Pv), pos, gate]`` (:func:`controller_layout`;
with the COM observer of :mod:`ballbot_casadi.estimation.com_observer` its state ``obs``
follows, and the observer reads ``x_hat`` before the controllers) and the sensor state ``[tau_prev, bias, phi_prev]`` (:data:`SENSOR_STATE`) are carried
by the mission.  The sensors belong to the plant (``p_plant`` and the sensor
parameters ``s``); the filters run on their own model parameters ``p_est``.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Any, Mapping

import casadi as ca
import numpy as np

from ballbot_casadi.control import BALANCE_CONTROLLERS, make_velocity_controller
from ballbot_casadi.control.velocity import (
    VELOCITY_NZ,
    measured_tilt,
    tilt_heading_quaternion,
)
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import (
    ATTITUDE_FILTER_STATE,
    STATE,
    STATE_DXY,
    STATE_XY,
    VELOCITY_CONTROLLER_STATE,
    VELOCITY_FILTER_STATE,
    Layout,
)
from ballbot_casadi.core.params import PARAM_NAMES
from ballbot_casadi.errors import BuildError, ScenarioError, ShapeError
from ballbot_casadi.estimation import (
    DEFAULT_TUNING,
    make_qekf,
    make_qukf,
    make_tilt_correction,
    make_vekf,
    make_vukf,
)
from ballbot_casadi.estimation.attitude import (
    ATTITUDE_GATE,
    ATTITUDE_MEAS,
    ATTITUDE_NOISE,
    tangent_map,
)
from ballbot_casadi.estimation.velocity import VELOCITY_GATE
from ballbot_casadi.estimation.com_observer import COM_OBSERVER_STATE, make_com_observer
from ballbot_casadi.estimation.heading import HEADING_FILTER_STATE, make_qukf_heading
from ballbot_casadi.estimation.predecessor import QEKF_HEADING_STATE, make_qekf_heading
from ballbot_casadi.estimation.tuning import QEKF_P0_RADIAL, QUKF_P0
from ballbot_casadi.estimation.adaptive_walk import WALK_SIZE, WalkAdaptation
from ballbot_casadi.estimation.velocity import encoder_rate
from ballbot_casadi.model.dynamics import make_affine, make_ode, make_wheel_speeds
from ballbot_casadi.model.sensors import (
    make_encoders,
    make_gyro_bias_step,
    make_heading_sensor,
    make_imu,
)
from ballbot_casadi.sim.period import controller_part
from ballbot_casadi.sim.ports import (
    OBSERVER_CONSTANTS,
    PeriodBlocks,
    controller_state,
    embedded_ports,
)

__all__ = [
    "DEFAULT_ESTIMATOR",
    "THESIS_ESTIMATOR",
    "ESTIMATOR_FILTERS",
    "controller_blocks",
    "MATCHED_VELOCITY",
    "ADAPTIVE_VELOCITY",
    "GATE_GROUPS",
    "NOISE",
    "VALID",
    "MEAS",
    "MEAS_HEADING",
    "SENSOR_STATE",
    "readings_layout",
    "embedded_readings",
    "EstimatorBlocks",
    "estimator_blocks",
    "estimator_layout",
    "controller_layout",
    "software_layout",
    "software_blocks",
    "sense",
    "make_embedded_step",
    "embedded_software",
    "make_initial_controller_state",
    "initial_controller_state_function",
    "initial_controller_state",
    "initial_estimator_state",
]

#: Filters of each estimator choice: (attitude filter, velocity filter).  ``ukf_heading``
#: is the QUKF with the heading reading and the z gyro bias as a state
#: (:mod:`~ballbot_casadi.estimation.heading`, thesis (4.30), ch. 11 future work);
#: ``ekf_heading`` the predecessor's QEKF with its heading correction and gyro-bias
#: states (:mod:`~ballbot_casadi.estimation.predecessor`, thesis §6) and the VEKF;
#: ``ukf_consistent`` the QUKF with the matched velocity filter (:data:`MATCHED_VELOCITY`),
#: ``ukf_adaptive`` the same with its acceleration random walk adapted online
#: (:data:`ADAPTIVE_VELOCITY`).
ESTIMATOR_FILTERS: Mapping[str, tuple[str, str]] = {"ukf": ("qukf", "vukf"), "ekf": ("qekf", "vekf"),
                                                    "ukf_heading": ("qukf_heading", "vukf"),
                                                    "ekf_heading": ("qekf_heading", "vekf"),
                                                    "ukf_consistent": ("qukf", "vukf"),
                                                    "ukf_adaptive": ("qukf", "vukf")}
#: The estimator the embedded software runs unless told otherwise: the default of the
#: controller FMU (``BallbotController`` is the FLC with it), the SIL, the firmware and the
#: guided mission (a key of :data:`ESTIMATOR_FILTERS`): the QUKF with the matched VUKF
#: adapting its acceleration random walk (:data:`ADAPTIVE_VELOCITY`, issue 22: consistent
#: on every shipped UKF scenario).  The thesis's filters are ``"ukf"``, a switch.  Scenario
#: files name theirs; a scenario without one reads the true state.
DEFAULT_ESTIMATOR = "ukf_adaptive"
#: The thesis's own filters (QUKF + VUKF, thesis ch. 4-5), one switch away from
#: :data:`DEFAULT_ESTIMATOR` (``--estimator ukf`` / ``--set estimator=ukf``): the thesis's
#: set-up that the studies run beside ours.
THESIS_ESTIMATOR = "ukf"
#: Estimator choices whose velocity filter has the matched model of issue 22
#: (``make_vukf(..., matched=True)``): the encoders' body-rate term from the gyro reading
#: (estimation.velocity.encoder_rate), the period's acceleration noise on the velocity
#: (estimation.velocity.period_acceleration_noise) and the attitude error as a slowly
#: varying accelerometer offset (estimation.velocity.attitude_offset_noise).  The README
#: compares it with the thesis-model "ukf".
MATCHED_VELOCITY = frozenset({"ukf_consistent", "ukf_adaptive"})
#: Estimator choices whose (matched) velocity filter adapts its acceleration random walk
#: online (``make_vukf(..., adaptive=WalkAdaptation())``,
#: :mod:`~ballbot_casadi.estimation.adaptive_walk`): the estimate, per axis x and y, is a
#: state of the filter (field ``walk`` of :func:`estimator_layout`, ``[q_x, q_y, n]`` with
#: ``n`` its sample count, 0 at power-on: the configured ``Qv``'s acceleration block is the
#: prior).  ``ukf_consistent`` keeps the
#: constant pair :data:`~ballbot_casadi.estimation.velocity.MATCHED_ACC_PROCESS_VAR`.
ADAPTIVE_VELOCITY = frozenset({"ukf_adaptive"})
#: The state layouts of the attitude filters that read the heading sensor (the others'
#: is :data:`~ballbot_casadi.core.layout.ATTITUDE_FILTER_STATE`).
_HEADING_FILTERS: Mapping[str, Layout] = {"qukf_heading": HEADING_FILTER_STATE,
                                          "qekf_heading": QEKF_HEADING_STATE}
#: Attitude filters on the predecessor's additive chart (covariance on the quaternion's
#: four components).
_ADDITIVE_FILTERS = ("qekf", "qekf_heading")
#: Per-period standard-normal noise input of the sensors (the heading sensor's last: a
#: noise stream of its own, so it changes no other sensor's numbers).
NOISE = Layout("sensor noise", [("acc", 3), ("gyro", 3), ("gyro_rw", 3), ("heading", 1)])
#: Per-period sensor availability (1 = reading available, 0 = missing); the heading
#: sensor's entry is 0 unless the scenario switches the sensor on (``heading_sensor``),
#: then 1 at its own rate (:func:`~ballbot_casadi.model.sensors.heading_schedule`).
VALID = Layout("sensor availability", [("acc", 1), ("gyro", 1), ("enc", 1), ("heading", 1)])
#: The readings the embedded software gets: m/s^2, rad/s, ticks/s (NaN = missing).
MEAS = Layout("sensor readings", [("acc", 3), ("gyro", 3), ("enc", 3)])
#: The readings of an estimator with the heading sensor: :data:`MEAS` and the heading
#: (rad, wrapped to (-pi, pi]; NaN = no reading this period).
MEAS_HEADING = Layout("sensor readings with heading", [("acc", 3), ("gyro", 3), ("enc", 3),
                                                      ("heading", 1)])
#: Plant-side sensor state: torque of the previous period, gyro bias, wheel angles at the last sample.
SENSOR_STATE = Layout("sensor state", [("tau_prev", 3), ("bias", 3), ("phi_prev", 3)])
#: The innovation gate's measurement groups, attitude filter's then velocity filter's: the
#: entries of the output ``rejections`` (1 = the group's reading was rejected this period)
#: and of the controller state's ``gate`` (consecutive rejections).
GATE_GROUPS = Layout("innovation-gate groups",
                     [*((f"attitude_{n}", 1) for n in ATTITUDE_GATE.names),
                      *((f"velocity_{n}", 1) for n in VELOCITY_GATE.names)])


@dataclass(frozen=True)
class EstimatorBlocks:
    """The sensing and estimation Functions of one estimator choice.

    Attributes
    ----------
    imu, bias_step, encoders
        ``ballbot_imu``, ``ballbot_gyro_bias_step``, ``ballbot_encoders``
        (:mod:`ballbot_casadi.model.sensors`).
    attitude, velocity
        The filters (``ballbot_qukf``/``ballbot_qekf`` with the acceleration input,
        ``ballbot_vukf``/``ballbot_vekf`` with mid-period encoder prediction), with the
        chi-square innovation gate (input ``n_rej``; filters without it are used ungated).
    tilt_correction
        ``ballbot_tilt_correction`` (:mod:`~ballbot_casadi.estimation.tilt_aiding`).
    name
        ``"ukf"`` or ``"ekf"``.
    ode, wheel_speeds
        The model Functions the sensors and filters were built on (the plant of a
        mission with these sensors uses the same ones).
    heading
        ``ballbot_heading`` (:func:`~ballbot_casadi.model.sensors.make_heading_sensor`)
        when the attitude filter reads the heading (``ukf_heading``), else ``None``: the
        readings are then :data:`MEAS_HEADING`, otherwise :data:`MEAS`.
    """

    imu: ca.Function
    bias_step: ca.Function
    encoders: ca.Function
    attitude: ca.Function
    velocity: ca.Function
    name: str
    tilt_correction: ca.Function
    ode: ca.Function | None = None
    wheel_speeds: ca.Function | None = None
    heading: ca.Function | None = None

    @property
    def readings(self) -> Layout:
        """The readings layout of this estimator (:data:`MEAS` or :data:`MEAS_HEADING`)."""
        return MEAS if self.heading is None else MEAS_HEADING


def _filters_of(estimator: str) -> tuple[str, str]:
    """The (attitude, velocity) filters of ``estimator``; an unknown one is refused with
    the allowed ones (:data:`ESTIMATOR_FILTERS`)."""
    if estimator not in ESTIMATOR_FILTERS:
        raise ScenarioError(f"unknown estimator {estimator!r}; allowed: {', '.join(ESTIMATOR_FILTERS)}")
    return ESTIMATOR_FILTERS[estimator]


def readings_layout(estimator: str) -> Layout:
    """The readings the embedded software of ``estimator`` gets: :data:`MEAS_HEADING` for
    an estimator with the heading sensor, :data:`MEAS` otherwise."""
    return MEAS_HEADING if _filters_of(estimator)[0] in _HEADING_FILTERS else MEAS


def embedded_readings(embedded: ca.Function) -> Layout:
    """The readings layout of an embedded-software Function (by the size of its ``meas``
    input: :data:`MEAS` or :data:`MEAS_HEADING`).

    Raises
    ------
    BuildError
        The Function's ``meas`` matches neither.
    """
    n = embedded.numel_in(embedded.index_in("meas"))
    for layout in (MEAS, MEAS_HEADING):
        if n == layout.size:
            return layout
    raise BuildError(f"{embedded.name()}: readings of {n} entries match neither {MEAS} nor "
                     f"{MEAS_HEADING}")


def _attitude_state(att: str) -> Layout:
    return _HEADING_FILTERS.get(att, ATTITUDE_FILTER_STATE)


def estimator_blocks(estimator: str, ode: ca.Function, wheel_speeds: ca.Function) -> EstimatorBlocks:
    """The sensing and estimation Functions of an estimator choice (:data:`ESTIMATOR_FILTERS`)."""
    att, vel = _filters_of(estimator)
    if att in _HEADING_FILTERS:  # they compensate the acceleration (input a) always; no gate
        attitude = make_qukf_heading() if att == "qukf_heading" else make_qekf_heading()
    else:
        attitude = (make_qukf if att == "qukf" else make_qekf)(compensate_acceleration=True,
                                                               gate=True)
    adaptive = {"adaptive": WalkAdaptation()} if estimator in ADAPTIVE_VELOCITY else {}
    velocity = (make_vukf if vel == "vukf" else make_vekf)(
        wheel_speeds, midpoint=True, matched=estimator in MATCHED_VELOCITY, gate=True, **adaptive)
    return EstimatorBlocks(make_imu(ode), make_gyro_bias_step(), make_encoders(), attitude,
                           velocity, estimator, make_tilt_correction(), ode, wheel_speeds,
                           make_heading_sensor() if att in _HEADING_FILTERS else None)


def estimator_layout(estimator: str) -> Layout:
    """Layout of the filters' part of the controller state (an estimator of
    :data:`ESTIMATOR_FILTERS`; the heading-aided attitude filter's state ends with the z
    gyro bias, :data:`~ballbot_casadi.estimation.heading.HEADING_FILTER_STATE`)."""
    filters = _filters_of(estimator)
    XA = _attitude_state(filters[0])
    att, vel = (DEFAULT_TUNING[f] for f in filters)
    if (att.x0.size, vel.x0.size) != (XA.size, VELOCITY_FILTER_STATE.size):
        raise BuildError(f"estimator {estimator!r}: filter states of {att.x0.size} and "
                         f"{vel.x0.size} entries do not match the layouts {XA} "
                         f"and {VELOCITY_FILTER_STATE}")
    walk = (("walk", WALK_SIZE),) if estimator in ADAPTIVE_VELOCITY else ()
    return Layout("estimator state", [("xa", XA), ("Pa", att.P0.size),
                                      ("xv", VELOCITY_FILTER_STATE), ("Pv", vel.P0.size),
                                      ("pos", 2), ("gate", GATE_GROUPS.size), *walk])


def controller_layout(estimator: str, nz: int, n_obs: int = 0, n_guide: int = 0,
                      n_bal: int = 0) -> Layout:
    """Layout of the embedded software's state ``c``: velocity controller ``z``, then the
    filters, then (``n_obs > 0``) the COM observer's state ``obs``, then (``n_guide > 0``)
    the guidance block's state ``guide``, then (``n_bal > 0``) the balance controller's
    own state ``bal``."""
    e = estimator_layout(estimator)
    z = VELOCITY_CONTROLLER_STATE if nz == VELOCITY_CONTROLLER_STATE.size else nz
    return Layout("controller state c", [
        ("z", z), *((f, e.part(f) if f in ("xa", "xv") else e.size_of(f)) for f in e.fields),
        *((("obs", n_obs),) if n_obs else ()), *((("guide", n_guide),) if n_guide else ()),
        *((("bal", n_bal),) if n_bal else ())])


def software_layout(embedded: ca.Function, estimator: str, n_guide: int = 0) -> Layout:
    """The controller-state layout of an embedded-software Function (with the COM
    observer's state ``obs`` when the Function has the observer's inputs, the guidance
    block's state ``guide`` of ``n_guide`` entries, and the balance controller's own state
    ``bal`` last: the rest of the state).

    Raises
    ------
    BuildError
        The Function's state size does not match the layout.
    """
    has_obs = OBSERVER_CONSTANTS[0] in embedded.name_in()
    base = controller_layout(estimator, VELOCITY_NZ)
    n_obs = COM_OBSERVER_STATE.size if has_obs else 0
    n_bal = embedded.size1_in(0) - base.size - n_obs - n_guide
    if n_bal < 0:
        raise BuildError(f"{embedded.name()}: state of {embedded.size1_in(0)} entries does not "
                         f"match the layout {base}")
    return controller_layout(estimator, VELOCITY_NZ, n_obs, n_guide, n_bal=n_bal)


def _drop(y: Any, ok: Any) -> Any:
    """``y`` where ``ok``, NaN otherwise (the filters skip non-finite components)."""
    return ca.if_else(ok > 0.5, y, ca.DM.nan(y.numel()))


def sense(blocks: EstimatorBlocks, xk: ca.MX, s_state: ca.MX, noise: ca.MX, valid: ca.MX,
          p_plant: ca.MX, s: ca.MX, Ts: ca.MX) -> tuple[ca.MX, ca.MX]:
    """The readings at ``t_k`` and the sensor state after it (without the new ``tau_prev``).

    ``xk``: plant state with wheel angles (15) after the push; ``s_state``:
    :data:`SENSOR_STATE`.  Returns ``meas`` (``blocks.readings``: :data:`MEAS`, or
    :data:`MEAS_HEADING` with the heading sensor; NaN where missing) and
    ``[bias_next, phi]`` (the caller prepends the period's torque).
    """
    S = SENSOR_STATE
    x12, phi = xk[:STATE.size], xk[STATE.size:]
    acc, gyro = blocks.imu(x12, s_state[S["tau_prev"]], p_plant, s, s_state[S["bias"]],
                           noise[NOISE["acc"]], noise[NOISE["gyro"]])
    enc, _ = blocks.encoders(phi, s_state[S["phi_prev"]], p_plant, Ts)
    meas = ca.vertcat(_drop(acc, valid[VALID.index("acc")]), _drop(gyro, valid[VALID.index("gyro")]),
                      _drop(enc, valid[VALID.index("enc")]))
    if blocks.heading is not None:
        yaw = blocks.heading(x12[STATE["q"]], s, noise[NOISE["heading"]])
        meas = ca.vertcat(meas, _drop(yaw, valid[VALID.index("heading")]))
    bias_next = blocks.bias_step(s_state[S["bias"]], s, Ts, noise[NOISE["gyro_rw"]])
    return meas, ca.vertcat(bias_next, phi)


def make_embedded_step(balance: ca.Function, velocity: ca.Function, est: EstimatorBlocks,
                       observer: ca.Function | None = None,
                       guidance: ca.Function | None = None) -> ca.Function:
    """The embedded software's period ``ballbot_embedded_<ctrl>_<est>`` (module docstring, 2.).

    Inputs :data:`~ballbot_casadi.sim.ports.EMBEDDED_INPUTS`: the controller state ``c``
    (:func:`controller_layout`), the readings ``meas`` (:data:`MEAS`), the references
    ``q_ref, dq_ref, ddq_ref`` (balance-only mode) and ``v_ref`` (cascade), the
    controllers' and the filters' model parameters, gains, ``Ts``, the ``cascade`` and
    ``feedforward`` switches and the filter covariances (column-major).  Outputs
    :data:`~ballbot_casadi.sim.ports.EMBEDDED_OUTPUTS`: ``c_next``, ``tau_lim`` (the wheel torque command after
    the direction-preserving limit), ``tau_cmd``, ``x_hat`` (the estimate the
    controllers read), the references used, ``diag``, ``nis`` (attitude, velocity),
    ``repairs`` (covariance repairs this period) and ``rejections`` (:data:`GATE_GROUPS`:
    the measurement groups the innovation gates rejected this period).

    With ``observer`` (``ballbot_com_observer``,
    :mod:`ballbot_casadi.estimation.com_observer`, a called Function) ``c`` ends with the
    observer's state (field ``obs``), the inputs end with
    :data:`~ballbot_casadi.sim.ports.OBSERVER_CONSTANTS` (``com_observer`` switch,
    ``k_obs`` gains) and the outputs with :data:`~ballbot_casadi.sim.ports.OBSERVER_OUTPUTS`
    (``com_hat``, the estimate); the observer reads ``x_hat``
    (:func:`~ballbot_casadi.sim.period.controller_part`).

    With ``guidance`` (the period's guidance slot, e.g. the path-following MPC of
    :mod:`ballbot_casadi.sim.guided`) ``c`` carries its state ``guide`` after the
    observer's, the inputs end with ``k_guid`` and the outputs with ``v_ref_used``; it
    reads ``x_hat``.
    """
    blocks = PeriodBlocks(balance, velocity, observer, guidance)
    NP = len(PARAM_NAMES)
    Z = controller_state(blocks, NP)
    C = controller_layout(est.name, Z.size_of("z"), *(Z.size_of(f) if Z.has(f) else 0
                                                      for f in ("obs", "guide", "bal")))
    na = int(round(np.sqrt(C.size_of("Pa"))))
    nv = int(round(np.sqrt(C.size_of("Pv"))))
    M = est.readings
    nq, nr = est.attitude.size1_in(est.attitude.index_in("Q")), M.size - 3  # no encoders
    ports = embedded_ports(blocks, NP, C, M.size,
                           {"Qa": nq * nq, "Ra": nr * nr, "Qv": nv * nv, "Rv": 36})
    sym = ports.symbols()
    c, meas, Ts, p_est = sym["c"], sym["meas"], sym["Ts"], sym["p_est"]
    acc, gyro, enc = meas[M["acc"]], meas[M["gyro"]], meas[M["enc"]]
    XA, XV = C.part("xa"), VELOCITY_FILTER_STATE
    # the attitude filter reads [acc, gyro] (and the heading, thesis (4.30) with the bias)
    z_att = ca.vertcat(acc, gyro, *((meas[M["heading"]],) if M.has("heading") else ()))

    # the innovation gates' consecutive-rejection counters (filters without a gate: none)
    gate = c[C["gate"]]
    n_att = len(ATTITUDE_GATE.groups)
    gate_in = {"att": {"n_rej": gate[:n_att]} if "n_rej" in est.attitude.name_in() else {},
               "vel": {"n_rej": gate[n_att:]} if "n_rej" in est.velocity.name_in() else {}}
    # the velocity filter's last acceleration estimate compensates the accelerometer
    xv_prev = c[C["xv"]]
    att = est.attitude(xhat=c[C["xa"]], P=ca.reshape(c[C["Pa"]], na, na), z=z_att,
                       Q=ca.reshape(sym["Qa"], nq, nq), R=ca.reshape(sym["Ra"], nr, nr), dt=Ts,
                       p=p_est, a=ca.vertcat(xv_prev[XV["a"]], 0), **gate_in["att"])
    xa = att["xhat_next"]
    # a velocity filter with the body-rate covariance input (the matched model) predicts the
    # encoders with the period's gyroscope reading and its noise covariance (the attitude
    # filter's gyro block of Ra, plus a third of its rate process noise: the rate's change
    # within the period), the same covariance driving its accelerometer-offset walk
    # (estimation.velocity.attitude_offset_noise); in a gyro dropout with the attitude
    # filter's rate and covariance
    # (the rate block of its covariance: the tangent has one entry less than the state
    # on S^3, the additive chart of the QEKF none): estimation.velocity.encoder_rate
    r0 = XA.offset("omega") - (XA.size - na)
    # the velocity filter reads the attitude [q, omega] (a bias state of the attitude
    # filter is not the velocity filter's)
    xa_qw = xa if XA.size == ATTITUDE_FILTER_STATE.size else xa[:ATTITUDE_FILTER_STATE.size]
    rate, att_v = {}, xa_qw
    if "P_rate" in est.velocity.name_in():
        if (nr, nq) != (ATTITUDE_MEAS.size, ATTITUDE_NOISE.size):
            raise BuildError(f"{est.velocity.name()} with the gyro-rate input needs the attitude "
                             f"filter's R and Q in the layouts {ATTITUDE_MEAS} and "
                             f"{ATTITUDE_NOISE}, got {nr} x {nr} and {nq} x {nq}")
        g, w = ATTITUDE_MEAS["gyro"], ATTITUDE_NOISE["omega"]  # Ra's gyro block, Qa's rate block
        w_enc, P_rate = encoder_rate(xa[XA["omega"]], att["P_next"][r0:r0 + 3, r0:r0 + 3], gyro,
                                     ca.reshape(sym["Ra"], nr, nr)[g, g],
                                     ca.reshape(sym["Qa"], nq, nq)[w, w])
        rate, att_v = {"P_rate": P_rate}, ca.vertcat(xa[XA["q"]], w_enc)
    if "walk" in est.velocity.name_in():  # the adapted acceleration random walk (a state)
        rate["walk"] = c[C["walk"]]
    vel = est.velocity(xhat=xv_prev, P=ca.reshape(c[C["Pv"]], nv, nv), z=ca.vertcat(enc * Ts, acc),
                       att=att_v, P_att=att["P_att"], Q=ca.reshape(sym["Qv"], nv, nv),
                       R=ca.reshape(sym["Rv"], 6, 6), dt=Ts, p=p_est, **rate, **gate_in["vel"])
    xv = vel["xhat_next"]
    no_gate = ca.DM.zeros(n_att), ca.DM.zeros(GATE_GROUPS.size - n_att)
    rejected = ca.vertcat(*(f.get("rejected", z0) for f, z0 in zip((att, vel), no_gate)))
    gate_next = ca.vertcat(*(f.get("n_rej_next", z0) for f, z0 in zip((att, vel), no_gate)))
    # the velocity filter's horizontal accelerometer bias is the attitude filter's slow
    # tilt error (velocity-aided tilt, estimation.tilt_aiding): the controllers read q_c
    q_hat = est.tilt_correction(q=xa[XA["q"]], a=xv[XV["a"]], b_acc=xv[XV["b_acc"]], p=p_est)["q_c"]
    w_hat, v_hat = xa[XA["omega"]], xv[XV["v"]]
    pos = c[C["pos"]] + Ts * v_hat
    x_hat = ca.vertcat(pos, q_hat, v_hat, 0.5 * Q.mul(q_hat, ca.vertcat(0, w_hat)))  # STATE layout

    z_parts = [c[C[f]] for f in Z.fields]
    z_ctrl = z_parts[0] if len(z_parts) == 1 else ca.vertcat(*z_parts)
    ctrl = controller_part(blocks, x_hat, z_ctrl, sym, sym)
    z_next = ctrl["z_next"]
    if len(Z.fields) > 1:
        z_next = z_next[Z["z"]]
    after = [ctrl["z_next"][Z[f]] for f in Z.fields[1:]]
    walk = (vel["walk_next"],) if C.has("walk") else ()
    c_next = ca.vertcat(z_next, xa, ca.vec(att["P_next"]), xv, ca.vec(vel["P_next"]), pos,
                        gate_next, *walk, *after)
    outs = {"c_next": c_next, "x_hat": x_hat, "nis": ca.vertcat(att["nis"], vel["nis"]),
            "repairs": att["n_repair"] + vel["n_repair"], "rejections": rejected, **ctrl}
    return ports.function(f"ballbot_embedded_{blocks.name}_{est.name}", sym, outs)


@lru_cache(maxsize=None)
def _shared_controllers() -> tuple[ca.Function, ca.Function, ca.Function]:
    """The input-affine model, the velocity controller and the COM observer, built once
    (every embedded Function and mission step shares them: one copy each in C)."""
    return make_affine(), make_velocity_controller(), make_com_observer()


@lru_cache(maxsize=None)
def _estimator(estimator: str) -> EstimatorBlocks:
    return estimator_blocks(estimator, make_ode(), make_wheel_speeds())


def software_blocks(controller: str, estimator: str, observer: bool = True
                    ) -> tuple[PeriodBlocks, EstimatorBlocks]:
    """The controller blocks and the estimator Functions of the package's embedded
    software (built once per process and shared).

    Raises
    ------
    ScenarioError
        Unknown controller or estimator (the message lists the allowed ones).
    """
    if estimator not in ESTIMATOR_FILTERS:
        raise ScenarioError(f"unknown estimator {estimator!r}; the embedded software reads "
                            f"sensors: allowed {', '.join(ESTIMATOR_FILTERS)}")
    return controller_blocks(controller, observer), _estimator(estimator)


def controller_blocks(controller: str = "flc", observer: bool = True) -> PeriodBlocks:
    """The controller blocks alone (balance controller, velocity LQR, COM observer unless
    ``observer`` is false), for loops that read the true state and for prediction models:
    no estimator is built.  The same shared Functions :func:`software_blocks` returns.

    Raises
    ------
    ScenarioError
        Unknown controller (the message lists the allowed ones).
    """
    if controller not in BALANCE_CONTROLLERS:
        raise ScenarioError(f"unknown controller {controller!r}; allowed: "
                            f"{', '.join(BALANCE_CONTROLLERS)}")
    _, velocity, obs = _shared_controllers()
    return PeriodBlocks(_balance(controller), velocity, obs if observer else None)


@lru_cache(maxsize=None)
def _balance(controller: str) -> ca.Function:
    return BALANCE_CONTROLLERS[controller](_shared_controllers()[0])


@lru_cache(maxsize=None)
def embedded_software(controller: str = "flc", estimator: str = DEFAULT_ESTIMATOR,
                      observer: bool = True, guidance: ca.Function | None = None) -> ca.Function:
    """The package's embedded software ``ballbot_embedded_<controller>_<estimator>``
    (:func:`make_embedded_step`, with the COM observer unless ``observer`` is false, and
    the period's ``guidance`` block when given), built once per process and per block:
    the compiled mission, the controller FMU and the firmware use this one Function, and
    asking for it builds no mission.

    Raises
    ------
    ScenarioError
        Unknown controller or estimator (the message lists the allowed ones).
    """
    blocks, est = software_blocks(controller, estimator, observer)
    return make_embedded_step(blocks.balance, blocks.velocity, est, blocks.observer, guidance)


def make_initial_controller_state(estimator: str, observer: bool = True,
                                  n_bal: int = 0) -> ca.Function:
    """``ballbot_initial_controller_state_<estimator>[_obs]``: the embedded software's state
    ``c`` at power-on (:func:`controller_layout`) from the robot's state ``x0`` and the
    controllers' model ``p_ctrl``; the compiled mission starts from it and the controller
    FMU evaluates its generated C at initialisation.

    * ``z``: the velocity controller's reference at the measured tilt and heading, tilt
      rates and position error zero (a bumpless start,
      :func:`~ballbot_casadi.control.velocity.velocity_initial_state`);
    * the filters aligned with the initial attitude, body rate ``omega = 2 vec(q* o dq)``
      and velocity (as after the robot's start-up calibration at rest) with the thesis's
      initial covariances (4.4, 5.4; the QEKF's ``G P0 G^T + radial blkdiag(q q^T, 0)``)
      and a zero accelerometer-bias estimate (and z gyro-bias estimate, ``ukf_heading``);
      the position estimate at the true position; no innovation-gate rejections yet
      (``gate`` zero);
    * with ``observer``, the COM observer's state: the model's COM offset as both
      estimates, the measurement filters at the initial attitude's static measurement,
      ball velocity and body rate
      (:func:`~ballbot_casadi.estimation.com_observer.com_observer_initial_state`).

    The attitude quaternion of ``x0`` is normalised first.  Inputs ``x0`` (12),
    ``p_ctrl`` (:data:`~ballbot_casadi.core.params.PARAM_NAMES`); output ``c0``.

    Raises
    ------
    ScenarioError
        Unknown estimator.
    """
    filters = _filters_of(estimator)  # refuses an unknown estimator (ScenarioError)
    att, vel = (DEFAULT_TUNING[f] for f in filters)
    x0 = ca.SX.sym("x0", STATE.size)
    p = ca.SX.sym("p_ctrl", len(PARAM_NAMES))
    q = x0[STATE["q"]] / ca.norm_2(x0[STATE["q"]])
    dq = x0[STATE["dq"]]
    # velocity controller: reference = measured tilt and heading
    th = measured_tilt(q)
    qz = Q.mul(Q.conj(tilt_heading_quaternion(th[0], th[1], 0.0)), q)
    z = {"theta_r": th, "psi_r": 2 * ca.atan2(qz[3], qz[0])}
    parts: dict[str, Any] = {"z": ca.vertcat(*(
        z.get(f, ca.SX.zeros(VELOCITY_CONTROLLER_STATE.size_of(f)))
        for f in VELOCITY_CONTROLLER_STATE.fields))}
    # filters
    omega = 2 * Q.vee(Q.mul(Q.conj(q), dq))
    Pa = ca.DM(att.P0)
    if filters[0] in _ADDITIVE_FILTERS:  # around the initial attitude
        P7 = ca.mtimes([tangent_map(q), ca.DM(QUKF_P0), tangent_map(q).T])
        P7[:4, :4] += QEKF_P0_RADIAL * ca.mtimes(q, q.T)
        Pa = ca.diagcat(P7, ca.DM(att.P0[7:, 7:])) if att.P0.shape[0] > 7 else P7
    xv = {f: ca.DM(vel.x0[VELOCITY_FILTER_STATE[f]]) for f in VELOCITY_FILTER_STATE.fields}
    xv["v"] = x0[STATE_DXY]
    # the heading-aided filter's z gyro bias estimate starts at zero (HEADING_P0_BIAS)
    xa = ca.vertcat(q, omega, ca.SX.zeros(att.x0.size - ATTITUDE_FILTER_STATE.size))
    parts.update({"xa": xa, "Pa": ca.vec(Pa),
                  "xv": ca.vertcat(*(xv[f] for f in VELOCITY_FILTER_STATE.fields)),
                  "Pv": ca.vec(ca.DM(vel.P0)), "pos": x0[STATE_XY],
                  "gate": ca.DM.zeros(GATE_GROUPS.size), "walk": ca.DM.zeros(WALK_SIZE)})
    # COM observer
    if observer:
        pi = {n: PARAM_NAMES.index(n) for n in ("com_x", "com_y", "l")}
        R = Q.rotation_matrix(q)
        Rh, rhs = R[0:2, 0:2], -p[pi["l"]] * R[0:2, 2]
        com = ca.vertcat(p[pi["com_x"]], p[pi["com_y"]])
        o = {"com_bal": com, "com": com, "s_f": ca.solve(Rh, rhs), "v_f": x0[STATE_DXY],
             "w_f": 2 * Q.vee(Q.mul(dq, Q.conj(q)))[0:2]}
        parts["obs"] = ca.vertcat(*(o[f] for f in COM_OBSERVER_STATE.fields))
    if n_bal:  # the balance controller's own state starts at rest
        parts["bal"] = ca.SX.zeros(n_bal)
    L = controller_layout(estimator, VELOCITY_NZ, COM_OBSERVER_STATE.size if observer else 0,
                          n_bal=n_bal)
    for f in L.fields:
        if parts[f].numel() != L.size_of(f):
            raise BuildError(f"initial controller state: field {f} has {parts[f].numel()} "
                             f"entries, the layout {L.size_of(f)}")
    name = (f"ballbot_initial_controller_state_{estimator}{'_obs' if observer else ''}"
            f"{f'_bal{n_bal}' if n_bal else ''}")
    return ca.Function(name, [x0, p], [ca.vertcat(*(parts[f] for f in L.fields))],
                       ["x0", "p_ctrl"], ["c0"])


@lru_cache(maxsize=None)
def initial_controller_state_function(estimator: str, observer: bool = True,
                                      n_bal: int = 0) -> ca.Function:
    """:func:`make_initial_controller_state`, built once per process (the mission, the
    controller FMU and the firmware use this one Function)."""
    return make_initial_controller_state(estimator, observer, n_bal)


def initial_controller_state(estimator: str, x0: Any, p_ctrl: Any,
                             observer: bool = True, n_bal: int = 0) -> np.ndarray:
    """The embedded software's state at power-on, evaluated by
    :func:`initial_controller_state_function` (a float vector in :func:`controller_layout`).

    Raises
    ------
    ShapeError
        ``x0`` not a finite 12-state or ``p_ctrl`` of the wrong size.
    """
    x = np.asarray(x0, float).ravel()
    p = np.asarray(p_ctrl, float).ravel()
    if x.shape != (STATE.size,) or not np.all(np.isfinite(x)):
        raise ShapeError(f"x0 must be a finite 12-state, got shape {x.shape}")
    if p.shape != (len(PARAM_NAMES),):
        raise ShapeError(f"p_ctrl must have {len(PARAM_NAMES)} entries, got {p.size}")
    f = initial_controller_state_function(estimator, observer, n_bal)
    return np.asarray(f(x, p), float).ravel()


def initial_estimator_state(estimator: str, x0: np.ndarray) -> np.ndarray:
    """The filters' part of ``c`` at the start of a run (:func:`estimator_layout`), from
    :func:`initial_controller_state_function` (the filters do not depend on ``p_ctrl``)."""
    c = initial_controller_state(estimator, x0, np.zeros(len(PARAM_NAMES)), observer=False)
    L = controller_layout(estimator, VELOCITY_NZ)
    return np.concatenate([c[L[f]] for f in estimator_layout(estimator).fields])

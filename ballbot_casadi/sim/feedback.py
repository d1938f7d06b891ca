"""What the controllers read: noisy sensors and the estimators (thesis Fig. 9.8, §9.3).

With an estimator in the loop, the plant state carries the three wheel angles as well
(``[x; phi]``, 15 entries, integrated with the plant) and every control period starts
with the robot's sensing and estimation:

1. **sensors** at ``t_k`` (after a push), thesis §3.1: the IMU
   (``ballbot_imu``: specific force at the IMU including the body's own acceleration,
   scale, bias, misalignment, noise) with the torque that acted on the plant just
   before ``t_k``, the gyroscope bias ``b_k`` (random walk, ``ballbot_gyro_bias_step``)
   and the encoders (``ballbot_encoders``: wheel angles quantised to ``n_ticks`` per
   revolution, differenced over the period).  Standard-normal noise enters as the
   per-period input ``noise = [n_acc, n_gyro, n_rw]``;
2. **dropouts**: the per-period input ``valid = [acc, gyro, enc]`` (1 available, 0 not)
   replaces missing readings by NaN, which the filters treat as predict-only for that
   sensor;
3. **attitude filter** (QUKF thesis ch. 4, or the predecessor's QEKF) on
   ``[acc, gyro]`` - its accelerometer prediction compensated by the velocity filter's
   last estimate of the ball's acceleration (the thesis's model (4.29) takes the
   accelerometer as measuring gravity only, which tilts the estimate by ``atan(a/g)``
   whenever the ball accelerates) - then the **velocity filter** (VUKF ch. 5, or VEKF) on the encoder
   tick increments and the accelerometer, with the attitude estimate and covariance;
4. the **estimate** the controllers read: ``x_hat = [pos, q, v, dq]`` with ``q, omega``
   from the attitude filter (``dq = 1/2 q o [0, omega]``), the velocity from the
   velocity filter, and the position by integrating that velocity (the robot has no
   position sensor, so it drifts).

The carried feedback state ``e`` is the layout :func:`feedback_layout`.  The sensors
belong to the plant (plant parameters ``p_plant`` and sensor parameters ``s``); the
filters run on their own model parameters ``p_est``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

import casadi as ca
import numpy as np

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import STATE, STATE_DXY, STATE_XY, Layout
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.estimation import DEFAULT_TUNING, initial_state

__all__ = [
    "ESTIMATOR_FILTERS",
    "NOISE",
    "VALID",
    "N_WHEEL",
    "EstimatorBlocks",
    "feedback_layout",
    "sense_and_estimate",
    "FEEDBACK_OUTPUTS",
]

#: Filters of each estimator choice: (attitude filter, velocity filter).
ESTIMATOR_FILTERS: Mapping[str, tuple[str, str]] = {"ukf": ("qukf", "vukf"), "ekf": ("qekf", "vekf")}
#: Per-period standard-normal noise input of the sensors.
NOISE = Layout("sensor noise", [("acc", 3), ("gyro", 3), ("gyro_rw", 3)])
#: Per-period sensor availability (1 = reading available, 0 = missing).
VALID = Layout("sensor availability", [("acc", 1), ("gyro", 1), ("enc", 1)])
#: Wheel angles appended to the plant state.
N_WHEEL = 3
#: Per-period outputs of the feedback stage (logged).
FEEDBACK_OUTPUTS = ("x_hat", "meas", "nis", "repairs")


@dataclass(frozen=True)
class EstimatorBlocks:
    """The sensing and estimation Functions of one estimator choice.

    Attributes
    ----------
    imu, bias_step, encoders
        ``ballbot_imu``, ``ballbot_gyro_bias_step``, ``ballbot_encoders``
        (:mod:`ballbot_casadi.model.sensors`).
    attitude, velocity
        The filters (``ballbot_qukf``/``ballbot_qekf``, ``ballbot_vukf``/``ballbot_vekf``).
    name
        ``"ukf"`` or ``"ekf"``.
    """

    imu: ca.Function
    bias_step: ca.Function
    encoders: ca.Function
    attitude: ca.Function
    velocity: ca.Function
    name: str

    @property
    def n_att_cov(self) -> int:
        """Side of the attitude filter's covariance matrix (6 for the QUKF, 7 for the QEKF)."""
        return self.attitude.size1_in(1)


def feedback_layout(estimator: str) -> Layout:
    """Layout of the carried feedback state ``e`` of estimator choice ``"ukf"`` or ``"ekf"``.

    ``tau_prev`` (torque that acted on the plant in the previous period), ``bias``
    (gyroscope bias), ``phi_prev`` (wheel angles at the previous sample), the attitude
    filter's state and covariance (column-major), the velocity filter's, and the
    integrated position estimate.
    """
    if estimator not in ESTIMATOR_FILTERS:
        raise ScenarioError(f"unknown estimator {estimator!r}; allowed: {', '.join(ESTIMATOR_FILTERS)}")
    att, vel = (DEFAULT_TUNING[f] for f in ESTIMATOR_FILTERS[estimator])
    return Layout("feedback state e", [
        ("tau_prev", 3), ("bias", 3), ("phi_prev", N_WHEEL),
        ("xa", att.x0.size), ("Pa", att.P0.size), ("xv", vel.x0.size), ("Pv", vel.P0.size),
        ("pos", 2),
    ])


def _drop(y: Any, ok: Any) -> Any:
    """``y`` where ``ok``, NaN otherwise (the filters skip non-finite components)."""
    return ca.if_else(ok > 0.5, y, ca.DM.nan(y.numel()))


def sense_and_estimate(
    blocks: EstimatorBlocks,
    xk: ca.MX,
    e: ca.MX,
    seq: Mapping[str, Any],
    const: Mapping[str, Any],
) -> dict[str, Any]:
    """Sensors, dropouts and both filters for one period (symbolic; see the module docstring).

    Parameters
    ----------
    xk
        Plant state with wheel angles at ``t_k`` after the push (15).
    e
        Feedback state (:func:`feedback_layout`).
    seq
        This period's ``noise`` (:data:`NOISE`) and ``valid`` (:data:`VALID`).
    const
        ``p_plant``, ``s`` (sensor parameters), ``p_est``, ``Qa``, ``Ra``, ``Qv``,
        ``Rv``, ``Ts``.

    Returns
    -------
    dict
        ``x_hat`` (12, what the controllers read), ``e_next`` (with ``tau_prev`` still
        to be set by the caller), ``meas`` (9: acc, gyro, encoder rates as read),
        ``nis`` (2: attitude, velocity), ``repairs`` (covariance repairs this period).
    """
    if not isinstance(xk, ca.MX) or xk.numel() != STATE.size + N_WHEEL:
        raise ScenarioError("sense_and_estimate needs the symbolic plant state with wheel angles")
    L = feedback_layout(blocks.name)
    x12, phi = xk[:STATE.size], xk[STATE.size:]
    noise, valid = seq["noise"], seq["valid"]
    p_plant, s, p_est, Ts = const["p_plant"], const["s"], const["p_est"], const["Ts"]

    acc, gyro = blocks.imu(x12, e[L["tau_prev"]], p_plant, s, e[L["bias"]],
                           noise[NOISE["acc"]], noise[NOISE["gyro"]])
    enc, dticks = blocks.encoders(phi, e[L["phi_prev"]], p_plant, Ts)
    acc_m = _drop(acc, valid[VALID.index("acc")])
    gyro_m = _drop(gyro, valid[VALID.index("gyro")])
    dticks_m = _drop(dticks, valid[VALID.index("enc")])

    na, nv = blocks.n_att_cov, blocks.velocity.size1_in(1)
    Pa = ca.reshape(e[L["Pa"]], na, na)
    # the velocity filter's last acceleration estimate compensates the accelerometer
    a_prev = ca.vertcat(e[L["xv"]][2:4], 0)
    att = blocks.attitude(xhat=e[L["xa"]], P=Pa, z=ca.vertcat(acc_m, gyro_m),
                          Q=const["Qa"], R=const["Ra"], dt=Ts, p=p_est, a=a_prev)
    xa = att["xhat_next"]
    Pv = ca.reshape(e[L["Pv"]], nv, nv)
    vel = blocks.velocity(xhat=e[L["xv"]], P=Pv, z=ca.vertcat(dticks_m, acc_m), att=xa,
                          P_att=att["P_att"], Q=const["Qv"], R=const["Rv"], dt=Ts, p=p_est)
    xv = vel["xhat_next"]

    q_hat, w_hat, v_hat = xa[0:4], xa[4:7], xv[0:2]
    pos = e[L["pos"]] + Ts * v_hat
    dq_hat = 0.5 * Q.mul(q_hat, ca.vertcat(0, w_hat))
    x_hat = ca.vertcat(pos, q_hat, v_hat, dq_hat)

    e_next = ca.vertcat(
        e[L["tau_prev"]],  # set by the caller once the period's torque is known
        blocks.bias_step(e[L["bias"]], s, Ts, noise[NOISE["gyro_rw"]]),
        phi,
        xa, ca.vec(att["P_next"]),
        xv, ca.vec(vel["P_next"]),
        pos,
    )
    return {
        "x_hat": x_hat,
        "e_next": e_next,
        "meas": ca.vertcat(acc_m, gyro_m, enc),
        "nis": ca.vertcat(att["nis"], vel["nis"]),
        "repairs": att["n_repair"] + vel["n_repair"],
    }


def initial_feedback_state(estimator: str, x0: np.ndarray, bias0: np.ndarray) -> np.ndarray:
    """The feedback state ``e`` at the start of a run.

    The filters start aligned with the robot's initial attitude, body rate and velocity
    (as after the robot's start-up calibration at rest) with the thesis's initial
    covariances (4.4, 5.4) and zero accelerometer-bias estimate; the position estimate
    starts at the true position, the wheel angles and the previous torque at zero.
    """
    L = feedback_layout(estimator)
    att, vel = ESTIMATOR_FILTERS[estimator]
    x0 = np.asarray(x0, float).reshape(-1)
    q = x0[STATE["q"]] / np.linalg.norm(x0[STATE["q"]])
    omega = 2 * Q.vee(Q.mul(Q.conj(q), x0[STATE["dq"]]))
    xa0, Pa0 = initial_state(att, np.concatenate([q, omega]))
    xv_default, Pv0 = initial_state(vel)
    xv0 = xv_default.copy()
    xv0[0:2] = x0[STATE_DXY]
    e = np.zeros(L.size)
    e[L["bias"]] = bias0
    e[L["xa"]] = xa0
    e[L["Pa"]] = np.asarray(Pa0, float).ravel(order="F")
    e[L["xv"]] = xv0
    e[L["Pv"]] = np.asarray(Pv0, float).ravel(order="F")
    e[L["pos"]] = x0[STATE_XY]
    return e


__all__ += ["initial_feedback_state"]

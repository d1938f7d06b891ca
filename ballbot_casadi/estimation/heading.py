"""Heading-aided attitude filter: the QUKF with a heading reading and the z gyro bias as a state.

The thesis's QUKF (ch. 4, :mod:`~ballbot_casadi.estimation.attitude`) cannot observe the
heading: the accelerometer sees only the gravity direction, so the yaw is the integral
of the z gyroscope and drifts with its bias (§3.1, §4.2; ch. 11 lists the heading
correction as future work).  With an absolute heading reading (the heading sensor of
:func:`~ballbot_casadi.model.sensors.make_heading_sensor`) the bias becomes observable
and is carried as a state, the gyroscope model of thesis (3.7)/(4.30) with its bias:

* state ``x = [q, omega, b_z]`` (8) on ``S^3 x R^4``
  (:func:`~ballbot_casadi.estimation.manifold.attitude` with ``n_vec = 4``), tangent
  ``[rotation vector (body), omega, b_z]`` (7);
* process (4.14-4.18): constant rate, ``q_k = q_{k-1} o exp(omega dt / 2)``; the bias
  a random walk (its variance per period is the last entry of ``Q``: ``sigma_rw^2 dt``
  for the sensor's bias random walk, thesis (3.9));
* measurement ``z = [acc (m/s^2), gyro (rad/s), yaw (rad)]`` (7)::

      h = [R(q)^T e_z + a_B / g,  omega + [0, 0, b_z],  wrap(yaw(q) - yaw_prior)]

  the first two blocks the QUKF's (4.29), (4.30) with the bias; the heading is compared
  relative to the prior estimate's yaw ``yaw_prior`` (the same for every sigma point),
  and the reading is passed as ``wrap(yaw - yaw_prior)``: the innovation is then the
  wrapped angle difference and no sigma point crosses the ``±pi`` cut.  Per sigma point
  the relative heading is one ``atan2`` of ``v conj(v_prior)``, ``v = (cos yaw, sin yaw)``
  up to a positive factor (the arguments of the yaw's ``atan2``), not two ``atan2`` and a
  ``sin``/``cos`` pair.  A missing heading reading (NaN, the sensor samples at a low rate)
  makes this a QUKF period with the bias predicted only: that period runs the
  accelerometer and gyroscope update alone (a conditional, no heading predictions), equal
  to the masked 7-component update.

The accelerometer is normalised by ``g`` and compensated by the given acceleration as in
:func:`~ballbot_casadi.estimation.attitude.make_qukf` (``compensate_acceleration``).
The filter uses the generic UKF step of :mod:`~ballbot_casadi.estimation.core` unchanged.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
from scipy.linalg import block_diag

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import Layout
from ballbot_casadi.core.params import PARAM_NAMES, ParamView
from ballbot_casadi.estimation.core import OUTPUT_NAMES, FilterModel, flat_function, ukf_step
from ballbot_casadi.estimation.linalg import FINITE_MAX
from ballbot_casadi.estimation.manifold import attitude
from ballbot_casadi.estimation.quaternion_mean import MEAN_ITERATIONS
from ballbot_casadi.estimation.tuning import QUKF_P0, QUKF_Q, QUKF_R, QUKF_X0, read_only

__all__ = [
    "HEADING_FILTER_STATE",
    "HEADING_MEAS",
    "HEADING_INPUT_NAMES",
    "HEADING_OUTPUT_NAMES",
    "heading_tuning",
    "make_qukf_heading",
    "HEADING_P0_BIAS",
]

#: State of the heading-aided attitude filter: the QUKF's ``[q, omega]`` and the z gyro bias.
HEADING_FILTER_STATE = Layout("heading-aided attitude filter state", [("q", 4), ("omega", 3),
                                                                      ("b_z", 1)])
#: Its measurement: accelerometer, gyroscope, heading (NaN = missing).
HEADING_MEAS = Layout("heading-aided attitude measurement", [("acc", 3), ("gyro", 3), ("yaw", 1)])
#: Inputs of ``ballbot_qukf_heading``.
HEADING_INPUT_NAMES = ("xhat", "P", "z", "Q", "R", "dt", "p", "a")
#: Outputs: the core outputs plus ``P_att`` (3x3 attitude covariance, as the QUKF's).
HEADING_OUTPUT_NAMES = (*OUTPUT_NAMES, "P_att")
#: Initial variance of the bias state, (rad/s)^2: a calibrated gyroscope's residual
#: zero-rate offset of about 0.1 deg/s (1 sigma).
HEADING_P0_BIAS = float(np.radians(0.1) ** 2)

_NP = len(PARAM_NAMES)
_NX, _ND, _NZ = HEADING_FILTER_STATE.size, HEADING_FILTER_STATE.size - 1, HEADING_MEAS.size


def _wrap(a: ca.SX) -> ca.SX:
    return ca.atan2(ca.sin(a), ca.cos(a))


def _heading_vector(q: ca.SX) -> ca.SX:
    """The x and y arguments of the yaw's ``atan2`` in
    :func:`~ballbot_casadi.core.quaternion.to_rpy`: ``(cos yaw, sin yaw)`` times a positive
    factor."""
    q0, q1, q2, q3 = (q[i] for i in range(4))
    return ca.vertcat(1 - 2 * (q2**2 + q3**2), 2 * (q0 * q3 + q1 * q2))


def _models() -> tuple[ca.Function, ca.Function, ca.Function]:
    """Process and measurement models, the latter with and without the heading;
    ``u = [a_B / g (3), heading vector of the prior (2)]``."""
    x, u, dt, p = ca.SX.sym("x", _NX), ca.SX.sym("u", 5), ca.SX.sym("dt"), ca.SX.sym("p", _NP)
    X = HEADING_FILTER_STATE
    q, w, b = x[X["q"]], x[X["omega"]], x[X["b_z"]]
    f = ca.Function("att_heading_process", [x, u, dt, p],
                    [ca.vertcat(Q.mul(q, Q.exp(0.5 * dt * w)), w, b)], ["x", "u", "dt", "p"],
                    ["x_next"], {"cse": True})
    g_b = Q.rotate_inv(q, ca.DM([0.0, 0.0, 1.0])) + u[:3]
    gyro = w + ca.vertcat(0, 0, b)
    # wrap(yaw(q) - yaw_prior) as the angle of v conj(v_prior) (one atan2, no sin/cos)
    v, v0 = _heading_vector(q), u[3:5]
    yaw = ca.atan2(v[1] * v0[0] - v[0] * v0[1], v[0] * v0[0] + v[1] * v0[1])
    h = ca.Function("att_heading_measurement", [x, u, dt, p], [ca.vertcat(g_b, gyro, yaw)],
                    ["x", "u", "dt", "p"], ["z"], {"cse": True})
    h_imu = ca.Function("att_heading_measurement_imu", [x, u, dt, p], [ca.vertcat(g_b, gyro)],
                        ["x", "u", "dt", "p"], ["z"], {"cse": True})
    return f, h, h_imu


def _period(mean_iterations: int, with_heading: bool) -> ca.Function:
    """One filter period with the heading reading in the update, or (``with_heading``
    False) with the accelerometer and gyroscope only: the period without a reading, whose
    masked 7-component update equals this 6-component one (the heading is the last
    component), so skipping the heading's sigma-point predictions changes no result."""
    f, h, h_imu = _models()
    model = FilterModel(attitude(mean_iterations, n_vec=4), f, h if with_heading else h_imu,
                        noise="pre")
    xhat, P, z = ca.MX.sym("xhat", _NX), ca.MX.sym("P", _ND, _ND), ca.MX.sym("z", _NZ)
    Qn, R = ca.MX.sym("Q", _ND, _ND), ca.MX.sym("R", _NZ, _NZ)
    dt, p, a = ca.MX.sym("dt"), ca.MX.sym("p", _NP), ca.MX.sym("a", 3)
    q_prior = xhat[HEADING_FILTER_STATE["q"]]
    u = ca.vertcat(Q.rotate_inv(q_prior, a) / ParamView(p).g, _heading_vector(q_prior))
    M = HEADING_MEAS
    zn = ca.vertcat(z[M["acc"]] / ParamView(p).g, z[M["gyro"]])
    if with_heading:
        zn = ca.vertcat(zn, _wrap(z[M["yaw"]] - Q.to_rpy(q_prior)[2]))
        out = ukf_step(model, xhat, P, zn, u, Qn, R, dt, p, kappa=0.0)
    else:
        n = zn.numel()
        out = ukf_step(model, xhat, P, zn, u, Qn, R[:n, :n], dt, p, kappa=0.0)
        out["nu"] = ca.vertcat(out["nu"], ca.MX.zeros(_NZ - n))
    return flat_function(f"qukf_heading_{'with' if with_heading else 'without'}_reading",
                         [xhat, P, z, Qn, R, dt, p, a],
                         [*(out[k] for k in OUTPUT_NAMES), out["P_next"][:3, :3]],
                         list(HEADING_INPUT_NAMES), list(HEADING_OUTPUT_NAMES))


def make_qukf_heading(mean_iterations: int = MEAN_ITERATIONS) -> ca.Function:
    """``ballbot_qukf_heading``: one period of the heading-aided QUKF (module docstring).

    A period without a heading reading (non-finite ``z[6]``, most periods: the sensor
    samples at a low rate) runs the 6-component update only (a conditional in the
    generated C), with the same results as the masked 7-component one.

    Returns
    -------
    casadi.Function
        ``(xhat[8], P[7x7], z[7], Q[7x7], R[7x7], dt, p[NP], a[3]) -> (xhat_next[8],
        P_next[7x7], nu[7], nis, n_valid, n_repair, P_att[3x3])``: ``z = [acc (m/s^2),
        gyro (rad/s), yaw (rad)]`` (non-finite components unused), ``R`` with the
        accelerometer block in units of g^2 (as the QUKF's) and the heading variance
        last, ``a`` the IMU's linear acceleration in {K} (m/s^2) removed from the
        accelerometer's prediction (zero: the thesis's model).
    """
    full = _period(mean_iterations, with_heading=True)
    step = ca.Function.conditional("qukf_heading_period",
                                   [_period(mean_iterations, with_heading=False)], full)
    args = full.mx_in()
    z = args[HEADING_INPUT_NAMES.index("z")]
    has_reading = ca.fabs(z[HEADING_MEAS["yaw"]]) <= FINITE_MAX  # case 0: no reading
    return ca.Function("ballbot_qukf_heading", args, step(has_reading, *args),
                       list(HEADING_INPUT_NAMES), list(HEADING_OUTPUT_NAMES))


def heading_tuning(heading_var: float, bias_rw: float, dt: float
                   ) -> dict[str, np.ndarray]:
    """``Q``, ``R``, ``P0``, ``x0`` of the heading-aided filter: the thesis's QUKF tuning
    (4.3, 4.4, 4.37-4.40) extended by the bias random walk ``bias_rw^2 dt`` (rad/s/sqrt(s),
    thesis (3.9), the sensor's ``gyro_bias_rw``), the heading variance ``heading_var``
    (rad^2, the sensor's ``heading_noise_var``) and the initial bias variance
    :data:`HEADING_P0_BIAS`."""
    return {"Q": read_only(block_diag(QUKF_Q, [[bias_rw ** 2 * dt]])),
            "R": read_only(block_diag(QUKF_R, [[heading_var]])),
            "P0": read_only(block_diag(QUKF_P0, [[HEADING_P0_BIAS]])),
            "x0": read_only(np.concatenate([QUKF_X0, [0.0]]))}

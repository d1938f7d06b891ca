"""The predecessor's attitude EKF as the thesis describes it: heading correction and gyro-bias states.

The thesis compares its QUKF with the QEKF of the V2019 robot [thesis ref. 6] (§6.1,
§6.3): "the UKF with no heading available produces as accurate estimations as the EKF
that has heading readings available for correction", and explains the VEKF's "slightly
better performance in the y-axis velocity" by "a heading correction in the QEKF".  The
baseline :func:`~ballbot_casadi.estimation.attitude.make_qekf` has neither the heading
reading nor the bias states; this module builds the predecessor's filter with both, in
its own algorithm (the V2019 QEKF, public as ``Estimators/QEKF/QEKF.m`` of the Kugle
MATLAB repository; non-sensor-driven mode, bias estimation on):

* state ``x = [q, omega, b]`` (10) on the additive chart (no quaternion algebra in the
  covariance: ``P`` is 10 x 10 on ``[q0..q3, omega, b]``);
* process: forward Euler ``q_k = q + dt 1/2 Phi(q) [0; omega]``, ``omega`` and ``b``
  constant; the process noise is added to the predicted covariance,
  ``Q = blkdiag(0_4, sigma2_omega I3, sigma2_bias dt I3)`` (the quaternion block zero:
  its uncertainty enters through the rate);
* measurement ``z = [acc / g, gyro, heading]`` (7)::

      h = [R(q)^T e_z + a_B / g,  omega + b,  atan2(2 (q0 q3 + q1 q2), q0^2 + q1^2 - q2^2 - q3^2)]

  the accelerometer "nominally normalised" by ``g`` as the predecessor did, the gyroscope
  with its bias (thesis (4.30) with the bias of (3.7)), the heading as the azimuth of the
  body x axis (the ZYX yaw; the formula is invariant to the norm of ``q``, which the
  additive chart does not keep);
* the quaternion renormalised after every correction (the predecessor's "forced unitary
  norm", thesis §6.3).

Departures from the V2019 code, each for a stated reason: the heading innovation is
wrapped to ``(-pi, pi]`` (the predecessor subtracts the angles, a 2 pi jump at the cut;
here the reading is passed relative to the prior's heading, as in
:mod:`~ballbot_casadi.estimation.heading`); the Jacobians come from CasADi AD instead of
the hand-derived ones (the same derivatives); the accelerometer-vibration covariance
scaling is left out (off in the thesis's comparison set-up, which uses constant
covariances).  The numbers (``sigma2_omega``, the sensors' covariances) are this
project's tuning of the QUKF (:func:`qekf_heading_tuning`), so the two filters differ in
the algorithm, not in the noise they assume.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
from scipy.linalg import block_diag

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import Layout
from ballbot_casadi.core.params import PARAM_NAMES, ParamView
from ballbot_casadi.estimation.attitude import qekf_initial_covariance
from ballbot_casadi.estimation.core import OUTPUT_NAMES, FilterModel, ekf_step, flat_function
from ballbot_casadi.estimation.heading import HEADING_MEAS, HEADING_P0_BIAS
from ballbot_casadi.estimation.manifold import attitude_additive
from ballbot_casadi.estimation.tuning import QUKF_P0, QUKF_Q, QUKF_R, QUKF_X0, read_only

__all__ = [
    "QEKF_HEADING_STATE",
    "QEKF_HEADING_INPUT_NAMES",
    "QEKF_HEADING_OUTPUT_NAMES",
    "make_qekf_heading",
    "qekf_heading_tuning",
]

#: State of the predecessor's QEKF: quaternion, body rate, gyroscope bias (3 axes).
QEKF_HEADING_STATE = Layout("predecessor QEKF state", [("q", 4), ("omega", 3), ("b", 3)])
#: Inputs of ``ballbot_qekf_heading`` (as the heading-aided QUKF's).
QEKF_HEADING_INPUT_NAMES = ("xhat", "P", "z", "Q", "R", "dt", "p", "a")
#: Outputs: the core outputs plus ``P_att`` (3x3 body rotation-vector covariance).
QEKF_HEADING_OUTPUT_NAMES = (*OUTPUT_NAMES, "P_att")

_NP = len(PARAM_NAMES)
_NX, _NZ = QEKF_HEADING_STATE.size, HEADING_MEAS.size


def _wrap(a):
    return ca.atan2(ca.sin(a), ca.cos(a))


def _heading(q):
    """Azimuth of the body x axis (the ZYX yaw), invariant to the norm of ``q``."""
    return ca.atan2(2 * (q[0] * q[3] + q[1] * q[2]), q[0]**2 + q[1]**2 - q[2]**2 - q[3]**2)


def _models() -> tuple[ca.Function, ca.Function]:
    """Process and measurement models; ``u = [a_B / g (3), heading_prior]``."""
    x, u, dt, p = ca.SX.sym("x", _NX), ca.SX.sym("u", 4), ca.SX.sym("dt"), ca.SX.sym("p", _NP)
    X = QEKF_HEADING_STATE
    q, w, b = x[X["q"]], x[X["omega"]], x[X["b"]]
    q_next = q + dt * 0.5 * Q.mul(q, ca.vertcat(0, w))  # forward Euler (V2019)
    f = ca.Function("qekf_heading_process", [x, u, dt, p], [ca.vertcat(q_next, w, b)],
                    ["x", "u", "dt", "p"], ["x_next"], {"cse": True})
    g_b = Q.rotate_inv(q, ca.DM([0.0, 0.0, 1.0])) + u[:3]
    h = ca.Function("qekf_heading_measurement", [x, u, dt, p],
                    [ca.vertcat(g_b, w + b, _wrap(_heading(q) - u[3]))],
                    ["x", "u", "dt", "p"], ["z"], {"cse": True})
    return f, h


def make_qekf_heading() -> ca.Function:
    """``ballbot_qekf_heading``: one period of the predecessor's QEKF (module docstring).

    Returns
    -------
    casadi.Function
        ``(xhat[10], P[10x10], z[7], Q[10x10], R[7x7], dt, p[NP], a[3]) -> (xhat_next[10],
        P_next[10x10], nu[7], nis, n_valid, n_repair, P_att[3x3])``: ``z = [acc (m/s^2),
        gyro (rad/s), heading (rad)]`` (non-finite components unused: between the heading
        sensor's samples the heading is NaN), ``R`` with the accelerometer block in units
        of g^2, ``a`` the IMU's linear acceleration in {K} (m/s^2) removed from the
        accelerometer's prediction (rotated once with the prior, as the QUKF's).
        ``P_att = T P_qq T^T`` with ``T = 2 [0 I3] Phi(q)^T`` (as the QEKF's).
    """
    f, h = _models()
    model = FilterModel(attitude_additive(_NX), f, h, noise="additive")
    xhat, P, z = ca.MX.sym("xhat", _NX), ca.MX.sym("P", _NX, _NX), ca.MX.sym("z", _NZ)
    Qn, R = ca.MX.sym("Q", _NX, _NX), ca.MX.sym("R", _NZ, _NZ)
    dt, p, a = ca.MX.sym("dt"), ca.MX.sym("p", _NP), ca.MX.sym("a", 3)
    q_prior = xhat[QEKF_HEADING_STATE["q"]]
    heading_prior = _heading(q_prior)
    g = ParamView(p).g
    u = ca.vertcat(Q.rotate_inv(q_prior, a) / g, heading_prior)
    M = HEADING_MEAS
    zn = ca.vertcat(z[M["acc"]] / g, z[M["gyro"]], _wrap(z[M["yaw"]] - heading_prior))
    out = ekf_step(model, xhat, P, zn, u, Qn, R, dt, p)
    q_next = out["xhat_next"][QEKF_HEADING_STATE["q"]]
    T = 2 * Q.Phi(q_next).T[1:, :]
    P_att = ca.mtimes([T, out["P_next"][:4, :4], T.T])
    return flat_function("ballbot_qekf_heading", [xhat, P, z, Qn, R, dt, p, a],
                         [*(out[k] for k in OUTPUT_NAMES), P_att],
                         list(QEKF_HEADING_INPUT_NAMES), list(QEKF_HEADING_OUTPUT_NAMES))


def qekf_heading_tuning(heading_var: float, bias_rw: float, dt: float,
                        q0=QUKF_X0[:4]) -> dict[str, np.ndarray]:
    """``Q``, ``R``, ``P0``, ``x0`` of the predecessor's QEKF on this project's noise:
    ``sigma2_omega`` the QUKF's body-rate process noise (4.39), ``sigma2_bias dt =
    bias_rw^2 dt`` per axis (the sensor's bias random walk, thesis (3.9)), ``R`` the QUKF's
    (4.40) with the heading variance ``heading_var`` last; ``P0`` the QEKF's 7 x 7 around
    ``q0`` (:func:`~ballbot_casadi.estimation.attitude.qekf_initial_covariance`) and
    :data:`~ballbot_casadi.estimation.heading.HEADING_P0_BIAS` per bias axis."""
    Qn = block_diag(np.zeros((4, 4)), QUKF_Q[3:, 3:], bias_rw ** 2 * dt * np.eye(3))
    return {"Q": read_only(Qn),
            "R": read_only(block_diag(QUKF_R, [[heading_var]])),
            "P0": read_only(block_diag(qekf_initial_covariance(q0, QUKF_P0),
                                       HEADING_P0_BIAS * np.eye(3))),
            "x0": read_only(np.concatenate([QUKF_X0, np.zeros(3)]))}

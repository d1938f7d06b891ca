"""Attitude filters: the QUKF of thesis ch. 4 and the predecessor's additive QEKF baseline.

State ``x = [q, omega]`` (thesis 4.1): the attitude quaternion ``q = ^K_B q`` (scalar
first) and the body angular velocity ``omega = ^B omega_{B|K}`` (rad/s).  Measurement
``z = [acc, gyro]`` (4.2): the accelerometer in m/s^2 and the gyroscope in rad/s, both in
{B} (thesis 3.6, 3.10; :mod:`ballbot_casadi.model.sensors` gives exactly these).

Models (shared by both filters)
-------------------------------
* Process (4.14-4.18): ``omega_k = omega_{k-1}``,
  ``q_k = q_{k-1} o [cos(|omega| dt/2), omega/|omega| sin(|omega| dt/2)]`` - the exact
  rotation for a constant rate over the period, a product of unit quaternions.
* Measurement (4.29, 4.30): ``h = [R(q)^T e_z, omega]``, the gravity *direction* in {B}
  and the rate (with the optional acceleration compensation, ``R(q)^T e_z + a_B / g``,
  ``a_B`` the given acceleration rotated into {B} with the prior attitude).  As in the thesis and its predecessor (whose code divides the
  accelerometer by ``g`` - its "nominal normalisation"), the accelerometer input is
  divided by ``g`` (from ``p``) inside the Function before it is compared with ``h``, so
  the accelerometer block of ``R`` and the first three entries of ``nu`` are in units of
  ``g``: the thesis' ``R = blkdiag(alpha_trust Sigma_acc, Sigma_gyro)`` (4.40) applies its
  (m/s^2)^2 accelerometer covariance to these normalised readings, which de-weights the
  accelerometer by ``g^2`` - deliberately, as the QUKF treats every linear acceleration as
  noise.  (A caller who wants the physically consistent weight passes an accelerometer
  block divided by ``g^2``.)
* No gyroscope bias state: thesis §3.1 and §4.2 show it is unobservable without a
  heading sensor.

QUKF (:func:`make_qukf`): the unscented filter on ``S^3 x R^3``
(:func:`~ballbot_casadi.estimation.manifold.attitude`) with the process noise applied
to the sigma points (4.5), the equally weighted 2d-point set (4.6, 4.19; ``kappa = 0``)
and the Karcher quaternion mean.  The quaternion is never renormalised: every operation
on it is a product with ``exp`` of a pure quaternion, so it stays unit to rounding.

QEKF (:func:`make_qekf`): the predecessor's filter [thesis ref. 6] as the thesis
describes it (§6.3): an EKF on the additive 7-component chart, Jacobians by AD, the
process noise added to the predicted covariance, and the quaternion forcibly
renormalised after each correction.  Its covariance is 7 x 7 (quaternion components and
rate); its ``Q`` input is the same 6 x 6 tangent matrix as the QUKF's, mapped with
``G = blkdiag(1/2 Phi(q) [0; I3], I3)``.  The predecessor propagated the quaternion by
forward Euler (``q + dt dq``) and carried gyroscope-bias states; the baseline uses the
thesis' models above, so the two filters differ only in the filter algorithm and the
quaternion algebra.  The predecessor's filter as the thesis describes it (forward Euler,
gyro-bias states, heading correction) is :mod:`~ballbot_casadi.estimation.predecessor`.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import Layout
from ballbot_casadi.core.params import PARAM_NAMES, ParamView
from ballbot_casadi.estimation.core import (
    GATE_OUTPUT_NAMES,
    OUTPUT_NAMES,
    FilterModel,
    InnovationGate,
    ekf_step,
    flat_function,
    ukf_step,
)
from ballbot_casadi.estimation.manifold import attitude, attitude_additive
from ballbot_casadi.estimation.quaternion_mean import MEAN_ITERATIONS
from ballbot_casadi.estimation.tuning import (
    GATE_SCALE_ATTITUDE,
    QEKF_P0_RADIAL,
    QUKF_P0,
    QUKF_X0,
)

__all__ = [
    "ATTITUDE_GATE",
    "ATTITUDE_MEAS",
    "ATTITUDE_NOISE",
    "ATTITUDE_OUTPUT_NAMES",
    "INPUT_NAMES",
    "make_attitude_measurement",
    "make_attitude_process",
    "make_additive_ukf",
    "make_qekf",
    "make_qukf",
    "qekf_initial_covariance",
    "tangent_map",
]


#: Inputs of ``ballbot_qukf`` and ``ballbot_qekf``.
INPUT_NAMES = ("xhat", "P", "z", "Q", "R", "dt", "p")
#: Outputs: the core outputs plus ``P_att``, the 3x3 attitude covariance (body rotation vector).
ATTITUDE_OUTPUT_NAMES = (*OUTPUT_NAMES, "P_att")
#: The attitude filters' measurement ``z`` (the rows and columns of ``R``): accelerometer,
#: gyroscope (thesis 4.29-4.30).
ATTITUDE_MEAS = Layout("attitude filter measurement", [("acc", 3), ("gyro", 3)])
#: The attitude filters' process noise ``Q`` on the tangent (thesis 4.37-4.39): the body
#: rotation vector, then the body rate (the rows and columns of ``Q``).
ATTITUDE_NOISE = Layout("attitude filter process noise", [("rotation", 3), ("omega", 3)])
#: Measurement groups of the attitude filters' gate (``gate=True``): the accelerometer
#: and the gyroscope rows of :data:`ATTITUDE_MEAS`.
ATTITUDE_GATE = InnovationGate.per_field(ATTITUDE_MEAS, scale=GATE_SCALE_ATTITUDE, name="attitude_gate")

_NP = len(PARAM_NAMES)
_NO_INPUT = ca.DM.zeros(3)


def _model_symbols() -> tuple[ca.SX, ca.SX, ca.SX, ca.SX]:
    # u is the linear acceleration of the IMU in {B} in units of g (zero in the thesis's
    # model); the process model does not use it.
    return ca.SX.sym("x", 7), ca.SX.sym("u", 3), ca.SX.sym("dt"), ca.SX.sym("p", _NP)


def make_attitude_process() -> ca.Function:
    """``att_process(x, u, dt, p) -> x_next``: constant-rate attitude model (thesis 4.14-4.18)."""
    x, u, dt, p = _model_symbols()
    q, w = x[:4], x[4:]
    x_next = ca.vertcat(Q.mul(q, Q.exp(0.5 * dt * w)), w)
    return ca.Function("att_process", [x, u, dt, p], [x_next], ["x", "u", "dt", "p"], ["x_next"],
                       {"cse": True})


def make_attitude_measurement() -> ca.Function:
    """``att_measurement(x, u, dt, p) -> [f_B / g, omega]``: thesis (4.29), (4.30).

    The accelerometer predicts the specific force in {B} in units of g,
    ``R(q)^T e_z + u``; with ``u = 0`` (the thesis's model) the accelerometer measures
    gravity only, with ``u`` the IMU's linear acceleration in {B} (units of g) it is
    compensated.
    """
    x, u, dt, p = _model_symbols()
    g_b = Q.rotate_inv(x[:4], ca.DM([0.0, 0.0, 1.0])) + u
    return ca.Function("att_measurement", [x, u, dt, p], [ca.vertcat(g_b, x[4:])],
                       ["x", "u", "dt", "p"], ["z"], {"cse": True})


def _inputs(nP: int) -> tuple[ca.MX, ...]:
    return (ca.MX.sym("xhat", 7), ca.MX.sym("P", nP, nP), ca.MX.sym("z", 6),
            ca.MX.sym("Q", 6, 6), ca.MX.sym("R", 6, 6), ca.MX.sym("dt"), ca.MX.sym("p", _NP))


def _normalised_z(z: ca.MX, p: ca.MX) -> ca.MX:
    """Accelerometer in units of g, gyroscope unchanged (see the module docstring)."""
    return ca.vertcat(z[:3] / ParamView(p).g, z[3:])


def _function(name: str, args: tuple, out: dict, P_att: ca.MX,
              gate: dict | None = None) -> ca.Function:
    names = list(INPUT_NAMES) + ["a"] * (len(args) - len(INPUT_NAMES))
    outs, names_out = [*(out[k] for k in OUTPUT_NAMES), P_att], list(ATTITUDE_OUTPUT_NAMES)
    if gate:
        args, names = (*args, gate["n_rej"]), [*names, "n_rej"]
        outs += [out[k] for k in GATE_OUTPUT_NAMES]
        names_out += GATE_OUTPUT_NAMES
    return flat_function(name, list(args), outs, names, names_out)


def _gate(gate: bool) -> dict:
    """The step functions' gate keywords (empty without gating)."""
    if not gate:
        return {}
    return {"gate": ATTITUDE_GATE, "n_rej": ca.MX.sym("n_rej", len(ATTITUDE_GATE.groups))}


def _acceleration(args: tuple, p: ca.MX, compensate: bool) -> tuple[tuple, ca.MX]:
    """The filter's input ``a`` (IMU acceleration in {K}, m/s^2), if any, as the
    measurement model's ``u``: rotated into {B} with the prior attitude ``xhat`` (the
    same for every sigma point) and in units of g (see :func:`make_qukf`)."""
    if not compensate:
        return args, _NO_INPUT
    a = ca.MX.sym("a", 3)
    return (*args, a), Q.rotate_inv(args[0][:4], a) / ParamView(p).g


def make_qukf(mean_iterations: int = MEAN_ITERATIONS, compensate_acceleration: bool = False,
              renormalise: bool = False, gate: bool = False) -> ca.Function:
    """``ballbot_qukf``: one period of the quaternion UKF (thesis 4.1-4.40).

    Parameters
    ----------
    mean_iterations
        Karcher steps of the quaternion mean (replaces the sweep of thesis 4.20).
    compensate_acceleration
        Add a last input ``a`` (3, m/s^2): the IMU's linear acceleration in {K}, removed
        from the accelerometer's prediction (e.g. the velocity filter's estimate).  The
        thesis's model (4.29) assumes the accelerometer measures gravity only, which
        biases the tilt while the ball accelerates (1 m/s^2 reads as 5.8 deg of tilt).
        ``a`` is rotated into {B} once, with the prior attitude ``xhat``, and added to
        every sigma point's prediction as a known body-frame term: rotated per sigma
        point it would make the accelerometer observe the heading through ``a``, whose
        direction in {K} the velocity filter took from this filter's own heading - a
        circular, spurious heading measurement that drifts the heading systematically
        (the full study's report shows the heading error).
    renormalise
        Renormalise the quaternion after the update (``ballbot_qukf_renorm``): the forced
        unit norm the thesis's conclusions (ch. 10) say made its first UKF "deeply
        deviate".  Here every operation keeps the norm, so it changes the estimate only
        at rounding level (:mod:`~ballbot_casadi.analysis.renormalisation`); the
        deviation the thesis saw comes from the additive sigma points and weighted-sum
        mean, :func:`make_additive_ukf`.
    gate
        Chi-square gating of the accelerometer and the gyroscope (:data:`ATTITUDE_GATE`,
        :class:`~ballbot_casadi.estimation.core.InnovationGate`): a last input ``n_rej``
        (2, consecutive rejections of ``[acc, gyro]``) and the outputs ``rejected`` and
        ``n_rej_next`` (2 each) appended.

    Returns
    -------
    casadi.Function
        ``ballbot_qukf(xhat[7], P[6x6], z[6], Q[6x6], R[6x6], dt, p[NP])`` ->
        ``(xhat_next[7], P_next[6x6], nu[6], nis, n_valid, n_repair, P_att[3x3])``.
        ``xhat = [q, omega]``; ``P``, ``Q`` on the tangent ``[rotation vector (body), omega]``;
        ``z = [acc (m/s^2), gyro (rad/s)]`` (a non-finite component is not used);
        ``R`` with the accelerometer block in units of g^2; ``p`` the parameter vector
        (only ``g`` is used).  ``nu`` is the innovation (0 where invalid), ``nis`` its
        normalised square, ``n_valid`` the number of valid components, ``n_repair`` the
        number of covariance repairs, ``P_att = P_next[:3, :3]`` (the VUKF input).
    """
    model = FilterModel(attitude(mean_iterations, renormalise=renormalise), make_attitude_process(),
                        make_attitude_measurement(), noise="pre")
    args = xhat, P, z, Qn, R, dt, p = _inputs(6)
    args, u = _acceleration(args, p, compensate_acceleration)
    g = _gate(gate)
    out = ukf_step(model, xhat, P, _normalised_z(z, p), u, Qn, R, dt, p, kappa=0.0, **g)
    return _function("ballbot_qukf_renorm" if renormalise else "ballbot_qukf", args, out,
                     out["P_next"][:3, :3], g)


def make_additive_ukf() -> ca.Function:
    """``ballbot_qukf_additive``: the classical UKF on the additive ``[q, omega]`` chart with
    the quaternion renormalised after every correction - the thesis's first QUKF (ch. 10:
    "the resultant quaternion estimate was deeply deviated"), as the QEKF treats the
    quaternion but with sigma points.

    Same inputs and outputs as :func:`make_qekf`: ``P`` is 7 x 7 on ``[q0..q3, omega]``,
    ``Q`` the 6 x 6 tangent matrix added as ``G Q G^T``; sigma points are ``xhat +- s L``
    (additive, off the unit sphere), the mean is their weighted sum, deviations are
    differences (thesis 3.20-3.31 without the quaternion algebra of ch. 4).
    """
    model = FilterModel(attitude_additive(), make_attitude_process(), make_attitude_measurement(),
                        noise="additive")
    args = xhat, P, z, Qn, R, dt, p = _inputs(7)
    G = tangent_map(xhat[:4])
    out = ukf_step(model, xhat, P, _normalised_z(z, p), _NO_INPUT, ca.mtimes([G, Qn, G.T]), R, dt, p)
    q_next = out["xhat_next"][:4]
    T = 2 * Q.Phi(q_next).T[1:, :]
    return _function("ballbot_qukf_additive", args, out, ca.mtimes([T, out["P_next"][:4, :4], T.T]))


def tangent_map(q: Any) -> Any:
    """``G = blkdiag(1/2 Phi(q) [0; I3], I3)`` (7x6): additive-chart image of a tangent vector.

    ``q`` numpy (returns numpy) or CasADi (returns CasADi).
    """
    Gq = 0.5 * Q.Phi(q)[:, 1:]
    if isinstance(q, (ca.SX, ca.MX, ca.DM)):
        return ca.diagcat(Gq, ca.DM.eye(3))
    G = np.zeros((7, 6))
    G[:4, :3], G[4:, 3:] = Gq, np.eye(3)
    return G


def qekf_initial_covariance(q: Any = QUKF_X0[:4], P0: Any = QUKF_P0,
                            radial: float = QEKF_P0_RADIAL) -> np.ndarray:
    """7 x 7 initial covariance of the QEKF: ``G P0 G^T + radial blkdiag(q q^T, 0)``.

    ``P0`` is a 6 x 6 tangent covariance (default thesis 4.4); ``radial`` is the variance
    along ``q`` that keeps the additive covariance positive definite.
    """
    q = np.asarray(q, dtype=float)
    G = tangent_map(q)
    P = G @ np.asarray(P0, dtype=float) @ G.T
    P[:4, :4] += radial * np.outer(q, q)
    return P


def make_qekf(compensate_acceleration: bool = False, gate: bool = False) -> ca.Function:
    """``ballbot_qekf``: the predecessor's additive quaternion EKF (baseline, thesis §6.3).

    Same inputs and outputs as :func:`make_qukf` (including ``compensate_acceleration``
    and ``gate``) except that ``P`` and ``P_next`` are
    7 x 7 covariances of ``[q0..q3, omega]`` (the additive chart).  ``Q`` is the QUKF's
    6 x 6 tangent matrix, added as ``G Q G^T`` (:func:`tangent_map` at ``xhat``) to the
    predicted covariance; the quaternion is renormalised after the correction.
    ``P_att = T P_qq T^T`` with ``T = 2 [0 I3] Phi(q)^T``, the body rotation-vector
    covariance the VEKF takes.
    """
    model = FilterModel(attitude_additive(), make_attitude_process(), make_attitude_measurement(),
                        noise="additive")
    args = xhat, P, z, Qn, R, dt, p = _inputs(7)
    args, u = _acceleration(args, p, compensate_acceleration)
    G = tangent_map(xhat[:4])
    g = _gate(gate)
    out = ekf_step(model, xhat, P, _normalised_z(z, p), u, ca.mtimes([G, Qn, G.T]),
                   R, dt, p, **g)
    q_next = out["xhat_next"][:4]
    T = 2 * Q.Phi(q_next).T[1:, :]
    P_att = ca.mtimes([T, out["P_next"][:4, :4], T.T])
    return _function("ballbot_qekf", args, out, P_att, g)

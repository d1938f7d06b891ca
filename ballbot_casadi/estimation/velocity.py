"""Velocity filters: the VUKF of thesis ch. 5 and the predecessor's VEKF baseline.

State ``x = [dx, dy, ddx, ddy, b_acc]`` (thesis 5.1; 7 entries): the ball velocity and
acceleration in the inertial frame and the accelerometer bias in {B}.  Measurement
``z = [enc, acc]`` (5.2): the encoder tick increments of the three wheels over the
filter period ``dt`` (thesis 3.14-3.15: ``Delta i_ticks``, *not* a rate; multiply
:mod:`ballbot_casadi.model.sensors`' ``enc`` (ticks/s) by ``dt``) and the accelerometer
in m/s^2 (thesis 3.6).  The filter takes the attitude filter's estimate as an input:
``att = [q, omega]`` (the QUKF state) and ``P_att`` (its 3 x 3 attitude covariance, body
rotation vector).

Models (shared by both filters)
-------------------------------
* Process (5.9-5.11): ``v_k = v_{k-1} + dt a_{k-1}``, ``a_k = a_{k-1}``, ``b_k = b_{k-1}``.
* Encoders (3.17, 5.17): ``n_ticks / (2 pi) dt dphi`` with ``dphi`` the wheel speeds of
  the inverse kinematics (B.47) at ``[q, dx, dy, dq]``, ``dq = 1/2 q o [0, omega]``.  The
  kinematics is *received* as a CasADi Function ``wheel_speeds(x12, p) -> dphi`` (the
  model's ``ballbot_wheel_speeds``, state ``[x, y, q, dx, dy, dq]``) and called.
* Accelerometer (5.18): ``R(q)^T [ddx, ddy, g] + b_acc`` (IMU at the ball centre).
* Measurement noise (5.27-5.28): ``R + blkdiag(0, J P_att J^T)`` where
  ``J = d acc / d r`` is the sensitivity of the predicted accelerometer to a body
  rotation vector ``r`` of the attitude (CasADi AD, at the predicted mean).  The thesis
  adds the QUKF covariance block to ``Sigma_acc`` directly, which mixes rad^2 with
  (m/s^2)^2; mapping it through ``J`` (as the predecessor's VEKF does with its
  quaternion covariance) is the dimensionally consistent reading, and near upright it is
  ``g^2`` times the tilt block.

Reading of the printed equations: (5.1) labels the last three states a gyroscope bias,
the text and (5.10), (5.18) an accelerometer bias - it is the accelerometer bias; (3.17)
and (5.17) print ``- 2 q`` where the inverse kinematics (B.47) has ``- 2 dq``; (5.22)
omits the weights of (5.13), which are used.

VUKF (:func:`make_vukf`): additive process noise (5.14), 2N+1 sigma points with
``kappa = 3 - N`` (5.6, 5.13), measurement sigma points redrawn after ``Q`` is added
(see :func:`~ballbot_casadi.estimation.core.ukf_step`).  Every model is linear in the
filter state (``q`` and ``omega`` are inputs), so the unscented transform is exact here
and the VUKF equals the Kalman filter - and the VEKF - to rounding (tested); the
generated filter therefore computes the transform in closed form (``closed_form``, the
default: the sigma points' covariances without the sigma points), which is cheaper and
gives the sigma-point form's results to rounding (tested).
VEKF (:func:`make_vekf`): the same models in the EKF core (the predecessor's filter).

The matched model (``matched=True``, issue 22; the estimator ``ukf_consistent``) fixes
the thesis's model where the loop's innovations showed it wrong: the encoder prediction's
body-rate term with its covariance (:func:`encoder_rate`), the period's acceleration
increment on the velocity (:func:`period_acceleration_noise`) and the attitude error as a
slowly varying accelerometer offset instead of white noise (:func:`attitude_offset_noise`).
"""

from __future__ import annotations

import math

import casadi as ca

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import Layout
from ballbot_casadi.core.params import PARAM_NAMES, ParamView
from ballbot_casadi.errors import BallbotTypeError
from ballbot_casadi.estimation.adaptive_walk import (
    ACC_STATE,
    WALK_SIZE,
    WalkAdaptation,
    adapt_walk,
    make_walk_sample,
    prior_walk,
    with_walk,
)
from ballbot_casadi.estimation.core import (
    GATE_OUTPUT_NAMES,
    OUTPUT_NAMES,
    FilterModel,
    InnovationGate,
    ekf_step,
    flat_function,
    ukf_step,
)
from ballbot_casadi.estimation.linalg import FINITE_MAX
from ballbot_casadi.estimation.manifold import euclidean
from ballbot_casadi.estimation.tuning import GATE_SCALE_VELOCITY

__all__ = [
    "INPUT_NAMES",
    "VELOCITY_GATE",
    "VELOCITY_MEAS",
    "KAPPA",
    "MATCHED_ACC_PROCESS_VAR",
    "NX",
    "make_vekf",
    "make_velocity_model",
    "make_vukf",
    "attitude_offset_noise",
    "encoder_rate",
    "period_acceleration_noise",
]


#: Size of the velocity filter state (thesis 5.1).
NX = 7
#: Sigma-point parameter of the VUKF, ``kappa = 3 - N`` (thesis 5.6).
KAPPA = 3.0 - NX
#: The matched model's acceleration random walk per period, x and y, (m/s^2)^2: the
#: calibration a scenario with the matched filter (estimator ``ukf_consistent``) runs with
#: when its file sets none of ``acc_process_var``, ``_x``, ``_y`` (those set their axes over
#: it; the thesis-model filter keeps its 1e-2).  Measured by ``ballbot study consistency``
#: (issue 22): per scenario, the variance of the true ball acceleration's change per period
#: in the matched filter's own closed loop (second matched run) on the five scenarios with
#: an estimator and no path (full_sine, full_velocity, com_observer, com_observer_centred,
#: com_ukf: x 0.0103/0.0116/0.0905/0.0827/0.0919, y 0.0129/0.0113/0.1176/0.1093/0.1140);
#: the mean over the five, rounded to two digits.  The ``full`` profiles' ball jitters
#: less than the standing COM robot's (1e-2 against 0.09-0.12): one pair is a compromise.
MATCHED_ACC_PROCESS_VAR = (0.057, 0.073)
#: Inputs of ``ballbot_vukf`` and ``ballbot_vekf``.
INPUT_NAMES = ("xhat", "P", "z", "att", "P_att", "Q", "R", "dt", "p")

#: The velocity filters' measurement ``z`` (thesis 5.2): the three wheel encoders'
#: increments over the period, then the accelerometer.
VELOCITY_MEAS = Layout("velocity filter measurement", [("enc", 3), ("acc", 3)])
#: Measurement groups of the velocity filters' gate (``gate=True``): the rows of each
#: sensor in :data:`VELOCITY_MEAS`.
VELOCITY_GATE = InnovationGate.per_field(VELOCITY_MEAS, scale=GATE_SCALE_VELOCITY,
                                         name="velocity_gate")

_NP = len(PARAM_NAMES)
_NU = 7 + 9  # att = [q, omega], then P_att column-major


def _check_wheel_speeds(wheel_speeds: ca.Function) -> None:
    ok = (isinstance(wheel_speeds, ca.Function) and wheel_speeds.n_in() == 2
          and wheel_speeds.n_out() == 1 and wheel_speeds.size_in(0) == (12, 1)
          and wheel_speeds.size_in(1) == (_NP, 1) and wheel_speeds.size_out(0) == (3, 1))
    if not ok:
        raise BallbotTypeError(
            f"wheel_speeds must be a CasADi Function (x[12], p[{_NP}]) -> dphi[3], e.g. "
            "make_model_functions()['wheel_speeds']"
        )


def _accelerometer(q, a_xy, b, g):
    """Thesis (5.18): ``R(q)^T [ddx, ddy, g] + b``."""
    return Q.rotate_inv(q, ca.vertcat(a_xy, g)) + b


def make_velocity_model(wheel_speeds: ca.Function, midpoint: bool = False,
                        attitude_noise: bool = True) -> FilterModel:
    """The velocity filters' :class:`FilterModel` (thesis 5.9-5.11, 5.17, 5.18, 5.28).

    ``u = [q(4), omega(3), vec(P_att)(9)]``; ``p`` the parameter vector (``g``,
    ``n_ticks`` and the kinematic parameters of ``wheel_speeds``).  With ``midpoint``
    the encoder prediction uses the ball velocity at the middle of the period,
    ``v - dt/2 a`` (the tick increment is the integral of the wheel speed over the
    period; the thesis's (5.17) evaluates it at the period's end, half a period late).

    Why minus: the update of period ``k`` runs on the *predicted* state, which the process
    model (5.9) has advanced from ``t_{k-1}`` to ``t_k``: ``v = v_k``.  The increment it is
    compared with is ``phi(t_k) - phi(t_{k-1})`` (the encoders are differenced at the
    samples, :func:`~ballbot_casadi.model.sensors.make_encoders`), i.e.
    ``integral_{t_{k-1}}^{t_k} dphi(v(t)) dt``.  The wheel speed is linear in the ball
    velocity at a fixed attitude, so for a constant acceleration ``a`` the integral is
    exactly ``dt dphi(v(t_k - dt/2)) = dt dphi(v_k - dt/2 a)``: the midpoint lies half a
    period *before* the state's instant.  Settled on a synthetic constant-acceleration
    case with exact increments (tests/estimation/test_vukf_midpoint.py): this sign is
    exact there; without the midpoint the estimate lags by ``dt/2 a``, with ``+`` by ``dt a``.

    With ``attitude_noise`` false the measurement noise is ``R`` alone (no
    ``J P_att J^T``): the matched model carries the attitude error's image in the
    accelerometer as the slowly varying offset ``b_acc`` instead
    (:func:`attitude_offset_noise`).
    """
    _check_wheel_speeds(wheel_speeds)
    x, u, dt, p = ca.MX.sym("x", NX), ca.MX.sym("u", _NU), ca.MX.sym("dt"), ca.MX.sym("p", _NP)
    names = ["x", "u", "dt", "p"]
    P = ParamView(p)
    x_next = ca.vertcat(x[:2] + dt * x[2:4], x[2:])
    process = ca.Function("vel_process", [x, u, dt, p], [x_next], names, ["x_next"])

    q, w = u[:4], u[4:7]
    dq = 0.5 * Q.mul(q, Q.hat(w))
    v = x[:2] - 0.5 * dt * x[2:4] if midpoint else x[:2]
    dphi = wheel_speeds(ca.vertcat(0, 0, q, v, dq), p)
    enc = P.n_ticks / (2 * math.pi) * dt * dphi
    z = ca.vertcat(enc, _accelerometer(q, x[2:4], x[4:7], P.g))
    measurement = ca.Function("vel_measurement", [x, u, dt, p], [z], names, ["z"])

    if not attitude_noise:
        return FilterModel(euclidean(NX), process, measurement, "additive", None)
    # Attitude uncertainty of the accelerometer prediction (5.27-5.28), mapped by J.
    jac = _acc_attitude_jacobian()
    R = ca.MX.sym("R", 6, 6)
    Ja = jac(x, q, P.g)
    P_att = ca.reshape(u[7:], 3, 3)
    R_eff = R + ca.diagcat(ca.DM.zeros(3, 3), ca.mtimes([Ja, P_att, Ja.T]))
    noise = ca.Function("vel_measurement_noise", [x, u, p, R], [R_eff], ["x", "u", "p", "R"],
                        ["R_eff"])
    return FilterModel(euclidean(NX), process, measurement, "additive", noise)


def _acc_attitude_jacobian() -> ca.Function:
    """``J = d acc / d r`` (3 x 3): the predicted accelerometer's sensitivity to a body
    rotation vector ``r`` of the attitude (CasADi AD at ``r = 0``), inputs ``(x, q, g)``;
    near upright and at rest ``g [[0, -1, 0], [1, 0, 0], [0, 0, 0]]``."""
    r = ca.SX.sym("r", 3)
    xs, qs, gs = ca.SX.sym("x", NX), ca.SX.sym("q", 4), ca.SX.sym("g")
    acc_r = _accelerometer(Q.mul(qs, Q.from_rotation_vector(r)), xs[2:4], xs[4:7], gs)
    J = ca.substitute(ca.jacobian(acc_r, r), r, ca.DM.zeros(3))
    return ca.Function("acc_attitude_jacobian", [xs, qs, gs], [J], ["x", "q", "g"], ["J"])


def _encoder_rate_jacobian(wheel_speeds: ca.Function) -> ca.Function:
    """``J_w = d enc / d omega`` (3 x 3): the encoder increments' sensitivity to the body
    rate.  The wheel speeds are linear in ``(v, dq)`` at a fixed attitude, so ``J_w``
    depends on ``q`` (and ``dt``, ``p``) only."""
    att, dt, p = ca.MX.sym("att", 7), ca.MX.sym("dt"), ca.MX.sym("p", _NP)
    w = ca.MX.sym("omega", 3)
    q = att[:4]
    dphi = wheel_speeds(ca.vertcat(0, 0, q, 0, 0, 0.5 * Q.mul(q, Q.hat(w))), p)
    enc = ParamView(p).n_ticks / (2 * math.pi) * dt * dphi
    J = ca.substitute(ca.jacobian(enc, w), w, att[4:7])
    return ca.Function("enc_rate_jacobian", [att, dt, p], [J], ["att", "dt", "p"], ["J_w"])


def period_acceleration_noise(Q, dt):
    """``G Q G^T`` with ``G = [[I2, dt I2, 0], [0, I2, 0], [0, 0, I3]]``: the process noise
    when the acceleration's random-walk increment of a period acts *during* that period.

    The accelerometer at ``t_k`` reads the acceleration the torque of the period ending at
    ``t_k`` gives (:func:`~ballbot_casadi.sim.embedded.sense`), so the filter's ``a_k`` is
    the acceleration over ``[t_{k-1}, t_k]`` and ``v_k = v_{k-1} + dt a_k``.  With the
    random walk ``a_k = a_{k-1} + w_k`` that is the thesis's process (5.9-5.10) plus
    ``dt w_k`` on the velocity: additive noise ``G Q G^T``, whose velocity block
    ``dt^2 Q_a`` and cross terms ``dt Q_a`` the diagonal ``Q`` of (5.26) leaves out (with
    ``sigma_v = 0`` the velocity then cannot follow an acceleration step for a period).
    """
    G = ca.MX.eye(NX) + ca.vertcat(ca.horzcat(ca.MX.zeros(2, 2), dt * ca.MX.eye(2),
                                              ca.MX.zeros(2, 3)), ca.MX.zeros(5, NX))
    return ca.mtimes([G, Q, G.T])


def attitude_offset_noise(J, P_rate, dt):
    """``dt^2 J P_rate J^T`` (3 x 3): the per-period change of the accelerometer offset an
    attitude error makes, the process noise the matched model adds to ``b_acc``.

    The attitude the velocity filter receives is off by a slowly varying rotation
    ``dtheta`` (measured in the loop: lag-1 autocorrelation 0.99 and more); the
    accelerometer prediction (5.18) is then off by ``J dtheta`` (``J = d acc / d r``),
    which is a slowly varying offset like the bias, not the white noise
    ``J P_att J^T`` of (5.27-5.28): taken as white, the filter averages it away and is
    overconfident in the velocity it integrates from the accelerometer.  The attitude
    filter propagates the attitude with a body rate, so over one period the attitude
    error changes by ``dt`` times the rate error: ``b_acc`` (the accelerometer's offset in
    {B}, the state that already absorbs the slow tilt error,
    :mod:`~ballbot_casadi.estimation.tilt_aiding`) walks by ``dt J w``, ``w ~ N(0, P_rate)``.
    """
    return dt * dt * ca.mtimes([J, P_rate, J.T])


def _build(name: str, wheel_speeds: ca.Function, kind: str, midpoint: bool = False,
           matched: bool = False, gate: bool = False,
           adaptive: WalkAdaptation | None = None, closed_form: bool = True) -> ca.Function:
    model = make_velocity_model(wheel_speeds, midpoint, attitude_noise=not matched)
    args = (ca.MX.sym("xhat", NX), ca.MX.sym("P", NX, NX), ca.MX.sym("z", 6), ca.MX.sym("att", 7),
            ca.MX.sym("P_att", 3, 3), ca.MX.sym("Q", NX, NX), ca.MX.sym("R", 6, 6),
            ca.MX.sym("dt"), ca.MX.sym("p", _NP))
    xhat, P, z, att, P_att, Qn, R, dt, p = args
    u = ca.vertcat(att, ca.vec(0.5 * (P_att + P_att.T)))
    names = list(INPUT_NAMES)
    if adaptive is not None:  # the acceleration block of Q from the filter's own estimate
        walk = ca.MX.sym("walk", WALK_SIZE)
        q_used = prior_walk(walk, Qn)
        Qn = with_walk(Qn, q_used)
    if matched:
        P_rate = ca.MX.sym("P_rate", 3, 3)
        args = (*args, P_rate)
        names.append("P_rate")
        P_rate = 0.5 * (P_rate + P_rate.T)
        Qn = period_acceleration_noise(0.5 * (Qn + Qn.T), dt)
        J = _acc_attitude_jacobian()(xhat, att[:4], ParamView(p).g)
        Qn = Qn + ca.diagcat(ca.DM.zeros(4, 4), attitude_offset_noise(J, P_rate, dt))
        Jw = _encoder_rate_jacobian(wheel_speeds)(att, dt, p)
        R = R + ca.diagcat(ca.mtimes([Jw, P_rate, Jw.T]), ca.DM.zeros(3, 3))
    if adaptive is not None:
        args, names = (*args, walk), [*names, "walk"]
    g, names_out = {}, list(OUTPUT_NAMES)
    if gate:
        g = {"gate": VELOCITY_GATE, "n_rej": ca.MX.sym("n_rej", len(VELOCITY_GATE.groups))}
        args, names = (*args, g["n_rej"]), [*names, "n_rej"]
        names_out += GATE_OUTPUT_NAMES
    if kind == "ukf":
        out = ukf_step(model, xhat, P, z, u, Qn, R, dt, p, kappa=KAPPA, closed_form=closed_form,
                       **g)
    else:
        out = ekf_step(model, xhat, P, z, u, Qn, R, dt, p, **g)
    if adaptive is not None:
        # h_i = H G e_i: the measurements' sensitivity to the walk's increment on axis i
        # (H by AD; the models are linear in the state; G of period_acceleration_noise)
        GE = ca.MX.zeros(NX, 2)
        GE[ACC_STATE, :] = ca.MX.eye(2)
        if matched:
            GE[0:2, :] = dt * ca.MX.eye(2)
        xs = ca.MX.sym("x", NX)  # two forward directions, not the 6 x 7 Jacobian
        HG = ca.substitute(ca.jtimes(model.measurement(xs, u, dt, p), xs, GE), xs, xhat)
        sample, ok = make_walk_sample(6)(out["nu"], out["P_zz"], HG, q_used)
        out["walk_next"] = adapt_walk(walk, q_used, sample,
                                      ca.logic_and(out["n_valid"] >= 5.5, ok), adaptive)
        names_out.append("walk_next")
    return flat_function(name, list(args), [out[k] for k in names_out], names, names_out)


def make_vukf(wheel_speeds: ca.Function, midpoint: bool = False, matched: bool = False,
              gate: bool = False, adaptive: WalkAdaptation | None = None,
              closed_form: bool = True) -> ca.Function:
    """``ballbot_vukf``: one period of the velocity UKF (thesis 5.1-5.28).

    Parameters
    ----------
    wheel_speeds
        Inverse kinematics ``(x[12], p[NP]) -> dphi[3]`` (the model's
        ``ballbot_wheel_speeds``); it is called, not inlined.
    midpoint
        Predict the encoder increments at the period's middle (see
        :func:`make_velocity_model`) instead of the thesis's end of period.
    matched
        The matched model (issue 22; the thesis's model where it was found wrong), with a
        last input ``P_rate`` (3 x 3, the covariance of the body rate in ``att``; the
        embedded software passes the period's gyroscope reading and its noise,
        :func:`encoder_rate`):

        * the encoder prediction depends on the body rate through ``dq`` (5.17, B.47):
          ``J_w P_rate J_w^T`` (``J_w = d enc / d omega``, AD) is added to the encoder
          block of ``R``, as the attitude covariance is to the accelerometer's (5.27-5.28);
        * the acceleration's random-walk increment of a period acts during that period:
          ``Q`` enters as ``G Q G^T`` (:func:`period_acceleration_noise`) instead of the
          thesis's diagonal (5.26);
        * the attitude error is a slowly varying accelerometer offset, not white noise:
          ``P_att`` is not used (no ``J P_att J^T`` in ``R``) and ``b_acc`` walks by the
          attitude error's change per period, ``dt^2 J P_rate J^T``
          (:func:`attitude_offset_noise`, ``J`` at the prior mean).
    gate
        Chi-square gating of the encoders and the accelerometer (:data:`VELOCITY_GATE`,
        :class:`~ballbot_casadi.estimation.core.InnovationGate`): a last input ``n_rej``
        (2, consecutive rejections of ``[enc, acc]``) and the outputs ``rejected`` and
        ``n_rej_next`` (2 each) appended.
    adaptive
        Adapt the acceleration random walk online (issue 22,
        :mod:`~ballbot_casadi.estimation.adaptive_walk`: covariance matching of the
        accelerometer innovations with a Sage-Husa forgetting factor, bounded): an input
        ``walk`` (``[q_x, q_y, n]``, the walk per axis and its sample count, a state of the
        filter; 0 = use ``Q``'s acceleration block as the prior, the power-on value) after
        ``P_rate`` and before ``n_rej``, and a last output ``walk_next``.  ``Q``'s
        acceleration block is then replaced by ``diag(q_x, q_y)``.
    closed_form
        Compute the unscented transform in closed form (default): every model of the
        filter is affine in its state, so the sigma points' mean and covariances equal
        ``F P F^T``, ``H P H^T``, ``P H^T`` exactly
        (:func:`~ballbot_casadi.estimation.core.ukf_step`); ``False`` builds the
        sigma-point form (2N+1 points, the thesis's equations as printed), which gives the
        same results to rounding and costs more.

    Returns
    -------
    casadi.Function
        ``ballbot_vukf(xhat[7], P[7x7], z[6], att[7], P_att[3x3], Q[7x7], R[6x6], dt, p[NP])``
        -> ``(xhat_next[7], P_next[7x7], nu[6], nis, n_valid, n_repair)``.
        ``z = [encoder ticks over the period (3), accelerometer m/s^2 (3)]`` (a
        non-finite component is not used); ``att = [q, omega]`` and ``P_att`` from the
        attitude filter; ``R`` without the attitude term (added inside).
    """
    return _build("ballbot_vukf", wheel_speeds, "ukf", midpoint, matched, gate, adaptive,
                  closed_form)


def make_vekf(wheel_speeds: ca.Function, midpoint: bool = False, matched: bool = False,
              gate: bool = False) -> ca.Function:
    """``ballbot_vekf``: the predecessor's velocity EKF, same interface as :func:`make_vukf`."""
    return _build("ballbot_vekf", wheel_speeds, "ekf", midpoint, matched, gate)


def encoder_rate(omega_att, P_rate_att, gyro, Sigma_gyro, Q_rate) -> tuple[ca.MX, ca.MX]:
    """The body rate the encoder prediction uses, and its covariance (the ``P_rate`` input).

    The tick increment of a period depends on the body rate through ``dq`` (thesis 5.17,
    B.47): ``J_w = d enc / d omega`` is about 60-100 ticks per period per rad/s, so the
    rate's error dominates the encoder's quantisation (``I/9`` ticks^2).  The attitude
    filter's rate ``omega_att`` is the gyroscope low-passed by its rate random walk
    (thesis 4.39): its error is *coloured* (correlated over several periods), which the
    velocity filter, taking ``J_w P_rate J_w^T`` as white measurement noise, cannot
    represent - it averages the correlated error away and becomes overconfident in the
    velocity.  The period's gyroscope reading ``gyro`` has white noise of the known
    covariance ``Sigma_gyro`` (thesis 3.8), so it is the matched input.  The increment
    integrates the rate over the period while the gyro reads it at the period's end: for
    the attitude filter's rate random walk of ``Q_rate`` per period (thesis 4.39) the end
    value differs from the period's mean by a variance of ``Q_rate / 3``.

    Returns ``(gyro, Sigma_gyro + Q_rate / 3)`` when every gyro component is a reading,
    else (a dropout) ``(omega_att, P_rate_att)``.
    """
    ok = ca.logic_and(ca.logic_and(ca.fabs(gyro[0]) <= FINITE_MAX, ca.fabs(gyro[1]) <= FINITE_MAX),
                      ca.fabs(gyro[2]) <= FINITE_MAX)
    safe = ca.if_else(ok, gyro, ca.DM.zeros(3))  # no NaN reaches the arithmetic
    return (ca.if_else(ok, safe, omega_att),
            ca.if_else(ok, Sigma_gyro + Q_rate / 3.0, P_rate_att))

"""Online observer of the body's centre-of-mass offset (thesis §8.4.2, §9.2, ch. 11).

``ballbot_com_observer(x, v_ref, o, p, k, Ts) -> (o_next, p_hat, com_hat, com_meas)``,
one call per control period, on what the robot's controllers read (the true state or
the estimate ``x_hat``: attitude, body rate, ball velocity).

The problem
-----------
The body's centre of mass sits at ``p_com = (com_x, com_y, l)`` in {B} (thesis App. C,
B.10, C.21).  A horizontal offset the controllers do not know moves the balance point:
the balance controller then holds the wrong attitude and the robot runs away (thesis
§8.4.2, Fig. 8.12-8.13); the velocity loop stops it only by integrating the run-away
into a tilt (§9.2), which leaves a position error and a static attitude tracking error.
The thesis leaves an observer of the COM as future work (ch. 11).

Measurement: the moment balance about the contact point
--------------------------------------------------------
Floor reaction and friction act at the contact point ``P``, the motor torques are
internal, so the moments about ``P`` of gravity and of the inertial forces of ball and
body cancel (the Euler-Lagrange model of thesis App. C, written about ``P``).  With the
ball acceleration ``a`` (horizontal, {K}), the body's angular acceleration ``dw`` ({K})
and ``d = [R(q) p_com]_xy`` the horizontal offset of the COM from the ball centre::

    M_b g d = (M_b (r_k + l) + M_k r_k + J_k / r_k) a - (M_b l (r_k + l) + J_b) e_z x dw
    d = kappa a - lambda e_z x dw                                            (1)

to first order in the tilt and neglecting the terms quadratic in the rates (the
coefficients agree with the model's own accelerations to 0.5 %, see the tests).  At
rest (1) is the static-balance condition: the COM straight above the contact point
(``R(q) p_com`` vertical, the balance point of
:func:`~ballbot_casadi.model.linearization.balance_point`).  Given the attitude, ``a``
and ``dw``, (1) is linear in ``(com_x, com_y)``::

    R_h [com_x, com_y]^T = kappa a - lambda e_z x dw - l R[0:2, 2]           (2)

with ``R_h = R[0:2, 0:2]`` (invertible for tilts below 90 deg).  The static part
``-l R_h^-1 R[0:2, 2]`` and the ball velocity and horizontal body rate are low-passed
(time constant ``t_diff``); ``a`` and ``dw`` are the exact differences of the filtered
signals (a linear filter commutes with d/dt, so both parts of (2) see the same filter);
the sum is the measurement ``com_meas`` (clipped to ``+-c_max``).

Observer
--------
Two first-order filters, updated while the commanded velocity ``v_ref`` is zero
(``w = 1``; frozen, ``w = 0``, while a motion is commanded)::

    com_bal <- com_bal + w (1 - exp(-Ts / t_obs)) (com_meas - com_bal)   balance point
    com_hat <- com_hat + w (1 - exp(-Ts / t_com)) (com_bal - com_hat)    COM offset

``p_hat`` is ``p`` with ``com_x, com_y = com_bal``: the balance controller's internal
model and the velocity controller's balance point
(:func:`~ballbot_casadi.control.velocity.equilibrium_tilt`) use it, so the equilibrium
tilt is commanded; ``com_hat``, the slower average, is the estimate of the offset.

Why it converges
----------------
Write ``com_meas = c + e`` with ``c`` the observable part of the offset (below) and
``e`` the measurement error: sensor/estimate noise and the neglected terms of (1)
(rate-squared terms, friction).  Each filter's error obeys
``eps <- (1 - w beta) eps + w beta e``: a stable first-order filter whatever the
controller does, because (1) accounts for the motion the controller causes - the
observer does not close a loop through the robot's response.  That holds only with
*both* terms of (1): without ``lambda e_z x dw`` the body's own swing reads as a COM
offset, a fast balance-point filter then feeds the controllers a moving balance point
and in simulation the standing robot diverges.  At rest every term of ``e`` but the noise
vanishes, and the accumulated effect of the neglected dynamics is a difference of
bounded momenta that the filters average out: after the robot stops the errors decay as
``exp(-t / t_obs)`` and ``exp(-t / t_com)`` down to the filtered noise.

The attitude the observer reads is an estimate: a slowly varying tilt error ``delta``
of the attitude filter reads, at rest, exactly like a COM offset of ``l delta`` (the
two are indistinguishable without a further sensor).  The balance point ``com_bal``
follows it within ``t_obs``, so the controllers balance about the attitude that *is*
the robot's equilibrium in the estimator's frame: the robot does not accelerate on the
attitude filter's error, which is what the position hold needs (the velocity loop's
``p_e`` then measures the position error alone).  A constant measurement bias (a
miscalibrated IMU, a constant wheel-torque disturbance) becomes a constant estimate
bias for the same reason.

Observability
-------------
* Standstill: (1) says only that ``R(q) p_com`` is vertical, i.e. it fixes the
  *direction* of ``p_com`` in {B} (two angles) but not its length.  The horizontal
  offset is observable up to that scale: with the model's ``l`` the estimate converges
  to ``l / l_true (com_x, com_y)`` (the observable part, :func:`observable_offset`),
  which has the true direction and therefore gives the exact balance point.  The height
  error ``l_true - l`` is *not* observable at rest (every point on the vertical through
  the ball centre balances).
* In motion the height enters ``kappa``, ``lambda`` and the pendulum stiffness, so it is
  observable in principle, but only weakly (a 3 cm height error changes ``d`` by about
  0.5 mm per 0.5 m/s^2 of acceleration change) and confounded with the body inertia
  and masses, which the controller does not know better (thesis §8.4.1).  It is not
  estimated; the balance point does not depend on it.  During commanded motion the
  filters are frozen (``w = 0``): viscous friction at constant speed needs a lean that
  (1) would read as a COM offset.

Tuning
------
Gains ``k = [t_obs, t_com, t_diff, c_max]`` (:data:`COM_OBSERVER_GAIN_NAMES`), default
``[0.3 s, 2 s, 0.1 s, 0.1 m]``: ``t_obs`` well below the velocity loop's time
constants (its slowest closed-loop pole is -0.4 rad/s) so the balance point absorbs the
attitude filter's slow tilt error, ``t_diff`` smooths the differentiated rate noise of
the estimate (a faster balance point or a shorter ``t_diff`` lets that noise move the
robot), ``t_com = 2 s`` brings a 4 cm initial error below 2 mm within 10 s of standstill
and averages the balance point's noise; ``c_max`` lies beyond the 3.7 cm of a balance
point at the 5 deg tilt limit (thesis §7.1).  State ``o = [com_bal, com_hat, s_f, v_f,
w_f]`` (:data:`COM_OBSERVER_STATE`; the last three the filtered static measurement,
ball velocity and horizontal body rate in {K}).
"""

from __future__ import annotations

import math
from typing import Any

import casadi as ca
import numpy as np

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import STATE, STATE_DXY, Layout
from ballbot_casadi.core.params import PARAM_NAMES, Params, ParamView
from ballbot_casadi.errors import ArgumentError, ShapeError

__all__ = [
    "COM_OBSERVER_STATE",
    "COM_OBSERVER_GAIN_NAMES",
    "COM_OBSERVER_DEFAULT_GAINS",
    "NKO",
    "com_moment_coefficients",
    "make_com_observer",
    "com_observer_initial_state",
    "check_com_observer_gains",
    "observable_offset",
]

#: Observer state: balance-point estimate (the controllers' model), COM-offset estimate
#: (its average), low-passed static measurement, ball velocity and horizontal body rate ({K}).
COM_OBSERVER_STATE = Layout(
    "COM observer state",
    [("com_bal", 2), ("com", 2), ("s_f", 2), ("v_f", 2), ("w_f", 2)],
    ("com_bal_x", "com_bal_y", "com_x", "com_y", "s_fx", "s_fy", "v_fx", "v_fy", "w_fx", "w_fy"),
)
#: Gain vector layout: time constants (s) of the balance-point filter, of the COM-offset
#: average and of the measurement filter, and the bound of the measurement (m).
COM_OBSERVER_GAIN_NAMES = ("t_obs", "t_com", "t_diff", "c_max")
#: Default gains (module docstring, Tuning).
COM_OBSERVER_DEFAULT_GAINS = np.array([0.3, 2.0, 0.1, 0.10])
#: Number of gains.
NKO = len(COM_OBSERVER_GAIN_NAMES)
#: Commanded speeds (m/s, rad/s) below this count as a standstill command.
_V_REF_ZERO = 1e-9


def com_moment_coefficients(p: Any) -> tuple[Any, Any]:
    """``kappa`` (s^2) and ``lambda`` (s^2) of the moment balance (1) for parameters ``p``.

    ``kappa = (M_b (r_k + l) + M_k r_k + J_k / r_k) / (M_b g)``,
    ``lambda = (M_b l (r_k + l) + (J_bx + J_by) / 2) / (M_b g)``; numpy or CasADi.
    """
    v = ParamView(p)
    mg = v.Mb * v.g
    kappa = (v.Mb * (v.rk + v.l) + v.Mk * v.rk + v.Jk / v.rk) / mg
    lam = (v.Mb * v.l * (v.rk + v.l) + 0.5 * (v.Jbx + v.Jby)) / mg
    return kappa, lam


def _horizontal_rate(q: Any, dq: Any) -> Any:
    """Horizontal components of the body's angular velocity in {K}, ``2 vec(dq o q*)`` (E.35)."""
    w = 2 * Q.vee(Q.mul(dq, Q.conj(q)))
    return w[0:2]


def _alpha(tc: Any, Ts: Any) -> Any:
    """Gain ``1 - exp(-Ts / tc)`` of a first-order filter discretised exactly; 1 for ``tc = 0``."""
    return ca.if_else(tc > 0, 1 - ca.exp(-Ts / ca.fmax(tc, 1e-300)), 1)


def _solve_h(R: Any, rhs: Any) -> Any:
    """``R[0:2, 0:2]^-1 rhs`` (explicit 2 x 2 inverse)."""
    det = R[0, 0] * R[1, 1] - R[0, 1] * R[1, 0]
    return ca.vertcat(R[1, 1] * rhs[0] - R[0, 1] * rhs[1], R[0, 0] * rhs[1] - R[1, 0] * rhs[0]) / det


def make_com_observer() -> ca.Function:
    """Build ``ballbot_com_observer`` (module docstring; thesis App. C (C.21), ch. 11).

    Returns
    -------
    casadi.Function
        ``ballbot_com_observer(x[12], v_ref[3], o[10], p[NP], k[4], Ts) ->
        (o_next[10], p_hat[NP], com_hat[2], com_meas[2])``: ``x`` what the controllers
        read, ``v_ref`` the commanded velocity (the filters update while it is zero),
        ``o`` :data:`COM_OBSERVER_STATE`, ``p`` the controller's internal-model
        parameters, ``k`` :data:`COM_OBSERVER_GAIN_NAMES`.  ``p_hat`` is ``p`` with
        ``com_x``, ``com_y`` replaced by the updated balance-point estimate,
        ``com_hat`` the updated COM-offset estimate, ``com_meas`` the filtered
        measurement (2) the balance-point filter follows.
    """
    SX = ca.SX.sym
    O = COM_OBSERVER_STATE
    x, v_ref, o = SX("x", STATE.size), SX("v_ref", 3), SX("o", O.size)
    p, k, Ts = SX("p", len(PARAM_NAMES)), SX("k", NKO), SX("Ts")
    t_obs, t_com, t_diff, c_max = (k[i] for i in range(NKO))
    pv = ParamView(p)
    q, dq = x[STATE["q"]], x[STATE["dq"]]
    q = q / ca.norm_2(q)
    R = Q.rotation_matrix(q)
    standstill = ca.dot(v_ref, v_ref) <= _V_REF_ZERO**2
    # measurement filter (t_diff) on the static part and on v, w: the filter commutes
    # with d/dt, so a and dw are the exact derivatives of the filtered signals
    ad = _alpha(t_diff, Ts)
    static = _solve_h(R, -pv.l * R[0:2, 2])                         # (2) with d = 0
    s_f = o[O["s_f"]] + ad * (static - o[O["s_f"]])
    v, w = x[STATE_DXY], _horizontal_rate(q, dq)
    v_f, w_f = o[O["v_f"]], o[O["w_f"]]
    v_fn, w_fn = v_f + ad * (v - v_f), w_f + ad * (w - w_f)
    a, dw = (v_fn - v_f) / Ts, (w_fn - w_f) / Ts
    kappa, lam = com_moment_coefficients(p)
    d = ca.vertcat(kappa * a[0] + lam * dw[1], kappa * a[1] - lam * dw[0])   # (1), e_z x (u, v) = (-v, u)
    meas = ca.fmin(ca.fmax(s_f + _solve_h(R, d), -c_max), c_max)            # (2)
    beta = ca.if_else(standstill, _alpha(t_obs, Ts), 0)
    com_bal = o[O["com_bal"]] + beta * (meas - o[O["com_bal"]])
    gamma = ca.if_else(standstill, _alpha(t_com, Ts), 0)
    com = o[O["com"]] + gamma * (com_bal - o[O["com"]])
    i_x, i_y = PARAM_NAMES.index("com_x"), PARAM_NAMES.index("com_y")
    p_hat = ca.vertcat(*[com_bal[0] if i == i_x else com_bal[1] if i == i_y else p[i]
                         for i in range(len(PARAM_NAMES))])
    return ca.Function(
        "ballbot_com_observer",
        [x, v_ref, o, p, k, Ts],
        [ca.vertcat(com_bal, com, s_f, v_fn, w_fn), p_hat, com, meas],
        ["x", "v_ref", "o", "p", "k", "Ts"],
        ["o_next", "p_hat", "com_hat", "com_meas"],
    )


def check_com_observer_gains(k: Any) -> np.ndarray:
    """Validate an observer gain vector: 4 finite numbers, ``t_obs > 0``, ``t_com > 0``,
    ``t_diff >= 0``, ``c_max > 0``.

    Raises
    ------
    ArgumentError
        Wrong length, non-finite or out-of-range entries (the message names them).
    """
    try:
        arr = np.asarray(k, dtype=float).ravel()
    except (TypeError, ValueError):
        raise ArgumentError(f"COM observer gains must be numbers, got {k!r}") from None
    if arr.size != NKO:
        raise ArgumentError(f"COM observer gains need {NKO} entries {COM_OBSERVER_GAIN_NAMES}, "
                            f"got {arr.size}")
    lower = (0.0, 0.0, 0.0, 0.0)
    strict = (True, True, False, True)
    bad = [f"{n} = {float(v)!r}" for n, v, lo, st in zip(COM_OBSERVER_GAIN_NAMES, arr, lower, strict)
           if not (math.isfinite(v) and (v > lo if st else v >= lo))]
    if bad:
        raise ArgumentError("COM observer gains out of range (t_obs > 0 s, t_com > 0 s, "
                            f"t_diff >= 0 s, c_max > 0 m): {', '.join(bad)}")
    return arr


def com_observer_initial_state(x0: Any, p: Any) -> np.ndarray:
    """Observer state at the start of a run: the model's COM offset as both estimates,
    the measurement filters at the initial attitude's static measurement, ball velocity
    and body rate (a bumpless start)."""
    x0 = np.asarray(x0, dtype=float).ravel()
    if x0.shape != (STATE.size,) or not np.all(np.isfinite(x0)):
        raise ShapeError(f"x0 must be a finite 12-state, got shape {x0.shape}")
    pv = ParamView(p.to_vector() if isinstance(p, Params) else np.asarray(p, float).ravel())
    q = x0[STATE["q"]] / np.linalg.norm(x0[STATE["q"]])
    R = Q.rotation_matrix(q)
    O = COM_OBSERVER_STATE
    o = np.zeros(O.size)
    o[O["com_bal"]] = o[O["com"]] = [float(pv.com_x), float(pv.com_y)]
    o[O["s_f"]] = np.linalg.solve(R[0:2, 0:2], -float(pv.l) * R[0:2, 2])
    o[O["v_f"]] = x0[STATE_DXY]
    o[O["w_f"]] = _horizontal_rate(q, x0[STATE["dq"]])
    return o


def observable_offset(com_true: Any, l_true: float, l_model: float) -> np.ndarray:
    """The part of a horizontal COM offset the observer can see at rest, in the model's scale.

    ``l_model / l_true * (com_x, com_y)``: the direction of ``(com_x, com_y, l_true)``
    with the model's height (module docstring, Observability).
    """
    return np.asarray(com_true, float).reshape(2) * (float(l_model) / float(l_true))

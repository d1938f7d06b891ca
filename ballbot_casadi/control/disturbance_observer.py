"""Feedback linearisation with a disturbance observer, ``"flc_dob"`` (thesis ch. 8, ch. 11 future work).

``ballbot_flc_dob(x, q_ref, dq_ref, ddq_ref, p, k, zb) -> (tau, diag, zb_next)``: the
FLC's interface (:func:`~ballbot_casadi.control.flc.make_flc`) plus a *balance-controller
state* ``zb`` (:data:`DOB_STATE`) as the last input and its next value as the last output,
like the super-twisting controller (:mod:`~ballbot_casadi.control.super_twisting`).

The thesis's conclusions (ch. 11) propose extending the FLC "with extra terms for the
disturbances".  On the exact error-output dynamics of the FLC (thesis 8.12-8.25,
:mod:`~ballbot_casadi.control.decoupling`) everything the internal model misses - a wheel
torque disturbance ``tau_d`` (``delta = E tau_d``), a COM offset, wrong inertias - is a
lumped error acceleration ``delta``::
    ddy = D(x) + E(x) tau + delta

Observer (a discrete disturbance observer on the affine form)
------------------------------------------------------------
Per axis, with the period ``h``, the applied torque ``tau_a`` (the command after the
controller's direction-preserving limit at ``p[tau_max]``,
:func:`~ballbot_casadi.control.saturate_torques`, so a saturated command is not mistaken
for a disturbance) and the observer gain ``L`` (1/s)::
    dy_pred(k+1) = dy(k) + h (D(k) + E(k) tau_a(k) + d_hat(k))       (Euler prediction)
    d_hat(k+1)   = d_hat(k) + L (dy(k+1) - dy_pred(k+1))              (innovation)

The innovation is ``h (delta - d_hat)`` to first order in ``h``, so the estimation error
obeys ``e(k+1) = (1 - L h) e(k)``: a first-order filter of bandwidth ``L`` for
``0 < L h < 1`` (deadbeat at ``L h = 1``, stable up to 2).  The first period after power-on
(``armed = 0``) only arms the predictor, so the zero power-on state is bumpless.

Control law
-----------
The FLC's (thesis 8.26, 8.43, 8.44) with the estimate subtracted::
    tau = E^-1 (v - D - d_hat),        v = -K_p y - K_d dy

so with an exact estimate the error dynamics are again those of thesis (8.45).  The
estimation error decays on its own (``e`` above does not depend on ``y``): controller and
observer separate, and a constant ``delta`` leaves no static error (the FLC alone keeps
``y = delta / K_p``).

Gains ``k = [K_p1..3, K_d1..3, L1..3, h]`` (:data:`DOB_GAIN_NAMES`): the FLC's default
gains (:data:`~ballbot_casadi.control.flc.FLC_DEFAULT_GAINS`) and observer bandwidths
``L = 3 omega`` of each channel's FLC pole (30 rad/s tilt, 15 rad/s yaw: the estimate
settles three times faster than the loop it feeds, the usual separation rule for a
disturbance observer, and ``L h = 0.15`` keeps the estimate a low-pass filter of the
noisy rate innovation); ``h`` must equal the period's ``Ts`` (set by
:func:`~ballbot_casadi.control.default_balance_gains`).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from ballbot_casadi.control.decoupling import (
    DAMPING_MU,
    QE0_MIN,
    RCOND_MIN,
    check_affine,
    damped_solve,
    error_output_dynamics,
)
from ballbot_casadi.control.flc import FLC_DEFAULT_GAINS, FLC_GAIN_NAMES
from ballbot_casadi.control.torque_limit import saturate_torques
from ballbot_casadi.core.constants import TS_CONTROL
from ballbot_casadi.core.layout import Layout
from ballbot_casadi.core.params import PARAM_NAMES

__all__ = ["DOB_GAIN_NAMES", "DOB_DEFAULT_GAINS", "DOB_STATE", "DOB_NZ", "make_flc_dob"]

#: Gain vector layout: the FLC's gains, the observer bandwidths (1/s) and the period ``h``.
DOB_GAIN_NAMES = (*FLC_GAIN_NAMES, "L1", "L2", "L3", "h")
#: The observer's state: the estimate, the predicted error rate, the armed flag.
DOB_STATE = Layout("disturbance observer state", [("d_hat", 3), ("dy_pred", 3), ("armed", 1)])
#: Size of the balance-controller state ``zb``.
DOB_NZ = DOB_STATE.size
_SEPARATION = 3.0  # observer bandwidth / FLC pole per channel (module docstring)
#: Default gains: the FLC's, ``L = 3 omega`` per channel, ``h = 5 ms``.
DOB_DEFAULT_GAINS = np.concatenate([FLC_DEFAULT_GAINS,
                                    _SEPARATION * FLC_DEFAULT_GAINS[3:6] / 2, [TS_CONTROL]])
_TAU_MAX = PARAM_NAMES.index("tau_max")


def make_flc_dob(
    affine: ca.Function,
    qe0_min: float = QE0_MIN,
    rcond_min: float = RCOND_MIN,
    mu: float = DAMPING_MU,
) -> ca.Function:
    """Build the FLC with a disturbance observer (module docstring).

    Parameters
    ----------
    affine
        The model Function ``affine(x, p) -> (f, g)``; it stays a called Function.
    qe0_min, rcond_min, mu
        Singularity thresholds and relative damping of the regularised inverse
        (:func:`~ballbot_casadi.control.decoupling.damped_solve`).

    Returns
    -------
    casadi.Function
        ``ballbot_flc_dob(x[12], q_ref[4], dq_ref[4], ddq_ref[4], p[NP], k[10],
        zb[7]) -> (tau[3], diag[12], zb_next[7])``; ``tau`` unsaturated, ``diag`` as the
        FLC's (:data:`~ballbot_casadi.control.flc.DIAG_NAMES`, ``v`` the PD law's output).
    """
    _, np_ = check_affine(affine)
    x, q_ref, dq_ref, ddq_ref = (ca.MX.sym(n, m) for n, m in
                                 (("x", 12), ("q_ref", 4), ("dq_ref", 4), ("ddq_ref", 4)))
    p, k, zb = ca.MX.sym("p", np_), ca.MX.sym("k", len(DOB_GAIN_NAMES)), ca.MX.sym("zb", DOB_NZ)
    Kp, Kd, L, h = k[0:3], k[3:6], k[6:9], k[9]
    S = DOB_STATE
    d_prev, dy_pred, armed = zb[S["d_hat"]], zb[S["dy_pred"]], zb[S["armed"]]
    f, g = affine(x, p)
    o = error_output_dynamics(x, q_ref, dq_ref, ddq_ref, f, g)
    on = armed > 0.5
    d_hat = ca.if_else(on, d_prev + L * (o["dy"] - dy_pred), d_prev)
    v = -Kp * o["y"] - Kd * o["dy"]  # (8.44)
    tau, singular, margin = damped_solve(
        o["E"], v - o["D"] - d_hat, o["qe0"], o["G"], qe0_min, rcond_min, mu
    )  # (8.26) with the estimate subtracted
    tau_a = saturate_torques(tau, p[_TAU_MAX])
    dy_next = o["dy"] + h * (o["D"] + ca.mtimes(o["E"], tau_a) + d_hat)
    diag = ca.vertcat(singular, margin, o["sigma"], o["y"], o["dy"], v)
    return ca.Function(
        "ballbot_flc_dob",
        [x, q_ref, dq_ref, ddq_ref, p, k, zb],
        [tau, diag, ca.vertcat(d_hat, dy_next, 1)],
        ["x", "q_ref", "dq_ref", "ddq_ref", "p", "k", "zb"],
        ["tau", "diag", "zb_next"],
    )

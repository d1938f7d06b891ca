"""Feedback linearisation with a disturbance observer, ``"flc_dob"`` (thesis ch. 8, ch. 11 future work).

``ballbot_flc_dob(x, q_ref, dq_ref, ddq_ref, p, k, zb) -> (tau, diag, zb_next)``: the
FLC's interface (:func:`~ballbot_casadi.control.flc.make_flc`) plus a *balance-controller
state* ``zb`` (:data:`DOB_STATE`) as the last input and its next value as the last output,
like the super-twisting controller (:mod:`~ballbot_casadi.control.super_twisting`).

The thesis's conclusions (ch. 11) propose extending the FLC "with extra terms for the
disturbances".  Everything the internal model misses - a wheel-torque disturbance
``tau_d``, a COM offset, wrong inertias - shows in the body's angular acceleration as a
lumped term ``d`` (rad/s^2, body frame).  With ``omega = 2 vec(q* o dq)`` and the model's
affine form ``ddchi = f + g tau`` (thesis 8.12; ``dq* o dq`` is real, so only ``ddq`` enters)::
    domega = F(x) + G(x) tau + d,     F = 2 vec(q* o f_q),  G = 2 vec(q* o g_q)

(``G`` is the torque -> body-acceleration map of :mod:`~ballbot_casadi.control.decoupling`;
a wheel-torque disturbance gives ``d = G tau_d``).  The observer works on the body rate,
not on the error output: the rate does not depend on the reference, so a reference whose
rate and acceleration do not match exactly from period to period (the velocity
controller's, under sensor noise) is not mistaken for a disturbance.

Observer (a discrete disturbance observer on the affine form)
------------------------------------------------------------
Per body axis, with the period ``h``, the applied torque ``tau_a`` (the command after the
controller's direction-preserving limit at ``p[tau_max]``,
:func:`~ballbot_casadi.control.saturate_torques`, so a saturated command is not mistaken
for a disturbance) and the observer gain ``L`` (1/s)::
    omega_pred(k+1) = omega(k) + h (F(k) + G(k) tau_a(k) + d_hat(k))   (Euler prediction)
    d_hat(k+1)      = d_hat(k) + L (omega(k+1) - omega_pred(k+1))     (innovation)

The innovation is ``h (d - d_hat)`` to first order in ``h``, so the estimation error
obeys ``e(k+1) = (1 - L h) e(k)``: a first-order filter of bandwidth ``L`` for
``0 < L h < 1`` (deadbeat at ``L h = 1``, stable up to 2).  The first period after power-on
(``armed = 0``) only arms the predictor, so the zero power-on state is bumpless.

Control law
-----------
The FLC's (thesis 8.26, 8.43, 8.44) minus the torque equivalent of the estimate::
    tau = E^-1 (v - D) - G^-1 d_hat,        v = -K_p y - K_d dy

so a disturbance entering with the torque (``d = G tau_d``) is cancelled at its source and
with an exact estimate the error dynamics are again those of thesis (8.45).  The
estimation error decays on its own (``e`` above does not depend on ``y``): controller and
observer separate, and a constant ``d`` leaves no static error (the FLC alone keeps
``y = E G^-1 d / K_p``).

Gains ``k = [K_p1..3, K_d1..3, L1..3, h]`` (:data:`DOB_GAIN_NAMES`): the FLC's default
gains (:data:`~ballbot_casadi.control.flc.FLC_DEFAULT_GAINS`) and observer bandwidths
``L = 10 omega`` of each channel's FLC pole (100 rad/s roll and pitch, 50 rad/s yaw;
``L h = 0.5`` and ``0.25``: still a low-pass of the rate innovation, one pole inside the
unit circle).  The usual separation rule ``L = 3 omega`` (the estimate settles three times
faster than the loop it feeds) rejects disturbances on the true state just as well but,
with the estimators in the velocity cascade, a slow estimate makes the standing robot
wander more than the FLC alone; from about ``10 omega`` on it wanders less, at the price
of more torque activity (the gain sweep of ``ballbot study envelope``).  ``h`` must equal
the period's ``Ts`` (set by :func:`~ballbot_casadi.control.default_balance_gains`).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from ballbot_casadi.control.balance_frame import BalanceFrame, balance_controller
from ballbot_casadi.control.decoupling import DampedInverse, solve3
from ballbot_casadi.control.flc import FLC_DEFAULT_GAINS, FLC_GAIN_NAMES, pd_error_acceleration
from ballbot_casadi.control.torque_limit import saturate_torques
from ballbot_casadi.core.constants import TS_CONTROL
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import GENERALISED, STATE, Layout
from ballbot_casadi.core.params import PARAM_NAMES

__all__ = ["DOB_GAIN_NAMES", "DOB_DEFAULT_GAINS", "DOB_SEPARATION", "DOB_STATE", "DOB_NZ",
           "make_flc_dob"]

#: Gain vector layout: the FLC's gains, the observer bandwidths (1/s) and the period ``h``.
DOB_GAIN_NAMES = (*FLC_GAIN_NAMES, "L1", "L2", "L3", "h")
#: The observer's state: the estimate (rad/s^2, body frame), the predicted body rate, the armed flag.
DOB_STATE = Layout("disturbance observer state", [("d_hat", 3), ("w_pred", 3), ("armed", 1)])
#: Size of the balance-controller state ``zb``.
DOB_NZ = DOB_STATE.size
#: Observer bandwidth / FLC pole per channel (module docstring).
DOB_SEPARATION = 10.0
#: Default gains: the FLC's, ``L = 10 omega`` per channel, ``h = 5 ms``.
DOB_DEFAULT_GAINS = np.concatenate([FLC_DEFAULT_GAINS,
                                    DOB_SEPARATION * FLC_DEFAULT_GAINS[3:6] / 2, [TS_CONTROL]])
_TAU_MAX = PARAM_NAMES.index("tau_max")


def make_flc_dob(affine: ca.Function, inverse: DampedInverse = DampedInverse()) -> ca.Function:
    """Build ``ballbot_flc_dob``, the FLC with a disturbance observer (module docstring).

    ``affine``, ``inverse``, the signature with ``zb`` (:data:`DOB_STATE`) and ``diag``
    (``v`` the PD law's output): as in
    :func:`~ballbot_casadi.control.balance_frame.balance_controller`; ``k`` as
    :data:`DOB_GAIN_NAMES`; ``tau`` unsaturated.
    """

    def observer_law(b: BalanceFrame) -> tuple[ca.MX, ca.MX, ca.MX]:
        Kp, Kd, L, h = b.k[0:3], b.k[3:6], b.k[6:9], b.k[9]
        S = DOB_STATE
        d_prev, w_pred, armed = b.zb[S["d_hat"]], b.zb[S["w_pred"]], b.zb[S["armed"]]
        q, dq = b.x[STATE["q"]], b.x[STATE["dq"]]
        qc = Q.Phi(q).T  # left multiplication by q* (unit q)
        omega = 2 * ca.mtimes(qc, dq)[1:4]
        F = 2 * ca.mtimes(qc, b.f[GENERALISED["q"]])[1:4]
        G = b.o["G"]  # 2 vec(q* o g_q), torque -> body angular acceleration
        d_hat = ca.if_else(armed > 0.5, d_prev + L * (omega - w_pred), d_prev)
        v = pd_error_acceleration(b, Kp, Kd)  # (8.44)
        tau_flc, diag = b.linearising_torque(v)  # (8.26)
        tau = tau_flc - solve3(G, d_hat)
        tau_a = saturate_torques(tau, b.p[_TAU_MAX])
        w_next = omega + h * (F + ca.mtimes(G, tau_a) + d_hat)
        return tau, diag, ca.vertcat(d_hat, w_next, 1)

    return balance_controller("flc_dob", affine, len(DOB_GAIN_NAMES), observer_law, DOB_NZ,
                              inverse=inverse)

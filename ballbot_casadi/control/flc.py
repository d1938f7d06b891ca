"""Feedback-linearising balance controller (thesis ch. 8).

``ballbot_flc(x, q_ref, dq_ref, ddq_ref, p, k) -> (tau, diag)``.

Control law
-----------
With the error output ``y = vec(sigma q_ref* o q)`` (thesis 7.4, 8.7, shortest-path
sign fix §7.4) the model gives ``ddy = D(x) + E(x) tau`` (thesis 8.12-8.25; see
:mod:`~ballbot_casadi.control.decoupling`, which includes the reference
derivatives exactly, thesis 7.5).  The linearising feedback (thesis 8.26)::
    tau = E^-1 (v - D),        v = -K_p y - K_d dy                       (8.43, 8.44)

makes every output an independent double integrator closed by a PD law, i.e. the error
dynamics of thesis (8.45) hold exactly: ``ddy_i + K_di dy_i + K_pi y_i = 0``.  The
reference acceleration ``ddq_ref`` is *not* assumed zero (unlike the thesis'
implementation of 8.44): it is the feedforward that makes sine tracking lag-free.

Gains ``k = [K_p1, K_p2, K_p3, K_d1, K_d2, K_d3]`` (axes: body x/roll, y/pitch, z/yaw).

Default gains (pole placement of 8.45, Jaulin §2.1)
---------------------------------------------------
Each error channel is given a critically damped double pole at ``-omega``:
``K_p = omega^2``, ``K_d = 2 omega`` (no overshoot, the fastest non-oscillating
response for a given torque peak).

* Tilt (x, y): ``omega = 10 rad/s`` -> ``K_p = 100``, ``K_d = 20``.
  - Lower bound, robustness: with a wrong internal model the realised error dynamics
    are ``ddy = E_true E_nom^-1 (v - D_nom) + D_true``; with inertias x3.2 (thesis
    §8.4.1) the effective gains drop ~3x, and they must still dominate the gravity
    term (open-loop pole 3.74 rad/s, i.e. ``D ~ 14 y``).  Also the static tilt error
    under a COM offset is ``K_p / (K_p + 14)`` of the reference: at ``K_p = 100`` the
    velocity loop reaches the COM-over-ball equilibrium of the thesis §9.2 test
    (-3.8 deg, 2.5 deg) with a reference of 4.3 deg, inside the 5 deg limit
    (``omega = 6`` would need 5.3 deg).
  - Lower bound, cascade: >= 3x faster than the velocity loop (thesis §7.1), whose
    dominant closed-loop poles are at -1 ... -4 rad/s.
  - Upper bound, torque: the tilt input gain is ``sigma(E) ~ 0.86 /(N m)``
    (vec-quaternion units, upright, default robot); a 5 deg roll + 5 deg pitch
    initial error asks ~(K_p + 14) |y| / 0.86 N m, so the wheels (1.98 N m) saturate
    for ~0.1 s on that test - tolerated, the peak tilt rate stays ~18 deg/s (< the
    20 deg/s of thesis §7.1); faster poles would saturate for longer.
  - Upper bound, sampling: ``omega Ts = 0.05`` at 200 Hz ZOH (well under the usual
    0.1-0.2), so the hold costs only ~Ts/2 of phase.
* Yaw (z): ``omega = 5 rad/s`` -> ``K_p = 25``, ``K_d = 10``: heading may be less
  aggressive than inclination (thesis §7.2 item 1) and is not gravity-unstable.

With the feedforward and exact decoupling, tracking errors only arise from the 5 ms
zero-order hold, so the sine test's lag is far below the 0.02 s requirement.

Near-singular E(x) is handled by damped least squares and reported in ``diag``
(see :func:`~ballbot_casadi.control.decoupling.damped_solve`).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from ballbot_casadi.control.balance_frame import BalanceFrame, balance_controller
from ballbot_casadi.control.decoupling import DampedInverse

__all__ = ["make_flc", "FLC_GAIN_NAMES", "FLC_DEFAULT_GAINS", "pd_error_acceleration"]

#: Gain vector layout of the FLC.
FLC_GAIN_NAMES = ("Kp1", "Kp2", "Kp3", "Kd1", "Kd2", "Kd3")
_W_TILT, _W_YAW = 10.0, 5.0
#: Default gains: critically damped double poles at -10 (tilt) and -5 rad/s (yaw).
FLC_DEFAULT_GAINS = np.array(
    [_W_TILT**2, _W_TILT**2, _W_YAW**2, 2 * _W_TILT, 2 * _W_TILT, 2 * _W_YAW]
)


def pd_error_acceleration(b: BalanceFrame, Kp: ca.MX, Kd: ca.MX) -> ca.MX:
    """``v = -K_p y - K_d dy`` (thesis 8.44) on the exact error output of ``b``."""
    return -Kp * b.o["y"] - Kd * b.o["dy"]


def make_flc(affine: ca.Function, inverse: DampedInverse = DampedInverse()) -> ca.Function:
    """Build ``ballbot_flc``, the feedback-linearising balance controller (thesis 8.12-8.26,
    8.43-8.45).

    ``affine``, ``inverse``, the signature and ``diag``: as in
    :func:`~ballbot_casadi.control.balance_frame.balance_controller`; ``k`` as
    :data:`FLC_GAIN_NAMES`; ``tau`` unsaturated.
    """

    def pd_law(b: BalanceFrame) -> tuple[ca.MX, ca.MX]:
        v = pd_error_acceleration(b, b.k[0:3], b.k[3:6])  # (8.44)
        return b.linearising_torque(v)  # (8.26)

    return balance_controller("flc", affine, len(FLC_GAIN_NAMES), pd_law, inverse=inverse)

"""Velocity-aided tilt correction: the attitude filter's slow tilt error, read from the
velocity filter's accelerometer bias (thesis 4.29, 5.1, 5.18; beyond the thesis).

``ballbot_tilt_correction(q, a, b_acc, p) -> (q_c, r)``: the attitude ``q`` of the
attitude filter (QUKF or QEKF) corrected by the body rotation ``r`` that the velocity
filter's (VUKF or VEKF) accelerometer-bias estimate ``b_acc`` stands for.

Why the attitude filter leaves a slow tilt error
------------------------------------------------
The attitude filter propagates the gyroscope's rate and pulls the tilt towards the
accelerometer's gravity direction (thesis 4.29) with a weight that the thesis keeps
small on purpose (4.40: ``alpha_trust Sigma_acc`` applied to readings in units of g),
because every acceleration of the ball reads as tilt.  Between the accelerometer's
slow corrections the gyroscope's white noise integrates into a tilt error ``r`` with a
correlation time of seconds, which averaging over a standstill does not remove (the
``com`` study reports it).  Trusting the accelerometer more does not help in closed
loop: the ball's own balancing acceleration then enters the tilt estimate, and the
acceleration compensation of the embedded software lags at the balance loop's
frequencies, so the loop oscillates.

Why the velocity filter sees it
-------------------------------
The velocity filter's accelerometer model (thesis 5.18) is
``acc = R(q)^T [ddx, ddy, g] + b_acc`` with the attitude filter's ``q`` as an input.
If the true attitude is ``q o exp(r / 2)`` (``r`` a small rotation vector in {B}), the
accelerometer reads ``R(q)^T [a, g] - r x g_B`` with ``g_B = R(q)^T [ddx, ddy, g]``,
so the velocity filter explains the difference as a bias ``b_acc = -r x g_B``: the
accelerometer alone cannot tell a tilt error from a bias, but the velocity filter also
has the encoders, whose velocity must be the integral of ``[ddx, ddy]`` - the classic
velocity-aided attitude of inertial navigation.  A horizontal ``b_acc`` is therefore the
attitude filter's tilt error, observed through the velocity within a fraction of a
second, and the part of ``r`` perpendicular to ``g_B`` is recovered as::

    r = (b_acc x g_B) / |g_B|^2                                          (1)

(``g_B x (-r x g_B) = -|g_B|^2 r_perp``); the rotation about ``g_B`` (heading) leaves
the accelerometer unchanged and is not observable.  The controllers read
``q_c = q o exp(r / 2)``.  Nothing is fed back into either filter, so the two filters
run exactly as in the thesis; ``b_acc`` can follow the attitude filter's error only as
fast as its process noise allows (the ``acc_bias_process_var`` of the scenario's
``estimator_tuning``: with the predecessor's ``1e-9`` per period it follows over
minutes; the ``full`` and ``com`` scenario files raise it so that it follows within
seconds).

A real accelerometer bias is indistinguishable from a tilt error for both filters (the
attitude filter already turns it into a tilt error of ``b / g``; the velocity filter
then sees no bias), so the correction neither helps nor hurts there.
"""

from __future__ import annotations

import casadi as ca

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.params import PARAM_NAMES, ParamView

__all__ = ["TILT_CORRECTION_INPUTS", "TILT_CORRECTION_OUTPUTS", "make_tilt_correction"]

#: Inputs of ``ballbot_tilt_correction``.
TILT_CORRECTION_INPUTS = ("q", "a", "b_acc", "p")
#: Outputs of ``ballbot_tilt_correction``.
TILT_CORRECTION_OUTPUTS = ("q_c", "r")


def make_tilt_correction() -> ca.Function:
    """``ballbot_tilt_correction(q, a, b_acc, p) -> (q_c, r)``, equation (1) of the module.

    Inputs: ``q`` (4, the attitude filter's quaternion, scalar first), ``a`` (2, the
    velocity filter's ball acceleration ``[ddx, ddy]`` in {K}, m/s^2), ``b_acc`` (3, its
    accelerometer bias in {B}, m/s^2, thesis 5.1), ``p`` (model parameters, uses ``g``).
    Outputs: ``q_c = q o exp(r / 2)`` (unit for a unit ``q``) and ``r`` (3, rad, body
    frame, perpendicular to the specific force ``g_B = R(q)^T [a, g]``).
    """
    q, a, b = ca.SX.sym("q", 4), ca.SX.sym("a", 2), ca.SX.sym("b_acc", 3)
    p = ca.SX.sym("p", len(PARAM_NAMES))
    g_b = Q.rotate_inv(q, ca.vertcat(a, ParamView(p).g))
    r = ca.cross(b, g_b) / ca.dot(g_b, g_b)
    q_c = Q.mul(q, Q.from_rotation_vector(r))
    return ca.Function("ballbot_tilt_correction", [q, a, b, p], [q_c, r],
                       list(TILT_CORRECTION_INPUTS), list(TILT_CORRECTION_OUTPUTS), {"cse": True})

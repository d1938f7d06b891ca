"""Default tuning of the estimators (thesis §3.1, §4.3, §5.3), defined once.

Sensor covariances (MPU-9250, from the predecessor project, thesis ref. [6]):

* :data:`SIGMA_ACC` - accelerometer, (m/s^2)^2, thesis (3.4);
* :data:`SIGMA_GYRO` - gyroscope, (rad/s)^2, thesis (3.8);
* :data:`SIGMA_ENC` - encoder tick increments, ticks^2: ``(1/3)^2 I3`` (thesis §3.1.3,
  3 sigma = one tick).

Attitude filters (QUKF, QEKF), on the tangent ``[rotation vector, omega]``:

* :data:`QUKF_Q` = ``blkdiag(1e-20 I3, 1e-5 I3)`` (4.37-4.39);
* :data:`QUKF_R` = ``blkdiag(ALPHA_TRUST Sigma_acc, Sigma_gyro)``, ``ALPHA_TRUST = 2``
  (4.40), its accelerometer block applied to the accelerometer in units of g (see
  :mod:`~ballbot_casadi.estimation.attitude`);
* :data:`QUKF_P0` = ``diag(1e-7, 1e-7, 1e-9, 1e-7, 1e-7, 1e-9)`` (4.4);
  :data:`QUKF_X0` = ``[1, 0, 0, 0, 0, 0, 0]`` (4.3).
* The QEKF's 7 x 7 initial covariance is ``G P0 G^T`` plus :data:`QEKF_P0_RADIAL`
  along ``q`` (the predecessor's initial ``q0`` variance), so its additive covariance
  starts positive definite
  (:func:`~ballbot_casadi.estimation.attitude.qekf_initial_covariance`).

Velocity filters (VUKF, VEKF), state ``[dx, dy, ddx, ddy, b_acc]``:

* :data:`VUKF_Q` = ``blkdiag(sigma_v I2, sigma_a I2, Sigma_bias)`` (5.26; the thesis
  prints it as 6 x 6 but the state has 7 entries).  The thesis gives no numbers; they
  are the predecessor's (thesis ref. [6]): ``sigma_v = 0`` (no velocity noise beyond the
  integrated acceleration), ``sigma_a = 1e-5`` and ``Sigma_bias = 1e-9 I3``;
* :data:`VUKF_R` = ``blkdiag(Sigma_enc, Sigma_acc)`` (5.28; the attitude term is added
  inside the filter);
* :data:`VUKF_P0` = ``diag(1e-1 I2, 1e-2 I2, 1e-9 I3)`` (5.4); :data:`VUKF_X0` = 0 (5.3).

Innovation gating (not in the thesis; what filters in the field do against glitch
readings, :class:`~ballbot_casadi.estimation.core.InnovationGate`):

* :data:`GATE_PROBABILITY` = ``1 - 1e-6``: a measurement group is rejected when its
  normalised innovation squared exceeds the chi-square quantile of this probability
  (``k`` degrees of freedom for ``k`` valid components: 23.9, 27.6, 30.7 for 1, 2, 3), so
  a consistent filter rejects one group reading in a million;
* :data:`GATE_SCALE_ATTITUDE` = 10, :data:`GATE_SCALE_VELOCITY` = 1000: the innovation
  covariance the gate assumes is this multiple of the filter's ``S``.  The chi-square
  test presumes a consistent filter; these are not: the models leave out what the
  simulated sensors see (the IMU's lever arm and the body's own acceleration, the COM
  offset, the attitude filter's lag in the encoder prediction), so the normalised
  innovations of the shipped runs exceed their degrees of freedom by far - the velocity
  filter's by orders of magnitude (``studies/consistency.py`` measures the means).  The
  gate is then a guard against gross glitches (a saturated or corrupted sample: tens of
  g, tens of rad/s, hundreds of ticks), not a consistency test;
* :data:`GATE_MAX_REJECTIONS` = 20: after that many consecutive rejections of a group
  (0.1 s at the 5 ms period) the gate opens and stays open until an innovation passes
  it again (the guard against lock-out after a real manoeuvre or a long dropout).

Acceleration random-walk adaptation of the velocity filter (``estimator = "ukf_adaptive"``,
:mod:`~ballbot_casadi.estimation.adaptive_walk`; not in the thesis):

* :data:`ADAPTIVE_WALK_FORGETTING` = 0.0025: the Sage-Husa weight of the newest squared
  acceleration correction, a time constant of 2 s at the 5 ms period (the estimate of a
  stationary walk then spreads by about 5 %, ``sqrt(lambda)``);
* :data:`ADAPTIVE_WALK_PRIOR_SAMPLES` = 20: the prior (the configured walk) counts as 20
  squared corrections (0.1 s) at power-on;
* :data:`ADAPTIVE_WALK_FLOOR` = 1e-3, :data:`ADAPTIVE_WALK_CEILING` = 1.0 (m/s^2)^2 per
  period: the bounds of the estimate, a decade below the moving robot's measured walk
  (~1e-2) and a decade above the standing robot's (~0.1);
* :data:`ADAPTIVE_WALK_SAMPLE_MAX` = 10 (m/s^2)^2: each period's sample enters clipped to
  it (a glitch moves the estimate by at most ``lambda`` times it, 0.025).

Every array is read-only.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import block_diag

__all__ = [
    "ADAPTIVE_WALK_CEILING",
    "ADAPTIVE_WALK_FLOOR",
    "ADAPTIVE_WALK_FORGETTING",
    "ADAPTIVE_WALK_PRIOR_SAMPLES",
    "ADAPTIVE_WALK_SAMPLE_MAX",
    "ALPHA_TRUST",
    "GATE_MAX_REJECTIONS",
    "GATE_PROBABILITY",
    "GATE_SCALE_ATTITUDE",
    "GATE_SCALE_VELOCITY",
    "QEKF_P0_RADIAL",
    "QUKF_P0",
    "QUKF_Q",
    "QUKF_R",
    "QUKF_X0",
    "SIGMA_ACC",
    "SIGMA_ENC",
    "SIGMA_GYRO",
    "VUKF_P0",
    "VUKF_Q",
    "VUKF_R",
    "VUKF_X0",
    "read_only",
]


def read_only(a: np.ndarray) -> np.ndarray:
    """A float copy of ``a`` that cannot be written to."""
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a


#: Accelerometer noise covariance, (m/s^2)^2, thesis (3.4).
SIGMA_ACC = read_only(np.array([[0.3945, 0.0006, -0.0234],
                                [0.0006, 0.3922, -0.0036],
                                [-0.0234, -0.0036, 0.9941]]) * 1e-3)
#: Gyroscope noise covariance, (rad/s)^2, thesis (3.8).
SIGMA_GYRO = read_only(np.array([[0.4969, 0.0201, 0.0035],
                                 [0.0201, 0.1749, -0.0260],
                                 [0.0035, -0.0260, 1.3970]]) * 1e-3)
#: Encoder tick-increment noise covariance, ticks^2, thesis §3.1.3.
SIGMA_ENC = read_only(np.eye(3) / 9.0)
#: Accelerometer de-weighting factor of the QUKF, thesis (4.40).
ALPHA_TRUST = 2.0

#: QUKF process noise, tangent [rotation vector, omega], thesis (4.37)-(4.39).
QUKF_Q = read_only(np.diag([1e-20] * 3 + [1e-5] * 3))
#: QUKF measurement noise [acc (g units), gyro], thesis (4.40).
QUKF_R = read_only(block_diag(ALPHA_TRUST * SIGMA_ACC, SIGMA_GYRO))
#: QUKF initial covariance, thesis (4.4).
QUKF_P0 = read_only(np.diag([1e-7, 1e-7, 1e-9, 1e-7, 1e-7, 1e-9]))
#: QUKF initial state [q, omega]: upright and at rest, thesis (4.3).
QUKF_X0 = read_only([1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
#: Initial variance of the QEKF's additive chart along q (predecessor's q0 variance).
QEKF_P0_RADIAL = 1e-7

#: VUKF process noise [dx, dy, ddx, ddy, b_acc], thesis (5.26) with the predecessor's values.
VUKF_Q = read_only(np.diag([0.0, 0.0, 1e-5, 1e-5, 1e-9, 1e-9, 1e-9]))
#: VUKF measurement noise [encoder ticks, acc m/s^2], thesis (5.28) without the attitude term.
VUKF_R = read_only(block_diag(SIGMA_ENC, SIGMA_ACC))
#: VUKF initial covariance, thesis (5.4).
VUKF_P0 = read_only(np.diag([1e-1, 1e-1, 1e-2, 1e-2, 1e-9, 1e-9, 1e-9]))
#: VUKF initial state: at rest, zero bias, thesis (5.3).
VUKF_X0 = read_only(np.zeros(7))


#: Probability of the chi-square innovation gate (see the module docstring).
GATE_PROBABILITY = 1.0 - 1e-6
#: Innovation-covariance scale of the attitude filters' gate (see the module docstring).
GATE_SCALE_ATTITUDE = 10.0
#: Innovation-covariance scale of the velocity filters' gate (see the module docstring).
GATE_SCALE_VELOCITY = 1000.0
#: Consecutive rejections of a measurement group after which its gate opens.
GATE_MAX_REJECTIONS = 20

#: Sage-Husa weight of the newest squared acceleration correction (see the module docstring).
ADAPTIVE_WALK_FORGETTING = 0.0025
#: Lower bound of the adapted acceleration random walk, (m/s^2)^2 per period.
ADAPTIVE_WALK_FLOOR = 1e-3
#: Upper bound of the adapted acceleration random walk, (m/s^2)^2 per period.
ADAPTIVE_WALK_CEILING = 1.0
#: Number of squared corrections the prior of the adapted random walk counts for.
ADAPTIVE_WALK_PRIOR_SAMPLES = 20.0
#: Each sample of the adapted random walk enters clipped to this, (m/s^2)^2 per period.
ADAPTIVE_WALK_SAMPLE_MAX = 10.0

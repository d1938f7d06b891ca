"""Synthetic truth and sensor data for the estimator tests (seeded, independent of the filters).

The truth is analytic: ZYX Euler angles and planar ball velocities as sums of sines.
Body rates come from CasADi differentiation of the truth quaternion,
``omega = v(2 Phi(q)^T dq)``; the sensors follow thesis §3.1 with the noise
covariances of (3.4) and (3.8):

* gyroscope ``omega + v_gyro`` (no bias: the filters model none, thesis §3.1);
* accelerometer ``R(q)^T [ddx, ddy, g] + b_acc + v_acc`` (IMU at the ball centre);
* encoders: the tick increments of (3.14) - the wheel angles are integrated exactly
  (Simpson on a 0.5 ms grid) from the model's inverse kinematics and rounded (3.13),
  so the only encoder error is the quantisation the thesis models as noise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca
import numpy as np

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.estimation.tuning import SIGMA_ACC, SIGMA_GYRO

DT = 0.005


@dataclass
class Truth:
    t: np.ndarray  # (N+1,)
    q: np.ndarray  # (4, N+1)
    w: np.ndarray  # (3, N+1) body rates
    dq: np.ndarray  # (4, N+1)
    v: np.ndarray  # (2, N+1) ball velocity
    a: np.ndarray  # (2, N+1) ball acceleration


def _sines(t: ca.SX, terms) -> ca.SX:
    return sum(amp * ca.sin(2 * math.pi * f * t + ph) for amp, f, ph in terms) if terms else 0 * t


#: Default attitude motion (amplitude rad, frequency Hz, phase rad): roll 3 deg at 0.5 Hz
#: plus small pitch (1 deg) and yaw (5 deg) motion.
ROLL = ((math.radians(3.0), 0.5, 0.0),)
PITCH = ((math.radians(1.0), 0.23, 0.4),)
YAW = ((math.radians(5.0), 0.1, 0.0),)


def truth(duration: float, roll=ROLL, pitch=PITCH, yaw=YAW, vx=(), vy=(), dt: float = DT,
          sub: int = 1) -> Truth:
    """Analytic truth on the grid ``k dt / sub``, k = 0 .. N sub."""
    t = ca.SX.sym("t")
    q = Q.from_rpy(_sines(t, roll), _sines(t, pitch), _sines(t, yaw))
    dq = ca.jacobian(q, t)
    w = Q.vee(2 * ca.mtimes(Q.Phi(q).T, dq))
    vel = ca.vertcat(_sines(t, vx), _sines(t, vy))
    acc = ca.jacobian(vel, t)
    n = round(duration / dt) * sub
    f = ca.Function("truth", [t], [q, w, dq, vel, acc]).map(n + 1)
    ts = np.arange(n + 1) * (dt / sub)
    qs, ws, dqs, vs, accs = (np.array(o) for o in f(ts))
    return Truth(ts, qs, ws, dqs, vs, accs)


def _rotate_inv() -> ca.Function:
    q, v = ca.SX.sym("q", 4), ca.SX.sym("v", 3)
    return ca.Function("rotate_inv", [q, v], [Q.rotate_inv(q, v)])


def imu(tr: Truth, rng: np.random.Generator, g: float, b_acc=(0.0, 0.0, 0.0),
        acc_cov=SIGMA_ACC, gyro_cov=SIGMA_GYRO) -> np.ndarray:
    """Accelerometer and gyroscope rows (6, N+1) on the truth grid."""
    n = tr.t.size
    spec = np.vstack([tr.a, np.full((1, n), g)])
    acc = np.array(_rotate_inv().map(n)(tr.q, spec))
    acc += np.asarray(b_acc, dtype=float)[:, None]
    acc += np.linalg.cholesky(acc_cov) @ rng.standard_normal((3, n))
    gyro = tr.w + np.linalg.cholesky(gyro_cov) @ rng.standard_normal((3, n))
    return np.vstack([acc, gyro])


def encoder_ticks(fine: Truth, sub: int, wheel_speeds: ca.Function, p: np.ndarray,
                  n_ticks: float) -> np.ndarray:
    """Tick increments (3, N) over each period from a truth sampled ``sub`` times per period."""
    n = fine.t.size
    x12 = np.vstack([np.zeros((2, n)), fine.q, fine.v, fine.dq])
    dphi = np.array(wheel_speeds.map(n)(x12, p))
    h = fine.t[1] - fine.t[0]
    # Composite Simpson over pairs of fine steps (sub even): wheel angle at every period end.
    inc = h / 3 * (dphi[:, 0:-1:2] + 4 * dphi[:, 1::2] + dphi[:, 2::2])
    theta = np.concatenate([np.zeros((3, 1)), np.cumsum(inc, axis=1)], axis=1)[:, :: sub // 2]
    ticks = n_ticks / (2 * math.pi) * theta
    counts = np.sign(ticks) * np.floor(np.abs(ticks) + 0.5)  # thesis (3.13)
    return np.diff(counts, axis=1)


def attitude_f(x: np.ndarray) -> np.ndarray:
    """Thesis (4.14)-(4.18) in numpy on the additive chart (q, omega): one period's
    quaternion propagation, independent of the CasADi model Functions."""
    w = x[4:]
    n = np.linalg.norm(w) * DT / 2
    return np.r_[Q.mul(x[:4], np.r_[np.cos(n), np.sin(n) * w / np.linalg.norm(w)]), w]


def attitude_h(x: np.ndarray) -> np.ndarray:
    """Thesis (4.29)-(4.30) in numpy on the (unnormalised) additive chart: the gravity
    direction in the body frame and the rate."""
    return np.r_[Q.vee(Q.mul(Q.mul(Q.conj(x[:4]), [0, 0, 0, 1.0]), x[:4])), x[4:]]

"""Metrics of runs with sensors and estimators in the loop (thesis ch. 6, §9.3).

Attitude errors are split into *tilt* (the angle between the two body z axes) and
*heading* (the rotation about the vertical), computed as

    q_e = q_a* o q_b,   tilt = 2 atan2(|(q_e1, q_e2)|, |(q_e0, q_e3)|),
    heading = 2 atan2(q_e3, q_e0)  (wrapped to +-180 deg)

which keep full precision near zero (no ``arccos`` of a number close to 1).  The same
decomposition measures the tracking error (true attitude against the reference, the
thesis §7.2 specs: tilt within +-1 deg, heading within +-5 deg) and the estimation error
(estimate against the true attitude).
"""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import STATE, STATE_DXY, STATE_XY
from ballbot_casadi.sim.embedded import VALID

__all__ = ["tilt_heading_error_deg", "tracking_metrics", "estimation_metrics",
           "quat_norm_dev_per_hour", "QUAT_NORM_MIN_HOURS"]

#: Shortest run length (h) :func:`quat_norm_dev_per_hour` divides by: one minute, so the
#: rounding floor of a few-second run (~1e-15) is not read as a drift.
QUAT_NORM_MIN_HOURS = 1.0 / 60.0


def quat_norm_dev_per_hour(max_dev: float, duration_s: float) -> float:
    """The estimate's quaternion-norm deviation per simulated hour: ``max_dev`` over the
    run length in hours (at least :data:`QUAT_NORM_MIN_HOURS`).

    The norm error of an unrenormalised filter grows with time (about 6e-12 per hour
    measured over 10 h), so a fixed bound fails long runs; a bound on this rate holds
    for runs of any length and still catches a filter that loses the norm.
    """
    return float(max_dev) / max(float(duration_s) / 3600.0, QUAT_NORM_MIN_HOURS)


def _arrays(log: Any) -> Mapping[str, np.ndarray]:
    return log.arrays if hasattr(log, "arrays") else log


def _conj_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rows of ``conj(a) o b`` for quaternion rows (N, 4)."""
    a0, a1, a2, a3 = a.T
    b0, b1, b2, b3 = b.T
    return np.column_stack([
        a0 * b0 + a1 * b1 + a2 * b2 + a3 * b3,
        a0 * b1 - a1 * b0 - a2 * b3 + a3 * b2,
        a0 * b2 + a1 * b3 - a2 * b0 - a3 * b1,
        a0 * b3 - a1 * b2 + a2 * b1 - a3 * b0,
    ])


def tilt_heading_error_deg(q_ref: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tilt and heading angle (deg) of ``q`` relative to ``q_ref`` (rows, see module docstring).

    The tilt is >= 0; the heading error is signed, in (-180, 180].  Both quaternions are
    normalised first, so a filter's small norm error does not read as an attitude error.
    """
    q_ref = np.asarray(q_ref, float).reshape(-1, 4)
    q = np.asarray(q, float).reshape(-1, 4)
    e = _conj_mul(q_ref / np.linalg.norm(q_ref, axis=1)[:, None], q / np.linalg.norm(q, axis=1)[:, None])
    e *= np.where(e[:, :1] < 0, -1.0, 1.0)  # shortest path
    tilt = 2 * np.arctan2(np.hypot(e[:, 1], e[:, 2]), np.hypot(e[:, 0], e[:, 3]))
    heading = 2 * np.arctan2(e[:, 3], e[:, 0])
    return np.degrees(tilt), (np.degrees(heading) + 180.0) % 360.0 - 180.0


def _rms(v: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(v)))) if np.size(v) else float("nan")


def tracking_metrics(log: Any) -> dict[str, float]:
    """Attitude tracking of the true state against the reference (thesis §7.2 specs).

    ``tilt_error_rms_deg``, ``tilt_error_max_deg``, ``heading_error_max_deg`` (absolute),
    and for a velocity profile ``velocity_error_rms_mps`` (true ball velocity against
    the reference).
    """
    a = _arrays(log)
    n = a["q_ref"].shape[0]
    tilt, heading = tilt_heading_error_deg(a["q_ref"], a["state"][:n, STATE["q"]])
    out = {
        "tilt_error_rms_deg": _rms(tilt),
        "tilt_error_max_deg": float(np.max(tilt)),
        "heading_error_max_deg": float(np.max(np.abs(heading))),
    }
    if "v_ref" in a:
        e = a["state"][:n, STATE_DXY] - a["v_ref"][:, :2]
        out["velocity_error_rms_mps"] = _rms(np.hypot(e[:, 0], e[:, 1]))
    return out


#: The sensors sampled every period (columns of the log's ``valid``).
_EVERY_PERIOD = [VALID.index(f) for f in ("acc", "gyro", "enc")]


def estimation_metrics(log: Any) -> dict[str, Any]:
    """Estimates against the truth (thesis ch. 6 figures as numbers).

    ``x_hat`` (N, 12) is what the controllers read at ``t_k`` and ``state`` the true
    plant state at the same instant.  Returns the estimator's tilt error (RMS, max, per
    axis roll/pitch RMS from the ZYX angles), heading drift (final and max), body-rate
    error RMS, velocity error RMS and max, position drift (final distance between the
    integrated and the true position), the worst deviation of the estimated quaternion's
    norm from 1 (and per hour, :func:`quat_norm_dev_per_hour`), the mean normalised innovation squared of both filters, the number of
    covariance repairs, the innovation-gate rejections (``gate_rejections``: readings of a
    measurement group the filters' chi-square gate rejected, summed over the groups and
    the run; 0 for a log without the ``rejections`` output) and the fraction of missing
    readings of the sensors sampled every period (accelerometer, gyroscope, encoders; the
    heading sensor samples at its own low rate, so its empty periods are not missing
    readings).

    Thesis ch. 6 as numbers: ``estimator_q2_error_max`` / ``estimator_q3_error_max`` (the
    largest error of the quaternion components q2, q3, sign-aligned; thesis §6.1:
    +-0.001 / +-0.002), ``estimator_vx_drift_mps`` (mean x-velocity error, §6.2: -0.0002
    m/s), ``estimator_vx_error_rms_mps`` / ``estimator_vy_error_rms_mps`` (per axis, §6.2:
    the VEKF slightly better in y) and ``estimator_x_error_final_m`` (x-position error at
    the end of the run, §6.2: 2 cm after 100 s); the body-rate noise is
    ``estimator_rate_rms_dps``.
    """
    a = _arrays(log)
    xh = np.asarray(a["x_hat"], float)
    n = xh.shape[0]
    x = np.asarray(a["state"], float)[:n]
    qh, qt = xh[:, STATE["q"]], x[:, STATE["q"]]
    tilt, heading = tilt_heading_error_deg(qt, qh)
    rpy_e = np.degrees(Q.to_rpy(qh / np.linalg.norm(qh, axis=1)[:, None]) - Q.to_rpy(qt))
    qdev = float(np.max(np.abs(np.linalg.norm(qh, axis=1) - 1.0)))
    rpy_e = (rpy_e + 180.0) % 360.0 - 180.0

    def omega(xx: np.ndarray) -> np.ndarray:
        q, dq = xx[:, STATE["q"]], xx[:, STATE["dq"]]
        return 2 * _conj_mul(q, dq)[:, 1:] / np.sum(q**2, axis=1)[:, None]

    w_err = omega(xh) - omega(x)
    v_err = xh[:, STATE_DXY] - x[:, STATE_DXY]
    v_abs = np.hypot(v_err[:, 0], v_err[:, 1])
    p_err = xh[-1, STATE_XY] - x[-1, STATE_XY]
    q_err = qh * np.where(np.sum(qh * qt, axis=1) < 0, -1.0, 1.0)[:, None] - qt
    nis = np.asarray(a["nis"], float)
    valid = np.asarray(a.get("valid", np.ones((n, 3))), float)
    return {
        "estimator_tilt_rms_deg": _rms(tilt),
        "estimator_tilt_max_deg": float(np.max(tilt)),
        "estimator_roll_rms_deg": _rms(rpy_e[:, 0]),
        "estimator_pitch_rms_deg": _rms(rpy_e[:, 1]),
        "estimator_heading_drift_deg": float(heading[-1]),
        "estimator_heading_max_deg": float(np.max(np.abs(heading))),
        "estimator_rate_rms_dps": float(np.degrees(_rms(np.linalg.norm(w_err, axis=1)))),
        "estimator_velocity_rms_mps": _rms(v_abs),
        "estimator_velocity_max_mps": float(np.max(v_abs)),
        "position_drift_m": float(np.hypot(*p_err)),
        "estimator_q2_error_max": float(np.max(np.abs(q_err[:, 2]))),
        "estimator_q3_error_max": float(np.max(np.abs(q_err[:, 3]))),
        "estimator_vx_drift_mps": float(np.mean(v_err[:, 0])),
        "estimator_vx_error_rms_mps": _rms(v_err[:, 0]),
        "estimator_vy_error_rms_mps": _rms(v_err[:, 1]),
        "estimator_x_error_final_m": float(p_err[0]),
        "quat_norm_max_dev": qdev,
        "quat_norm_dev_per_hour": quat_norm_dev_per_hour(qdev, float(np.asarray(a["time"])[n - 1])
                                                         if "time" in a else 0.0),
        "nis_attitude_mean": float(np.mean(nis[:, 0])),
        "nis_velocity_mean": float(np.mean(nis[:, 1])),
        "covariance_repairs": int(np.sum(a["repairs"])),
        "gate_rejections": int(np.sum(a["rejections"])) if "rejections" in a else 0,
        "missing_reading_fraction": float(1.0 - np.mean(valid[:, _EVERY_PERIOD])),
    }

"""Metrics of the COM-offset observer and of the position hold (thesis §8.4.2, §9.2, ch. 11).

Computed from a log with the observer's estimate ``com_hat`` (N, 2; every mission with
the package's steps has it, the observer runs in the shadow when the controllers do
not use it) and the run's parameters:

* **estimate** - against the *observable part* of the true offset,
  ``l_model / l_true (com_x, com_y)`` (the direction of the true COM vector at the
  model's height; the height error is not observable at rest, see
  :mod:`ballbot_casadi.estimation.com_observer`), and against the truth itself;
* **position hold** - the final distance from the commanded position ``x0 + integral
  v_ref dt`` (with a zero velocity command: where the robot started), and the distance
  of the mean position over the last :data:`HOLD_WINDOW_S` seconds (where the robot
  stands while noisy sensors make it jitter around that point);
* **standing tilt error** - the inclination error between two attitudes, the angle
  between their body-frame verticals ``R(q)^T e_z`` (a heading difference does not
  count), as the *mean* error vector over the last :data:`WINDOW_S` seconds: the
  systematic error a wrong internal model leaves (thesis §9.2: the balance controller
  cannot reach the reference it is given), with the zero-mean jitter of noisy sensors
  averaged out.  ``standing_tilt_error_deg`` compares the true attitude with the
  reference; ``standing_tilt_error_est_deg`` the attitude the controllers read (the
  estimate, or the true state without estimators) with the reference - the difference of
  the two is the attitude filter's own error, which no controller can see.

The standstill starts where the velocity command last becomes zero (the start of the
run for a zero command).
"""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

from ballbot_casadi.core.layout import STATE, STATE_XY
from ballbot_casadi.estimation.com_observer import observable_offset

__all__ = ["WINDOW_S", "HOLD_WINDOW_S", "ESTIMATE_TOL_M", "ESTIMATE_BY_S", "standstill_start",
           "commanded_position", "vertical_in_body", "inclination_error_deg", "trailing_mean_angle_deg",
           "com_observer_metrics"]

#: Averaging window of the standing tilt errors (s).
WINDOW_S = 10.0
#: Averaging window of the standing position (s).
HOLD_WINDOW_S = 2.0
#: Tolerance of the estimate for its settling time (m).
ESTIMATE_TOL_M = 0.002
#: Time after the standstill command by which the estimate must be within the tolerance (s).
ESTIMATE_BY_S = 10.0


def _arrays(log: Any) -> Mapping[str, np.ndarray]:
    return log.arrays if hasattr(log, "arrays") else log


def standstill_start(v_ref: np.ndarray, Ts: float) -> float:
    """Time (s) from which the velocity command stays zero to the end (0 for an all-zero
    command, ``N Ts`` when it never settles)."""
    moving = np.nonzero(np.any(np.asarray(v_ref, float) != 0.0, axis=1))[0]
    return 0.0 if moving.size == 0 else float((moving[-1] + 1) * Ts)


def commanded_position(x0: np.ndarray, v_ref: np.ndarray, Ts: float) -> np.ndarray:
    """``x0 + Ts sum v_ref`` at the end of the run: where the velocity command leads."""
    return np.asarray(x0, float)[STATE_XY] + Ts * np.sum(np.asarray(v_ref, float)[:, :2], axis=0)


def vertical_in_body(q: np.ndarray) -> np.ndarray:
    """Rows ``R(q)^T e_z``: the vertical seen from the body (normalised quaternions)."""
    q = np.asarray(q, float).reshape(-1, 4)
    q = q / np.linalg.norm(q, axis=1)[:, None]
    q0, q1, q2, q3 = q.T
    return np.column_stack([2 * (q1 * q3 - q0 * q2), 2 * (q2 * q3 + q0 * q1),
                            q0**2 - q1**2 - q2**2 + q3**2])


def inclination_error_deg(q: np.ndarray, q_ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-row inclination error vectors ``n x n_ref`` (sin of the angle, body frame) and
    angles (deg) between the body-frame verticals of ``q`` and ``q_ref``."""
    n, n_ref = vertical_in_body(q), vertical_in_body(q_ref)
    e = np.cross(n, n_ref)
    ang = np.degrees(np.arctan2(np.linalg.norm(e, axis=1), np.sum(n * n_ref, axis=1)))
    return e, ang


def _angle_deg(m: np.ndarray) -> np.ndarray:
    """Angles (deg) of (rows of) mean inclination-error vectors (sines of the angles)."""
    return np.degrees(np.arcsin(np.minimum(1.0, np.linalg.norm(m, axis=-1))))


def _mean_angle_deg(e: np.ndarray) -> float:
    """Angle (deg) of the mean error vector."""
    return float(_angle_deg(np.mean(e, axis=0))) if len(e) else math.nan


def trailing_mean_angle_deg(e: np.ndarray, t: np.ndarray, window_s: float = WINDOW_S) -> np.ndarray:
    """At every instant, the angle (deg) of the mean of the error vectors ``e`` (rows of
    :func:`inclination_error_deg`) over the preceding ``window_s`` (from the start while
    shorter): the standing tilt errors' quantity as it evolves."""
    c = np.vstack([np.zeros((1, e.shape[1])), np.cumsum(e, axis=0)])
    k = np.arange(1, len(e) + 1)
    k0 = np.searchsorted(t, t - window_s + 1e-12)
    return _angle_deg((c[k] - c[k0]) / (k - k0)[:, None])


def com_observer_metrics(log: Any) -> dict[str, Any]:
    """The observer's and the position hold's metrics of a run (module docstring).

    ``log`` is a :class:`~ballbot_casadi.sim.log.SimulationLog` with ``com_hat``.
    Returns ``com_estimate_error_mm`` (final, observable part), ``com_estimate_error_max_mm``
    (largest from :data:`ESTIMATE_BY_S` s after the standstill command on; NaN for a
    shorter run), ``com_estimate_settle_s`` (time after the standstill command from which
    the error stays within :data:`ESTIMATE_TOL_M`), ``com_estimate_raw_error_mm`` (final,
    against the true offset), ``com_height_error_mm`` (true minus model height: the part
    not observable at rest), ``final_position_error_m``, ``hold_position_error_m``,
    ``standing_tilt_error_deg``,
    ``standing_tilt_error_est_deg``, ``standing_tilt_error_rms_deg`` (true attitude,
    jitter included) and ``standstill_start_s``.
    """
    a = _arrays(log)
    params, ctrl = log.params, log.ctrl_params
    Ts = float(log.scenario["Ts"])
    n = a["q_ref"].shape[0]
    t = a["time"][:n]
    t_s = standstill_start(a["v_ref"], Ts)
    com_true = np.array([params.com_x, params.com_y])
    com_obs = observable_offset(com_true, params.l, ctrl.l)
    err = np.linalg.norm(a["com_hat"] - com_obs, axis=1)
    after = t >= t_s - 1e-12
    outside = np.nonzero(after & (err > ESTIMATE_TOL_M))[0]
    settle = (0.0 if outside.size == 0 else
              float(t[outside[-1] + 1] - t_s) if outside[-1] + 1 < n else math.inf)
    late = t >= t_s + ESTIMATE_BY_S - 1e-12
    x = a["state"]
    target = commanded_position(np.asarray(log.scenario["x0"], float), a["v_ref"], Ts)
    win = (t >= t[-1] + Ts - WINDOW_S - 1e-12) & after
    hold = np.append(t >= t[-1] + Ts - HOLD_WINDOW_S - 1e-12, True)
    e_true, ang = inclination_error_deg(x[:n, STATE["q"]][win], a["q_ref"][win])
    seen = a["x_hat"] if "x_hat" in a else x[:n]
    e_seen, _ = inclination_error_deg(seen[win][:, STATE["q"]], a["q_ref"][win])
    return {
        "standstill_start_s": t_s,
        "com_estimate_error_mm": float(err[-1] * 1e3),
        "com_estimate_error_max_mm": float(np.max(err[late]) * 1e3) if np.any(late) else math.nan,
        "com_estimate_settle_s": settle,
        "com_estimate_raw_error_mm": float(np.linalg.norm(a["com_hat"][-1] - com_true) * 1e3),
        "com_height_error_mm": float((params.l - ctrl.l) * 1e3),
        "com_hat_x_mm": float(a["com_hat"][-1, 0] * 1e3),
        "com_hat_y_mm": float(a["com_hat"][-1, 1] * 1e3),
        "com_observable_x_mm": float(com_obs[0] * 1e3),
        "com_observable_y_mm": float(com_obs[1] * 1e3),
        "final_position_error_m": float(np.linalg.norm(x[-1, STATE_XY] - target)),
        "hold_position_error_m": float(np.linalg.norm(np.mean(x[hold][:, STATE_XY], axis=0) - target)),
        "standing_tilt_error_deg": _mean_angle_deg(e_true),
        "standing_tilt_error_est_deg": _mean_angle_deg(e_seen),
        "standing_tilt_error_rms_deg": float(np.sqrt(np.mean(ang**2))) if ang.size else math.nan,
    }

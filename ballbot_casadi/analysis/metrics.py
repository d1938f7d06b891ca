"""Metrics of closed-loop runs, computed from the log arrays only.

Angles are ZYX roll/pitch/yaw of the attitude quaternion (the thesis reports errors in
Euler angles, Fig. 8.6, 8.8); *errors* are ``angle - reference angle`` wrapped to
(-180, 180] deg.  Logs are the arrays of
:class:`~ballbot_casadi.sim.log.SimulationLog`: ``time`` (N+1), ``state`` (N+1, 12),
``q_ref`` (N, 4), ``v_ref`` (N, 3), ``tau_cmd`` / ``tau`` (N, 3), ...  Which metrics a
study reports and its specs are in :mod:`ballbot_casadi.studies.registry`.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

from ballbot_casadi.core.layout import STATE
from ballbot_casadi.core import quaternion as Q

__all__ = [
    "rpy_deg",
    "tilt_deg",
    "attitude_error_deg",
    "sine_lag",
    "total_variation",
    "base_metrics",
    "zero_metrics",
    "sine_metrics",
    "push_metrics",
    "com_metrics",
    "velocity_metrics",
    "com_equilibrium_deg",
]


def _arrays(log: Any) -> Mapping[str, np.ndarray]:
    return log.arrays if hasattr(log, "arrays") else log


def rpy_deg(q: np.ndarray) -> np.ndarray:
    """ZYX roll, pitch, yaw (deg) of quaternion rows (N, 4) (``quaternion.to_rpy``)."""
    return np.degrees(Q.to_rpy(np.asarray(q, float).reshape(-1, 4)))


def tilt_deg(q: np.ndarray) -> np.ndarray:
    """Inclination (deg): angle between the body z axis and the vertical."""
    q = np.asarray(q, float)
    c = (q[:, 0] ** 2 - q[:, 1] ** 2 - q[:, 2] ** 2 + q[:, 3] ** 2) / np.sum(q**2, axis=1)
    return np.degrees(np.arccos(np.clip(c, -1.0, 1.0)))


def _wrap(a: np.ndarray) -> np.ndarray:
    return (a + 180.0) % 360.0 - 180.0


def attitude_error_deg(log: Any) -> np.ndarray:
    """Euler-angle tracking error (N, 3) in deg at the control instants."""
    a = _arrays(log)
    n = a["q_ref"].shape[0]
    return _wrap(rpy_deg(a["state"][:n, STATE["q"]]) - rpy_deg(a["q_ref"]))


def _window(t: np.ndarray, t_from: float) -> np.ndarray:
    return t >= t_from - 1e-12


def _fit_phase(t: np.ndarray, y: np.ndarray, f: float) -> tuple[float, float]:
    """Amplitude and phase of the fundamental of ``y`` at ``f`` Hz (least squares)."""
    w = 2 * np.pi * f
    A = np.column_stack([np.sin(w * t), np.cos(w * t), np.ones_like(t)])
    (a, b, _), *_ = np.linalg.lstsq(A, y, rcond=None)
    return float(np.hypot(a, b)), float(np.arctan2(b, a))


def sine_lag(t: np.ndarray, y: np.ndarray, y_ref: np.ndarray, f: float) -> tuple[float, float]:
    """Lag (s, > 0 when ``y`` trails ``y_ref``) and amplitude ratio at ``f`` Hz.

    Both signals are fitted with ``a sin + b cos + c`` at the known frequency; the lag is
    the phase difference divided by ``2 pi f``.
    """
    amp, ph = _fit_phase(t, y, f)
    amp_r, ph_r = _fit_phase(t, y_ref, f)
    dphi = (ph_r - ph + np.pi) % (2 * np.pi) - np.pi
    return float(dphi / (2 * np.pi * f)), float(amp / amp_r) if amp_r > 0 else math.nan


def total_variation(u: np.ndarray) -> float:
    """Total variation ``sum_k |u[k+1] - u[k]|`` summed over columns."""
    u = np.asarray(u, float)
    return float(np.sum(np.abs(np.diff(u, axis=0)))) if u.shape[0] > 1 else 0.0


def _smooth_fit(t: np.ndarray, u: np.ndarray, f: float, harmonics: int = 5) -> np.ndarray:
    """Least-squares Fourier fit (harmonics of ``f``) of each column of ``u``."""
    cols = [np.ones_like(t)]
    for h in range(1, harmonics + 1):
        cols += [np.sin(2 * np.pi * h * f * t), np.cos(2 * np.pi * h * f * t)]
    A = np.column_stack(cols)
    coef, *_ = np.linalg.lstsq(A, u, rcond=None)
    return A @ coef


def base_metrics(log: Any) -> dict[str, float]:
    """Metrics every run reports: tilt, speed, torques, saturation, finiteness."""
    a = _arrays(log)
    x, tau_cmd, tau = a["state"], a["tau_cmd"], a["tau"]
    tilt = tilt_deg(x[:, STATE["q"]])
    speed = np.hypot(x[:, STATE.index("dx")], x[:, STATE.index("dy")])
    sat = np.any(np.abs(tau_cmd - tau) > 1e-12, axis=1)
    return {
        "finite": bool(np.all(np.isfinite(x)) and np.all(np.isfinite(tau_cmd))),
        "duration_s": float(a["time"][-1]),
        "final_tilt_deg": float(tilt[-1]),
        "max_tilt_deg": float(np.max(tilt)),
        "final_speed_mps": float(speed[-1]),
        "max_speed_mps": float(np.max(speed)),
        "max_abs_torque_nm": float(np.max(np.abs(tau))),
        "saturation_fraction": float(np.mean(sat)),
        "quat_norm_error_max": float(np.max(np.abs(np.linalg.norm(x[:, STATE["q"]], axis=1) - 1))),
        "final_rpy_deg": [float(v) for v in rpy_deg(x[-1:, STATE["q"]])[0]],
    }


def zero_metrics(log: Any, window_s: float = 1.0, band_deg: float = 0.1) -> dict[str, float]:
    """Convergence to the reference: steady-state error (last ``window_s``) and settling time.

    ``settling_time_s`` is the first instant after which every Euler-angle error stays
    inside ``band_deg``.
    """
    a = _arrays(log)
    t = a["time"][: a["q_ref"].shape[0]]
    err = np.max(np.abs(attitude_error_deg(a)), axis=1)
    win = _window(t, t[-1] - window_s)
    outside = np.nonzero(err > band_deg)[0]
    settle = 0.0 if outside.size == 0 else (float(t[outside[-1] + 1]) if outside[-1] + 1 < t.size else math.inf)
    return {
        "steady_state_error_deg": float(np.max(err[win])),
        "settling_time_s": settle,
        "max_error_deg": float(np.max(err)),
    }


def sine_metrics(log: Any, frequency_hz: float, t_from: float = 0.0) -> dict[str, float]:
    """Roll-sine tracking (thesis §8.2.5): lag, coupling errors, torque smoothness.

    ``torque_total_variation`` is the total variation of the applied torques (N m,
    summed over wheels) from ``t_from``; ``torque_tv_ratio`` divides it by the total
    variation of a 5-harmonic Fourier fit of the same torques, ~1 for smooth torques
    and >> 1 with chattering.
    """
    a = _arrays(log)
    n = a["q_ref"].shape[0]
    t = a["time"][:n]
    win = _window(t, t_from)
    ang = rpy_deg(a["state"][:n, STATE["q"]])
    ref = rpy_deg(a["q_ref"])
    err = _wrap(ang - ref)
    lag, ratio = sine_lag(t[win], ang[win, 0], ref[win, 0], frequency_hz)
    tau = a["tau"][win]
    tv = total_variation(tau)
    tv_fit = total_variation(_smooth_fit(t[win], tau, frequency_hz))
    return {
        "roll_lag_s": lag,
        "roll_amplitude_ratio": ratio,
        "roll_error_max_deg": float(np.max(np.abs(err[win, 0]))),
        "pitch_error_max_deg": float(np.max(np.abs(err[win, 1]))),
        "yaw_error_max_deg": float(np.max(np.abs(err[win, 2]))),
        "torque_total_variation": tv,
        "torque_tv_ratio": tv / tv_fit if tv_fit > 0 else math.inf,
    }


def push_metrics(log: Any, t_push: float, band_deg: float = 0.1) -> dict[str, float]:
    """Recovery from an attitude jump at ``t_push`` (thesis §8.4.3)."""
    a = _arrays(log)
    t = a["time"]
    tilt = tilt_deg(a["state"][:, STATE["q"]])
    after = _window(t, t_push)
    outside = np.nonzero(after & (tilt > band_deg))[0]
    rec = math.inf if outside.size and outside[-1] + 1 >= t.size else (
        float(t[outside[-1] + 1] - t_push) if outside.size else 0.0)
    return {"push_max_tilt_deg": float(np.max(tilt[after])), "recovery_time_s": rec}


def com_equilibrium_deg(com_x: float, com_y: float, l: float) -> tuple[float, float]:
    """Roll and pitch (deg, ZYX) that put the COM ``(com_x, com_y, l)`` over the ball centre.

    With ``R = Rz Ry Rx``: roll zeroes the y component, ``tan(roll) = com_y / l``; pitch
    then zeroes x, ``tan(pitch) = -com_x / sqrt(com_y^2 + l^2)``.  Independent of yaw.
    """
    roll = math.atan2(com_y, l)
    pitch = math.atan2(-com_x, math.hypot(com_y, l))
    return math.degrees(roll), math.degrees(pitch)


def com_metrics(balance_only: Any, cascade: Any, params: Any, window_s: float = 2.0) -> dict[str, float]:
    """COM offset (thesis §8.4.2, §9.2): runaway without, equilibrium with the velocity loop."""
    b, c = _arrays(balance_only), _arrays(cascade)
    xb, xc = b["state"], c["state"]
    win = _window(c["time"], c["time"][-1] - window_s)
    ang = rpy_deg(xc[:, STATE["q"]])
    roll_a, pitch_a = com_equilibrium_deg(params.com_x, params.com_y, params.l)
    eq_roll, eq_pitch = float(np.mean(ang[win, 0])), float(np.mean(ang[win, 1]))
    return {
        "runaway_speed_mps": float(np.hypot(xb[-1, STATE.index("dx")], xb[-1, STATE.index("dy")])),
        "runaway_distance_m": float(np.hypot(xb[-1, 0], xb[-1, 1])),
        "final_speed_mps": float(np.hypot(xc[-1, STATE.index("dx")], xc[-1, STATE.index("dy")])),
        "equilibrium_roll_deg": eq_roll,
        "equilibrium_pitch_deg": eq_pitch,
        "equilibrium_roll_analytic_deg": roll_a,
        "equilibrium_pitch_analytic_deg": pitch_a,
        "equilibrium_error_deg": max(abs(eq_roll - roll_a), abs(eq_pitch - pitch_a)),
        "final_position_drift_m": float(np.hypot(xc[-1, 0], xc[-1, 1])),
    }


def _yaw_rate(x: np.ndarray) -> np.ndarray:
    """Heading rate: z component of the angular velocity in {K}, ``2 vec(dq o q*)``."""
    q, dq = x[:, STATE["q"]], x[:, STATE["dq"]]
    # z component of dq o conj(q)
    return 2 * (-dq[:, 0] * q[:, 3] + dq[:, 3] * q[:, 0] - dq[:, 1] * q[:, 2] + dq[:, 2] * q[:, 1])


def velocity_metrics(log: Any, max_delay_s: float = 1.0) -> dict[str, float]:
    """Velocity-profile tracking (thesis §9.2): errors, best-fit delay, inclination.

    The ballbot is non-minimum phase (thesis §7.3: ramps are tracked with a constant
    delay), so besides the raw error the error after removing the best constant delay
    (searched in [0, ``max_delay_s``]) is reported.
    """
    a = _arrays(log)
    n = a["v_ref"].shape[0]
    t, x, vr = a["time"][:n], a["state"][:n], a["v_ref"]
    e = np.hypot(x[:, STATE.index("dx")] - vr[:, 0], x[:, STATE.index("dy")] - vr[:, 1])
    ts = float(t[1] - t[0]) if n > 1 else 1.0
    best = (math.inf, 0.0, math.inf)
    for d in range(int(max_delay_s / ts) + 1):
        vd = np.vstack([np.zeros((d, 3)), vr[: n - d]]) if d else vr
        ed = np.hypot(x[:, STATE.index("dx")] - vd[:, 0], x[:, STATE.index("dy")] - vd[:, 1])
        rms = float(np.sqrt(np.mean(ed**2)))
        if rms < best[0]:
            best = (rms, d * ts, float(np.max(ed)))
    yr = _yaw_rate(x)
    return {
        "velocity_error_max_mps": float(np.max(e)),
        "velocity_error_rms_mps": float(np.sqrt(np.mean(e**2))),
        "velocity_lag_s": best[1],
        "velocity_error_rms_delayed_mps": best[0],
        "velocity_error_max_delayed_mps": best[2],
        "final_velocity_error_mps": float(e[-1]),
        "yaw_rate_error_max_rps": float(np.max(np.abs(yr - vr[:, 2]))),
        "max_tilt_deg": float(np.max(tilt_deg(x[:, STATE["q"]]))),
        "max_abs_roll_pitch_deg": float(np.max(np.abs(rpy_deg(x[:, STATE["q"]])[:, :2]))),
    }

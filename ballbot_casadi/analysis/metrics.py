"""Metrics of closed-loop runs, computed from the log arrays only.

Angles are ZYX roll/pitch/yaw of the attitude quaternion (the thesis reports errors in
Euler angles, Fig. 8.6, 8.8); *errors* are ``angle - reference angle``, wrapped to
(-180, 180] deg only where they leave that range (so a tiny error keeps its digits
instead of rounding through ``(e + 180) % 360 - 180``).  The tilt is
``2 atan2(sqrt(q1^2 + q2^2), sqrt(q0^2 + q3^2))`` (the swing angle of the quaternion),
exact near zero where ``arccos`` of the body-z component floors to 0 below ~1e-6 deg.
Logs are the arrays of
:class:`~ballbot_casadi.sim.log.SimulationLog`: ``time`` (N+1), ``state`` (N+1, 12),
``q_ref`` (N, 4), ``v_ref`` (N, 3), ``tau_cmd`` / ``tau`` (N, 3), ...  Which metrics a
study reports and its specs are in :mod:`ballbot_casadi.studies.registry`.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

from ballbot_casadi.core.layout import STATE
from ballbot_casadi.analysis.com_observer import com_observer_metrics
from ballbot_casadi.analysis.estimates import estimation_metrics, tracking_metrics
from ballbot_casadi.analysis.path_metrics import path_metrics
from ballbot_casadi.core import quaternion as Q

__all__ = [
    "rpy_deg",
    "tilt_deg",
    "attitude_error_deg",
    "sine_lag",
    "crossing_lag",
    "transition_metrics",
    "total_variation",
    "base_metrics",
    "zero_metrics",
    "sine_metrics",
    "push_metrics",
    "velocity_metrics",
    "com_equilibrium_deg",
    "tilt_rate_deg_s",
    "limit_metrics",
    "limit_rows",
    "LIMIT_KEYS",
    "robustness_metrics",
    "overshoot_deg",
    "standing_metrics",
    "run_metrics",
]


def _arrays(log: Any) -> Mapping[str, np.ndarray]:
    return log.arrays if hasattr(log, "arrays") else log


def rpy_deg(q: np.ndarray) -> np.ndarray:
    """ZYX roll, pitch, yaw (deg) of quaternion rows (N, 4) (``quaternion.to_rpy``)."""
    return np.degrees(Q.to_rpy(np.asarray(q, float).reshape(-1, 4)))


def tilt_deg(q: np.ndarray) -> np.ndarray:
    """Inclination (deg): angle between the body z axis and the vertical.

    ``2 atan2(|(q1, q2)|, |(q0, q3)|)``: the angle of the swing part of the attitude
    (``cos tilt = q0^2 - q1^2 - q2^2 + q3^2``), accurate to the last digit near zero.
    """
    q = np.asarray(q, float).reshape(-1, 4)
    return np.degrees(2.0 * np.arctan2(np.hypot(q[:, 1], q[:, 2]), np.hypot(q[:, 0], q[:, 3])))


def tilt_rate_deg_s(x: np.ndarray) -> np.ndarray:
    """Inclination rate (deg/s): norm of the horizontal components of the body's angular
    velocity in {K}, ``omega = 2 vec(dq o q*)`` (thesis E.35); it bounds ``|d tilt / dt|``
    and is the quantity limited to 20 deg/s by thesis §7.1 (item 6)."""
    x = np.asarray(x, float)
    q, dq = x[:, STATE["q"]], x[:, STATE["dq"]]
    w0, w1, w2, w3 = q.T
    d0, d1, d2, d3 = dq.T
    ox = -d0 * w1 + d1 * w0 - (d2 * w3 - d3 * w2)
    oy = -d0 * w2 + d2 * w0 - (d3 * w1 - d1 * w3)
    return np.degrees(2.0 * np.hypot(ox, oy))


def _wrap(a: np.ndarray) -> np.ndarray:
    """Wrap an angle outside [-180, 180] deg into [-180, 180), leaving values already inside
    untouched (no rounding)."""
    a = np.asarray(a, float)
    return np.where(np.abs(a) > 180.0, (a + 180.0) % 360.0 - 180.0, a)


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


def crossing_lag(t: np.ndarray, y: np.ndarray, y_ref: np.ndarray, level: float) -> float:
    """Time by which ``y`` first reaches ``level`` after ``y_ref`` does (s; ``inf`` if
    ``y`` never does).  Both start below ``level`` (an upward transition; flip the signs
    for a downward one)."""
    k_ref = np.nonzero(y_ref >= level)[0]
    k = np.nonzero(y >= level)[0]
    if k_ref.size == 0:
        raise ValueError("the reference never reaches the level")
    return float(t[k[0]] - t[k_ref[0]]) if k.size else math.inf


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


def transition_metrics(log: Any, axis: str = "roll", level: float = 0.5) -> dict[str, float]:
    """Tracking lag of a step or ramp reference on ``axis`` (thesis §7.2 item 4: < 0.1 s;
    item 5: < 1 s without a rate reference): ``roll_lag_s`` is the time by which the
    angle reaches ``level`` (50 %) of the transition after the reference does
    (:func:`crossing_lag`; for a ramp that settles into tracking, its steady delay).  A
    reference that ends where it starts has no transition to time: its lag is ``nan``
    (undefined, so a spec on it fails)."""
    a = _arrays(log)
    n = a["q_ref"].shape[0]
    t = a["time"][:n]
    i = ("roll", "pitch", "yaw").index(axis)
    ang = rpy_deg(a["state"][:n, STATE["q"]])[:, i]
    ref = rpy_deg(a["q_ref"])[:, i]
    if ref[-1] == ref[0]:
        return {f"{axis}_lag_s": math.nan}
    sign = 1.0 if ref[-1] >= ref[0] else -1.0
    lvl = sign * (ref[0] + level * (ref[-1] - ref[0]))
    return {f"{axis}_lag_s": crossing_lag(t, sign * ang, sign * ref, lvl)}


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

    Thesis §7.1 items 1-4 as measured results (not clamps): ``max_speed_mps`` (ball
    speed), ``max_acceleration_mps2`` (ball acceleration, finite difference over one
    control period), ``max_yaw_rate_rps`` and ``max_yaw_accel_rps2`` (heading rate and its
    finite difference).  ``yaw_error_mean_deg`` is the mean heading error against the
    velocity controller's attitude reference (thesis §9.3.2: -0.2 deg on average).
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
    v = x[:, [STATE.index("dx"), STATE.index("dy")]]
    acc = np.hypot(*(np.diff(v, axis=0) / ts).T) if n > 1 else np.zeros(1)
    yaw_err = (_wrap(rpy_deg(x[:, STATE["q"]]) - rpy_deg(a["q_ref"][:n]))[:, 2] if "q_ref" in a
               else np.full(n, math.nan))
    return {
        "max_speed_mps": float(np.max(np.hypot(v[:, 0], v[:, 1]))),
        "max_acceleration_mps2": float(np.max(acc)),
        "max_yaw_rate_rps": float(np.max(np.abs(yr))),
        "max_yaw_accel_rps2": float(np.max(np.abs(np.diff(yr)) / ts)) if n > 1 else 0.0,
        "yaw_error_mean_deg": float(np.mean(yaw_err)),
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


#: Metric keys of :func:`limit_metrics`, with the thesis §7.1 limit each is compared with.
LIMIT_KEYS: Mapping[str, tuple[str, str]] = {
    "peak_tilt_deg": ("tilt_max", "inclination limit +-5 deg (thesis §7.1, item 5)"),
    "peak_tilt_rate_deg_s": ("tilt_rate_max", "inclination rate < 20 deg/s (thesis §7.1, item 6)"),
    "peak_torque_nm": ("tau_max", "motor torque limit tau_max (thesis App. A)"),
}


def limit_metrics(log: Any, tau_max: float) -> dict[str, Any]:
    """Peaks of the quantities thesis §7.1 limits: tilt, tilt rate, commanded torque.

    ``peak_torque_nm`` is the largest *commanded* wheel torque (before the limit), so a
    controller asking for more than ``tau_max`` shows as exceeding it;
    ``torque_saturated_fraction`` is the share of periods with a command at or beyond
    ``tau_max``.  ``initial_tilt_deg``, ``initial_tilt_rate_deg_s`` and the reference's
    own peaks (``reference_peak_tilt_deg``, ``reference_peak_tilt_rate_deg_s``) say whether
    the scenario itself starts or asks to go beyond a limit.
    """
    a = _arrays(log)
    x = a["state"]
    tilt = tilt_deg(x[:, STATE["q"]])
    rate = tilt_rate_deg_s(x)
    cmd = np.abs(np.asarray(a["tau_cmd"], float))
    ref = np.zeros((a["q_ref"].shape[0], STATE.size))
    ref[:, STATE["q"]], ref[:, STATE["dq"]] = a["q_ref"], a["dq_ref"]
    with np.errstate(invalid="ignore"):
        return {
            "reference_peak_tilt_deg": float(np.max(tilt_deg(a["q_ref"]))),
            "reference_peak_tilt_rate_deg_s": float(np.max(tilt_rate_deg_s(ref))),
            "peak_tilt_deg": float(np.nanmax(tilt)) if np.any(np.isfinite(tilt)) else math.nan,
            "peak_tilt_rate_deg_s": float(np.nanmax(rate)) if np.any(np.isfinite(rate)) else math.nan,
            "peak_torque_nm": float(np.nanmax(cmd)) if np.any(np.isfinite(cmd)) else math.nan,
            "tau_max_nm": float(tau_max),
            "torque_saturated_fraction": float(np.mean(np.any(cmd >= tau_max * (1 - 1e-12), axis=1))),
            "initial_tilt_deg": float(tilt[0]),
            "initial_tilt_rate_deg_s": float(rate[0]),
        }


def limit_rows(metrics: Mapping[str, Any], limits: Mapping[str, float]) -> list[dict[str, Any]]:
    """The thesis §7.1 limit rows of a run: ``metric, value, limit, exceeded, by_scenario, source``.

    ``limits`` holds ``tilt_max`` and ``tilt_rate_max`` in rad and rad/s (as
    :data:`~ballbot_casadi.core.constants.THESIS_LIMITS`); the torque row uses the run's
    ``tau_max_nm``.  ``by_scenario`` is true when the scenario already starts beyond the
    limit (its initial state), i.e. the experiment as the thesis defines it exceeds it.
    A row is *reported*, exceeded or not; it does not decide a study's pass/fail.
    """
    lim = {"peak_tilt_deg": math.degrees(limits["tilt_max"]),
           "peak_tilt_rate_deg_s": math.degrees(limits["tilt_rate_max"]),
           "peak_torque_nm": metrics.get("tau_max_nm", math.nan)}
    start = {"peak_tilt_deg": max(metrics.get("initial_tilt_deg", 0.0),
                                  metrics.get("reference_peak_tilt_deg", 0.0)),
             "peak_tilt_rate_deg_s": max(metrics.get("initial_tilt_rate_deg_s", 0.0),
                                         metrics.get("reference_peak_tilt_rate_deg_s", 0.0)),
             "peak_torque_nm": 0.0}
    rows = []
    for key, (_, source) in LIMIT_KEYS.items():
        v = metrics.get(key, math.nan)
        exceeded = not (isinstance(v, (int, float)) and v <= lim[key] * (1 + 1e-9))
        if key == "peak_torque_nm":
            exceeded = not (isinstance(v, (int, float)) and v < lim[key] * (1 - 1e-12))
        rows.append({"metric": key, "value": v, "limit": lim[key], "exceeded": bool(exceeded),
                     "by_scenario": bool(start[key] > lim[key] * (1 + 1e-9)), "source": source})
    return rows


def overshoot_deg(log: Any, min_initial_deg: float = 0.1) -> float:
    """How far the Euler-angle errors swing past zero (deg, >= 0), over the axes whose
    initial error exceeds ``min_initial_deg`` (thesis §8.4.1: "reaches upright")."""
    err = attitude_error_deg(_arrays(log))
    e0 = err[0]
    past = [np.max(-np.sign(e0[i]) * err[:, i]) for i in range(err.shape[1]) if abs(e0[i]) > min_initial_deg]
    return float(max(0.0, *past)) if past else 0.0


def robustness_metrics(nominal: Any, perturbed: Any, band_deg: float = 0.1) -> dict[str, Any]:
    """A perturbed run against the nominal one (thesis §8.4.1, Fig. 8.10-8.11).

    ``settling_time_ratio`` compares the perturbed run's :func:`zero_metrics` with the
    nominal run's; ``overshoot_deg`` (``nominal_overshoot_deg``) is how far the perturbed
    (nominal) run swings past the reference on the axes that start off it
    (:func:`overshoot_deg`; the largest error overall is the initial one, so a peak-error
    ratio would be 1 by construction); ``deviation_<axis>_deg`` is the largest
    difference of that Euler angle between the two runs and ``relative_deviation_<axis>``
    divides it by the nominal run's largest excursion of the same angle.  The thesis
    observes that the inertia change affects yaw most; ``yaw_affected_most`` checks it in
    degrees, ``yaw_affected_most_relative`` relative to each angle's own excursion.
    """
    zn, zp = zero_metrics(nominal, band_deg=band_deg), zero_metrics(perturbed, band_deg=band_deg)
    an, ap = _arrays(nominal), _arrays(perturbed)
    n = min(an["state"].shape[0], ap["state"].shape[0])
    rn, rp = rpy_deg(an["state"][:n, STATE["q"]]), rpy_deg(ap["state"][:n, STATE["q"]])
    dev = np.max(np.abs(_wrap(rp - rn)), axis=0)
    exc = np.max(np.abs(rn), axis=0)
    rel = dev / np.maximum(exc, 1e-300)
    axes = ("roll", "pitch", "yaw")
    out: dict[str, Any] = {
        "nominal_settling_time_s": zn["settling_time_s"],
        "settling_time_ratio": zp["settling_time_s"] / zn["settling_time_s"] if zn["settling_time_s"] > 0 else math.inf,
        "nominal_max_error_deg": zn["max_error_deg"],
        "overshoot_deg": overshoot_deg(perturbed),
        "nominal_overshoot_deg": overshoot_deg(nominal),
    }
    for i, ax in enumerate(axes):
        out[f"deviation_{ax}_deg"] = float(dev[i])
        out[f"relative_deviation_{ax}"] = float(rel[i])
    out["most_affected_axis"] = axes[int(np.argmax(dev))]
    out["most_affected_axis_relative"] = axes[int(np.argmax(rel))]
    out["yaw_affected_most"] = out["most_affected_axis"] == "yaw"
    out["yaw_affected_most_relative"] = out["most_affected_axis_relative"] == "yaw"
    return out


def standing_metrics(log: Any, params: Any, window_s: float = 2.0) -> dict[str, float]:
    """A cascade run standing still: tilt equilibrium against the COM over the ball
    (:func:`com_equilibrium_deg`), final speed and drift (thesis §9.2, Fig. 9.6-9.7)."""
    a = _arrays(log)
    x = a["state"]
    win = _window(a["time"], a["time"][-1] - window_s)
    ang = rpy_deg(x[:, STATE["q"]])
    roll_a, pitch_a = com_equilibrium_deg(params.com_x, params.com_y, params.l)
    eq_roll, eq_pitch = float(np.mean(ang[win, 0])), float(np.mean(ang[win, 1]))
    return {
        "equilibrium_roll_deg": eq_roll,
        "equilibrium_pitch_deg": eq_pitch,
        "equilibrium_roll_analytic_deg": roll_a,
        "equilibrium_pitch_analytic_deg": pitch_a,
        "equilibrium_error_deg": max(abs(eq_roll - roll_a), abs(eq_pitch - pitch_a)),
        "final_position_drift_m": float(np.hypot(x[-1, 0], x[-1, 1])),
    }


def run_metrics(log: Any) -> dict[str, Any]:
    """Every metric that applies to one run, chosen from what its scenario contains.

    Always :func:`base_metrics`, :func:`limit_metrics` (thesis §7.1) and
    :func:`zero_metrics` (tracking error, settling); a roll sine adds
    :func:`sine_metrics`, a roll step or ramp :func:`transition_metrics`, a push :func:`push_metrics`, a velocity profile
    :func:`velocity_metrics`, a cascade standing still :func:`standing_metrics`; every
    run gets the tilt/heading tracking errors and, with estimators in the loop, the
    estimation errors (:mod:`ballbot_casadi.analysis.estimates`); a run with the COM
    observer on, its estimate and position-hold metrics
    (:mod:`ballbot_casadi.analysis.com_observer`); a run that follows a path, its
    path-following metrics (:mod:`ballbot_casadi.analysis.path_metrics`).
    ``log`` is a :class:`~ballbot_casadi.sim.log.SimulationLog` (its scenario and plant
    parameters are used).  Chirp runs get their bandwidth metrics from
    :func:`ballbot_casadi.analysis.bandwidth.chirp_metrics`.
    """
    sc = log.scenario
    out: dict[str, Any] = {**base_metrics(log), **limit_metrics(log, log.params.tau_max)}
    finite = out["finite"]
    with np.errstate(invalid="ignore", over="ignore"):
        out.update(zero_metrics(log))
        roll = (sc.get("attitude") or {}).get("roll", {})
        if roll.get("type") == "sine" and finite:
            out.update(sine_metrics(log, roll["frequency_hz"]))
        if roll.get("type") in ("step", "ramp") and finite:
            out.update(transition_metrics(log, "roll"))
        if sc.get("pushes"):
            out.update(push_metrics(log, sc["pushes"][0][0]))
        if sc.get("cascade") and sc.get("velocity_keyframes"):
            out.update(velocity_metrics(log))
        elif sc.get("cascade"):
            out.update(standing_metrics(log, log.params))
        out.update(tracking_metrics(log))
        if "x_hat" in log.arrays and finite:
            out.update(estimation_metrics(log))
        if sc.get("com_observer") and "com_hat" in log.arrays and finite:
            out.update(com_observer_metrics(log))
        if sc.get("path"):
            out.update(path_metrics(log))
    return out

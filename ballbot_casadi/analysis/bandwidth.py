"""Bandwidth from a chirp test (thesis §9.1): sliding-window sine fits of output vs reference.

The thesis excites the roll reference with a linear chirp (0.05 Hz rising 0.05 Hz/s to
5 Hz over 100 s) and reads the bandwidth off the time plot where tracking is lost
(Fig. 9.1, ≈1.25 Hz).  Here the same run is turned into a measured frequency response:

* :func:`chirp_phase` gives the chirp's instantaneous phase ``phi(t)`` and frequency
  ``f(t)`` (the same formula as :func:`ballbot_casadi.sim.references.chirp`).
* :func:`sliding_response` fits, in a window of a few periods around each centre time,
  the output ``y`` and the reference ``r`` by least squares onto ``[sin phi, cos phi,
  1]``.  Their complex amplitudes give the gain ``|Y / R|`` and phase ``arg(Y / R)`` at
  the window's frequency ``f(t_c)``.  Because the basis follows the chirp's own phase,
  the fit is exact for a linear time-invariant system in steady state and only the
  slow drift of the frequency inside the window (a few per cent) limits it.
* :func:`bandwidth_from_response` returns the first frequency where tracking is lost:
  the gain falls below -3 dB (half the power: the usual definition of bandwidth) **or**
  the phase lag exceeds 90 deg (beyond that the output moves against the reference:
  the error ``|1 - G|`` exceeds the reference itself once the gain is near 1, so the loop
  no longer tracks even if the amplitude looks right).  Linear interpolation between
  the two grid points around the crossing.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ballbot_casadi.analysis.metrics import rpy_deg, tilt_deg
from ballbot_casadi.core.layout import STATE
from ballbot_casadi.errors import ScenarioError

__all__ = [
    "GAIN_DB",
    "PHASE_LAG_DEG",
    "CRITERION",
    "chirp_phase",
    "sliding_response",
    "bandwidth_from_response",
    "second_order_bandwidth_hz",
    "response_at",
    "chirp_metrics",
    "FALL_TILT_DEG",
    "CROSS_AXIS_DEG",
]

#: The robot has fallen once its tilt exceeds this (deg) or its state is not finite:
#: far beyond the 5 deg limit of thesis §7.1, where the wheels lose the ball in reality.
FALL_TILT_DEG = 30.0

#: The other tilt axis "degrades" once its tracking error exceeds this (deg): the thesis's
#: §9.1 reading of Fig. 9.1 (pitch starts to degrade at ~23 s while the roll chirp runs).
CROSS_AXIS_DEG = 0.1

#: Gain threshold of the bandwidth criterion (dB).
GAIN_DB = -3.0
#: Phase-lag threshold of the bandwidth criterion (deg).
PHASE_LAG_DEG = 90.0
#: The criterion in words (``bandwidth_criterion`` of the chirp study).
CRITERION = (f"first frequency where the sliding-window sine-fit gain falls below {GAIN_DB:g} dB "
             f"or the phase lag exceeds {PHASE_LAG_DEG:g} deg")


def chirp_phase(t: np.ndarray, f0: float, f1: float, duration: float) -> tuple[np.ndarray, np.ndarray]:
    """Phase ``phi(t)`` (rad) and instantaneous frequency ``f(t)`` (Hz) of a linear chirp.

    ``f(t) = f0 + (f1 - f0) t / duration`` on ``[0, duration]``, ``f1`` afterwards.
    """
    t = np.asarray(t, float)
    if not (duration > 0 and f0 >= 0 and f1 >= 0):
        raise ScenarioError(f"chirp needs duration > 0 and f0, f1 >= 0, got {duration}, {f0}, {f1}")
    c = (f1 - f0) / duration
    tc = np.clip(t, 0.0, duration)
    phi = 2 * np.pi * (f0 * tc + 0.5 * c * tc**2 + f1 * np.clip(t - duration, 0.0, None))
    f = np.where(t <= duration, f0 + c * tc, f1)
    return phi, f


def _fit(phi: np.ndarray, y: np.ndarray) -> complex:
    A = np.column_stack([np.sin(phi), np.cos(phi), np.ones_like(phi)])
    (a, b, _), *_ = np.linalg.lstsq(A, y, rcond=None)
    return complex(a, b)  # y ~ a sin + b cos = Im((a + j b) e^{j phi})


def sliding_response(
    t: np.ndarray,
    y: np.ndarray,
    r: np.ndarray,
    phi: np.ndarray,
    f: np.ndarray,
    *,
    cycles: float = 3.0,
    min_window_s: float = 0.5,
    max_window_s: float = 10.0,
    step_s: float = 0.25,
    t_end: float | None = None,
) -> dict[str, np.ndarray]:
    """Measured frequency response of ``y`` to ``r`` along a chirp (sliding sine fits).

    Parameters
    ----------
    t, y, r
        Time (s), output and reference samples (same length).
    phi, f
        The chirp's phase and frequency at ``t`` (:func:`chirp_phase`).
    cycles
        Window length in periods of the local frequency, clipped to
        ``[min_window_s, max_window_s]``.
    step_s
        Spacing of the window centres.
    t_end
        Ignore samples after this time (e.g. after a fall).

    Returns
    -------
    dict
        ``t`` (window centres), ``f_hz``, ``gain`` (``|Y/R|``), ``gain_db``,
        ``phase_deg`` (unwrapped along frequency, negative = lag).  Windows with
        non-finite samples are dropped.
    """
    t, y, r, phi, f = (np.asarray(v, float) for v in (t, y, r, phi, f))
    if not (t.shape == y.shape == r.shape == phi.shape == f.shape) or t.ndim != 1:
        raise ScenarioError("sliding_response: t, y, r, phi and f must be 1-D arrays of one length")
    last = t[-1] if t_end is None else min(t[-1], t_end)
    centres, freqs, G = [], [], []
    for tc in np.arange(t[0], last + 1e-12, step_s):
        fc = float(np.interp(tc, t, f))
        half = 0.5 * min(max(cycles / max(fc, 1e-9), min_window_s), max_window_s)
        lo, hi = tc - half, tc + half
        if lo < t[0] - 1e-12 or hi > last + 1e-12:
            continue
        m = (t >= lo) & (t <= hi)
        if np.count_nonzero(m) < 8 or not (np.all(np.isfinite(y[m])) and np.all(np.isfinite(r[m]))):
            continue
        R = _fit(phi[m], r[m])
        if abs(R) == 0:
            continue
        centres.append(tc)
        freqs.append(fc)
        G.append(_fit(phi[m], y[m]) / R)
    G_arr = np.asarray(G, complex)
    gain = np.abs(G_arr)
    with np.errstate(divide="ignore"):
        gain_db = 20 * np.log10(gain)
    return {"t": np.asarray(centres), "f_hz": np.asarray(freqs), "gain": gain, "gain_db": gain_db,
            "phase_deg": np.degrees(np.unwrap(np.angle(G_arr))) if G_arr.size else np.zeros(0)}


def bandwidth_from_response(
    f_hz: np.ndarray,
    gain_db: np.ndarray,
    phase_deg: np.ndarray,
    gain_threshold_db: float = GAIN_DB,
    phase_lag_deg: float = PHASE_LAG_DEG,
) -> tuple[float | None, str | None]:
    """First frequency where tracking is lost (see the module docstring).

    Returns
    -------
    (bandwidth_hz, reason)
        ``reason`` is ``"gain"`` or ``"phase"`` (which criterion crossed first), both
        ``None`` when tracking holds over the whole sweep.
    """
    f, g, p = (np.asarray(v, float) for v in (f_hz, gain_db, phase_deg))
    if f.size == 0:
        return None, None
    lost_g = g < gain_threshold_db
    lost_p = p < -phase_lag_deg
    lost = np.nonzero(lost_g | lost_p)[0]
    if lost.size == 0:
        return None, None
    i = int(lost[0])
    reason = "gain" if lost_g[i] else "phase"
    if i == 0:
        return float(f[0]), reason
    # interpolate the crossing of whichever criterion fired
    a, b = (g[i - 1], g[i]) if reason == "gain" else (p[i - 1], p[i])
    target = gain_threshold_db if reason == "gain" else -phase_lag_deg
    frac = 1.0 if a == b or not math.isfinite(b) else float(np.clip((a - target) / (a - b), 0, 1))
    return float(f[i - 1] + frac * (f[i] - f[i - 1])), reason


def second_order_bandwidth_hz(wn: float, zeta: float) -> float:
    """-3 dB frequency (Hz) of ``wn^2 / (s^2 + 2 zeta wn s + wn^2)`` (closed form)."""
    b = 1 - 2 * zeta**2
    return float(wn * math.sqrt(b + math.sqrt(b * b + 1)) / (2 * math.pi))


def response_at(resp: dict[str, Any], f_hz: float) -> tuple[float, float]:
    """Gain (dB) and phase (deg) of a measured response interpolated at ``f_hz``."""
    return (float(np.interp(f_hz, resp["f_hz"], resp["gain_db"])),
            float(np.interp(f_hz, resp["f_hz"], resp["phase_deg"])))


def chirp_metrics(log: Any, axis: str | None = None) -> dict[str, Any]:
    """Chirp test of thesis §9.1 on one run: bandwidth, first saturation, fall.

    Parameters
    ----------
    log
        A :class:`~ballbot_casadi.sim.log.SimulationLog` whose scenario has a chirp on
        ``axis`` (roll or pitch; default: the first chirp axis found).

    Returns
    -------
    dict
        ``bandwidth_hz`` (``None`` when tracking holds over the sweep),
        ``bandwidth_reason`` (``gain``/``phase``), ``bandwidth_criterion``,
        ``first_saturation_s`` / ``first_saturation_hz`` (first command ``|tau_cmd_i|
        >= tau_max`` of any motor, with the chirp frequency then; ``None`` if never),
        ``first_saturation_motor``, ``saturation_s_per_motor``,
        ``saturation_hz_per_motor``, ``fell_at_s`` / ``fell_at_hz`` (tilt >
        :data:`FALL_TILT_DEG` or non-finite state; ``None`` if not), ``cross_axis_onset_s``
        / ``cross_axis_onset_hz`` (first time the other tilt axis's tracking error exceeds
        :data:`CROSS_AXIS_DEG` before the fall; ``None`` if never: thesis §9.1, pitch
        degrades at ~23 s), ``cross_axis_error_max_deg`` (before the fall), ``chirp_axis``
        and the measured ``response`` (``f_hz``, ``gain_db``, ``phase_deg``).
    """
    sc = log.scenario
    att = sc.get("attitude") or {}
    if axis is None:
        axis = next((ax for ax in ("roll", "pitch", "yaw") if att.get(ax, {}).get("type") == "chirp"), None)
    spec = att.get(axis or "", {})
    if spec.get("type") != "chirp":
        raise ScenarioError(f"scenario {sc.get('name')!r} has no chirp on axis {axis!r}")
    i_ax = ("roll", "pitch", "yaw").index(axis)
    a = log.arrays
    n = a["q_ref"].shape[0]
    t = a["time"][:n]
    phi, f = chirp_phase(t, spec["f0_hz"], spec["f1_hz"], spec["duration"])
    x = a["state"][:n]
    with np.errstate(invalid="ignore"):
        tilt = tilt_deg(x[:, STATE["q"]])
        bad = ~np.all(np.isfinite(x), axis=1) | ~(tilt <= FALL_TILT_DEG)
    k_fall = int(np.argmax(bad)) if np.any(bad) else None
    fell_at = float(t[k_fall]) if k_fall is not None else None
    ang = rpy_deg(np.nan_to_num(x[:, STATE["q"]], nan=0.0))
    ref = rpy_deg(a["q_ref"])
    y, r = ang[:, i_ax], ref[:, i_ax]
    other = 1 if i_ax == 0 else 0
    cross = np.abs(ang[:, other] - ref[:, other])[:k_fall]
    k_cross = np.nonzero(cross > CROSS_AXIS_DEG)[0]
    resp = sliding_response(t, y, r, phi, f, t_end=fell_at)
    bw, reason = bandwidth_from_response(resp["f_hz"], resp["gain_db"], resp["phase_deg"])
    if bw is None and fell_at is not None:
        bw, reason = float(np.interp(fell_at, t, f)), "fall"
    tau_max = float(log.params.tau_max)
    cmd = np.abs(np.asarray(a["tau_cmd"], float))
    sat_s, sat_hz = [], []
    for i in range(cmd.shape[1]):
        k = np.nonzero(cmd[:, i] >= tau_max * (1 - 1e-9))[0]
        sat_s.append(float(t[k[0]]) if k.size else None)
        sat_hz.append(float(f[k[0]]) if k.size else None)
    hits = [(s, i) for i, s in enumerate(sat_s) if s is not None]
    first = min(hits) if hits else None
    return {
        "chirp_axis": axis,
        "bandwidth_hz": bw,
        "bandwidth_reason": reason,
        "bandwidth_criterion": CRITERION,
        "first_saturation_s": first[0] if first else None,
        "first_saturation_hz": sat_hz[first[1]] if first else None,
        "first_saturation_motor": first[1] if first else None,
        "saturation_s_per_motor": sat_s,
        "saturation_hz_per_motor": sat_hz,
        "fell_at_s": fell_at,
        "fell_at_hz": float(np.interp(fell_at, t, f)) if fell_at is not None else None,
        "cross_axis_onset_s": float(t[k_cross[0]]) if k_cross.size else None,
        "cross_axis_onset_hz": float(f[k_cross[0]]) if k_cross.size else None,
        "cross_axis_error_max_deg": float(np.max(cross)) if cross.size else 0.0,
        "response": {k: np.asarray(resp[k]).tolist() for k in ("f_hz", "gain_db", "phase_deg")},
    }

"""Reference generators with analytic derivatives (no numerical differentiation).

Every generator is a pure numpy function of a time vector ``t`` (shape (N,), any
float array) and returns a :class:`Signal` ``(value, d1, d2)`` of arrays shaped like
``t`` (scalar signals) or ``(N, m)`` (vector signals):

* :func:`step` - (optionally smoothed) step,
* :func:`sine` - sinusoid,
* :func:`chirp` - linear chirp (frequency rising linearly, thesis §9.1),
* :func:`velocity_profile` - piecewise-linear ball-velocity and heading-rate profile with
  acceleration-limited ramps, checked against the specifications of thesis §7.1,
* :func:`rpy_reference` - roll/pitch/yaw trajectories -> quaternion ``q`` and its first
  and second time derivatives ``dq``, ``ddq`` (arrays (N, 4)), the input of the
  balance controllers.

Example: the thesis §8.2.5 roll sine (3 deg, 0.5 Hz)::
    t = np.arange(0, 10, 0.005)
    q, dq, ddq = rpy_reference(sine(t, np.radians(3), 0.5), 0.0, 0.0)
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple, Sequence

import numpy as np

from ballbot_casadi.core.constants import THESIS_LIMITS
from ballbot_casadi.errors import ScenarioError, ShapeError

__all__ = [
    "Signal",
    "SPEC",
    "step",
    "ramp",
    "sine",
    "chirp",
    "velocity_profile",
    "rpy_reference",
    "FIG93_KEYFRAMES",
    "FIG93_ACCEL",
]

#: Design specifications of thesis §7.1 (SI units): :data:`ballbot_casadi.core.constants.THESIS_LIMITS`.
SPEC = THESIS_LIMITS


class Signal(NamedTuple):
    """A reference signal and its first two time derivatives."""

    value: np.ndarray
    d1: np.ndarray
    d2: np.ndarray


def _time(t: Any) -> np.ndarray:
    arr = np.asarray(t, dtype=float)
    if arr.ndim == 0:
        arr = arr.reshape(1)
    if arr.ndim != 1:
        raise ShapeError(f"time must be a scalar or a 1-D array, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ScenarioError("time vector contains NaN or inf")
    return arr


def _finite(name: str, value: Any) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ScenarioError(f"{name} must be a real number, got {value!r}") from None
    if not math.isfinite(v):
        raise ScenarioError(f"{name} must be finite, got {v}")
    return v


def step(
    t: Any, amplitude: float = 1.0, t_step: float = 0.0, rise_time: float = 0.0,
    offset: float = 0.0,
) -> Signal:
    """Step from ``offset`` to ``offset + amplitude`` at ``t_step``.

    With ``rise_time > 0`` the transition is the quintic ``10 s^3 - 15 s^4 + 6 s^5``
    (``s = (t - t_step)/rise_time``), whose first and second derivatives are continuous
    and zero at both ends; with ``rise_time = 0`` it is an ideal step with zero
    derivatives (the Dirac parts are not representable).
    """
    t = _time(t)
    amplitude, t_step = _finite("amplitude", amplitude), _finite("t_step", t_step)
    rise_time, offset = _finite("rise_time", rise_time), _finite("offset", offset)
    if rise_time < 0:
        raise ScenarioError(f"rise_time must be >= 0, got {rise_time}")
    if rise_time == 0:
        y = offset + amplitude * (t >= t_step)
        return Signal(y.astype(float), np.zeros_like(t), np.zeros_like(t))
    s = np.clip((t - t_step) / rise_time, 0.0, 1.0)
    inside = (t > t_step) & (t < t_step + rise_time)
    y = offset + amplitude * (10 * s**3 - 15 * s**4 + 6 * s**5)
    dy = amplitude * (30 * s**2 - 60 * s**3 + 30 * s**4) / rise_time * inside
    ddy = amplitude * (60 * s - 180 * s**2 + 120 * s**3) / rise_time**2 * inside
    return Signal(y, dy, ddy)


def ramp(t: Any, amplitude: float = 1.0, t_start: float = 0.0, rate: float = 1.0,
         offset: float = 0.0) -> Signal:
    """Ramp from ``offset`` at ``t_start`` with slope ``rate`` (> 0, units of amplitude
    per second, towards the sign of ``amplitude``), held at ``offset + amplitude`` once
    reached (thesis §7.2 item 4: lag when tracking a ramp).  The derivative is the slope
    inside the ramp and zero outside; the second derivative is zero (the Dirac parts at
    the corners are not representable)."""
    t = _time(t)
    amplitude, t_start = _finite("amplitude", amplitude), _finite("t_start", t_start)
    rate, offset = _finite("rate", rate), _finite("offset", offset)
    if rate <= 0:
        raise ScenarioError(f"rate must be > 0, got {rate}")
    sign = 1.0 if amplitude >= 0 else -1.0
    y = offset + sign * np.clip(rate * (t - t_start), 0.0, abs(amplitude))
    inside = (t >= t_start) & (t < t_start + abs(amplitude) / rate)
    return Signal(y, sign * rate * inside.astype(float), np.zeros_like(t))


def sine(
    t: Any, amplitude: float, frequency: float, phase: float = 0.0, offset: float = 0.0
) -> Signal:
    """``offset + amplitude sin(2 pi frequency t + phase)`` (frequency in Hz)."""
    t = _time(t)
    amplitude, frequency = _finite("amplitude", amplitude), _finite("frequency", frequency)
    phase, offset = _finite("phase", phase), _finite("offset", offset)
    if frequency < 0:
        raise ScenarioError(f"frequency must be >= 0 Hz, got {frequency}")
    w = 2 * np.pi * frequency
    arg = w * t + phase
    return Signal(
        offset + amplitude * np.sin(arg),
        amplitude * w * np.cos(arg),
        -amplitude * w**2 * np.sin(arg),
    )


def chirp(
    t: Any, amplitude: float, f0: float, f1: float, duration: float, offset: float = 0.0
) -> Signal:
    """Linear chirp ``amplitude sin(phi(t))``, frequency ``f0 -> f1`` Hz over ``duration``.

    The instantaneous frequency is ``f0 + (f1 - f0) t / duration`` for
    ``0 <= t <= duration`` and stays ``f1`` afterwards (phase continuous);
    ``y = offset`` for ``t < 0``.  Thesis §9.1: ``chirp(t, A, 0.05, 5.0, 99.0)``
    (0.05 Hz rising by 0.05 Hz/s).
    """
    t = _time(t)
    amplitude, f0, f1 = (_finite(n, v) for n, v in (("amplitude", amplitude), ("f0", f0), ("f1", f1)))
    duration, offset = _finite("duration", duration), _finite("offset", offset)
    if duration <= 0 or f0 < 0 or f1 < 0:
        raise ScenarioError(
            f"chirp needs duration > 0 and frequencies >= 0, got duration={duration}, "
            f"f0={f0}, f1={f1}"
        )
    c = (f1 - f0) / duration  # Hz/s
    tc = np.clip(t, 0.0, duration)
    phi = 2 * np.pi * (f0 * tc + 0.5 * c * tc**2 + f1 * np.clip(t - duration, 0.0, None))
    dphi = 2 * np.pi * np.where(t <= duration, f0 + c * tc, f1)
    ddphi = 2 * np.pi * c * ((t >= 0) & (t <= duration))
    on = t >= 0
    y = offset + amplitude * np.sin(phi) * on
    dy = amplitude * dphi * np.cos(phi) * on
    ddy = amplitude * (ddphi * np.cos(phi) - dphi**2 * np.sin(phi)) * on
    return Signal(y, dy, ddy)


#: Acceleration of the ramps of :data:`FIG93_KEYFRAMES` (m/s^2).  Below the 1 m/s^2
#: limit of thesis §7.1 on purpose: a steady acceleration ``a`` needs a body tilt of
#: about ``a / g`` (plus the ball's inertia), so 1 m/s^2 needs ~6 deg, beyond the 5 deg
#: inclination limit; at 0.25 m/s^2 the tilt stays ~2.5 deg.
FIG93_ACCEL = 0.25
#: Keyframes ``(t_start, vx, vy, yaw_rate, accel)`` of a profile in the spirit of thesis
#: Fig. 9.3 (forward, diagonal, sideways at the speed limit, stop and turn, backwards,
#: rest).
FIG93_KEYFRAMES: tuple[tuple[float, ...], ...] = (
    (1.0, 0.3, 0.0, 0.0, FIG93_ACCEL),
    (4.0, 0.3, 0.3, 0.0, FIG93_ACCEL),
    (7.0, 0.0, 0.5, 0.0, FIG93_ACCEL),
    (10.0, 0.0, 0.0, 0.5, FIG93_ACCEL),
    (12.5, -0.3, 0.0, 0.0, FIG93_ACCEL),
    (15.0, 0.0, 0.0, 0.0, FIG93_ACCEL),
)


def velocity_profile(
    t: Any,
    keyframes: Sequence[Sequence[float]] = FIG93_KEYFRAMES,
    a_max: float = SPEC["a_max"],
    yaw_acc_max: float = SPEC["yaw_acc_max"],
) -> Signal:
    """Piecewise-linear velocity reference ``[vx, vy, yaw_rate]`` with limited ramps.

    Parameters
    ----------
    t
        Time vector (s).
    keyframes
        Rows ``(t_start, vx, vy, yaw_rate)`` or ``(t_start, vx, vy, yaw_rate, accel)``:
        from ``t_start`` the reference ramps from its current value to the new target,
        the translational part along a straight line at acceleration ``accel``
        (vector norm; default ``a_max``, never above it) and the heading rate at
        ``yaw_acc_max``, the longer of the two setting the ramp duration.  The start
        value is zero.  ``t_start`` must increase and each ramp must end before the
        next keyframe.
    a_max, yaw_acc_max
        Ramp accelerations, at most the specification (1 m/s^2, 10 rad/s^2).

    Returns
    -------
    Signal
        ``value`` and ``d1`` of shape (N, 3): ``[vx, vy, yaw_rate]`` (inertial frame,
        m/s, rad/s) and its derivative; ``d2`` is zero (piecewise-constant acceleration).

    Raises
    ------
    ScenarioError
        A target faster than 0.5 m/s (norm) or 1 rad/s, ramps faster than the limits,
        overlapping ramps or non-increasing times.
    """
    t = _time(t)
    a_max, yaw_acc_max = _finite("a_max", a_max), _finite("yaw_acc_max", yaw_acc_max)
    if not (0 < a_max <= SPEC["a_max"]) or not (0 < yaw_acc_max <= SPEC["yaw_acc_max"]):
        raise ScenarioError(
            f"ramp limits must satisfy 0 < a_max <= {SPEC['a_max']} m/s^2 and "
            f"0 < yaw_acc_max <= {SPEC['yaw_acc_max']} rad/s^2 (thesis §7.1)"
        )
    try:  # each row its own length: a row without accel ramps at a_max
        rows = [np.asarray(row, dtype=float) for row in keyframes]
    except (TypeError, ValueError):
        rows = []
    if not rows or any(r.ndim != 1 or r.size not in (4, 5) for r in rows):
        raise ShapeError(
            f"keyframes must be rows (t_start, vx, vy, yaw_rate[, accel]), got {keyframes!r}"
        )
    if not all(np.all(np.isfinite(r)) for r in rows):
        raise ScenarioError("keyframes contain NaN or inf")
    kf = np.array([r if r.size == 5 else np.append(r, a_max) for r in rows])
    value = np.zeros((t.size, 3))
    d1 = np.zeros((t.size, 3))
    prev = np.zeros(3)
    t_free = -np.inf
    for i, (ts, vx, vy, r, acc) in enumerate(kf):
        target = np.array([vx, vy, r])
        if not 0 < acc <= a_max:
            raise ScenarioError(
                f"keyframe {i}: ramp acceleration {acc} m/s^2 must be in (0, {a_max}]"
            )
        if np.hypot(vx, vy) > SPEC["v_max"] + 1e-12 or abs(r) > SPEC["yaw_rate_max"] + 1e-12:
            raise ScenarioError(
                f"keyframe {i}: target speed {np.hypot(vx, vy):.3g} m/s / yaw rate {r:.3g} rad/s "
                f"exceeds the limits {SPEC['v_max']} m/s, {SPEC['yaw_rate_max']} rad/s"
            )
        if ts < t_free:
            raise ScenarioError(
                f"keyframe {i} at t={ts} s starts before the previous ramp ends "
                f"(t={t_free:.3f} s) or times are not increasing"
            )
        delta = target - prev
        dur = max(np.hypot(delta[0], delta[1]) / acc, abs(delta[2]) / yaw_acc_max)
        if dur > 0:
            rate = delta / dur
            ramp = (t >= ts) & (t < ts + dur)
            value[ramp] = prev + np.outer(t[ramp] - ts, rate)
            d1[ramp] = rate
        value[t >= ts + dur] = target
        prev, t_free = target, ts + dur
    return Signal(value, d1, np.zeros_like(value))


def _as_signal(name: str, s: Any, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    if isinstance(s, (int, float, np.floating, np.integer)):
        v = _finite(name, s)
        return np.full(n, v), np.zeros(n), np.zeros(n)
    try:
        parts = [np.broadcast_to(np.asarray(a, dtype=float), (n,)) for a in s]
    except (TypeError, ValueError):
        raise ShapeError(
            f"{name} must be a number or a (value, d1, d2) triple of length-{n} arrays"
        ) from None
    if len(parts) != 3:
        raise ShapeError(f"{name} must be a (value, d1, d2) triple, got {len(parts)} parts")
    if not all(np.all(np.isfinite(a)) for a in parts):
        raise ScenarioError(f"{name} contains NaN or inf")
    return parts[0], parts[1], parts[2]


def _qmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise Hamilton product of (N, 4) arrays (thesis E.9)."""
    a0, a1, a2, a3 = a.T
    b0, b1, b2, b3 = b.T
    return np.stack(
        [
            a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
            a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
            a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1,
            a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0,
        ],
        axis=1,
    )


def _axis_quat(axis: int, a: np.ndarray, da: np.ndarray, dda: np.ndarray):
    """Elementary rotation ``[cos a/2, sin a/2 e_axis]`` and its two time derivatives."""
    n = a.size
    c, s = np.cos(a / 2), np.sin(a / 2)
    q, dq, ddq = np.zeros((n, 4)), np.zeros((n, 4)), np.zeros((n, 4))
    q[:, 0], q[:, axis] = c, s
    dq[:, 0], dq[:, axis] = -0.5 * da * s, 0.5 * da * c
    ddq[:, 0] = -0.5 * dda * s - 0.25 * da**2 * c
    ddq[:, axis] = 0.5 * dda * c - 0.25 * da**2 * s
    return q, dq, ddq


def rpy_reference(roll: Any, pitch: Any, yaw: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Quaternion reference from ZYX Euler angles with analytic derivatives.

    ``q = qz(yaw) o qy(pitch) o qx(roll)`` (the convention of
    :func:`ballbot_casadi.core.quaternion.from_rpy`); the derivatives follow from the
    product rule (thesis E.35).

    Parameters
    ----------
    roll, pitch, yaw
        Each a number (constant angle, rad) or a triple ``(value, d1, d2)`` of arrays of
        one common length N (e.g. a :class:`Signal`).  At least one must be a triple
        unless N = 1 is intended.

    Returns
    -------
    q, dq, ddq
        Arrays of shape (N, 4).
    """
    n = 1
    for s in (roll, pitch, yaw):
        if not isinstance(s, (int, float, np.floating, np.integer)):
            try:
                n = max(n, np.asarray(s[0], dtype=float).size)
            except (TypeError, IndexError, ValueError):
                raise ShapeError("angles must be numbers or (value, d1, d2) triples") from None
    qx = _axis_quat(1, *_as_signal("roll", roll, n))
    qy = _axis_quat(2, *_as_signal("pitch", pitch, n))
    qz = _axis_quat(3, *_as_signal("yaw", yaw, n))
    m = _qmul
    q = m(m(qz[0], qy[0]), qx[0])
    dq = m(m(qz[1], qy[0]), qx[0]) + m(m(qz[0], qy[1]), qx[0]) + m(m(qz[0], qy[0]), qx[1])
    ddq = (
        m(m(qz[2], qy[0]), qx[0])
        + m(m(qz[0], qy[2]), qx[0])
        + m(m(qz[0], qy[0]), qx[2])
        + 2 * m(m(qz[1], qy[1]), qx[0])
        + 2 * m(m(qz[1], qy[0]), qx[1])
        + 2 * m(m(qz[0], qy[1]), qx[1])
    )
    return q, dq, ddq

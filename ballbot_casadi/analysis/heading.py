"""Heading error of the attitude filters on matched synthetic data, with and without aiding.

A synthetic run (:func:`heading_run`) is a known attitude trajectory of a robot that
balances and turns (tilt oscillating by about 1 deg, the heading sweeping through several
turns, so the readings cross the ``±pi`` cut) and the readings of the package's sensor
models on it, with the noise of the sensor parameters
(:class:`~ballbot_casadi.core.sensor_params.SensorParams`):

* accelerometer: gravity in {B} plus white noise (no linear acceleration);
* gyroscope: the body rate over the period (the rate the constant-rate process model
  integrates exactly) plus the bias ``b`` (a random walk with ``gyro_bias_rw`` starting at
  ``gyro_bias0``, thesis (3.9)) plus white noise;
* heading: :func:`~ballbot_casadi.model.sensors.make_heading_sensor` at ``heading_rate``
  (:func:`~ballbot_casadi.model.sensors.heading_schedule`), missing during ``loss``.

The filters run on the data in compiled chunks (``mapaccum`` of the filter period,
generated C cached by hash): the heading-aided QUKF
(:func:`~ballbot_casadi.estimation.heading.make_qukf_heading`, ``aided = True``) or the
thesis's QUKF (:func:`~ballbot_casadi.estimation.make_qukf`, ``aided = False``: the
heading is the integral of the gyroscope).  Only every ``log_every``-th period is kept.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import casadi as ca
import numpy as np

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.constants import TS_CONTROL
from ballbot_casadi.core.params import load_params
from ballbot_casadi.core.rng import NoiseStream
from ballbot_casadi.core.sensor_params import SensorParams, load_sensor_params
from ballbot_casadi.core.toolchain import build_library, load_library
from ballbot_casadi.errors import ArgumentError
from ballbot_casadi.estimation import DEFAULT_TUNING, make_qukf
from ballbot_casadi.estimation.heading import (
    HEADING_FILTER_STATE,
    HEADING_MEAS,
    heading_tuning,
    make_qukf_heading,
)
from ballbot_casadi.model.sensors import (
    NOISE_STREAMS,
    heading_schedule,
    make_heading_sensor,
    wrap_angle,
)

__all__ = ["HEADING_CHUNK", "HeadingRun", "heading_truth", "heading_readings", "heading_run"]

#: Filter periods per compiled chunk.
HEADING_CHUNK = 2000
#: Heading sweep of the synthetic trajectory: yaw rate amplitude (rad/s) and period (s).
_YAW_RATE, _YAW_PERIOD = 0.3, 120.0
_TILT = np.radians(1.0)


@dataclass(frozen=True)
class HeadingRun:
    """A synthetic run's decimated log: ``time`` (s), true and estimated yaw (rad), the
    heading error ``wrap(yaw_hat - yaw)`` (rad), the true z gyro bias and its estimate
    (rad/s; the estimate is NaN for the unaided QUKF), and the heading NIS (nan when the
    reading was missing)."""

    time: np.ndarray
    yaw: np.ndarray
    yaw_hat: np.ndarray
    error: np.ndarray
    bias: np.ndarray
    bias_hat: np.ndarray

    def error_deg(self) -> np.ndarray:
        """The heading error in degrees."""
        return np.degrees(self.error)


def heading_truth(k0: int, k1: int, Ts: float = TS_CONTROL) -> tuple[np.ndarray, np.ndarray]:
    """The true attitude ``q`` at ``t_k`` (rows ``k0 .. k1``, one more than periods) and the
    body rate over ``[t_{k-1}, t_k]`` for ``k = k0 .. k1-1`` (rows; row 0 of a run is 0).

    ZYX angles: roll ``1 deg sin(2 pi 0.5 Hz t)``, pitch ``1 deg cos(2 pi 0.3 Hz t)``, yaw
    ``(0.3 rad/s) / w (1 - cos(w t))`` with ``w = 2 pi / 120 s`` (the heading sweeps
    0 .. 11.5 rad and back at up to 0.3 rad/s)."""
    t = np.arange(k0 - 1, k1 + 1) * Ts
    w = 2 * np.pi / _YAW_PERIOD
    yaw = _YAW_RATE / w * (1 - np.cos(w * t))
    roll = _TILT * np.sin(2 * np.pi * 0.5 * t)
    pitch = _TILT * np.cos(2 * np.pi * 0.3 * t)
    q = np.array([Q.from_rpy(r, p_, y) for r, p_, y in zip(roll, pitch, yaw)])
    rate = np.array([Q.to_rotation_vector(Q.mul(Q.conj(a), b)) / Ts
                     for a, b in zip(q[:-1], q[1:])])
    return q[1:], rate[:-1]


def heading_readings(k0: int, k1: int, seed: int, sensors: SensorParams, bias0: np.ndarray,
                     Ts: float = TS_CONTROL, loss: tuple[float, float] | None = None,
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The readings of periods ``k0 .. k1-1`` (:data:`HEADING_MEAS` rows, NaN = missing),
    the true attitude at those instants, the true gyro bias and the bias after ``k1 - 1``.

    ``bias0`` is the bias at period ``k0``; the noise is drawn by period index, so a run in
    chunks is the run in one piece.
    """
    n = k1 - k0
    rng = NoiseStream(seed)
    q, rate = heading_truth(k0, k1, Ts)
    q = q[:n]
    g = load_params().g
    n_acc, n_gyro = (rng.normal(NOISE_STREAMS[s], n, 3, start=k0) for s in ("acc", "gyro"))
    n_rw = rng.normal(NOISE_STREAMS["gyro_bias_rw"], n, 3, start=k0)
    n_h = rng.normal(NOISE_STREAMS["heading"], n, 1, start=k0)
    steps = np.sqrt(Ts) * np.asarray(sensors.gyro_bias_rw) * n_rw
    bias = bias0 + np.vstack([np.zeros(3), np.cumsum(steps, axis=0)])
    acc = np.array([Q.rotate_inv(a, [0.0, 0.0, g]) for a in q]) \
        + np.sqrt(sensors.acc_noise_var) * n_acc
    gyro = rate + bias[:-1] + np.sqrt(sensors.gyro_noise_var) * n_gyro
    yaw = np.asarray(make_heading_sensor().map(n)(q.T, sensors.to_vector(), n_h.T)).ravel()
    have = heading_schedule(k0, k1, Ts, sensors.heading_rate[0]) > 0
    if loss is not None:
        t = np.arange(k0, k1) * Ts
        have &= ~((t >= loss[0] - 1e-12) & (t < loss[1] - 1e-12))
    z = np.column_stack([acc, gyro, np.where(have, yaw, np.nan)])
    return z, q, bias[:-1], bias[-1]


@lru_cache(maxsize=None)
def _chunk(aided: bool) -> ca.Function:
    """The compiled ``HEADING_CHUNK``-period chunk of a filter (state and covariance
    accumulated; readings one column per period)."""
    f = make_qukf_heading() if aided else make_qukf(compensate_acceleration=True)
    name = "ballbot_heading_chunk_aided" if aided else "ballbot_heading_chunk_qukf"
    chunk = f.expand().mapaccum(name, HEADING_CHUNK, 2)
    lib = build_library(name, [chunk])
    return load_library(lib, [name])[name]


def heading_run(duration: float, seed: int = 0, aided: bool = True, *,
                loss: tuple[float, float] | None = None, log_every: int = 200,
                sensors: SensorParams | None = None, bias0: Any = (0.0, 0.0, 0.0),
                Ts: float = TS_CONTROL) -> HeadingRun:
    """Run a filter on a synthetic run of ``duration`` s (module docstring).

    Parameters
    ----------
    duration
        Length (s); rounded up to whole chunks of :data:`HEADING_CHUNK` periods.
    seed
        Noise seed.
    aided
        The heading-aided QUKF (True) or the thesis's QUKF (False).
    loss
        ``(t0, t1)``: the heading reading is missing in ``[t0, t1)`` (s).
    log_every
        Keep every ``log_every``-th period.
    sensors
        Sensor parameters (default the package's).
    bias0
        True gyro bias at ``t = 0`` (rad/s, 3); the filters start with a zero estimate.
    """
    if not (isinstance(log_every, int) and log_every >= 1) or not duration > 0:
        raise ArgumentError(f"heading_run needs duration > 0 and an int log_every >= 1, got "
                            f"{duration!r}, {log_every!r}")
    sensors = load_sensor_params() if sensors is None else sensors
    p = load_params().to_vector()
    n_chunks = int(np.ceil(round(duration / Ts) / HEADING_CHUNK))
    if aided:
        tun = heading_tuning(sensors.heading_noise_var[0], sensors.gyro_bias_rw[2], Ts)
        Qn, R, x, P = tun["Q"], tun["R"], np.array(tun["x0"]), np.array(tun["P0"])
    else:
        t = DEFAULT_TUNING["qukf"]
        Qn, R, x, P = t.Q, t.R, np.array(t.x0), np.array(t.P0)
    run = _chunk(aided)
    q0, _ = heading_truth(0, 1, Ts)
    x[0:4] = q0[0]  # aligned at start-up, as the closed loop's filters
    bias = np.asarray(bias0, float).reshape(3)
    logs: dict[str, list] = {k: [] for k in ("t", "yaw", "yaw_hat", "bias", "bias_hat")}
    for c in range(n_chunks):
        k0, k1 = c * HEADING_CHUNK, (c + 1) * HEADING_CHUNK
        z, q, b, bias = heading_readings(k0, k1, seed, sensors, bias, Ts, loss)
        if not aided:
            z = z[:, :HEADING_MEAS.offset("yaw")]
        out = run(x, P, z.T, Qn, R, Ts, p, np.zeros(3))
        X, Pn = np.asarray(out[0]), np.asarray(out[1])
        x, P = X[:, -1].copy(), Pn[:, -P.shape[1]:].copy()
        keep = np.nonzero((np.arange(k0, k1) % log_every) == 0)[0]
        logs["t"].append((k0 + keep) * Ts)
        logs["yaw"].append(np.array([Q.to_rpy(a)[2] for a in q[keep]]))
        logs["yaw_hat"].append(np.array([Q.to_rpy(X[0:4, i])[2] for i in keep]))
        logs["bias"].append(b[keep, 2])
        logs["bias_hat"].append(X[HEADING_FILTER_STATE["b_z"], keep].ravel() if aided
                                else np.full(keep.size, np.nan))
    a = {k: np.concatenate(v) for k, v in logs.items()}
    return HeadingRun(a["t"], a["yaw"], a["yaw_hat"], wrap_angle(a["yaw_hat"] - a["yaw"]),
                      a["bias"], a["bias_hat"])

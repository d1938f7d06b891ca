"""The plant FMU's oracle: its sensor readings from a numpy RK4 run of the model Functions.

:func:`plant_sensor_oracle` reproduces what ``BallbotPlant.fmu`` outputs in
Co-Simulation, by the same conventions (``fmu/plant/plant_model.c``) but from the CasADi
Functions of :mod:`ballbot_casadi.model` called from Python and the noise of
:class:`~ballbot_casadi.core.rng.NoiseStream` (the same Philox C file the FMU compiles):

* the state ``xw = [x; phi]`` (model states, wheel angles) is integrated by RK4 of
  ``ballbot_ode_wheel_angles``; each communication step ``[t, t + step]`` is split at the
  sensor sample instants ``t_k = start_time + k Ts_sensor`` inside it (an instant within
  ``GRID_TOL * Ts_sensor`` of the step end is the step end), each segment of length ``L``
  into ``ceil(L / h_internal)`` equal RK4 sub-steps, the torque held over the step;
* the torque acting on the plant is the commanded torque saturated at ``+-tau_max`` plus
  the disturbance torque;
* sample ``k`` reads the state at ``t_k``: ``ballbot_imu(x(t_k), tau_prev, p, s, b_k,
  n_acc_k, n_gyro_k)`` with ``tau_prev`` the torque of the step that ends at or contains
  ``t_k`` (zero for sample 0), ``b_0 = gyro_bias0``,
  ``b_k = ballbot_gyro_bias_step(b_{k-1}, s, Ts_sensor, n_rw_{k-1})``, and
  ``ballbot_encoders(phi(t_k), phi(t_{k-1}), p, Ts_sensor)`` with ``phi(t_{-1}) = phi(t_0)``;
* ``n_<source>_k[j]`` is element ``(k, j)`` of stream ``NOISE_STREAMS[<source>]`` of
  ``NoiseStream(seed)`` when ``noise_on``, else 0;
* a reading is held until the next sample.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ballbot_casadi.core.params import PARAM_NAMES, Params, load_params
from ballbot_casadi.core.rng import NoiseStream
from ballbot_casadi.core.sensor_params import (
    SENSOR_VECTOR_NAMES,
    SensorParams,
    load_sensor_params,
)
from ballbot_casadi.errors import ShapeError
from ballbot_casadi.fmi.plant.plant import (
    GRID_TOL,
    H_INTERNAL_DEFAULT,
    NXW,
    TS_SENSOR_DEFAULT,
)
from ballbot_casadi.model.dynamics import NU, NX, make_model_functions
from ballbot_casadi.model.integrators import make_rk4
from ballbot_casadi.model.sensors import (
    NOISE_STREAMS,
    make_encoders,
    make_gyro_bias_step,
    make_imu,
    make_wheel_angle_ode,
)

__all__ = ["plant_sensor_oracle"]


def _vec(v: Any) -> np.ndarray:
    return np.asarray(v, dtype=float).ravel()


def plant_sensor_oracle(x0: Any, tau: Any, tau_dist: Any = None, *, step: float = 0.005,
                           params: Params | None = None, sensors: SensorParams | None = None,
                           seed: int = 0, noise_on: bool = False,
                           Ts_sensor: float = TS_SENSOR_DEFAULT,
                           h_internal: float = H_INTERNAL_DEFAULT, phi0: Any = (0.0, 0.0, 0.0),
                           start_time: float = 0.0) -> dict[str, np.ndarray]:
    """Sensor readings of the plant FMU (Co-Simulation) computed in Python.

    Parameters
    ----------
    x0
        Model state at ``start_time`` (12).
    tau, tau_dist
        ``(N, 3)`` commanded wheel torques (FMU inputs ``tau0..2``) and disturbance torques
        (``tau_dist0..2``, default zero) of the N communication steps.
    step
        Communication step size; the step start times are accumulated as
        ``t <- t + step`` from ``start_time`` (like an importer that adds the step size).
    params, sensors
        Model and sensor parameters (default :func:`load_params`,
        :func:`load_sensor_params`).
    seed, noise_on, Ts_sensor, h_internal, phi0
        The FMU parameters of the same names and the start wheel angles.

    Returns
    -------
    dict
        At the N + 1 communication points: ``time``, ``xw`` (states and wheel angles, 15),
        the held readings ``acc``, ``gyro`` (3 each) and ``enc`` (3, ticks/s), ``bias``
        (the gyroscope bias in the held reading) and ``sample`` (its index k).
    """
    p = (params if params is not None else load_params()).to_vector()
    s = (sensors if sensors is not None else load_sensor_params()).to_vector()
    tau = np.atleast_2d(np.asarray(tau, dtype=float))
    dist = np.zeros_like(tau) if tau_dist is None else np.atleast_2d(np.asarray(tau_dist, float))
    if tau.ndim != 2 or tau.shape[1] != NU or dist.shape != tau.shape:
        raise ShapeError(f"tau and tau_dist must be (N, {NU}), got {tau.shape}, {dist.shape}")
    tmax = p[PARAM_NAMES.index("tau_max")]
    u_eff = np.clip(tau, -tmax, tmax) + dist
    f = make_model_functions()
    rk4 = make_rk4(make_wheel_angle_ode(f["ode"], f["wheel_speeds"]))
    imu, encoders, bias_step = make_imu(f["ode"]), make_encoders(), make_gyro_bias_step()
    n = tau.shape[0]
    t_last = start_time + n * step
    n_rows = int(math.floor((t_last - start_time) / Ts_sensor + GRID_TOL)) + 2
    noise = NoiseStream(seed) if noise_on else None
    draws = {name: (noise.normal(NOISE_STREAMS[name], n_rows, 3) if noise is not None
                    else np.zeros((n_rows, 3)))
             for name in ("acc", "gyro", "gyro_bias_rw")}
    xw = np.r_[_vec(x0), _vec(phi0)]
    if xw.shape != (NXW,):
        raise ShapeError(f"x0 must have {NX} entries and phi0 3, got {xw.size} in all")
    g0 = SENSOR_VECTOR_NAMES.index("gyro_bias0_x")
    state = {"b": s[g0:g0 + 3].copy(), "phi_prev": xw[NX:].copy(), "k": 0}

    def sample(k: int, u: np.ndarray) -> tuple[np.ndarray, ...]:
        if k > 0:
            state["b"] = _vec(bias_step(state["b"], s, Ts_sensor, draws["gyro_bias_rw"][k - 1]))
        acc, gyro = imu(xw[:NX], u, p, s, state["b"], draws["acc"][k], draws["gyro"][k])
        enc = encoders(xw[NX:], state["phi_prev"], p, Ts_sensor)[0]
        state["phi_prev"] = xw[NX:].copy()
        state["k"] = k
        return _vec(acc), _vec(gyro), _vec(enc), state["b"].copy()

    def integrate(x: np.ndarray, length: float, u: np.ndarray) -> np.ndarray:
        m = max(1, math.ceil(length / h_internal * (1.0 - 1e-12)))
        hs = length / m
        for _ in range(m):
            x = _vec(rk4(x, u, p, hs))
        return x

    reading = sample(0, np.zeros(NU))
    out = {key: [] for key in ("time", "xw", "acc", "gyro", "enc", "bias", "sample")}

    def record(t: float) -> None:
        for key, val in zip(("acc", "gyro", "enc", "bias"), reading):
            out[key].append(val)
        out["time"].append(t)
        out["xw"].append(xw.copy())
        out["sample"].append(state["k"])

    t = start_time
    record(t)
    tol = GRID_TOL * Ts_sensor
    for i in range(n):
        last = math.floor((t + step - start_time) / Ts_sensor + GRID_TOL)
        off = 0.0
        for k in range(state["k"] + 1, last + 1):
            d = start_time + float(k) * Ts_sensor - t
            end = step if d >= step - tol else d
            if end > off:
                xw = integrate(xw, end - off, u_eff[i])
                off = end
            reading = sample(k, u_eff[i])
        if off < step:
            xw = integrate(xw, step - off, u_eff[i])
        t += step
        record(t)
    return {key: np.asarray(val) for key, val in out.items()}

"""Velocity controller reference model: the thesis §7.1 limits hold for every state inside
the braking envelope (tilt-reference acceleration, rate, tilt), and the envelope is invariant."""

from __future__ import annotations

import numpy as np

from ballbot_casadi.control import default_velocity_gains, make_velocity_controller
from ballbot_casadi.control.velocity import (
    VELOCITY_DEFAULT_LIMITS,
    VELOCITY_LIMIT_NAMES,
)
from ballbot_casadi.core.constants import TS_CONTROL
from ballbot_casadi.core.layout import VELOCITY_CONTROLLER_STATE as Z
from ballbot_casadi.core.params import load_params
from ballbot_casadi.model.dynamics import make_jacobians
from ballbot_casadi.model.numeric import make_state

LIM = dict(zip(VELOCITY_LIMIT_NAMES, VELOCITY_DEFAULT_LIMITS))


def test_reference_acceleration_rate_and_tilt_stay_within_the_limits(rng):
    vel = make_velocity_controller()
    p = load_params().to_vector()
    k = default_velocity_gains(make_jacobians(), p, TS_CONTROL)
    a_max, rate_max, tilt_max = LIM["tilt_acc_max"], LIM["tilt_rate_max"], LIM["tilt_max"]
    Ts = TS_CONTROL
    n_checked = n_active = 0
    for _ in range(400):
        # a state inside the braking envelope |th| + dth^2 / (2 a_max) <= tilt_max
        th = rng.uniform(-tilt_max, tilt_max, 2)
        room = np.maximum(tilt_max - np.sign(rng.normal(size=2)) * th, 0)
        dth = np.clip(rng.uniform(-1, 1, 2) * np.sqrt(2 * a_max * room), -rate_max, rate_max)
        s = np.sign(dth)
        if np.any(s * th + dth**2 / (2 * a_max) > tilt_max):
            continue
        z = np.zeros(Z.size)
        z[Z["theta_r"]], z[Z["dtheta_r"]] = th, dth
        x = make_state(roll=rng.normal() * 0.05, pitch=rng.normal() * 0.05,
                       dx=rng.normal() * 0.5, dy=rng.normal() * 0.5)
        v_ref = np.r_[rng.normal(size=2) * 0.5, 0.0]
        z_next = vel(x, v_ref, z, p, k, Ts)[3].full().ravel()
        a = (z_next[Z["dtheta_r"]] - dth) / Ts
        n_checked += 1
        n_active += np.any(np.abs(a) > a_max - 1e-9)
        assert np.all(np.abs(a) <= a_max + 1e-9), (th, dth, a)
        assert np.all(np.abs(z_next[Z["dtheta_r"]]) <= rate_max + 1e-12)
        assert np.all(np.abs(z_next[Z["theta_r"]]) <= tilt_max + 1e-12)
    assert n_checked > 200 and n_active > 20  # the limits were exercised


def test_braking_bound_stops_at_the_tilt_limit():
    # moving outward at the fastest rate that can still stop at 5 deg: full braking
    vel = make_velocity_controller()
    p = load_params().to_vector()
    k = default_velocity_gains(make_jacobians(), p, TS_CONTROL)
    a_max, tilt_max = LIM["tilt_acc_max"], LIM["tilt_max"]
    th0 = 0.5 * tilt_max
    z = np.zeros(Z.size)
    z[Z["theta_r"]] = [th0, 0.0]
    z[Z["dtheta_r"]] = [np.sqrt(2 * a_max * (tilt_max - th0)) * 0.999, 0.0]
    x = make_state(dx=-0.5)  # the LQR wants to tilt further forward
    peak = 0.0
    for _ in range(400):
        z = vel(x, np.array([0.5, 0.0, 0.0]), z, p, k, TS_CONTROL)[3].full().ravel()
        peak = max(peak, z[Z["theta_r"]][0])
    assert peak <= tilt_max + 1e-12

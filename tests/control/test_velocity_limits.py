"""Velocity controller reference model: the thesis §7.1 limits hold for every state inside
the braking envelope (tilt-reference acceleration, rate, tilt), and the envelope is invariant."""

from __future__ import annotations

import numpy as np
import pytest

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


def test_the_braking_bound_is_the_largest_rate_that_still_stops_at_the_tilt_limit():
    """With the reference pushed outward, the next tilt-reference rate is exactly the
    bound ``v_n`` solving ``th + Ts (dth + v_n) / 2 + v_n^2 / (2 a_max) = tilt_max``
    (thesis §7.1 (5) with the acceleration limit (2)), or the rate limit; mirrored for a
    backward tilt, on the x axis and on y."""
    vel = make_velocity_controller()
    p = load_params().to_vector()
    k = default_velocity_gains(make_jacobians(), p, TS_CONTROL)
    a, rate_max, tilt_max, Ts = LIM["tilt_acc_max"], LIM["tilt_rate_max"], LIM["tilt_max"], TS_CONTROL
    n_braking = 0
    for th_frac, frac in ((0.8, 0.99), (0.95, 0.9), (0.95, 0.999), (-0.5, 0.99)):
        th = th_frac * tilt_max
        dth = min(frac * np.sqrt(2 * a * (tilt_max - th)), rate_max)
        # the quadratic's positive root: v_n = -a Ts / 2 + sqrt((a Ts / 2)^2 + 2 a room)
        room = tilt_max - th - 0.5 * Ts * dth
        v_n = -0.5 * a * Ts + np.sqrt((0.5 * a * Ts) ** 2 + 2 * a * room)
        assert abs(th + Ts * (dth + v_n) / 2 + v_n ** 2 / (2 * a) - tilt_max) < 1e-15
        want = min(v_n, rate_max)
        n_braking += v_n < rate_max
        for axis, sign in ((0, 1.0), (0, -1.0), (1, 1.0), (1, -1.0)):
            z = np.zeros(Z.size)
            z[Z["theta_r"].start + axis] = sign * th
            z[Z["dtheta_r"].start + axis] = sign * dth
            # a velocity error that pushes the tilt outward: theta_rx (about x) leans the
            # robot towards -y, theta_ry (about y) towards +x
            v_ref = np.zeros(3)
            v_ref[1 - axis] = (-2.0 if axis == 0 else 2.0) * sign
            z_next = vel(make_state(), v_ref, z, p, k, Ts)[3].full().ravel()
            assert z_next[Z["dtheta_r"]][axis] == pytest.approx(sign * want, rel=0, abs=1e-12), \
                (th_frac, frac, axis, sign)
    assert n_braking == 3  # the braking bound, not the rate limit, in three of the four

"""Defaults and limits of the reference signals against hand values: a scenario signal
given with its required keys only takes every optional key's documented default (start
times 0, no rise, no phase, no offset), the sampled signals' own defaults, and the
velocity profile's ramp limits exactly at and just past each bound with the message read
back (issue 23: a changed default, ``<`` for ``<=``, ``max`` for ``min`` survived)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.sim import references as R
from ballbot_casadi.sim.scenario.signals import make_signal, signal_from_file

D = math.radians


def _both(table, t):
    """The signal sampled from the file table and from the same Scenario signal."""
    t = np.asarray(t, float)
    a = make_signal(signal_from_file("pitch", table, 0.005), t)
    b = make_signal({k.replace("_s", "").replace("rate_deg", "rate"): v for k, v in table.items()}
                    if table["type"] != "chirp" else
                    {"type": "chirp", "amplitude_deg": table["amplitude_deg"], "f0_hz": table["f0_hz"],
                     "f1_hz": table["f1_hz"], "duration": table["sweep_s"]}, t)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)
    return a


def test_required_keys_only_take_the_documented_defaults():
    c = _both({"type": "const"}, [0.0, 2.0])
    np.testing.assert_array_equal(c.value, [0.0, 0.0])
    # step of 2 deg at t_step 0 (on at t >= 0), no rise, no offset
    s = _both({"type": "step", "amplitude_deg": 2.0}, [-0.01, 0.0, 0.5])
    np.testing.assert_allclose(s.value, [0.0, D(2.0), D(2.0)], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(s.d1, [0.0, 0.0, 0.0])
    # ramp of 2 deg at 4 deg/s from t_start 0: 1 deg at 0.25 s, held from 0.5 s
    r = _both({"type": "ramp", "amplitude_deg": 2.0, "rate_deg_s": 4.0}, [-0.1, 0.25, 1.0])
    np.testing.assert_allclose(r.value, [0.0, D(1.0), D(2.0)], rtol=0, atol=1e-15)
    np.testing.assert_allclose(r.d1, [0.0, D(4.0), 0.0], rtol=0, atol=1e-15)
    # sine without phase or offset
    w = _both({"type": "sine", "amplitude_deg": 2.0, "frequency_hz": 1.5}, [0.1])
    np.testing.assert_allclose(w.value, [D(2.0) * math.sin(2 * math.pi * 0.15)], rtol=1e-13)
    np.testing.assert_allclose(w.d1, [D(2.0) * 3 * math.pi * math.cos(2 * math.pi * 0.15)], rtol=1e-13)
    # chirp 1 -> 3 Hz over 2 s (1 Hz/s) without offset: phi = 2 pi (t + t^2 / 2)
    ch = _both({"type": "chirp", "amplitude_deg": 1.5, "f0_hz": 1.0, "f1_hz": 3.0, "sweep_s": 2.0},
               [-0.5, 0.25])
    np.testing.assert_allclose(ch.value, [0.0, D(1.5) * math.sin(2 * math.pi * 0.28125)], rtol=1e-13,
                               atol=1e-16)


def test_the_sampled_signals_own_defaults():
    s = R.step(np.array([-0.5, 0.0, 0.5]))  # unit step at 0, ideal
    np.testing.assert_array_equal(s.value, [0.0, 1.0, 1.0])
    r = R.ramp(np.array([-1.0, 0.5, 2.0]))  # unit ramp at 1 per second from 0
    np.testing.assert_allclose(r.value, [0.0, 0.5, 1.0], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(r.d1, [0.0, 1.0, 0.0])
    w = R.sine(np.array([0.25]), 2.0, 1.0)  # no phase, no offset: 2 sin(pi / 2)
    np.testing.assert_allclose(w.value, [2.0], rtol=1e-15)
    c = R.chirp(np.array([0.25]), 1.0, 1.0, 1.0, 1.0)  # constant 1 Hz, no offset
    np.testing.assert_allclose(c.value, [1.0], rtol=1e-15)
    v = R.velocity_profile(np.array([0.5]), [(0.0, 0.3, 0.4, 0.0)])  # default a_max 1 m/s^2
    np.testing.assert_allclose(v.value, [[0.3, 0.4, 0.0]], rtol=1e-15)


_LIMITS = ("ramp limits must satisfy 0 < a_max <= 1.0 m/s^2 and 0 < yaw_acc_max <= 10.0 rad/s^2 "
           "(thesis §7.1)")


@pytest.mark.parametrize("a_max, yaw_acc_max, ok", [
    (1.0, 10.0, True), (1.0 + 1e-9, 10.0, False), (0.0, 10.0, False), (1e-3, 10.0, True),
    (1.0, 10.0 + 1e-9, False), (1.0, 0.0, False), (1.0, 0.5, True), (1.0, 1e-3, True),
])
def test_ramp_limits_at_and_past_their_bounds(a_max, yaw_acc_max, ok):
    t = np.array([0.0])
    if ok:
        R.velocity_profile(t, [(0.0, 0.0, 0.0, 0.0)], a_max=a_max, yaw_acc_max=yaw_acc_max)
        return
    with pytest.raises(ScenarioError) as e:
        R.velocity_profile(t, [(0.0, 0.0, 0.0, 0.0)], a_max=a_max, yaw_acc_max=yaw_acc_max)
    assert str(e.value) == _LIMITS


def test_the_slower_of_the_two_ramps_sets_the_duration():
    # 0.5 m/s at 1 m/s^2 takes 0.5 s, 1 rad/s at 0.5 rad/s^2 takes 2 s: both ramp over 2 s
    v = R.velocity_profile(np.array([1.0, 2.0]), [(0.0, 0.3, 0.4, 1.0)], a_max=1.0, yaw_acc_max=0.5)
    np.testing.assert_allclose(v.value, [[0.15, 0.2, 0.5], [0.3, 0.4, 1.0]], rtol=1e-14)
    np.testing.assert_allclose(v.d1, [[0.15, 0.2, 0.5], [0.0, 0.0, 0.0]], rtol=1e-14)


def test_keyframe_bounds_at_and_past_their_limits():
    t = np.array([0.0, 1.0])
    # target speed exactly 0.5 m/s and 1 rad/s, acceleration exactly a_max: read
    R.velocity_profile(t, [(0.0, 0.3, 0.4, 1.0, 0.5)], a_max=0.5)
    with pytest.raises(ScenarioError) as e:
        R.velocity_profile(t, [(0.0, 0.3, 0.4, 0.0, 0.5 + 1e-9)], a_max=0.5)
    assert str(e.value).startswith("keyframe 0: ramp acceleration 0.500000001 m/s^2 must be in (0, 0.5]")
    for row, said in (((0.0, 0.3, 0.41, 0.0), "0.508 m/s / yaw rate 0 rad/s"),
                      ((0.0, 0.0, 0.0, -1.01), "0 m/s / yaw rate -1.01 rad/s")):
        with pytest.raises(ScenarioError) as e:
            R.velocity_profile(t, [row])
        assert str(e.value) == f"keyframe 0: target speed {said} exceeds the limits 0.5 m/s, 1.0 rad/s"
    # the limits carry a 1e-12 tolerance: exactly at it is read, one step of 1e-12 past it refused
    R.velocity_profile(t, [(0.0, 0.5 + 1e-12, 0.0, 1.0 + 1e-12)])
    for row in ((0.0, 0.5 + 2e-12, 0.0, 0.0), (0.0, 0.0, 0.0, -(1.0 + 2e-12))):
        with pytest.raises(ScenarioError, match="exceeds the limits"):
            R.velocity_profile(t, [row])
    # the second ramp may start exactly when the first one ends (0.5 s at 1 m/s^2), not before
    R.velocity_profile(t, [(0.0, 0.5, 0.0, 0.0), (0.5, 0.0, 0.0, 0.0)])
    with pytest.raises(ScenarioError) as e:
        R.velocity_profile(t, [(0.0, 0.5, 0.0, 0.0), (0.49, 0.0, 0.0, 0.0)])
    assert str(e.value) == ("keyframe 1 at t=0.49 s starts before the previous ramp ends "
                            "(t=0.500 s) or times are not increasing")

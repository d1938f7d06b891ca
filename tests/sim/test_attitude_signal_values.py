"""The attitude-reference schema of scenario files (sim.scenario.signals) against hand
values: each signal type's file keys land on the right argument (degrees converted,
phase kept in rad), the quaternion of each axis and of a roll-pitch pair, the Nyquist and
lower bounds exactly at and just past their limits, and the key each refusal names
(issue 23: a swapped key, a dropped conversion or a ``<`` for ``<=`` must show)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.sim.scenario.signals import (
    attitude_reference,
    check_attitude,
    make_signal,
    signal_from_file,
    signal_to_file,
)

TS = 0.005
D = math.radians


def _sig(table, t):
    s = make_signal(signal_from_file("roll", table, TS), np.asarray(t, float))
    return s.value, s.d1, s.d2


def test_const_and_ideal_step_from_file_keys():
    v, d1, _ = _sig({"type": "const", "value_deg": 3.0}, [0.0, 1.0])
    np.testing.assert_allclose(v, [D(3.0)] * 2, rtol=0, atol=1e-15)
    np.testing.assert_allclose(d1, 0.0, atol=0)
    v, _, _ = _sig({"type": "step", "amplitude_deg": 2.0, "t_step_s": 0.1, "offset_deg": 1.0},
                   [0.05, 0.1, 0.2])
    np.testing.assert_allclose(v, [D(1.0), D(3.0), D(3.0)], rtol=0, atol=1e-15)


def test_quintic_step_at_a_quarter_of_its_rise():
    # s = 0.25: y = 10/64 - 15/256 + 6/1024, dy = A (30/16 - 60/64 + 30/256) / T, ddy = A (15 - 11.25 + 1.875) / T^2
    v, d1, d2 = _sig({"type": "step", "amplitude_deg": 4.0, "t_step_s": 0.1, "rise_time_s": 0.2,
                      "offset_deg": -1.0}, [0.15])
    A = D(4.0)
    np.testing.assert_allclose(v, [D(-1.0) + A * 0.103515625], rtol=1e-12)
    np.testing.assert_allclose(d1, [A * 1.0546875 / 0.2], rtol=1e-12)
    np.testing.assert_allclose(d2, [A * 5.625 / 0.04], rtol=1e-12)


def test_sine_phase_stays_in_radians_and_offset_in_degrees():
    t = 0.1
    v, d1, d2 = _sig({"type": "sine", "amplitude_deg": 2.0, "frequency_hz": 1.5, "phase_rad": 0.3,
                      "offset_deg": 4.0}, [t])
    w, arg = 2 * math.pi * 1.5, 2 * math.pi * 1.5 * t + 0.3
    np.testing.assert_allclose(v, [D(4.0) + D(2.0) * math.sin(arg)], rtol=1e-12)
    np.testing.assert_allclose(d1, [D(2.0) * w * math.cos(arg)], rtol=1e-12)
    np.testing.assert_allclose(d2, [-D(2.0) * w * w * math.sin(arg)], rtol=1e-12)


def test_negative_ramp_from_its_start_to_its_hold():
    # -2 deg at 4 deg/s from t = 0.1 s: inside until 0.6 s, then held at offset - 2 deg
    v, d1, _ = _sig({"type": "ramp", "amplitude_deg": -2.0, "t_start_s": 0.1, "rate_deg_s": 4.0,
                     "offset_deg": 1.0}, [0.05, 0.35, 1.0])
    np.testing.assert_allclose(v, [D(1.0), D(0.0), D(-1.0)], rtol=0, atol=1e-15)
    np.testing.assert_allclose(d1, [0.0, D(-4.0), 0.0], rtol=0, atol=1e-15)


def test_chirp_reads_sweep_s_as_its_duration():
    # f 1 -> 3 Hz over 2 s: phi(t) = 2 pi (t + t^2 / 2); after the sweep the frequency stays 3 Hz
    v, d1, _ = _sig({"type": "chirp", "amplitude_deg": 1.5, "f0_hz": 1.0, "f1_hz": 3.0, "sweep_s": 2.0,
                     "offset_deg": 0.5}, [0.25, 2.5])
    phi = 2 * math.pi * np.array([0.25 + 0.5 * 0.25**2, 2.0 + 2.0 + 3.0 * 0.5])
    dphi = 2 * math.pi * np.array([1.0 + 0.25, 3.0])
    np.testing.assert_allclose(v, D(0.5) + D(1.5) * np.sin(phi), rtol=1e-12)
    np.testing.assert_allclose(d1, D(1.5) * dphi * np.cos(phi), rtol=1e-12)


def test_file_keys_map_to_scenario_names_and_back():
    tables = [{"type": "step", "amplitude_deg": 1.0, "t_step_s": 0.2, "rise_time_s": 0.1, "offset_deg": 3.0},
              {"type": "ramp", "amplitude_deg": 1.0, "t_start_s": 0.2, "rate_deg_s": 2.0, "offset_deg": 3.0},
              {"type": "chirp", "amplitude_deg": 1.0, "f0_hz": 0.1, "f1_hz": 2.0, "sweep_s": 9.0},
              {"type": "sine", "amplitude_deg": 1.0, "frequency_hz": 0.5, "phase_rad": 0.25}]
    names = [{"t_step": 0.2, "rise_time": 0.1}, {"t_start": 0.2, "rate": 2.0},
             {"f0_hz": 0.1, "f1_hz": 2.0, "duration": 9.0}, {"frequency_hz": 0.5, "phase_rad": 0.25}]
    for table, want in zip(tables, names):
        sig = signal_from_file("pitch", table, TS)
        for k, v in want.items():
            assert sig[k] == v, (table["type"], k)
        assert signal_to_file(sig) == table
        check_attitude({"pitch": sig}, TS)


@pytest.mark.parametrize("axis, index", [("roll", 1), ("pitch", 2), ("yaw", 3)])
def test_one_axis_rotates_about_its_own_axis(axis, index):
    q, dq, _ = attitude_reference({axis: {"type": "const", "value_deg": 10.0}}, np.zeros(2))
    want = np.zeros(4)
    want[0], want[index] = math.cos(D(5.0)), math.sin(D(5.0))
    np.testing.assert_allclose(q, [want, want], rtol=0, atol=1e-15)
    np.testing.assert_allclose(dq, 0.0, atol=0)


def test_roll_and_pitch_compose_zyx():
    r, p = D(10.0), D(-20.0)
    q, _, _ = attitude_reference({"roll": {"type": "const", "value_deg": 10.0},
                                  "pitch": {"type": "const", "value_deg": -20.0}}, np.zeros(1))
    cr, sr, cp, sp = math.cos(r / 2), math.sin(r / 2), math.cos(p / 2), math.sin(p / 2)
    np.testing.assert_allclose(q[0], [cp * cr, cp * sr, sp * cr, -sp * sr], rtol=0, atol=1e-15)
    np.testing.assert_allclose(q[0], np.asarray(Q.from_rpy(r, p, 0.0), float).ravel(), rtol=0, atol=1e-15)


def _key_of(table, axis="roll"):
    with pytest.raises(ScenarioError) as info:
        signal_from_file(axis, table, TS)
    return info.value.key, str(info.value)


def test_bounds_at_and_past_their_limits():
    # Nyquist at Ts = 5 ms: 100 Hz refused, just below accepted; frequencies may be 0
    ok = {"type": "sine", "amplitude_deg": 1.0, "frequency_hz": 99.99}
    signal_from_file("roll", ok, TS)
    signal_from_file("roll", {**ok, "frequency_hz": 0.0}, TS)
    key, text = _key_of({**ok, "frequency_hz": 100.0})
    assert key == "attitude.roll.frequency_hz" and "Nyquist frequency 100 Hz" in text
    assert _key_of({**ok, "frequency_hz": -1e-9})[0] == "attitude.roll.frequency_hz"
    chirp = {"type": "chirp", "amplitude_deg": 1.0, "f0_hz": 0.0, "f1_hz": 99.0, "sweep_s": 1.0}
    signal_from_file("roll", chirp, TS)
    assert _key_of({**chirp, "f1_hz": 100.0})[0] == "attitude.roll.f1_hz"
    assert _key_of({**chirp, "f0_hz": 100.0})[0] == "attitude.roll.f0_hz"
    key, text = _key_of({**chirp, "sweep_s": 0.0})
    assert key == "attitude.roll.sweep_s" and "must be > 0" in text
    ramp = {"type": "ramp", "amplitude_deg": 1.0, "rate_deg_s": 1e-9, "t_start_s": 0.0}
    signal_from_file("roll", ramp, TS)
    assert _key_of({**ramp, "rate_deg_s": 0.0})[0] == "attitude.roll.rate_deg_s"
    assert _key_of({**ramp, "t_start_s": -1e-9})[0] == "attitude.roll.t_start_s"
    step = {"type": "step", "amplitude_deg": 1.0, "t_step_s": 0.0, "rise_time_s": 0.0}
    signal_from_file("roll", step, TS)
    key, text = _key_of({**step, "rise_time_s": -1e-9})
    assert key == "attitude.roll.rise_time_s" and "must be >= 0" in text


def test_each_refusal_names_its_key():
    assert _key_of({"type": "sine", "frequency_hz": 1.0}, "yaw")[0] == "attitude.yaw.amplitude_deg"
    key, text = _key_of({"type": "const", "value": 1.0}, "pitch")
    assert key == "attitude.pitch.value" and "allowed here: type, value_deg" in text
    assert _key_of({"type": "square", "amplitude_deg": 1.0})[0] == "attitude.roll.type"
    assert _key_of([1, 2])[0] == "attitude.roll"
    assert _key_of({"type": "const", "value_deg": True})[0] == "attitude.roll.value_deg"
    assert _key_of({"type": "const", "value_deg": math.inf})[0] == "attitude.roll.value_deg"
    with pytest.raises(ScenarioError) as info:
        check_attitude({"heave": {"type": "const"}}, TS)
    assert info.value.key == "attitude.heave"
    with pytest.raises(ScenarioError) as info:
        check_attitude([("roll", {})], TS)
    assert info.value.key == "attitude"
    with pytest.raises(ScenarioError) as info:  # Scenario names (not file names) in code
        check_attitude({"roll": {"type": "step", "amplitude_deg": 1.0, "t_step_s": 0.1}}, TS)
    assert info.value.key == "attitude.roll.t_step_s"

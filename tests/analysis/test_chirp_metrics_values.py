"""Chirp-test metrics (thesis §9.1) of synthetic runs built so every number is known by hand.

The roll reference is a 5 deg chirp 0.1 -> 2.1 Hz over 20 s (``f(t) = 0.1 + 0.1 t``); the
"robot" tracks it with a chosen gain, its pitch error grows 0.02 deg/s (crossing the
0.1 deg cross-axis threshold between the samples at 5 s and 5.01 s), motors 2 and 0 saturate at 3 s and 7 s
(motor 1 never), and in the second run it falls (roll 40 deg) at 12 s.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from ballbot_casadi.analysis.bandwidth import CROSS_AXIS_DEG, FALL_TILT_DEG, chirp_metrics
from ballbot_casadi.core import quaternion as Q

TS, T_END, F0, F1 = 0.01, 20.0, 0.1, 2.1
TAU_MAX = 4.0


def _quats(roll_deg, pitch_deg):
    return np.array([np.asarray(Q.from_rpy(np.radians(r), np.radians(p), 0.0), float).reshape(4)
                     for r, p in zip(roll_deg, pitch_deg)])


def _log(gain, fall_at=None, axis="roll", other_ref=0.0):
    t = np.round(np.arange(0.0, T_END + TS / 2, TS), 10)
    phi = 2 * np.pi * (F0 * t + 0.5 * (F1 - F0) / T_END * t**2)
    ref = 5.0 * np.sin(phi)
    track = gain * ref
    other = 0.02 * (t - 0.005)  # the other axis's error, deg: 0.0999 at 5 s, 0.1001 at 5.01 s
    if fall_at is not None:
        track = np.where(t >= fall_at, 40.0, track)
        other = np.where(t >= fall_at, 50.0, other)
    zero = np.zeros_like(t) + other_ref  # the other axis's reference
    other = other + other_ref
    if axis == "roll":
        q_ref, q = _quats(ref, zero), _quats(track, other)
    else:
        q_ref, q = _quats(zero, ref), _quats(other, track)
    x = np.zeros((t.size, 12))
    x[:, 2:6] = q
    tau = np.zeros((t.size, 3))
    tau[:, 0] = np.where(t >= 7.0, TAU_MAX, 0.5)
    tau[:, 1] = 0.9 * TAU_MAX
    tau[:, 2] = np.where(t >= 3.0, -TAU_MAX, -1.0)
    spec = {"type": "chirp", "f0_hz": F0, "f1_hz": F1, "duration": T_END}
    return SimpleNamespace(
        scenario={"name": "chirp_by_hand", "attitude": {axis: spec}},
        arrays={"time": t, "q_ref": q_ref, "state": x, "tau_cmd": tau},
        params=SimpleNamespace(tau_max=TAU_MAX),
    )


def test_thresholds_are_the_documented_ones():
    assert CROSS_AXIS_DEG == 0.1 and FALL_TILT_DEG == 30.0


def test_halved_roll_gives_the_gain_criterion_saturation_and_cross_axis_by_hand():
    m = chirp_metrics(_log(0.5))
    assert m["chirp_axis"] == "roll"
    assert m["fell_at_s"] is None and m["fell_at_hz"] is None
    resp = m["response"]
    np.testing.assert_allclose(resp["gain_db"], 20 * np.log10(0.5), atol=1e-6)
    np.testing.assert_allclose(resp["phase_deg"], 0.0, atol=1e-6)
    # lost from the first window on: the bandwidth is its frequency
    assert m["bandwidth_reason"] == "gain"
    assert m["bandwidth_hz"] == pytest.approx(resp["f_hz"][0], rel=1e-12)
    # first command at the limit: motor 2 at 3 s (0.4 Hz), motor 0 at 7 s, motor 1 never
    assert m["saturation_s_per_motor"] == pytest.approx([7.0, None, 3.0])
    assert m["saturation_hz_per_motor"][0] == pytest.approx(0.8, rel=1e-9)
    assert m["saturation_hz_per_motor"][2] == pytest.approx(0.4, rel=1e-9)
    assert m["first_saturation_s"] == pytest.approx(3.0)
    assert m["first_saturation_motor"] == 2
    assert m["first_saturation_hz"] == pytest.approx(0.4, rel=1e-9)
    # pitch error 0.02 (t - 0.005) deg exceeds 0.1 deg first at t = 5.01 s
    assert m["cross_axis_onset_s"] == pytest.approx(5.01, abs=1e-9)
    assert m["cross_axis_onset_hz"] == pytest.approx(0.601, rel=1e-9)
    assert m["cross_axis_error_max_deg"] == pytest.approx(0.02 * (T_END - 0.005), rel=1e-6)


def test_perfect_tracking_until_a_fall_reports_the_fall_frequency():
    m = chirp_metrics(_log(1.0, fall_at=12.0))
    assert m["fell_at_s"] == pytest.approx(12.0)
    assert m["fell_at_hz"] == pytest.approx(0.1 + 0.1 * 12.0, rel=1e-9)
    # tracking held up to the fall (0 dB, 0 deg): the fall is the bandwidth
    assert m["bandwidth_reason"] == "fall"
    assert m["bandwidth_hz"] == pytest.approx(1.3, rel=1e-9)
    assert max(m["response"]["f_hz"]) < 1.3
    # the cross-axis error is measured before the fall only (50 deg after it)
    assert m["cross_axis_error_max_deg"] == pytest.approx(0.02 * (11.99 - 0.005), rel=1e-6)


def test_pitch_chirp_reads_pitch_and_watches_roll():
    m = chirp_metrics(_log(0.5, axis="pitch"))
    assert m["chirp_axis"] == "pitch"
    np.testing.assert_allclose(m["response"]["gain_db"], 20 * np.log10(0.5), atol=1e-6)
    assert m["cross_axis_onset_s"] == pytest.approx(5.01, abs=1e-9)


def test_cross_axis_error_is_measured_from_a_nonzero_reference():
    """The other axis held at 2 deg by its reference: its error is still 0.02 (t - 0.005)."""
    m = chirp_metrics(_log(0.5, other_ref=2.0))
    assert m["cross_axis_onset_s"] == pytest.approx(5.01, abs=1e-9)
    assert m["cross_axis_error_max_deg"] == pytest.approx(0.02 * (T_END - 0.005), rel=1e-5)

"""The envelope study's definitions against the thesis by hand: the push directions are unit
vectors along roll, pitch and the 45 deg diagonal, and the limits are §7.1's (5 deg, 20 deg/s,
0.5 m/s, 1 rad/s)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.studies.envelope import LIMITS, PUSH_DIRECTIONS


def test_push_directions_are_unit_vectors_along_roll_pitch_and_the_diagonal():
    assert set(PUSH_DIRECTIONS) == {"roll", "pitch", "diagonal"}
    assert PUSH_DIRECTIONS["roll"] == (1.0, 0.0) and PUSH_DIRECTIONS["pitch"] == (0.0, 1.0)
    np.testing.assert_allclose(PUSH_DIRECTIONS["diagonal"], [0.5 ** 0.5] * 2, rtol=1e-15)
    for d, v in PUSH_DIRECTIONS.items():
        assert math.hypot(*v) == pytest.approx(1.0, rel=1e-15), d


def test_limits_are_the_thesis_section_7_1_values():
    want = {"tilt_deg": 5.0, "tilt_rate_deg_s": 20.0, "speed_mps": 0.5, "yaw_rate_rad_s": 1.0}
    assert set(LIMITS) == set(want)
    for k, v in want.items():
        assert LIMITS[k] == pytest.approx(v, rel=1e-12), k

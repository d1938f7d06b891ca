"""The stateful balance controllers' default gains against the values their docstrings
document (hand-written here, not recomputed by the package's formulas)."""

from __future__ import annotations

import math

import numpy as np

from ballbot_casadi.control.disturbance_observer import DOB_DEFAULT_GAINS, DOB_GAIN_NAMES
from ballbot_casadi.control.flc import FLC_DEFAULT_GAINS
from ballbot_casadi.control.super_twisting import STA_DEFAULT_GAINS, STA_GAIN_NAMES


def test_super_twisting_defaults():
    # slopes 10, 10 (tilt) and 6 (yaw, V2019); Levant's k1 = 1.5 sqrt(L), k2 = 1.1 L for
    # L = 1.5, 1.5, 0.75; h = 5 ms
    want = [10.0, 10.0, 6.0, 1.5 * math.sqrt(1.5), 1.5 * math.sqrt(1.5), 1.5 * math.sqrt(0.75),
            1.65, 1.65, 0.825, 0.005]
    assert len(STA_GAIN_NAMES) == len(want)
    np.testing.assert_allclose(STA_DEFAULT_GAINS, want, rtol=1e-12, atol=0)


def test_disturbance_observer_defaults():
    # the FLC's gains, observer bandwidths 10 x the FLC pole: 100, 100, 50 rad/s; h = 5 ms
    assert len(DOB_GAIN_NAMES) == len(DOB_DEFAULT_GAINS) == 10
    np.testing.assert_array_equal(DOB_DEFAULT_GAINS[:6], FLC_DEFAULT_GAINS)
    np.testing.assert_allclose(DOB_DEFAULT_GAINS[6:], [100.0, 100.0, 50.0, 0.005], rtol=1e-12)

"""The heading filters' tuning against hand-written numbers (the synthetic heading data
they run on: ``tests/analysis/test_heading_data_values.py``)."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.estimation.heading import HEADING_P0_BIAS, heading_tuning
from ballbot_casadi.estimation.predecessor import qekf_heading_tuning


def test_heading_aided_qukf_tuning_is_the_qukf_tuning_extended_by_hand_values():
    tun = heading_tuning(heading_var=4e-4, bias_rw=3e-3, dt=0.01)
    # bias random walk per period: (3e-3 rad/s/sqrt(s))^2 * 0.01 s = 9e-8 (rad/s)^2
    assert tun["Q"].shape == (7, 7) and tun["Q"][6, 6] == pytest.approx(9e-8, rel=1e-12)
    np.testing.assert_allclose(np.diag(tun["Q"])[:6], [1e-20] * 3 + [1e-5] * 3, rtol=1e-12)
    assert tun["R"][6, 6] == 4e-4 and np.count_nonzero(tun["R"][6, :6]) == 0
    # 0.1 deg/s residual zero-rate offset, 1 sigma
    assert HEADING_P0_BIAS == pytest.approx((0.1 * np.pi / 180) ** 2, rel=1e-12)
    assert tun["P0"][6, 6] == HEADING_P0_BIAS
    np.testing.assert_allclose(np.diag(tun["P0"])[:6], [1e-7, 1e-7, 1e-9, 1e-7, 1e-7, 1e-9])
    np.testing.assert_array_equal(tun["x0"], [1, 0, 0, 0, 0, 0, 0, 0])


def test_predecessor_qekf_tuning_is_hand_values():
    tun = qekf_heading_tuning(heading_var=4e-4, bias_rw=3e-3, dt=0.01)
    Qd = np.diag(tun["Q"])
    np.testing.assert_allclose(Qd, [0] * 4 + [1e-5] * 3 + [9e-8] * 3, rtol=1e-12, atol=0)
    assert np.count_nonzero(tun["Q"] - np.diag(Qd)) == 0
    assert tun["R"][6, 6] == 4e-4
    np.testing.assert_allclose(np.diag(tun["P0"])[7:], [HEADING_P0_BIAS] * 3, rtol=1e-12)
    np.testing.assert_array_equal(tun["x0"], [1, 0, 0, 0, 0, 0, 0, 0, 0, 0])

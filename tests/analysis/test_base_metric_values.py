"""base_metrics against hand-computed values: speeds with different vx and vy, torque
saturation share, quaternion norm error, final attitude."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.analysis.metrics import base_metrics


def test_base_metrics_by_hand():
    n = 5
    state = np.zeros((n + 1, 12))
    state[:, 2] = 1.0
    state[:, 6] = [0.1, 0.3, -0.6, 0.0, 0.2, 0.05]
    state[:, 7] = [0.0, 0.4, 0.8, -0.1, 0.0, -0.12]
    a = math.radians(4.0) / 2
    state[-1, 2:6] = [1.0000001 * math.cos(a), 0.0, 1.0000001 * math.sin(a), 0.0]   # pitch 4 deg, |q| - 1 = 1e-7
    tau_cmd = np.array([[0.1, 0.2, 0.3], [2.5, -1.0, 0.0], [0.0, 0.0, 0.0], [-3.0, 1.0, 1.0], [0.4, 0.4, 0.4]])
    tau = np.array([[0.1, 0.2, 0.3], [2.0, -0.8, 0.0], [0.0, 0.0, 0.0], [-2.0, 0.67, 0.67], [0.4, 0.4, 0.4]])
    log = {"time": np.arange(n + 1) * 0.01, "state": state, "tau_cmd": tau_cmd, "tau": tau}
    m = base_metrics(log)
    assert m["finite"] is True
    assert m["duration_s"] == pytest.approx(0.05, abs=1e-15)
    assert m["max_speed_mps"] == pytest.approx(1.0, rel=1e-12)             # |(-0.6, 0.8)|
    assert m["final_speed_mps"] == pytest.approx(0.13, rel=1e-12)          # |(0.05, -0.12)|
    assert m["max_abs_torque_nm"] == pytest.approx(2.0, rel=1e-15)         # applied, not commanded
    assert m["saturation_fraction"] == pytest.approx(0.4, abs=1e-15)
    assert m["quat_norm_error_max"] == pytest.approx(1e-7, rel=1e-6)
    assert m["final_tilt_deg"] == pytest.approx(4.0, rel=1e-9)
    assert m["max_tilt_deg"] == pytest.approx(4.0, rel=1e-9)
    assert m["final_rpy_deg"] == pytest.approx([0.0, 4.0, 0.0], abs=1e-5)  # of the non-unit q
    state[2, 9] = np.nan
    assert base_metrics({**log, "state": state})["finite"] is False

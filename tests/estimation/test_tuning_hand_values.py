"""Every estimation constant against the value its docstring or the thesis documents,
written out by hand here (not recomputed by the package's formulas): a wrong digit, a
swapped entry or a lost off-diagonal term in a tuning table changes no filter enough for
a statistical test to see it, so the tables are read back entry by entry."""

from __future__ import annotations

import math
import sys

import numpy as np
import pytest

from ballbot_casadi.estimation import adaptive_walk as AW
from ballbot_casadi.estimation import com_observer as CO
from ballbot_casadi.estimation import heading as HD
from ballbot_casadi.estimation import linalg as LA
from ballbot_casadi.estimation import quaternion_mean as QM
from ballbot_casadi.estimation import tuning as T
from ballbot_casadi.estimation import velocity as V


def test_sensor_covariances_are_the_thesis_tables():
    acc = 1e-3 * np.array([[0.3945, 0.0006, -0.0234],  # thesis (3.4)
                           [0.0006, 0.3922, -0.0036],
                           [-0.0234, -0.0036, 0.9941]])
    gyro = 1e-3 * np.array([[0.4969, 0.0201, 0.0035],  # thesis (3.8)
                            [0.0201, 0.1749, -0.0260],
                            [0.0035, -0.0260, 1.3970]])
    np.testing.assert_allclose(T.SIGMA_ACC, acc, rtol=1e-12, atol=0)
    np.testing.assert_allclose(T.SIGMA_GYRO, gyro, rtol=1e-12, atol=0)
    np.testing.assert_allclose(T.SIGMA_ENC, np.eye(3) / 9.0, rtol=1e-12, atol=0)  # §3.1.3
    assert T.ALPHA_TRUST == 2.0  # (4.40)


def test_attitude_filter_tables_entry_by_entry():
    Q = np.zeros((6, 6))
    Q[[0, 1, 2], [0, 1, 2]] = 1e-20  # (4.38)
    Q[[3, 4, 5], [3, 4, 5]] = 1e-5  # (4.39)
    np.testing.assert_array_equal(T.QUKF_Q, Q)
    R = np.zeros((6, 6))
    R[:3, :3] = 2.0 * T.SIGMA_ACC  # (4.40)
    R[3:, 3:] = T.SIGMA_GYRO
    np.testing.assert_array_equal(T.QUKF_R, R)
    np.testing.assert_array_equal(T.QUKF_P0, np.diag([1e-7, 1e-7, 1e-9, 1e-7, 1e-7, 1e-9]))  # (4.4)
    np.testing.assert_array_equal(T.QUKF_X0, [1.0, 0, 0, 0, 0, 0, 0])  # (4.3)
    assert T.QEKF_P0_RADIAL == 1e-7


def test_velocity_filter_tables_entry_by_entry():
    np.testing.assert_array_equal(T.VUKF_Q, np.diag([0.0, 0.0, 1e-5, 1e-5, 1e-9, 1e-9, 1e-9]))
    R = np.zeros((6, 6))
    R[:3, :3] = np.eye(3) / 9.0  # (5.28): encoders, then the accelerometer
    R[3:, 3:] = T.SIGMA_ACC
    np.testing.assert_array_equal(T.VUKF_R, R)
    np.testing.assert_array_equal(T.VUKF_P0, np.diag([0.1, 0.1, 0.01, 0.01, 1e-9, 1e-9, 1e-9]))
    np.testing.assert_array_equal(T.VUKF_X0, np.zeros(7))  # (5.3)
    assert V.NX == 7 and V.KAPPA == -4.0  # kappa = 3 - N (5.6)
    assert V.MATCHED_ACC_PROCESS_VAR == (0.057, 0.073)
    assert V.INPUT_NAMES == ("xhat", "P", "z", "att", "P_att", "Q", "R", "dt", "p")


def test_gate_and_adaptation_constants():
    assert T.GATE_PROBABILITY == 1.0 - 1e-6
    assert T.GATE_SCALE_ATTITUDE == 10.0 and T.GATE_SCALE_VELOCITY == 1000.0
    assert T.GATE_MAX_REJECTIONS == 20 and isinstance(T.GATE_MAX_REJECTIONS, int)
    assert T.ADAPTIVE_WALK_FORGETTING == 0.0025  # 2 s at 5 ms
    assert T.ADAPTIVE_WALK_FLOOR == 1e-3 and T.ADAPTIVE_WALK_CEILING == 1.0
    assert T.ADAPTIVE_WALK_PRIOR_SAMPLES == 20.0 and T.ADAPTIVE_WALK_SAMPLE_MAX == 10.0
    a = AW.WalkAdaptation()
    assert (a.forgetting, a.floor, a.ceiling, a.prior_samples, a.sample_max) == (
        0.0025, 1e-3, 1.0, 20.0, 10.0)
    g = V.VELOCITY_GATE
    assert g.groups == (("enc", (0, 1, 2)), ("acc", (3, 4, 5)))
    assert g.scale == 1000.0 and g.probability == 1.0 - 1e-6 and g.max_rejections == 20
    assert g.name == "velocity_gate"


def test_filter_internals_constants():
    assert AW.ACC_STATE == slice(2, 4) and AW.WALK_SIZE == 3 and AW.FINITE_MIN == 1e-300
    assert LA.PIVOT_TOL == 1e-13 and LA.JITTER == 1e-9
    assert LA.FINITE_MAX == sys.float_info.max
    assert QM.MEAN_ITERATIONS == 3
    assert HD.HEADING_P0_BIAS == pytest.approx((0.1 * math.pi / 180) ** 2, rel=1e-12)
    assert HD.HEADING_INPUT_NAMES == ("xhat", "P", "z", "Q", "R", "dt", "p", "a")
    assert HD.HEADING_FILTER_STATE.size == 8 and HD.HEADING_MEAS.size == 7
    np.testing.assert_array_equal(CO.COM_OBSERVER_DEFAULT_GAINS, [0.3, 2.0, 0.1, 0.10])
    assert CO.COM_OBSERVER_GAIN_NAMES == ("t_obs", "t_com", "t_diff", "c_max") and CO.NKO == 4

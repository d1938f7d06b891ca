"""Estimator registry, default tuning (thesis values) and initial-state helper."""

from __future__ import annotations

import numpy as np
import pytest

import ballbot_casadi.estimation as E
from ballbot_casadi.errors import (
    ArgumentError,
    BallbotTypeError,
    ShapeError,
    StateError,
)
from ballbot_casadi.estimation import tuning as T


def test_registry_names_and_function_signatures():
    assert set(E.ESTIMATORS) == {"qukf", "qekf", "vukf", "vekf", "qukf_heading", "qekf_heading"}
    assert E.build_estimator("qekf_heading").size_in(1) == (10, 10)
    q = E.build_estimator("qukf")
    assert q.name() == "ballbot_qukf"
    assert q.name_in() == ["xhat", "P", "z", "Q", "R", "dt", "p"]
    assert q.name_out() == ["xhat_next", "P_next", "nu", "nis", "n_valid", "n_repair", "P_att"]
    assert q.size_in(1) == (6, 6) and E.build_estimator("qekf").size_in(1) == (7, 7)


def test_default_tuning_is_the_thesis_values_and_read_only():
    t = E.DEFAULT_TUNING["qukf"]
    np.testing.assert_array_equal(np.diag(t.Q), [1e-20] * 3 + [1e-5] * 3)  # (4.38), (4.39)
    np.testing.assert_array_equal(t.R[:3, :3], 2 * T.SIGMA_ACC)  # (4.40), alpha_trust = 2
    np.testing.assert_array_equal(t.R[3:, 3:], T.SIGMA_GYRO)
    assert T.SIGMA_ACC[2, 2] == pytest.approx(0.9941e-3)  # (3.4)
    assert T.SIGMA_GYRO[1, 2] == pytest.approx(-0.026e-3)  # (3.8)
    np.testing.assert_array_equal(np.diag(t.P0), [1e-7, 1e-7, 1e-9, 1e-7, 1e-7, 1e-9])  # (4.4)
    v = E.DEFAULT_TUNING["vukf"]
    np.testing.assert_array_equal(np.diag(v.P0), [0.1, 0.1, 0.01, 0.01, 1e-9, 1e-9, 1e-9])  # (5.4)
    np.testing.assert_array_equal(v.R[:3, :3], np.eye(3) / 9)  # §3.1.3
    # the heading-aided QUKF: the QUKF's blocks, then the nominal sensor's z gyro bias
    # random walk per period and heading variance (0.2 deg)^2 (default_params.toml)
    h = E.DEFAULT_TUNING["qukf_heading"]
    np.testing.assert_array_equal(h.Q[:6, :6], t.Q)
    np.testing.assert_array_equal(h.R[:6, :6], t.R)
    assert h.Q[6, 6] == pytest.approx(2e-5 ** 2 * 0.005, rel=1e-12)
    assert h.R[6, 6] == pytest.approx(np.radians(0.2) ** 2, rel=1e-4)
    assert h.x0.size == 8 and h.x0[7] == 0.0
    for tun in E.DEFAULT_TUNING.values():
        for a in (tun.Q, tun.R, tun.P0, tun.x0):
            with pytest.raises(ValueError):
                a[0] = 1.0
        assert np.all(np.linalg.eigvalsh(tun.R) > 0) and np.all(np.linalg.eigvalsh(tun.P0) > 0)


def test_initial_state_gives_fresh_copies():
    x, P = E.initial_state("qukf")
    x[0], P[0, 0] = 5.0, 5.0
    x2, P2 = E.initial_state("qukf")
    assert x2[0] == 1.0 and P2[0, 0] == 1e-7


def test_qekf_initial_covariance_follows_the_quaternion():
    q = np.array([np.cos(0.2), np.sin(0.2), 0.0, 0.0])
    _, P = E.initial_state("qekf", np.r_[q, 0, 0, 0])
    assert np.linalg.eigvalsh(P).min() > 0
    assert q @ P[:4, :4] @ q == pytest.approx(T.QEKF_P0_RADIAL, rel=1e-12)


@pytest.mark.parametrize("name,x0,err", [
    ("ukf", None, ArgumentError),
    ("qukf", np.zeros(6), ShapeError),
    ("qukf", np.r_[1.0, 0, 0, 0, np.nan, 0, 0], StateError),
    ("qukf", np.r_[1.1, 0, 0, 0, 0, 0, 0], StateError),
])
def test_initial_state_rejects_bad_input(name, x0, err):
    with pytest.raises(err):
        E.initial_state(name, x0)


def test_build_estimator_errors():
    with pytest.raises(ArgumentError, match="allowed"):
        E.build_estimator("kalman")
    with pytest.raises(BallbotTypeError):
        E.build_estimator("qukf", wheel_speeds=E.build_estimator("qukf"))

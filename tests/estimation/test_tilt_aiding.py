"""Velocity-aided tilt correction: the accelerometer bias a tilt error of the attitude
filter makes the velocity filter see is turned back into that tilt error (first order),
a vertical bias is no tilt, and the corrected quaternion stays unit."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.params import load_params
from ballbot_casadi.estimation import make_tilt_correction
from ballbot_casadi.estimation.tilt_aiding import (
    TILT_CORRECTION_INPUTS,
    TILT_CORRECTION_OUTPUTS,
)


@pytest.fixture(scope="module")
def corr():
    return make_tilt_correction()


@pytest.fixture(scope="module")
def p():
    return load_params()


def _case(rng, tilt_deg=10.0):
    roll, pitch, yaw = np.radians(rng.uniform(-tilt_deg, tilt_deg, 2)).tolist() + [rng.uniform(-np.pi, np.pi)]
    q = Q.from_rpy(roll, pitch, yaw)
    a = rng.uniform(-1.0, 1.0, 2)
    return np.asarray(q, float), a


def test_names_follow_the_conventions(corr):
    assert corr.name() == "ballbot_tilt_correction"
    assert tuple(corr.name_in()) == TILT_CORRECTION_INPUTS
    assert tuple(corr.name_out()) == TILT_CORRECTION_OUTPUTS


def test_the_bias_of_a_tilt_error_gives_that_tilt_error_back(corr, p):
    rng = np.random.default_rng(7)
    g = p.g
    for _ in range(20):
        q_hat, a = _case(rng)
        g_b = Q.rotate_inv(q_hat, np.array([a[0], a[1], g]))
        # a true attitude off by a small body rotation perpendicular to the specific force
        r = rng.normal(size=3) * 1e-3
        r -= g_b * (r @ g_b) / (g_b @ g_b)
        q_true = Q.mul(q_hat, Q.from_rotation_vector(r))
        acc = Q.rotate_inv(q_true, np.array([a[0], a[1], g]))
        b = acc - g_b  # what the velocity filter's model (thesis 5.18) calls the bias
        out = corr(q=q_hat, a=a, b_acc=b, p=p.to_vector())
        r_est, q_c = np.asarray(out["r"]).ravel(), np.asarray(out["q_c"]).ravel()
        np.testing.assert_allclose(r_est, r, rtol=0, atol=5e-6)  # second order in |r| = 1e-3
        angle = np.linalg.norm(Q.to_rotation_vector(Q.mul(Q.conj(q_true), q_c)))
        assert angle < 5e-6 < np.linalg.norm(r) / 100
        assert abs(np.linalg.norm(q_c) - 1.0) < 1e-14


def test_a_bias_along_the_specific_force_is_no_tilt_and_zero_bias_changes_nothing(corr, p):
    rng = np.random.default_rng(8)
    for _ in range(10):
        q_hat, a = _case(rng)
        g_b = Q.rotate_inv(q_hat, np.array([a[0], a[1], p.g]))
        out = corr(q=q_hat, a=a, b_acc=0.05 * g_b / np.linalg.norm(g_b), p=p.to_vector())
        np.testing.assert_allclose(np.asarray(out["r"]).ravel(), 0.0, atol=1e-15)
        np.testing.assert_allclose(np.asarray(out["q_c"]).ravel(), q_hat, rtol=0, atol=1e-15)
        zero = corr(q=q_hat, a=a, b_acc=np.zeros(3), p=p.to_vector())
        np.testing.assert_array_equal(np.asarray(zero["q_c"]).ravel(), q_hat)


def test_upright_the_horizontal_bias_maps_to_roll_and_pitch(corr, p):
    # b = -r x g e_z: a bias +y reads as a roll error +x, a bias +x as a pitch error -y
    out = corr(q=[1, 0, 0, 0], a=[0, 0], b_acc=[0.0, 0.01, 0.0], p=p.to_vector())
    np.testing.assert_allclose(np.asarray(out["r"]).ravel(), [0.01 / p.g, 0, 0], rtol=1e-12)
    out = corr(q=[1, 0, 0, 0], a=[0, 0], b_acc=[0.01, 0.0, 0.0], p=p.to_vector())
    np.testing.assert_allclose(np.asarray(out["r"]).ravel(), [0, -0.01 / p.g, 0], rtol=1e-12)

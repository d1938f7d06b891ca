"""Body-frame quaternion error (thesis 7.4), its derivatives (7.5) and the sign fix (§7.4)."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.control.quaternion_error import (
    make_quaternion_error,
    quaternion_error,
    quaternion_error_accel,
    quaternion_error_rate,
    shortest_path_sign,
)
from ballbot_casadi.core import quaternion as Q


def _traj(t: float) -> tuple[np.ndarray, np.ndarray]:
    """Two smooth unit-quaternion trajectories (attitude, reference)."""
    q = Q.from_rpy(0.3 * np.sin(1.3 * t), -0.2 * np.cos(0.7 * t), 0.5 * t)
    q_ref = Q.from_rpy(0.1 * np.cos(2.1 * t), 0.25 * np.sin(t), -0.3 * t + 1.0)
    return q, q_ref


def _fd(fun, t: float, h: float = 1e-4) -> tuple[np.ndarray, np.ndarray]:
    """Central first and second differences of fun at t."""
    fp, f0, fm = fun(t + h), fun(t), fun(t - h)
    return (fp - fm) / (2 * h), (fp - 2 * f0 + fm) / h**2


def test_identical_attitudes_give_identity_error(rng):
    q = Q.from_rpy(*rng.uniform(-1, 1, 3))
    np.testing.assert_allclose(quaternion_error(q, q), [1, 0, 0, 0], atol=1e-15)


def test_error_is_expressed_in_the_body_frame(rng):
    q_ref = Q.from_rpy(*rng.uniform(-1, 1, 3))
    delta = Q.from_rotation_vector(np.array([0.02, -0.03, 0.05]))
    q = Q.mul(q_ref, delta)  # body-frame perturbation of the reference
    np.testing.assert_allclose(quaternion_error(q, q_ref), delta, rtol=0, atol=1e-15)


def test_shortest_path_sign_flips_long_rotations():
    q_ref = np.array([1.0, 0, 0, 0])
    q = -Q.from_rpy(0.1, 0.0, 0.0)  # same attitude, other cover: angle 360 - 5.7 deg
    qe = quaternion_error(q, q_ref)
    assert qe[0] < 0
    assert shortest_path_sign(qe) == -1.0
    np.testing.assert_allclose(shortest_path_sign(qe) * qe, Q.from_rpy(0.1, 0, 0), atol=1e-15)
    assert shortest_path_sign(np.array([0.0, 1.0, 0.0, 0.0])) == 1.0


def test_rate_and_accel_match_finite_differences():
    def qe(t):
        q, q_ref = _traj(t)
        return quaternion_error(q, q_ref)

    for t in (0.3, 1.7, 4.2):
        h = 1e-4
        q, q_ref = _traj(t)
        dq, ddq = _fd(lambda s: _traj(s)[0], t, h)
        dq_ref, ddq_ref = _fd(lambda s: _traj(s)[1], t, h)
        d1, d2 = _fd(qe, t, h)
        np.testing.assert_allclose(quaternion_error_rate(q, dq, q_ref, dq_ref), d1, atol=1e-7)
        np.testing.assert_allclose(
            quaternion_error_accel(q, dq, ddq, q_ref, dq_ref, ddq_ref), d2, atol=1e-5
        )


def test_casadi_function_matches_numpy(rng):
    f = make_quaternion_error()
    assert f.name() == "ballbot_quaternion_error"
    q = Q.from_rpy(*rng.uniform(-2, 2, 3))
    q_ref = -Q.from_rpy(*rng.uniform(-2, 2, 3))
    dq, dq_ref = rng.normal(size=4), rng.normal(size=4)
    qe, dqe, sigma = (np.asarray(a).ravel() for a in f(q, dq, q_ref, dq_ref))
    s = shortest_path_sign(quaternion_error(q, q_ref))
    assert float(sigma[0]) == s
    assert qe[0] >= 0
    np.testing.assert_allclose(qe, s * quaternion_error(q, q_ref), atol=1e-14)
    np.testing.assert_allclose(dqe, s * quaternion_error_rate(q, dq, q_ref, dq_ref), atol=1e-14)


def test_symbolic_and_numeric_agree():
    q, r = ca.SX.sym("q", 4), ca.SX.sym("r", 4)
    f = ca.Function("f", [q, r], [quaternion_error(q, r)])
    a, b = Q.from_rpy(0.1, 0.2, 0.3), Q.from_rpy(-0.3, 0.1, 2.0)
    np.testing.assert_allclose(np.asarray(f(a, b)).ravel(), quaternion_error(a, b), atol=1e-15)


@pytest.mark.parametrize("bad", [np.zeros(3), np.zeros((2, 4))])
def test_wrong_shapes_are_rejected(bad):
    with pytest.raises(ValueError):
        quaternion_error(bad, np.array([1.0, 0, 0, 0]))

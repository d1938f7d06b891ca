"""Quaternion operators (thesis App. E) on numpy and CasADi inputs."""

import math

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.core import quaternion as Q


def _unit(rng):
    q = rng.normal(size=4)
    return q / np.linalg.norm(q)


def test_product_matrices(rng):
    for _ in range(20):
        q, p = rng.normal(size=4), rng.normal(size=4)
        # (E.9) vector form of the product
        ref = np.concatenate([[q[0] * p[0] - q[1:] @ p[1:]],
                              q[0] * p[1:] + p[0] * q[1:] + np.cross(q[1:], p[1:])])
        np.testing.assert_allclose(Q.Phi(q) @ p, ref, rtol=0, atol=1e-14)  # (E.10, E.11)
        np.testing.assert_allclose(Q.Gamma(p) @ q, ref, rtol=0, atol=1e-14)  # (E.12)
        np.testing.assert_allclose(Q.Phi(Q.conj(q)), Q.Phi(q).T, atol=0)  # (E.13)
        np.testing.assert_allclose(Q.Gamma(Q.conj(q)), Q.Gamma(q).T, atol=0)  # (E.14)


def test_hamilton_units():
    i, j, k = (np.eye(4)[n] for n in (1, 2, 3))
    np.testing.assert_allclose(Q.mul(i, j), k)  # (E.2)
    np.testing.assert_allclose(Q.mul(j, i), -k)
    np.testing.assert_allclose(Q.mul(Q.mul(i, j), k), [-1, 0, 0, 0])  # (E.3)


def test_rotation_is_orthogonal_and_matches_axis_angle(rng):
    for _ in range(10):
        q = _unit(rng)
        R = Q.rotation_matrix(q)
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-14)
        assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-14)
        v = rng.normal(size=3)
        np.testing.assert_allclose(Q.rotate(q, v), R @ v, atol=1e-14)
        np.testing.assert_allclose(Q.rotate_inv(q, Q.rotate(q, v)), v, atol=1e-14)
    # 90 deg about z maps x to y (E.23, E.24)
    qz = np.array([np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)])
    np.testing.assert_allclose(Q.rotate(qz, [1, 0, 0]), [0, 1, 0], atol=1e-15)


def test_exp_log_roundtrip(rng):
    for scale in (1e-9, 1e-3, 0.5, 1.4):
        v = rng.normal(size=3)
        v = scale * v / np.linalg.norm(v)
        q = Q.exp(v)
        assert np.linalg.norm(q) == pytest.approx(1.0, abs=1e-15)
        np.testing.assert_allclose(Q.log(q), v, rtol=1e-12, atol=1e-18)
    r = np.array([0.1, -0.2, 0.3])
    np.testing.assert_allclose(Q.to_rotation_vector(Q.from_rotation_vector(r)), r, atol=1e-15)
    np.testing.assert_allclose(Q.log(-Q.exp(r)), r, atol=1e-15)  # shortest path branch


def test_rpy_roundtrip_and_convention(rng):
    for _ in range(20):
        rpy = rng.uniform([-np.pi, -1.5, -np.pi], [np.pi, 1.5, np.pi])
        q = Q.from_rpy(*rpy)
        np.testing.assert_allclose(Q.to_rpy(q), rpy, atol=1e-12)
        c = np.cos
        s = np.sin
        r, p, y = rpy
        Rz = np.array([[c(y), -s(y), 0], [s(y), c(y), 0], [0, 0, 1]])  # (F.3)
        Ry = np.array([[c(p), 0, s(p)], [0, 1, 0], [-s(p), 0, c(p)]])  # (F.4)
        Rx = np.array([[1, 0, 0], [0, c(r), -s(r)], [0, s(r), c(r)]])  # (F.5)
        np.testing.assert_allclose(Q.rotation_matrix(q), Rz @ Ry @ Rx, atol=1e-14)


@pytest.mark.parametrize("sym", [ca.SX, ca.MX])
def test_casadi_matches_numpy(sym, rng):
    q_s, p_s, v_s = sym.sym("q", 4), sym.sym("p", 4), sym.sym("v", 3)
    exprs = {
        "Phi": (Q.Phi(q_s), lambda q, p, v: Q.Phi(q)),
        "Gamma": (Q.Gamma(q_s), lambda q, p, v: Q.Gamma(q)),
        "mul": (Q.mul(q_s, p_s), lambda q, p, v: Q.mul(q, p)),
        "conj": (Q.conj(q_s), lambda q, p, v: Q.conj(q)),
        "rotate": (Q.rotate(q_s, v_s), lambda q, p, v: Q.rotate(q, v)),
        "rotate_inv": (Q.rotate_inv(q_s, v_s), lambda q, p, v: Q.rotate_inv(q, v)),
        "exp": (Q.exp(v_s), lambda q, p, v: Q.exp(v)),
        "log": (Q.log(q_s), lambda q, p, v: Q.log(q)),
        "rpy": (Q.to_rpy(q_s), lambda q, p, v: Q.to_rpy(q)),
        "from_rpy": (Q.from_rpy(v_s[0], v_s[1], v_s[2]), lambda q, p, v: Q.from_rpy(*v)),
        "hat_vee": (Q.vee(Q.hat(v_s)), lambda q, p, v: v),
    }
    for name, (expr, ref) in exprs.items():
        f = ca.Function(name, [q_s, p_s, v_s], [expr])
        for _ in range(5):
            q, p, v = _unit(rng), rng.normal(size=4), rng.normal(size=3) * 0.7
            np.testing.assert_allclose(np.array(f(q, p, v)).squeeze(), np.squeeze(ref(q, p, v)),
                                       atol=1e-13, err_msg=name)


def test_exp_log_finite_at_zero_in_casadi():
    v = ca.SX.sym("v", 3)
    f = ca.Function("f", [v], [Q.exp(v), ca.jacobian(Q.exp(v), v)])
    val, jac = f([0, 0, 0])
    assert np.all(np.isfinite(np.array(val))) and np.all(np.isfinite(np.array(jac)))
    np.testing.assert_allclose(np.array(jac)[1:, :], np.eye(3), atol=1e-15)


@pytest.mark.parametrize("n", [0.0, 1e-9, 1e-7, 4e-7, 9e-7, 9.99e-7, 1.01e-6, 3e-6])
def test_exp_small_angles_match_sin_cos_to_the_last_bits(n):
    """Below |v| = 1e-6 exp uses the Taylor terms cos = 1 - n^2/2, sin(n)/n = 1 - n^2/6
    (the next terms are below 1e-25); both branches, numpy and CasADi, agree with
    math.cos and math.sin(n)/n to an ulp on either side of the switch."""
    v = np.array([0.6 * n, -0.8 * n, 0.0])
    sinc = math.sin(n) / n if n else 1.0
    want = np.array([math.cos(n), sinc * v[0], sinc * v[1], 0.0])
    s = ca.SX.sym("v", 3)
    f = ca.Function("f", [s], [Q.exp(s)])
    for got in (np.asarray(Q.exp(v), float).ravel(), np.array(f(v)).ravel()):
        assert abs(got[0] - want[0]) <= 2.3e-16
        np.testing.assert_allclose(got[1:3], want[1:3], rtol=3e-16, atol=0)


def test_bad_shapes():
    with pytest.raises(ValueError, match="shape"):
        Q.Phi(np.ones(3))
    with pytest.raises(ValueError, match="elements"):
        Q.Phi(ca.SX.sym("q", 3))


def test_rpy_of_rows_needs_four_columns():
    for shape in ((2, 3), (4, 3), (4, 5)):
        with pytest.raises(ValueError, match=rf"^expected quaternion rows of shape \(N, 4\), "
                                             rf"got \({shape[0]}, {shape[1]}\)$"):
            Q.to_rpy(np.zeros(shape))
    assert Q.to_rpy(np.tile([1.0, 0.0, 0.0, 0.0], (3, 1))).shape == (3, 3)

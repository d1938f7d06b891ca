"""Input-output decoupling (thesis 8.12-8.26) against numpy references written here.

The error dynamics terms ``D``, ``E``, ``G`` and the output ``y``, ``dy`` are rebuilt with
a hand-written Hamilton product; the damped inverse against
``(E^T E + lambda^2 I)^-1 E^T rhs`` with ``lambda^2`` from the documented margin.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.control import decoupling as dc
from ballbot_casadi.core.layout import STATE


def _hmul(a, b):
    a0, a1, a2, a3 = a
    b0, b1, b2, b3 = b
    return np.array([a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
                     a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
                     a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1,
                     a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0])


def _conj(q):
    return np.array([q[0], -q[1], -q[2], -q[3]])


def _unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def _eval_dynamics(x, q_ref, dq_ref, ddq_ref, f, g):
    xs, r, dr, ddr = ca.MX.sym("x", 12), ca.MX.sym("r", 4), ca.MX.sym("dr", 4), ca.MX.sym("ddr", 4)
    fs, gs = ca.MX.sym("f", 6), ca.MX.sym("g", 6, 3)
    out = dc.error_output_dynamics(xs, r, dr, ddr, fs, gs)
    names = ["y", "dy", "D", "E", "G", "qe0", "sigma"]
    F = ca.Function("dyn", [xs, r, dr, ddr, fs, gs], [out[k] for k in names])
    return {k: np.asarray(v, float).squeeze() for k, v in zip(names, F(x, q_ref, dq_ref, ddq_ref, f, g))}


@pytest.mark.parametrize("flip", [False, True])
def test_error_dynamics_match_a_hand_written_quaternion_reference(flip):
    rng = np.random.default_rng(11)
    q = _unit([0.9, 0.2, -0.3, 0.1])
    q_ref = _unit([0.95, -0.1, 0.2, 0.25])
    if flip:  # same attitude, other sign: the error's scalar part is negative, sigma = -1
        q = -q
    dq, dq_ref, ddq_ref = rng.normal(size=4), rng.normal(size=4), rng.normal(size=4)
    x = np.zeros(12)
    x[STATE["q"]], x[STATE["dq"]] = q, dq
    x[[0, 1]] = [0.3, -0.7]
    f, g = rng.normal(size=6), rng.normal(size=(6, 3))
    got = _eval_dynamics(x, q_ref, dq_ref, ddq_ref, f, g)

    qe = _hmul(_conj(q_ref), q)
    sigma = -1.0 if qe[0] < 0 else 1.0
    assert (sigma < 0) == flip and got["sigma"] == sigma
    dqe = _hmul(_conj(dq_ref), q) + _hmul(_conj(q_ref), dq)
    drift = _hmul(_conj(ddq_ref), q) + 2 * _hmul(_conj(dq_ref), dq) + _hmul(_conj(q_ref), f[2:6])
    E = np.column_stack([_hmul(_conj(q_ref), g[2:6, j])[1:] for j in range(3)])
    G = np.column_stack([2 * _hmul(_conj(q), g[2:6, j])[1:] for j in range(3)])
    np.testing.assert_allclose(got["y"], sigma * qe[1:], atol=1e-12)
    np.testing.assert_allclose(got["dy"], sigma * dqe[1:], atol=1e-12)
    np.testing.assert_allclose(got["D"], sigma * drift[1:], atol=1e-12)
    np.testing.assert_allclose(got["E"], sigma * E, atol=1e-12)
    np.testing.assert_allclose(got["G"], G, atol=1e-12)
    assert got["qe0"] == pytest.approx(abs(qe[0]) / np.linalg.norm(qe), abs=1e-12)


def test_solve3_and_rcond_match_numpy():
    M = np.array([[2.0, -1.0, 0.5], [0.3, 1.5, -0.7], [-0.4, 0.2, 3.0]])
    b = np.array([1.0, -2.0, 0.5])
    np.testing.assert_allclose(np.asarray(dc.solve3(ca.DM(M), ca.DM(b)), float).ravel(),
                               np.linalg.solve(M, b), rtol=1e-12)
    adj = np.linalg.det(M) * np.linalg.inv(M)
    want = abs(np.linalg.det(M)) / (np.linalg.norm(M) * np.linalg.norm(adj))
    assert float(dc.rcond_fro(ca.DM(M))) == pytest.approx(want, rel=1e-12)


def _damped(E, rhs, qe0, G, inverse=dc.DampedInverse()):
    Es, rs, q0, Gs = ca.MX.sym("E", 3, 3), ca.MX.sym("r", 3), ca.MX.sym("q"), ca.MX.sym("G", 3, 3)
    F = ca.Function("d", [Es, rs, q0, Gs], list(dc.damped_solve(Es, rs, q0, Gs, inverse)))
    tau, s, m = F(E, rhs, qe0, G)
    return np.asarray(tau, float).ravel(), float(s), float(m)


E0 = np.array([[1.2, 0.1, -0.3], [0.0, 0.9, 0.2], [0.4, -0.2, 1.1]])
RHS = np.array([0.5, -1.0, 2.0])


def _rcond(M):
    adj = np.linalg.det(M) * np.linalg.inv(M)
    return abs(np.linalg.det(M)) / (np.linalg.norm(M) * np.linalg.norm(adj))


def test_damped_inverse_is_exact_with_a_healthy_margin():
    G = np.eye(3)  # rcond 1/3: far above 0.01
    tau, singular, margin = _damped(E0, RHS, 0.9, G)
    np.testing.assert_allclose(tau, np.linalg.solve(E0, RHS), rtol=1e-12)
    assert singular == 0.0
    assert margin == pytest.approx(min(0.9 / dc.QE0_MIN, _rcond(G) / dc.RCOND_MIN), rel=1e-12)


@pytest.mark.parametrize("qe0,G", [
    (0.02, np.eye(3)),                       # error angle beyond 174 deg: margin 0.4
    (0.9, np.diag([1.0, 1.0, 0.004])),       # ill-conditioned G: rcond below 0.01
])
def test_damped_inverse_below_the_margin_is_damped_least_squares(qe0, G):
    tau, singular, margin = _damped(E0, RHS, qe0, G)
    m = min(qe0 / dc.QE0_MIN, _rcond(G) / dc.RCOND_MIN)
    assert m < 1 and margin == pytest.approx(m, rel=1e-12) and singular == 1.0
    lam2 = dc.DAMPING_MU**2 * (np.sum(E0**2) + 1e-12) * (1 - m)
    want = np.linalg.solve(E0.T @ E0 + lam2 * np.eye(3), E0.T @ RHS)
    np.testing.assert_allclose(tau, want, rtol=1e-10)
    assert np.linalg.norm(tau - np.linalg.solve(E0, RHS)) > 1e-3  # the damping changed it


def test_damping_keeps_an_exactly_singular_error_finite():
    E = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0]])
    tau, singular, _ = _damped(E, RHS, 0.0, np.eye(3))
    lam2 = dc.DAMPING_MU**2 * (2.0 + 1e-12)
    np.testing.assert_allclose(tau, [RHS[0] / (1 + lam2), RHS[1] / (1 + lam2), 0.0], rtol=1e-12, atol=1e-15)
    assert singular == 1.0


def test_damping_floor_keeps_a_vanishing_error_matrix_a_descent_step():
    """||E||_F^2 far below the 1e-12 floor, fully damped (q_e0 = 0): lambda^2 keeps its
    floor, so E^T E + lambda^2 I stays positive definite and tau points along E^T rhs."""
    E = 1e-8 * E0
    tau, singular, margin = _damped(E, RHS, 0.0, np.eye(3))
    assert margin == 0.0 and singular == 1.0
    lam2 = dc.DAMPING_MU**2 * (np.sum(E**2) + 1e-12)
    np.testing.assert_allclose(tau, np.linalg.solve(E.T @ E + lam2 * np.eye(3), E.T @ RHS), rtol=1e-9)
    assert tau @ (E.T @ RHS) > 0


def test_custom_thresholds_are_used():
    inv = dc.DampedInverse(qe0_min=0.5, rcond_min=0.01, mu=0.3)
    tau, singular, margin = _damped(E0, RHS, 0.4, np.eye(3), inv)
    assert margin == pytest.approx(0.8, rel=1e-12) and singular == 1.0
    lam2 = 0.09 * (np.sum(E0**2) + 1e-12) * 0.2
    np.testing.assert_allclose(tau, np.linalg.solve(E0.T @ E0 + lam2 * np.eye(3), E0.T @ RHS), rtol=1e-10)


def test_documented_thresholds():
    """174 deg error (q_e0 = cos 87 deg ~ 0.05), rcond 0.01, cond <= 1/mu^2 = 100."""
    assert dc.QE0_MIN == 0.05 and dc.RCOND_MIN == 0.01 and dc.DAMPING_MU == 0.1
    assert dc.DampedInverse() == dc.DampedInverse(0.05, 0.01, 0.1)

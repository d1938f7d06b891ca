"""Generic filter core: UKF/EKF against the Kalman filter, masking, covariance repair."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.errors import BallbotTypeError, ShapeError
from ballbot_casadi.estimation.core import FilterModel, make_filter, sigma_weights
from ballbot_casadi.estimation.linalg import (
    make_cholesky,
    make_masked_update,
    make_spd_repair,
)
from ballbot_casadi.estimation.manifold import attitude, attitude_additive, euclidean

N, M, NU = 4, 3, 2


@pytest.fixture(scope="module")
def linear_system():
    rng = np.random.default_rng(11)
    A = np.eye(N) + 0.1 * rng.standard_normal((N, N))
    B = rng.standard_normal((N, NU))
    C = rng.standard_normal((M, N))
    x, u, dt, p = ca.SX.sym("x", N), ca.SX.sym("u", NU), ca.SX.sym("dt"), ca.SX.sym("p")
    # dt and p enter so that the core passes them through: A_eff = A at dt = 1, p = 0.
    f = ca.Function("f", [x, u, dt, p], [ca.mtimes(A, x) * dt + ca.mtimes(B, u) + p])
    h = ca.Function("h", [x, u, dt, p], [ca.mtimes(C, x)])
    return A, B, C, f, h


def _kalman(A, B, C, x, P, z, u, Qn, R, noise):
    """Textbook Kalman filter period; components of z that are NaN are skipped."""
    xp = A @ x + B @ u
    Pp = A @ P @ A.T + Qn if noise == "additive" else A @ (P + Qn) @ A.T
    ok = np.isfinite(z)
    if not ok.any():
        return xp, Pp
    Cv, Rv = C[ok], R[np.ix_(ok, ok)]
    S = Cv @ Pp @ Cv.T + Rv
    K = Pp @ Cv.T @ np.linalg.inv(S)
    return xp + K @ (z[ok] - Cv @ xp), Pp - K @ S @ K.T


def _spd(rng, n, scale=1.0):
    G = rng.standard_normal((n, n))
    return scale * (G @ G.T + 0.1 * np.eye(n))


CASES = [("ukf", "pre", 0.0), ("ukf", "additive", 0.0), ("ukf", "additive", 3.0 - N),
         ("ukf", "pre", 1.0), ("ekf", "pre", 0.0), ("ekf", "additive", 0.0)]


@pytest.mark.parametrize("kind,noise,kappa", CASES)
def test_linear_gaussian_filter_equals_kalman_filter(linear_system, kind, noise, kappa):
    A, B, C, f, h = linear_system
    F = make_filter("t", FilterModel(euclidean(N), f, h, noise), kind, kappa)
    rng = np.random.default_rng(5)
    Qn, R = _spd(rng, N, 0.05), _spd(rng, M, 0.2)
    x, P = rng.standard_normal(N), _spd(rng, N)
    xk, Pk = x.copy(), P.copy()
    for k in range(40):
        u, z = rng.standard_normal(NU), rng.standard_normal(M)
        if k % 7 == 3:
            z[1] = np.nan  # one sensor drops out now and then
        if k % 11 == 5:
            z[:] = np.nan
        out = F(x, P, z, u, Qn, R, 1.0, 0.0)
        x, P = np.array(out[0]).ravel(), np.array(out[1])
        xk, Pk = _kalman(A, B, C, xk, Pk, z, u, Qn, R, noise)
        assert float(out[4]) == np.isfinite(z).sum()
        assert float(out[5]) == 0
    np.testing.assert_allclose(x, xk, rtol=0, atol=1e-10)
    np.testing.assert_allclose(P, Pk, rtol=0, atol=1e-10)


def test_all_invalid_measurement_is_exactly_a_predict_step(linear_system):
    A, B, _, f, h = linear_system
    F = make_filter("t", FilterModel(euclidean(N), f, h, "additive"), "ukf", 0.0)
    rng = np.random.default_rng(2)
    x, P, Qn, R = rng.standard_normal(N), _spd(rng, N), _spd(rng, N, 0.1), _spd(rng, M)
    u = rng.standard_normal(NU)
    for bad in (np.nan, np.inf, -np.inf):
        out = F(x, P, np.full(M, bad), u, Qn, R, 1.0, 0.0)
        np.testing.assert_allclose(np.array(out[0]).ravel(), A @ x + B @ u, rtol=0, atol=1e-12)
        np.testing.assert_allclose(np.array(out[1]), A @ P @ A.T + Qn, rtol=0, atol=1e-12)
        assert np.all(np.array(out[2]) == 0) and float(out[3]) == 0 and float(out[4]) == 0


def test_nis_matches_the_innovation_covariance(linear_system):
    A, B, C, f, h = linear_system
    F = make_filter("t", FilterModel(euclidean(N), f, h, "additive"), "ekf")
    rng = np.random.default_rng(3)
    x, P, Qn, R, u, z = (rng.standard_normal(N), _spd(rng, N), _spd(rng, N, 0.1), _spd(rng, M),
                         rng.standard_normal(NU), rng.standard_normal(M))
    out = F(x, P, z, u, Qn, R, 1.0, 0.0)
    xp, Pp = A @ x + B @ u, A @ P @ A.T + Qn
    nu = z - C @ xp
    np.testing.assert_allclose(np.array(out[2]).ravel(), nu, rtol=1e-12)
    assert float(out[3]) == pytest.approx(nu @ np.linalg.solve(C @ Pp @ C.T + R, nu), rel=1e-10)


def test_sigma_set_reproduces_the_covariance():
    """The spread sqrt(n + kappa) (not the thesis' printed sqrt(2d)) gives back P exactly."""
    n, rng = 6, np.random.default_rng(4)
    P = _spd(rng, n)
    L = np.linalg.cholesky(P)
    for kappa in (0.0, 3.0 - n, 2.0):
        s, w = sigma_weights(n, kappa)
        D = np.hstack([np.zeros((n, 1)), s * L, -s * L])
        assert sum(w) == pytest.approx(1.0, abs=1e-15)
        np.testing.assert_allclose(D @ np.diag(w) @ D.T, P, rtol=1e-12)
    s2 = np.sqrt(2 * n)  # thesis (4.6) as printed, with weights 1/(2d): twice P
    D = np.hstack([s2 * L, -s2 * L])
    np.testing.assert_allclose(D @ D.T / (2 * n), 2 * P, rtol=1e-12)
    with pytest.raises(ShapeError):
        sigma_weights(3, -3.0)


def test_masked_update_does_not_leak_nan_in_any_output():
    upd = make_masked_update(3, 2)
    P = np.diag([1.0, 2.0, 3.0])
    Pxz = np.array([[0.5, 0.1], [0.0, 0.2], [0.1, 0.0]])
    Pzz = np.diag([2.0, 3.0])
    for z in ([np.nan, 1.0], [np.inf, np.nan], [5.0, -np.inf]):
        out = [np.array(o) for o in upd(P, Pxz, Pzz, z, [0.1, 0.2])]
        assert all(np.all(np.isfinite(o)) for o in out)
    dx, _, nu, _, nv = upd(P, Pxz, Pzz, [np.nan, 1.0], [0.1, 0.2])
    assert float(nv) == 1 and float(nu[0]) == 0
    np.testing.assert_allclose(np.array(dx).ravel(), Pxz[:, 1] / 3.0 * 0.8, rtol=1e-14)


def test_spd_repair_leaves_a_pd_matrix_and_counts():
    rep = make_spd_repair(3)
    A = np.array([[4.0, 1.0, 0.5], [1.0, 3.0, 0.2], [0.5, 0.2, 2.0]])
    out, flag = rep(A + np.triu(np.full((3, 3), 1e-3), 1))
    assert float(flag) == 0
    np.testing.assert_allclose(np.array(out), A + 0.5e-3 * (1 - np.eye(3)), rtol=0, atol=1e-15)
    for bad in (np.array([[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]]),  # indefinite
                -np.eye(3), np.zeros((3, 3)),
                np.array([[1.0, 1.0, 1.0], [1.0, 1.0, 1.0], [1.0, 1.0, 1.0]])):  # singular
        out, flag = rep(bad)
        out = np.array(out)
        assert float(flag) == 1
        np.testing.assert_allclose(out, out.T, rtol=0, atol=0)
        assert np.linalg.eigvalsh(out).min() > 0
        L, pd = make_cholesky(3)(out)
        assert float(pd) == 1
        np.testing.assert_allclose(np.array(L) @ np.array(L).T, out, rtol=1e-12, atol=1e-300)


def test_filter_repairs_and_counts_a_bad_incoming_covariance(linear_system):
    _, _, _, f, h = linear_system
    F = make_filter("t", FilterModel(euclidean(N), f, h, "pre"), "ukf")
    P_bad = np.diag([1.0, -1e-3, 1.0, 1.0])
    out = F(np.zeros(N), P_bad, np.zeros(M), np.zeros(NU), 1e-3 * np.eye(N), np.eye(M), 1.0, 0.0)
    assert float(out[5]) >= 1
    assert np.all(np.isfinite(np.array(out[0])))
    assert np.linalg.eigvalsh(np.array(out[1])).min() > 0


def test_attitude_manifold_retraction_and_inverse():
    man = attitude()
    rng = np.random.default_rng(8)
    for _ in range(20):
        x = np.concatenate([Q.from_rotation_vector(rng.uniform(-2, 2, 3)), rng.standard_normal(3)])
        d = np.concatenate([rng.uniform(-1, 1, 3), rng.standard_normal(3)])
        y = np.array(man.oplus(x, d)).ravel()
        assert abs(np.linalg.norm(y[:4]) - 1) < 1e-15
        np.testing.assert_allclose(np.array(man.ominus(y, x)).ravel(), d, rtol=0, atol=1e-13)
        # body-frame convention (thesis 4.12): q o exp(r/2)
        np.testing.assert_allclose(y[:4], Q.mul(x[:4], Q.from_rotation_vector(d[:3])), atol=1e-15)


def test_additive_chart_renormalises():
    man = attitude_additive()
    y = np.array(man.normalise([2.0, 0.0, 0.0, 0.0, 1.0, 2.0, 3.0])).ravel()
    np.testing.assert_allclose(y, [1, 0, 0, 0, 1, 2, 3])


def test_model_validation_errors(linear_system):
    _, _, _, f, h = linear_system
    with pytest.raises(BallbotTypeError):
        FilterModel(euclidean(N), f, h, "sometimes")
    with pytest.raises(ShapeError):
        FilterModel(euclidean(N + 1), f, h)
    with pytest.raises(BallbotTypeError):
        FilterModel(euclidean(N), f, "h")
    with pytest.raises(BallbotTypeError):
        make_filter("t", FilterModel(euclidean(N), f, h), "pf")


def test_the_repair_count_adds_the_incoming_and_the_predicted_repairs(linear_system):
    """``repairs`` counts each covariance the period had to repair: the incoming one
    (indefinite ``P``), the predicted one (an indefinite additive ``Q``), or both."""
    _, _, _, f, h = linear_system
    F = make_filter("t", FilterModel(euclidean(N), f, h, "additive"), "ukf")
    P_ok, P_bad = 0.1 * np.eye(N), np.diag([1.0, -1e-3, 1.0, 1.0])
    Q_ok, Q_bad = 1e-3 * np.eye(N), -np.eye(N)
    for P, Qn, want in ((P_ok, Q_ok, 0), (P_bad, Q_ok, 1), (P_ok, Q_bad, 1), (P_bad, Q_bad, 2)):
        out = F(np.zeros(N), P, np.zeros(M), np.zeros(NU), Qn, np.eye(M), 1.0, 0.0)
        assert float(out[5]) == want
        assert np.linalg.eigvalsh(np.array(out[1])).min() > 0

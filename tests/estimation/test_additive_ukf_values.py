"""The thesis's first UKF (``ballbot_qukf_additive``: additive ``[q, omega]`` chart, sigma
points off the unit sphere, weighted-sum mean, renormalised quaternion) and the QEKF's
remaining outputs, against a textbook unscented step written here in numpy from thesis
(3.20)-(3.31) with the models of (4.14)-(4.18) and (4.29)-(4.30)."""

from __future__ import annotations

import numpy as np
import pytest
from _estimation_synthetic import DT, attitude_f as _f, attitude_h as _h

import ballbot_casadi.estimation as E
from ballbot_casadi import load_params
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.estimation.attitude import make_additive_ukf

PAR = load_params()
PV = PAR.to_vector()
TQ = E.DEFAULT_TUNING["qukf"]




def _G(q):
    """7 x 6: half the body-rotation image on q, identity on omega."""
    G = np.zeros((7, 6))
    G[:4, :3] = 0.5 * Q.Phi(q)[:, 1:]
    G[4:, 3:] = np.eye(3)
    return G


def _T(q):
    return 2 * Q.Phi(q).T[1:, :]


def _sigma(x, P):
    n = x.size
    L = np.linalg.cholesky(P)
    s = np.sqrt(n)  # kappa = 0
    return np.column_stack([x] + [x + s * L[:, i] for i in range(n)] + [x - s * L[:, i] for i in range(n)])


def _case():
    x = np.r_[Q.from_rpy(0.05, -0.03, 0.6), 0.3, -0.2, 0.1]
    rng = np.random.default_rng(11)
    A = rng.standard_normal((7, 7))
    P = 1e-4 * (A @ A.T) + 1e-7 * np.eye(7)
    Qn = np.diag([1e-6, 2e-6, 3e-6, 1e-5, 2e-5, 3e-5])
    z = np.r_[PAR.g * Q.rotate_inv(Q.from_rpy(0.07, -0.01, 0.6), [0, 0, 1]), 0.33, -0.17, 0.12]
    return x, P, Qn, z


def test_one_period_equals_a_numpy_additive_ukf():
    x, P, Qn, z = _case()
    out = [np.asarray(o, float) for o in make_additive_ukf()(x, P, z, Qn, TQ.R, DT, PV)]
    n = 7
    w = np.r_[0.0, np.full(2 * n, 1.0 / (2 * n))]
    Xp = np.column_stack([_f(c) for c in _sigma(x, P).T])
    xp = Xp @ w
    dX = Xp - xp[:, None]
    Pp = dX @ np.diag(w) @ dX.T + _G(x[:4]) @ Qn @ _G(x[:4]).T
    Xs = _sigma(xp, Pp)  # redrawn from the predicted mean and covariance
    Zs = np.column_stack([_h(c) for c in Xs.T])
    zp = Zs @ w
    dZ, dXs = Zs - zp[:, None], Xs - xp[:, None]
    S = dZ @ np.diag(w) @ dZ.T + TQ.R
    K = (dXs @ np.diag(w) @ dZ.T) @ np.linalg.inv(S)
    nu = np.r_[z[:3] / PAR.g, z[3:]] - zp
    xk = xp + K @ nu
    xk[:4] /= np.linalg.norm(xk[:4])
    Pk = Pp - K @ S @ K.T
    np.testing.assert_allclose(out[0].ravel(), xk, rtol=0, atol=1e-12)
    np.testing.assert_allclose(out[1], Pk, rtol=1e-8, atol=1e-15)
    np.testing.assert_allclose(out[2].ravel(), nu, rtol=1e-8, atol=1e-14)
    assert out[3].item() == pytest.approx(nu @ np.linalg.solve(S, nu), rel=1e-8)
    assert out[4].item() == 6.0 and out[5].item() == 0.0
    T = _T(xk[:4])
    np.testing.assert_allclose(out[6], T @ Pk[:4, :4] @ T.T, rtol=1e-8, atol=1e-15)


def test_qekf_reports_its_innovation_and_the_body_attitude_covariance():
    x, P, Qn, z = _case()
    out = [np.asarray(o, float) for o in E.build_estimator("qekf")(x, P, z, Qn, TQ.R, DT, PV)]
    xp = _f(x)
    nu = np.r_[z[:3] / PAR.g, z[3:]] - _h(xp)
    np.testing.assert_allclose(out[2].ravel(), nu, rtol=1e-9, atol=1e-14)
    q = out[0].ravel()[:4]
    T = _T(q)
    np.testing.assert_allclose(out[6], T @ out[1][:4, :4] @ T.T, rtol=1e-12, atol=1e-18)
    assert out[4].item() == 6.0
    # one missing gyro component: five valid, its innovation zero
    z2 = z.copy()
    z2[4] = np.nan
    out2 = E.build_estimator("qekf")(x, P, z2, Qn, TQ.R, DT, PV)
    assert float(np.asarray(out2[4]).item()) == 5.0 and float(np.asarray(out2[2]).ravel()[4]) == 0.0

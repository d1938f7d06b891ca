"""The predecessor's QEKF and VEKF baselines (thesis §6): correctness and comparison."""

from __future__ import annotations

import numpy as np
import pytest
from _estimation_synthetic import DT, imu, truth, attitude_f as _f, attitude_h as _h

import ballbot_casadi.estimation as E
from ballbot_casadi import load_params
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.estimation.attitude import tangent_map
from ballbot_casadi.model.dynamics import make_model_functions

PAR = load_params()
PV = PAR.to_vector()
TQ = E.DEFAULT_TUNING["qukf"]




def _fd(fun, x, eps=1e-7):
    cols = [(fun(x + eps * e) - fun(x - eps * e)) / (2 * eps) for e in np.eye(x.size)]
    return np.stack(cols, axis=1)


# the thesis's Q (rotation block 1e-20) and one whose rotation noise shows in the
# quaternion block: G(q) Q G(q)^T must be mapped at the filter's attitude (yaw 0.6 rad)
@pytest.mark.parametrize("Qn", [TQ.Q, np.diag([1e-6, 2e-6, 3e-6, 1e-5, 1e-5, 1e-5])])
def test_qekf_step_equals_a_textbook_additive_ekf_with_renormalisation(Qn):
    qekf = E.build_estimator("qekf")
    x = np.r_[Q.from_rpy(0.05, -0.03, 0.6), 0.3, -0.2, 0.1]
    rng = np.random.default_rng(4)
    G = rng.standard_normal((7, 7))
    P = 1e-5 * (G @ G.T) + 1e-8 * np.eye(7)
    z = np.r_[PAR.g * Q.rotate_inv(Q.from_rpy(0.06, -0.02, 0.6), [0, 0, 1]), 0.31, -0.18, 0.1]
    out = qekf(x, P, z, Qn, TQ.R, DT, PV)
    Gm = tangent_map(x[:4])
    F = _fd(_f, x)
    xp = _f(x)
    Pp = F @ P @ F.T + Gm @ Qn @ Gm.T
    H = _fd(_h, xp)
    S = H @ Pp @ H.T + TQ.R
    K = Pp @ H.T @ np.linalg.inv(S)
    xk = xp + K @ (np.r_[z[:3] / PAR.g, z[3:]] - _h(xp))
    xk[:4] /= np.linalg.norm(xk[:4])  # the predecessor's forced renormalisation
    Pk = Pp - K @ S @ K.T
    np.testing.assert_allclose(np.asarray(out[0]).ravel(), xk, rtol=0, atol=1e-9)
    np.testing.assert_allclose(np.asarray(out[1]), Pk, rtol=1e-6, atol=1e-14)
    assert np.linalg.norm(np.asarray(out[0]).ravel()[:4]) == pytest.approx(1.0, abs=2e-16)
    # P_att is the body rotation-vector covariance of the updated quaternion
    T = 2 * Q.Phi(xk[:4]).T[1:, :]
    np.testing.assert_allclose(np.asarray(out[6]), T @ Pk[:4, :4] @ T.T, rtol=1e-6, atol=1e-15)


@pytest.fixture(scope="module")
def attitude_runs():
    tr = truth(100.0)
    z = imu(tr, np.random.default_rng(20201122), PAR.g)[:, 1:]
    n = z.shape[1]
    res = {}
    for name in ("qukf", "qekf"):
        x0, P0 = E.initial_state(name)
        out = E.build_estimator(name).mapaccum(name, n, 2)(x0, P0, z, TQ.Q, TQ.R, DT, PV)
        X = np.asarray(out[0])
        err = np.degrees(Q.to_rpy(X[:4].T) - Q.to_rpy(tr.q[:, 1:].T))
        res[name] = (np.sqrt(np.mean(err[:, :2] ** 2, axis=0)), X, np.asarray(out[5]).ravel())
    return res


def test_qekf_is_comparable_to_the_qukf(attitude_runs):
    """Thesis §6.1/6.3: the QEKF performs like the QUKF at 200 Hz (no strong nonlinearity)."""
    rms_u, _, _ = attitude_runs["qukf"]
    rms_e, X, rep = attitude_runs["qekf"]
    # measured: QUKF roll/pitch 0.080/0.071 deg, QEKF 0.082/0.071 deg
    assert np.all(rms_e <= 0.1)
    assert np.all(rms_e >= 0.97 * rms_u) and np.all(rms_e <= 1.1 * rms_u)
    assert rep.sum() == 0
    assert np.abs(np.linalg.norm(X[:4], axis=0) - 1).max() < 1e-15  # renormalised each step


def test_vekf_equals_vukf_on_the_linear_velocity_models():
    """Every velocity model is linear in the state, so UT, EKF and KF coincide (thesis §6.2)."""
    ws = make_model_functions()["wheel_speeds"]
    tv = E.DEFAULT_TUNING["vukf"]
    rng = np.random.default_rng(12)
    n = 300
    att = np.vstack([np.tile(Q.from_rpy(0.02, -0.01, 0.5)[:, None], (1, n)),
                     0.05 * rng.standard_normal((3, n))])
    P_att = np.tile(np.diag([1e-6, 1e-6, 1e-4]), (1, n))
    z = np.vstack([20 * rng.standard_normal((3, n)),
                   np.array([[0.0], [0.0], [PAR.g]]) + 0.1 * rng.standard_normal((3, n))])
    z[0, 50:60] = np.nan
    outs = []
    for name in ("vukf", "vekf"):
        x0, P0 = E.initial_state(name)
        F = E.build_estimator(name, ws).mapaccum(name, n, 2)
        outs.append([np.asarray(o) for o in F(x0, P0, z, att, P_att, tv.Q, tv.R, DT, PV)])
    np.testing.assert_allclose(outs[0][0], outs[1][0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(outs[0][1], outs[1][1], rtol=1e-7, atol=1e-15)

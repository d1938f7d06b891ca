"""The VUKF's body-rate covariance option: the attitude filter's rate uncertainty enters
the encoder prediction's noise through J_w = d enc / d omega (finite differences here)."""

from __future__ import annotations

import numpy as np
import pytest
from _estimation_synthetic import DT

import ballbot_casadi.estimation as E
from ballbot_casadi import load_params
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.estimation.velocity import make_velocity_model, make_vukf
from ballbot_casadi.model.dynamics import make_model_functions

PAR = load_params()
PV = PAR.to_vector()
TUN = E.DEFAULT_TUNING["vukf"]


@pytest.fixture(scope="module")
def ws():
    return make_model_functions()["wheel_speeds"]


def _case():
    q = Q.from_rpy(0.03, -0.02, 0.8)
    att = np.r_[q, 0.2, -0.1, 0.3]
    x = np.array([0.2, -0.1, 0.3, 0.1, 0.01, 0.0, -0.02])
    g = PAR.g
    z = np.r_[np.array([3.0, -2.0, 1.0]), Q.rotate_inv(q, [0.3, 0.1, g])]
    return x, att, z


def test_zero_rate_covariance_is_the_shipped_filter(ws):
    x, att, z = _case()
    base, rated = make_vukf(ws, midpoint=True), make_vukf(ws, midpoint=True, rate_covariance=True)
    assert rated.name_in()[-1] == "P_rate" and base.n_in() + 1 == rated.n_in()
    args = (x, TUN.P0, z, att, np.diag([1e-4, 2e-4, 3e-4]), TUN.Q, TUN.R, DT, PV)
    for a, b in zip(base(*args), rated(*args, np.zeros((3, 3)))):
        np.testing.assert_allclose(np.asarray(b), np.asarray(a), rtol=0, atol=1e-15)


def test_rate_covariance_enters_the_encoder_block_with_the_rate_sensitivity(ws):
    """One update with a huge encoder innovation: the NIS equals nu^T S^-1 nu with
    S = P_zz + J_w P_rate J_w^T, J_w by central differences of the measurement model."""
    x, att, z = _case()
    model = make_velocity_model(ws, midpoint=True)
    P_rate = np.diag([4e-4, 1e-4, 9e-4])
    u = np.r_[att, np.zeros(9)]
    J = np.zeros((3, 3))
    for i in range(3):
        d = np.zeros(16)
        d[4 + i] = 1e-6
        J[:, i] = (np.asarray(model.measurement(x, u + d, DT, PV)).ravel()[:3]
                   - np.asarray(model.measurement(x, u - d, DT, PV)).ravel()[:3]) / 2e-6
    assert np.abs(J).max() > 1.0  # ticks per period per rad/s: the rate matters
    f = make_vukf(ws, midpoint=True, rate_covariance=True)
    zero = np.zeros((3, 3))
    args = (x, TUN.P0, z, att, zero, TUN.Q, TUN.R, DT, PV)
    nis0, nis1 = float(f(*args, zero)[3]), float(f(*args, P_rate)[3])
    # the same innovation, a larger S: the NIS drops by the added term
    R2 = np.array(TUN.R)
    R2[:3, :3] += J @ P_rate @ J.T
    ref = make_vukf(ws, midpoint=True)
    nis_ref = float(ref(x, TUN.P0, z, att, zero, TUN.Q, R2, DT, PV)[3])
    assert nis1 < nis0
    assert nis1 == pytest.approx(nis_ref, rel=1e-6)

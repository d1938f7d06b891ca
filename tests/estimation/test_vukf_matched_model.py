"""The VUKF's matched model (``matched=True``), term by term against the shipped filter
fed with the same terms by hand; the Jacobians by central differences here.

* the body rate's covariance ``P_rate`` enters the encoder block of ``R`` through
  ``J_w = d enc / d omega``;
* ``Q`` enters as ``G Q G^T`` (the period's acceleration increment on the velocity);
* the attitude error is a slow accelerometer offset: no ``J P_att J^T`` in ``R``, and
  ``b_acc`` walks by ``dt^2 J P_rate J^T`` with ``J = d acc / d r`` (a body rotation ``r``).
"""

from __future__ import annotations

import numpy as np
import pytest
from _estimation_synthetic import DT

import ballbot_casadi.estimation as E
from ballbot_casadi import load_params
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.estimation.attitude import ATTITUDE_GATE, ATTITUDE_MEAS, ATTITUDE_NOISE
from ballbot_casadi.estimation.tuning import QUKF_Q, QUKF_R, SIGMA_GYRO
from ballbot_casadi.estimation.velocity import make_velocity_model, make_vukf
from ballbot_casadi.model.dynamics import make_model_functions

PAR = load_params()
PV = PAR.to_vector()
TUN = E.DEFAULT_TUNING["vukf"]
P_ATT = np.diag([1e-4, 2e-4, 3e-4])
P_RATE = np.diag([4e-4, 1e-4, 9e-4])


@pytest.fixture(scope="module")
def ws():
    return make_model_functions()["wheel_speeds"]


def _case():
    q = Q.from_rpy(0.03, -0.02, 0.8)
    att = np.r_[q, 0.2, -0.1, 0.3]
    x = np.array([0.2, -0.1, 0.3, 0.1, 0.01, 0.0, -0.02])
    z = np.r_[np.array([3.0, -2.0, 1.0]), Q.rotate_inv(q, [0.3, 0.1, PAR.g])]
    return x, att, z


def _jacobians(ws, x, att):
    """``J_w = d enc / d omega`` and ``J = d acc / d r`` (``q -> q o exp(r)``) by central
    differences of the measurement model."""
    model = make_velocity_model(ws, midpoint=True)

    def h(a):
        return np.asarray(model.measurement(x, np.r_[a, np.zeros(9)], DT, PV)).ravel()

    Jw, J, e = np.zeros((3, 3)), np.zeros((3, 3)), 1e-6
    for i in range(3):
        d = np.zeros(7)
        d[4 + i] = e
        Jw[:, i] = (h(att + d)[:3] - h(att - d)[:3]) / (2 * e)
        r = np.zeros(3)
        r[i] = e
        qp, qm = (np.r_[Q.mul(att[:4], Q.from_rotation_vector(s * r)), att[4:]] for s in (1, -1))
        J[:, i] = (h(qp)[3:] - h(qm)[3:]) / (2 * e)
    return Jw, J


def _gqg(Qn):
    G = np.eye(7)
    G[0:2, 2:4] = DT * np.eye(2)
    return G @ Qn @ G.T


def test_the_matched_model_is_the_shipped_filter_with_its_terms_added_by_hand(ws):
    """One update with a large encoder innovation: every output of the matched filter
    equals the shipped filter's with R + blkdiag(J_w P_rate J_w^T, 0), G Q G^T +
    blkdiag(0, dt^2 J P_rate J^T) and no attitude covariance."""
    x, att, z = _case()
    Jw, J = _jacobians(ws, x, att)
    assert np.abs(Jw).max() > 1.0  # ticks per period per rad/s: the rate matters
    assert abs(J[0, 1]) > 9.0 and abs(J[1, 0]) > 9.0  # ~g: a tilt shows as horizontal acc
    matched = make_vukf(ws, midpoint=True, matched=True)
    assert matched.name_in()[-1] == "P_rate"
    out = matched(x, TUN.P0, z, att, P_ATT, TUN.Q, TUN.R, DT, PV, P_RATE)
    R2 = np.array(TUN.R)
    R2[:3, :3] += Jw @ P_RATE @ Jw.T
    Q2 = _gqg(np.array(TUN.Q))
    Q2[4:, 4:] += DT ** 2 * J @ P_RATE @ J.T
    ref = make_vukf(ws, midpoint=True)(x, TUN.P0, z, att, np.zeros((3, 3)), Q2, R2, DT, PV)
    for a, b in zip(ref[:4], out[:4]):
        np.testing.assert_allclose(np.asarray(b), np.asarray(a), rtol=1e-6, atol=1e-12)


def test_the_matched_model_ignores_the_attitude_covariance(ws):
    """The attitude error is the offset state's, not white noise: P_att changes nothing
    (in the shipped filter it lowers the NIS through J P_att J^T)."""
    x, att, z = _case()
    matched = make_vukf(ws, midpoint=True, matched=True)
    a = matched(x, TUN.P0, z, att, np.zeros((3, 3)), TUN.Q, TUN.R, DT, PV, P_RATE)
    b = matched(x, TUN.P0, z, att, P_ATT, TUN.Q, TUN.R, DT, PV, P_RATE)
    for u, v in zip(a, b):
        np.testing.assert_array_equal(np.asarray(u), np.asarray(v))
    shipped = make_vukf(ws, midpoint=True)
    assert float(shipped(x, TUN.P0, z, att, P_ATT, TUN.Q, TUN.R, DT, PV)[3]) < \
        float(shipped(x, TUN.P0, z, att, np.zeros((3, 3)), TUN.Q, TUN.R, DT, PV)[3])


def test_the_attitude_filter_layouts_name_the_blocks_the_matched_filter_reads():
    """The embedded software takes the gyro block of the attitude filter's R and the rate
    block of its Q by these names (thesis 4.37-4.40: R = blkdiag(alpha Sigma_acc,
    Sigma_gyro), Q = blkdiag(1e-20 I, 1e-5 I))."""
    g, w = ATTITUDE_MEAS["gyro"], ATTITUDE_NOISE["omega"]
    np.testing.assert_array_equal(QUKF_R[g, g], SIGMA_GYRO)
    np.testing.assert_array_equal(QUKF_Q[w, w], 1e-5 * np.eye(3))
    assert (ATTITUDE_MEAS.size, ATTITUDE_NOISE.size) == (QUKF_R.shape[0], QUKF_Q.shape[0])
    assert dict(ATTITUDE_GATE.groups) == {"acc": (0, 1, 2), "gyro": (3, 4, 5)}

"""The renormalisation tools' plumbing by hand: a variant's start (normalised quaternion,
the rate, the covariance of its chart), the refusal of an unknown variant, and the replay
feeding each reading to a recording stand-in filter (accelerometer first, then gyroscope;
the state and covariance carried from one reading to the next)."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.analysis.renormalisation import ATTITUDE_VARIANTS, attitude_variant, norm_probe_dev, replay_attitude
from ballbot_casadi.core.params import PARAM_NAMES
from ballbot_casadi.estimation.attitude import qekf_initial_covariance
from ballbot_casadi.estimation.tuning import QUKF_P0
from ballbot_casadi.sim.embedded import MEAS


def test_variant_starts_from_the_normalised_attitude_and_its_charts_covariance():
    q0 = np.array([2.0, 0.2, -0.4, 0.1])
    w0 = np.array([0.1, -0.2, 0.3])
    qn = q0 / np.linalg.norm(q0)
    for name, (_, additive) in ATTITUDE_VARIANTS.items():
        f, x0, P0 = attitude_variant(name, q0, w0)
        np.testing.assert_allclose(x0, np.r_[qn, w0], rtol=0, atol=1e-15)
        want = qekf_initial_covariance(qn) if additive else np.array(QUKF_P0, float)
        np.testing.assert_allclose(P0, want, rtol=0, atol=0)
        assert f.n_in() == 7
    assert ATTITUDE_VARIANTS["qekf"][1] and ATTITUDE_VARIANTS["qukf_additive"][1]
    assert not ATTITUDE_VARIANTS["qukf"][1] and not ATTITUDE_VARIANTS["qukf_renorm"][1]
    with pytest.raises(ValueError, match=r"unknown attitude filter variant 'ukf'; allowed: qukf, "
                                         r"qukf_renorm, qukf_additive, qekf"):
        attitude_variant("ukf", q0, w0)


def test_replay_feeds_acc_then_gyro_and_carries_state_and_covariance():
    x, P = ca.SX.sym("x", 7), ca.SX.sym("P", 6, 6)
    z, Qn, R, dt, p = ca.SX.sym("z", 6), ca.SX.sym("Q", 6, 6), ca.SX.sym("R", 6, 6), ca.SX.sym("dt"), \
        ca.SX.sym("p", 2)
    # x+ = x + [z, dt * trace(P) + p1]; P+ = 2 P + Qn - R
    f = ca.Function("stub", [x, P, z, Qn, R, dt, p],
                    [x + ca.vertcat(z, dt * ca.trace(P) + p[1]), 2 * P + Qn - R])
    meas = np.zeros((3, 9))
    meas[:, MEAS["acc"]] = [[1, 2, 3], [4, 5, 6], [7, 8, 9]]
    meas[:, MEAS["gyro"]] = [[10, 20, 30], [40, 50, 60], [70, 80, 90]]
    meas[:, MEAS["enc"]] = 1e6                      # not used
    x0 = np.arange(7.0)
    P0, Qm, Rm = np.eye(6), 0.5 * np.eye(6), 0.25 * np.eye(6)
    out = replay_attitude(f, meas, x0, P0, Qm, Rm, 0.1, np.array([0.0, 0.01]))
    xs, Ps = [x0], [P0]
    for k in range(3):
        zk = np.r_[meas[k, 0:3], meas[k, 3:6]]
        xs.append(xs[-1] + np.r_[zk, 0.1 * np.trace(Ps[-1]) + 0.01])
        Ps.append(2 * Ps[-1] + Qm - Rm)
    np.testing.assert_allclose(out, np.array(xs[1:]), rtol=1e-15, atol=1e-12)
    assert out.shape == (3, 7)


def test_norm_probe_hands_the_documented_prior_and_reading():
    """A stand-in filter that returns its prior and records its arguments: the probe's
    prior is upright at norm 1 + eps, at rest, the reading is g on the accelerometer's z
    and 0 on the gyroscope, and the deviation reported is the output's |norm - 1|."""
    seen = []

    def f(x, P0, z, Qn, R, dt, p):
        seen.append((np.array(x), np.array(z), dt))
        return [np.asarray(x) * (1.0 + 3e-6)]

    p = np.arange(len(PARAM_NAMES), dtype=float) + 1.0
    dev = norm_probe_dev(f, np.eye(6), np.eye(6), np.eye(6), p, 0.005, eps=1e-6)
    x, z, dt = seen[0]
    np.testing.assert_array_equal(x, [1.0 + 1e-6, 0, 0, 0, 0, 0, 0])
    np.testing.assert_array_equal(z, [0, 0, PARAM_NAMES.index("g") + 1.0, 0, 0, 0])
    assert dt == 0.005
    assert dev == pytest.approx((1.0 + 1e-6) * (1.0 + 3e-6) - 1.0, rel=1e-9)

"""Renormalising the attitude filter's quaternion (thesis ch. 10): the probe tells a
renormalising filter from one that keeps the norm by its operations; the renormalising
QUKF does not deviate from the QUKF."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.analysis.renormalisation import (
    ATTITUDE_VARIANTS,
    PROBE_EPS,
    attitude_variant,
    norm_probe_dev,
    replay_attitude,
)
from ballbot_casadi.core.params import PARAM_NAMES, load_params
from ballbot_casadi.estimation import DEFAULT_TUNING

P = load_params().to_vector()
QA, RA = np.array(DEFAULT_TUNING["qukf"].Q), np.array(DEFAULT_TUNING["qukf"].R)


@pytest.mark.parametrize("name,renormalises", [("qukf", False), ("qukf_renorm", True),
                                               ("qukf_additive", True), ("qekf", True)])
def test_norm_probe_tells_renormalising_filters_apart(name, renormalises):
    f, _, P0 = attitude_variant(name, np.array([1.0, 0, 0, 0]), np.zeros(3))
    dev = norm_probe_dev(f, P0, QA, RA, P, 0.005)
    if renormalises:
        assert dev <= 1e-12
    else:
        assert dev == pytest.approx(PROBE_EPS, rel=1e-3)


def test_renormalised_qukf_does_not_deviate_on_a_tilting_body():
    """A body rocking 3 deg at 0.5 Hz about roll, seeded gyro/accelerometer noise: the
    QUKF with and without renormalisation agree to rounding; the additive UKF (the
    thesis's first attempt) is not worse than the QUKF by more than 20 %: no deep deviation."""
    rng = np.random.default_rng(7)
    dt, n = 0.005, 600
    t = np.arange(n) * dt
    a, w = np.radians(3.0), 2 * np.pi * 0.5
    roll, rate = a * np.sin(w * t), a * w * np.cos(w * t)
    g = 9.81
    meas = np.zeros((n, 9))
    meas[:, 1], meas[:, 2] = g * np.sin(roll), g * np.cos(roll)   # gravity in the body frame
    meas[:, 3] = rate
    meas[:, :6] += rng.normal(0.0, [0.02, 0.02, 0.03, 0.02, 0.013, 0.037], (n, 6))
    q_true = np.column_stack([np.cos(roll / 2), np.sin(roll / 2), np.zeros(n), np.zeros(n)])
    err = {}
    for name in ATTITUDE_VARIANTS:
        f, x0, P0 = attitude_variant(name, q_true[0], np.array([rate[0], 0, 0]))
        xh = replay_attitude(f, meas, x0, P0, QA, RA, dt, P)
        q = xh[:, :4] / np.linalg.norm(xh[:, :4], axis=1)[:, None]
        err[name] = np.degrees(2 * np.arccos(np.clip(np.abs(np.sum(q * q_true, axis=1)), 0, 1)))
    assert np.sqrt(np.mean(err["qukf"] ** 2)) < 0.5          # it tracks at all
    np.testing.assert_allclose(err["qukf_renorm"], err["qukf"], rtol=0, atol=1e-9)
    ratio = np.sqrt(np.mean(err["qukf_additive"] ** 2)) / np.sqrt(np.mean(err["qukf"] ** 2))
    assert ratio <= 1.2


def test_the_norm_probe_starts_at_rest_reading_gravity():
    """A stand-in filter that passes its prior through but scales it by 1 + (how far the probe
    is from rest: the prior's rate and the readings other than g on z): the probe must give
    exactly eps, the prior upright at norm 1 + eps, at rest, reading g."""
    x, P, z, Q, R, dt, p = (ca.SX.sym(n, *s) for n, s in (("x", (7, 1)), ("P", (6, 6)), ("z", (6, 1)),
                                                           ("Q", (6, 6)), ("R", (6, 6)), ("dt", (1, 1)),
                                                           ("p", (len(PARAM_NAMES), 1))))
    g = p[PARAM_NAMES.index("g")]
    off = ca.sumsqr(x[4:7]) + ca.sumsqr(z - ca.vertcat(0, 0, g, 0, 0, 0)) + ca.sumsqr(x[1:4])
    f = ca.Function("probe", [x, P, z, Q, R, dt, p], [ca.vertcat(x[:4] * (1 + off), x[4:7])])
    eps = 1e-6
    dev = norm_probe_dev(f, np.eye(6), np.eye(6), np.eye(6), load_params().to_vector(), 0.005, eps)
    assert dev == pytest.approx(eps, rel=1e-9)

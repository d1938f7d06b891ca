"""Boundaries and hand values of the filter building blocks: the sigma-point weights,
the Karcher mean's iteration count, the heading filter's "is there a reading" test at
the largest finite number, and each refusal's message."""

from __future__ import annotations

import math
import sys

import casadi as ca
import numpy as np
import pytest

import ballbot_casadi.estimation as E
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.params import load_params
from ballbot_casadi.errors import BallbotTypeError, ShapeError
from ballbot_casadi.estimation.core import InnovationGate, make_filter, sigma_weights
from ballbot_casadi.estimation.heading import make_qukf_heading
from ballbot_casadi.estimation.quaternion_mean import karcher_mean, make_karcher_mean


def test_sigma_weights_are_julier_s_set():
    spread, w = sigma_weights(7, -4.0)  # the VUKF: kappa = 3 - N (thesis 5.6, 5.13)
    assert spread == pytest.approx(math.sqrt(3.0), rel=1e-15)
    assert len(w) == 15
    assert w[0] == pytest.approx(-4.0 / 3.0, rel=1e-15)
    np.testing.assert_allclose(w[1:], 1.0 / 6.0, rtol=1e-15)
    spread, w = sigma_weights(6, 0.0)  # the QUKF (4.19): 2n equal weights, centre 0
    assert spread == pytest.approx(math.sqrt(6.0)) and w[0] == 0.0
    np.testing.assert_allclose(w[1:], 1.0 / 12.0, rtol=1e-15)
    assert sigma_weights(1, -0.5)[1] == pytest.approx([-1.0, 1.0, 1.0])  # n + kappa just > 0
    with pytest.raises(ShapeError, match="n \\+ kappa > 0, got n = 3, kappa = -3"):
        sigma_weights(3, -3.0)


def _z_rot(a):
    return np.array([math.cos(a / 2), 0.0, 0.0, math.sin(a / 2)])


def test_one_karcher_step_about_one_axis_is_the_weighted_angle():
    # rotations about one axis commute: one step from the identity lands on the weighted
    # mean angle exactly; a second step changes nothing
    a = [0.3, -0.1, 0.7]
    w = [0.5, 0.3, 0.2]
    want = _z_rot(0.5 * 0.3 - 0.3 * 0.1 + 0.2 * 0.7)
    Qs = np.stack([_z_rot(x) for x in a], axis=1)
    for it in (1, 2):
        m = np.asarray(make_karcher_mean(3, it)(Qs, w, [1.0, 0, 0, 0]), float).ravel()
        np.testing.assert_allclose(m, want, rtol=0, atol=1e-15)
    # from a start away from the mean (same axis): still exact in one step
    start = _z_rot(1.0)
    m1 = np.asarray(make_karcher_mean(3, 1)(Qs, w, start), float).ravel()
    np.testing.assert_allclose(m1, want, atol=1e-15)
    np.testing.assert_allclose(karcher_mean(Qs.T, np.array(w)), want, atol=1e-15)
    np.testing.assert_allclose(karcher_mean(Qs.T[:1]), _z_rot(0.3), atol=1e-15)


@pytest.mark.parametrize("n,it", [(0, 3), (3, 0)])
def test_karcher_mean_needs_a_point_and_a_step(n, it):
    with pytest.raises(ShapeError, match=f"need n_points >= 1 and iterations >= 1, got {n}, {it}"):
        make_karcher_mean(n, it)


def test_numpy_karcher_step_from_the_chordal_start_reaches_the_weighted_angle():
    # one axis, weights 0.9 / 0.1 on 0 and 2 rad: the start (the normalised weighted sum)
    # is off the mean by ~0.1 rad and one exact exponential step lands on 0.2 rad
    qs = np.stack([_z_rot(0.0), _z_rot(2.0)])
    w = np.array([0.9, 0.1])
    np.testing.assert_allclose(karcher_mean(qs, w, iterations=1), _z_rot(0.2), atol=1e-15)
    np.testing.assert_allclose(karcher_mean(qs, w, iterations=3), _z_rot(0.2), atol=1e-15)
    qs = np.stack([_z_rot(0.0), _z_rot(0.0)])
    np.testing.assert_array_equal(karcher_mean(qs, iterations=2), [1.0, 0, 0, 0])


@pytest.fixture(scope="module")
def heading():
    return make_qukf_heading()


def _heading_args(yaw):
    t = E.DEFAULT_TUNING["qukf_heading"]
    p = load_params().to_vector()
    x0 = np.array(t.x0, float)
    x0[:4] = np.asarray(Q.from_rpy(0.0, 0.0, 0.2), float).ravel()
    z = np.r_[0.0, 0.0, 9.81, 0.0, 0.0, 0.0, yaw]
    return [x0, t.P0, z, t.Q, t.R, 0.005, p, np.zeros(3)]


@pytest.mark.parametrize("yaw,n_valid", [(sys.float_info.max, 7), (-sys.float_info.max, 7),
                                         (0.25, 7), (math.inf, 6), (-math.inf, 6), (math.nan, 6)])
def test_a_heading_reading_is_any_finite_number(heading, yaw, n_valid):
    out = heading(*_heading_args(yaw))
    assert float(out[4]) == n_valid
    x = np.asarray(out[0], float).ravel()
    assert np.all(np.isfinite(x))


def test_a_heading_reading_moves_the_yaw_towards_it(heading):
    # prior yaw 0.2, reading 0.25: the innovation is +0.05 rad and the yaw estimate grows
    out = heading(*_heading_args(0.25))
    nu = np.asarray(out[2], float).ravel()
    assert nu[6] == pytest.approx(0.05, rel=1e-9)
    yaw = Q.to_rpy(np.asarray(out[0], float).ravel()[:4])[2]
    assert 0.2 < float(yaw) < 0.25


def test_filter_kind_and_gate_indices_are_checked():
    x = ca.MX.sym("x", 2)
    from ballbot_casadi.estimation.core import FilterModel
    from ballbot_casadi.estimation.manifold import euclidean
    u, dt, p = ca.MX.sym("u", 1), ca.MX.sym("dt"), ca.MX.sym("p", 1)
    f = ca.Function("f", [x, u, dt, p], [x])
    h = ca.Function("h", [x, u, dt, p], [x[0]])
    m = FilterModel(euclidean(2), f, h)
    with pytest.raises(BallbotTypeError, match="kind must be 'ukf' or 'ekf', got 'pf'"):
        make_filter("x", m, kind="pf")
    g = InnovationGate((("a", (0,)), ("b", (1,))))
    with pytest.raises(ShapeError, match="index beyond the 1 measurements"):
        g.function(1)
    assert g.function(2).size_in(0) == (2, 2)
    assert m.nz == 1 and m.nu == 1 and m.np == 1 and m.nd == 2

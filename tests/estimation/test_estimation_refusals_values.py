"""Every check of the estimation package's constructors exactly at and just past its limit
(the value on the limit accepted or refused as documented), with the one-line message
naming what was wrong; and the manifolds' charts on a state with a vector part."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.errors import ArgumentError, ShapeError
from ballbot_casadi.estimation.adaptive_walk import WalkAdaptation
from ballbot_casadi.estimation.com_observer import check_com_observer_gains
from ballbot_casadi.estimation.manifold import attitude, attitude_additive, euclidean
from ballbot_casadi.estimation.quaternion_mean import chordal_mean, karcher_mean


@pytest.mark.parametrize("kw", [dict(forgetting=1e-12), dict(forgetting=1 - 1e-12),
                                dict(floor=1e-300), dict(floor=0.5, ceiling=0.5 + 1e-12),
                                dict(sample_max=1.0), dict(prior_samples=0.0)])
def test_walk_adaptation_accepts_values_on_the_inside_of_each_limit(kw):
    a = WalkAdaptation(**kw)
    for k, v in kw.items():
        assert getattr(a, k) == v


@pytest.mark.parametrize("kw,msg", [
    (dict(forgetting=0.0), "forgetting must be in \\(0, 1\\), got 0.0"),
    (dict(forgetting=1.0), "forgetting must be in \\(0, 1\\), got 1.0"),
    (dict(floor=0.5, ceiling=0.5), "0 < floor < ceiling, got floor 0.5, ceiling 0.5"),
    (dict(floor=-1e-9), "0 < floor < ceiling, got floor -1e-09"),
    (dict(sample_max=1.0 - 1e-12), "sample_max must be >= ceiling 1.0"),
    (dict(prior_samples=-1e-12), "prior_samples must be >= 0, got -1e-12"),
    (dict(ceiling=math.inf), "must be finite numbers"),
    (dict(forgetting="0.1"), "must be finite numbers"),
])
def test_walk_adaptation_refusals_name_the_constant(kw, msg):
    with pytest.raises(ShapeError, match="^walk adaptation .*" + msg):
        WalkAdaptation(**kw)


def test_com_observer_gain_limits():
    # t_diff may be 0 (no measurement filter); every other gain must be > 0
    np.testing.assert_array_equal(check_com_observer_gains([1e-300, 1e-300, 0.0, 1e-300]),
                                  [1e-300, 1e-300, 0.0, 1e-300])
    for k, name in (([0.3, 0.0, 0.1, 0.1], "t_com = 0.0"), ([0.3, 2.0, 0.1, 0.0], "c_max = 0.0"),
                    ([0.3, 2.0, -1e-300, 0.1], "t_diff = -1e-300"),
                    ([0.3, 2.0, 0.1, math.inf], "c_max = inf")):
        with pytest.raises(ArgumentError, match=f"out of range .*: {name}$"):
            check_com_observer_gains(k)
    with pytest.raises(ArgumentError, match="t_obs = -1.0, t_com = 0.0$"):
        check_com_observer_gains([-1.0, 0.0, 0.1, 0.1])
    with pytest.raises(ArgumentError, match=r"need 4 entries .*got 5"):
        check_com_observer_gains([0.3] * 5)


def test_manifold_sizes_and_limits():
    assert (euclidean(1).nx, euclidean(1).nd) == (1, 1)
    with pytest.raises(ShapeError, match="euclidean manifold needs n >= 1, got 0"):
        euclidean(0)
    m0 = attitude(n_vec=0)
    assert (m0.nx, m0.nd, m0.name) == (4, 3, "S3xR0")
    with pytest.raises(ShapeError, match="attitude manifold needs n_vec >= 0, got -1"):
        attitude(n_vec=-1)
    a4 = attitude_additive(4)
    assert (a4.nx, a4.nd, a4.name) == (4, 4, "R4/normalised")
    with pytest.raises(ShapeError, match="additive attitude chart needs n >= 4, got 3"):
        attitude_additive(3)
    assert attitude().name == "S3xR3" and attitude(renormalise=True).name == "S3xR3/normalised"
    assert attitude().normalise is None and euclidean(3).normalise is None


def test_heading_state_chart_moves_the_bias_additively():
    m = attitude(n_vec=4)  # [q, omega, b]
    q = Q.from_rpy(0.1, -0.2, 0.3)
    x = np.r_[q, 0.5, -0.25, 0.125, 2.0]
    d = np.array([0.01, -0.02, 0.03, 1.0, 2.0, 3.0, -4.0])
    y = np.asarray(m.oplus(x, d), float).ravel()
    np.testing.assert_allclose(y[:4], Q.mul(q, Q.from_rotation_vector(d[:3])), atol=1e-15)
    np.testing.assert_allclose(y[4:], [1.5, 1.75, 3.125, -2.0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(np.asarray(m.ominus(y, x), float).ravel(), d, atol=1e-14)
    mean = m.mean(2)
    X = np.stack([x, y], axis=1)
    xm = np.asarray(mean(X, [0.75, 0.25], x), float).ravel()
    np.testing.assert_allclose(xm[4:], 0.75 * x[4:] + 0.25 * y[4:], atol=1e-15)
    np.testing.assert_allclose(xm[:4], Q.mul(q, Q.from_rotation_vector(0.25 * d[:3])), atol=1e-12)
    e = euclidean(3)
    np.testing.assert_array_equal(np.asarray(e.ominus([1.0, 2.0, 3.0], [0.5, 4.0, -1.0])).ravel(),
                                  [0.5, -2.0, 4.0])
    np.testing.assert_array_equal(np.asarray(e.mean(2)(np.array([[1.0, 3.0]] * 3), [0.25, 0.75],
                                                       np.zeros(3))).ravel(), [2.5] * 3)


@pytest.mark.parametrize("qs,w,msg", [(np.zeros((3, 3)), None, r"rows of shape \(N, 4\), got \(3, 3\)"),
                                      (np.zeros(4), None, r"rows of shape \(N, 4\), got \(4,\)"),
                                      (np.eye(4), np.ones(3) / 3, r"weights must have shape \(4,\), got \(3,\)")])
def test_quaternion_rows_are_checked(qs, w, msg):
    with pytest.raises(ShapeError, match=msg):
        karcher_mean(qs, w)
    with pytest.raises(ShapeError, match=msg):
        chordal_mean(qs, w)


def test_chordal_mean_sign_and_weights():
    a = np.array([math.cos(0.2), math.sin(0.2), 0.0, 0.0])
    b = -np.array([math.cos(0.4), math.sin(0.4), 0.0, 0.0])  # the other sign of a rotation
    m = chordal_mean(np.stack([a, b]), np.array([0.5, 0.5]))
    assert m[0] > 0
    np.testing.assert_allclose(m, [math.cos(0.3), math.sin(0.3), 0, 0], atol=1e-12)
    m = chordal_mean(np.stack([a, -b]), np.array([1.0, 0.0]))
    np.testing.assert_allclose(m, a, atol=1e-12)

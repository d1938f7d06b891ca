"""The velocity filter's online acceleration random walk (``make_vukf(adaptive=...)``,
:mod:`ballbot_casadi.estimation.adaptive_walk`).

Matched synthetic data as in ``test_vukf_consistency.py`` (the truth follows the matched
model: ``a_k = a_{k-1} + w_k`` acting during the period, the offset ``b`` walking by its
own noise and the image of a rate error, encoders at the true body rate plus
quantisation-sized noise, the accelerometer (5.18) plus noise, the gyroscope reading as
the encoder prediction's rate), here with a *known* walk per axis ``(QX, QY)`` that the
filter is not told: it starts from a prior a decade off, and its estimate must converge
to the truth; then NEES/NIS over 25 seeds in the chi2 bands with the adapted walk.
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi import load_params
from ballbot_casadi.analysis.consistency import chi2_band, nees
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.constants import TS_CONTROL as TS
from ballbot_casadi.errors import ShapeError
from ballbot_casadi.estimation.adaptive_walk import (
    WALK_SIZE,
    WalkAdaptation,
    adapt_walk,
    make_walk_sample,
    with_walk,
)
from ballbot_casadi.estimation.tuning import SIGMA_ACC, SIGMA_ENC, SIGMA_GYRO
from ballbot_casadi.estimation.velocity import make_vukf

PAR = load_params()
PV = PAR.to_vector()
N, SKIP, SEEDS = 3200, 2000, 25  # 16 s; judged after 10 s = 5 time constants
QX, QY, QB = 1e-2, 4e-2, 1e-8  # the true walk per axis (the standing COM robot's ~ 0.1)
R6 = np.block([[SIGMA_ENC, np.zeros((3, 3))], [np.zeros((3, 3)), SIGMA_ACC]])
P0 = np.diag([1e-2, 1e-2, 1e-1, 1e-1, 1e-4, 1e-4, 1e-4])
ATT_Q = Q.from_rpy(0.03, -0.02, 0.7)
ADAPT = WalkAdaptation()


def _data(ws, seed: int, qa=(QX, QY), n=N):
    """Truth (7, n+1), readings (6, n), filter attitude inputs (7, n); ``qa`` the walk
    per axis (a ``(n, 2)`` array: a walk that changes over time)."""
    rng = np.random.default_rng(seed)
    qa = np.broadcast_to(np.asarray(qa, float), (n, 2))
    x = rng.multivariate_normal(np.zeros(7), P0)
    xs, zs, atts = [x], [], []
    la, lg = np.linalg.cholesky(SIGMA_ACC), np.linalg.cholesky(SIGMA_GYRO)
    for k in range(n):
        a = x[2:4] + np.sqrt(qa[k]) * rng.standard_normal(2)
        v_mid = x[0:2] + TS / 2 * a
        f_b = Q.rotate_inv(ATT_Q, np.r_[a, PAR.g])
        skew = np.array([[0.0, -f_b[2], f_b[1]], [f_b[2], 0.0, -f_b[0]], [-f_b[1], f_b[0], 0.0]])
        db = math.sqrt(QB) * rng.standard_normal(3) + TS * skew @ (lg @ rng.standard_normal(3))
        x = np.r_[x[0:2] + TS * a, a, x[4:7] + db]
        omega = 0.3 * rng.standard_normal(3)
        dq = 0.5 * Q.mul(ATT_Q, np.r_[0.0, omega])
        dphi = np.asarray(ws(np.r_[0.0, 0.0, ATT_Q, v_mid, dq], PV)).ravel()
        ticks = PAR.n_ticks / (2 * math.pi) * TS * dphi
        acc = Q.rotate_inv(ATT_Q, np.r_[a, PAR.g]) + x[4:7]
        zs.append(np.r_[ticks, acc] + np.r_[rng.standard_normal(3) / 3.0, la @ rng.standard_normal(3)])
        xs.append(x)
        atts.append(np.r_[ATT_Q, omega + lg @ rng.standard_normal(3)])
    return np.array(xs).T, np.array(zs).T, np.array(atts).T


def _run(f, ws, seed, prior=(1e-1, 1e-1), qa=(QX, QY), n=N, z_edit=None):
    """Run the adaptive filter (state, covariance and walk accumulated); returns NEES,
    NIS and the walk estimate per period (n, 2)."""
    X, Z, A = _data(ws, seed, qa, n)
    if z_edit is not None:
        z_edit(Z)
    Qn = np.diag([0.0, 0.0, *prior, QB, QB, QB])
    i_q, o_q = f.index_in("walk"), f.index_out("walk_next")
    acc = f.mapaccum("v", n, [0, 1, i_q], [0, 1, o_q])
    out = acc(np.zeros(7), P0, Z, A, np.zeros((3, 3 * n)), Qn, R6, TS, PV,
              np.tile(SIGMA_GYRO, (1, n)), np.zeros(WALK_SIZE))
    xh = np.asarray(out[0]).T
    P = np.asarray(out[1]).T.reshape(n, 7, 7).transpose(0, 2, 1)
    q = np.asarray(out[o_q]).T[:, :2]
    return nees(xh - X[:, 1:].T, P), np.asarray(out[3]).ravel(), q


@pytest.fixture(scope="module")
def ws(model_functions):
    return model_functions["wheel_speeds"]


@pytest.fixture(scope="module")
def adaptive(ws):
    return make_vukf(ws, midpoint=True, matched=True, adaptive=ADAPT)


@pytest.fixture(scope="module")
def runs(adaptive, ws):
    return [_run(adaptive, ws, s) for s in range(SEEDS)]


def test_the_walk_estimate_converges_to_the_known_process_noise(runs):
    """From a prior of 0.1 on both axes (10x and 2.5x the truth) the estimate, averaged
    over the last 6 s of each run, is within 10 % of the true walk per axis on every seed,
    and within 4 % over the 25 seeds (its spread ~ sqrt(lambda) = 5 % per instant; measured
    0.0102/0.0399, at most 8 % off on a seed)."""
    q = np.array([r[2][SKIP:].mean(axis=0) for r in runs])  # (SEEDS, 2)
    np.testing.assert_allclose(q, np.tile([QX, QY], (SEEDS, 1)), rtol=0.10)
    np.testing.assert_allclose(q.mean(axis=0), [QX, QY], rtol=0.04)


def test_nees_and_nis_over_25_seeds_lie_in_the_chi2_bands_with_the_adapted_walk(runs):
    """Measured NEES 6.77 in [5.61, 8.54] (7 states), NIS 5.98 in [4.72, 7.43]."""
    ne = np.array([r[0][SKIP:].mean() for r in runs])
    ni = np.array([r[1][SKIP:].mean() for r in runs])
    lo, hi = chi2_band(7, SEEDS)
    assert lo <= ne.mean() <= hi
    lo, hi = chi2_band(6, SEEDS)
    assert lo <= ni.mean() <= hi


def test_the_estimate_follows_a_change_of_the_walk(adaptive, ws):
    """A standing-like walk (0.1) for 12 s, then a moving-like one (0.01): 10-12 s after
    the switch (5-6 time constants: the old walk's share decays to ~4 % of the new one) the
    estimate is within 15 % of the new walk."""
    n = 4800
    qa = np.where(np.arange(n)[:, None] < n // 2, 0.1, 0.01) * np.ones((n, 2))
    _, _, q = _run(adaptive, ws, 7, prior=(0.02, 0.02), qa=qa, n=n)
    np.testing.assert_allclose(q[n // 2 - 400:n // 2].mean(axis=0), [0.1, 0.1], rtol=0.15)
    np.testing.assert_allclose(q[-400:].mean(axis=0), [0.01, 0.01], rtol=0.15)


def test_a_glitch_moves_the_estimate_by_at_most_lambda_times_the_ceiling(adaptive, ws):
    """A 50 m/s^2 accelerometer glitch (the filter is ungated here): the walk stays in
    [floor, ceiling], jumps by at most ``lambda s_max`` (the sample enters clipped to
    ``sample_max``: 0.025, 2.5 times the walk of 0.01) and is back within 15 % of its
    unglitched value 4 time constants later (the excess decays to ``0.025 e^-4``, 5 %)."""
    n, k = 2400, 800

    def glitch(Z):
        Z[3:5, k] += 50.0

    _, _, q0 = _run(adaptive, ws, 3, prior=(QX, QY), n=n)
    _, _, q1 = _run(adaptive, ws, 3, prior=(QX, QY), n=n, z_edit=glitch)
    assert np.all(q1 >= ADAPT.floor) and np.all(q1 <= ADAPT.ceiling)
    jump = q1[k] - q0[k]
    assert np.all(jump <= ADAPT.forgetting * ADAPT.sample_max * (1 + 1e-9))
    assert np.all(jump > 0.5 * ADAPT.forgetting * ADAPT.sample_max)  # the glitch did enter
    np.testing.assert_allclose(q1[-1], q0[-1], rtol=0.15)


def _step(q, s, valid, n=1e9, a=ADAPT):
    """``adapt_walk`` from the state ``[q, n]`` with the walk ``q`` used."""
    ws, qs, ss, vs = ca.MX.sym("w", 3), ca.MX.sym("q", 2), ca.MX.sym("s", 2), ca.MX.sym("v")
    f = ca.Function("f", [ws, qs, ss, vs], [adapt_walk(ws, qs, ss, vs > 0.5, a)])
    return np.asarray(f(np.r_[q, n], q, s, valid)).ravel()


def test_the_update_is_the_sage_husa_mean_clipped_to_its_bounds():
    lam, n_max = ADAPT.forgetting, 1.0 / ADAPT.forgetting
    np.testing.assert_allclose(_step([0.02, 0.05], [0.01, 0.09], 1),
                               [(1 - lam) * 0.02 + lam * 0.01, (1 - lam) * 0.05 + lam * 0.09, n_max],
                               rtol=1e-14, atol=0)
    # growing memory at the start: the prior counts as n0 samples, the k-th has 1/(n0 + k)
    w = 1.0 / (ADAPT.prior_samples + 5 + 1)
    np.testing.assert_allclose(_step([0.02, 0.05], [0.01, 0.09], 1, n=5),
                               [(1 - w) * 0.02 + w * 0.01, (1 - w) * 0.05 + w * 0.09, 6],
                               rtol=1e-14, atol=0)
    # a missing reading (not every component used) or a non-finite sample: unchanged
    np.testing.assert_array_equal(_step([0.02, 0.05], [0.01, 0.09], 0, n=5), [0.02, 0.05, 5])
    np.testing.assert_array_equal(_step([0.02, 0.05], [np.nan, 0.0], 1, n=5), [0.02, 0.05, 5])
    np.testing.assert_array_equal(_step([0.02, 0.05], [np.inf, 0.0], 1, n=5), [0.02, 0.05, 5])
    # the bounds: a negative sample enters as 0 and cannot take it below the floor, a huge
    # one enters clipped to sample_max and cannot take it above the ceiling
    assert np.all(_step([ADAPT.floor, ADAPT.floor], [-5.0, 0.0], 1)[:2] == ADAPT.floor)
    np.testing.assert_allclose(_step([0.02, 0.05], [-5.0, 0.0], 1)[:2],
                               [(1 - lam) * 0.02, (1 - lam) * 0.05], rtol=1e-14)
    big = _step([0.02, ADAPT.ceiling], [1e6, 1e6], 1)[:2]
    np.testing.assert_allclose(big, [(1 - lam) * 0.02 + lam * ADAPT.sample_max, ADAPT.ceiling],
                               rtol=1e-14)


def test_the_sample_is_the_scoring_step_of_the_innovation_likelihood():
    """``s_i = q_i + (a_i^2 - b_i) / b_i^2``, ``a_i = h_i^T S^-1 nu``, ``b_i = h_i^T S^-1 h_i``
    (numpy reference); for a scalar measurement of the walk (``h = 1``) it is
    ``nu^2 - (S - q)``: the squared innovation less the variance that is not the walk."""
    rng = np.random.default_rng(0)
    A = rng.standard_normal((6, 6))
    S = A @ A.T + 0.5 * np.eye(6)
    nu, Hg, q = rng.standard_normal(6), rng.standard_normal((6, 2)), np.array([0.02, 0.04])
    s, ok = make_walk_sample(6)(nu, S, Hg, q)
    Si = np.linalg.inv(S)
    a, b = Hg.T @ Si @ nu, np.einsum("ji,jk,ki->i", Hg, Si, Hg)
    np.testing.assert_allclose(np.asarray(s).ravel(), q + (a * a - b) / b ** 2, rtol=1e-10)
    assert float(ok) == 1.0
    # scalar: S = 0.3 (of which q = 0.1 is the walk), nu = 0.5 -> 0.25 - 0.2 = 0.05
    s1, _ = make_walk_sample(1)(np.array([0.5]), np.array([[0.3]]), np.array([[1.0, 1.0]]),
                                np.array([0.1, 0.1]))
    np.testing.assert_allclose(np.asarray(s1).ravel(), [0.05, 0.05], rtol=1e-12)
    # a covariance that is not positive definite gives no sample
    assert float(make_walk_sample(6)(nu, -S, Hg, q)[1]) == 0.0


def test_with_walk_replaces_the_acceleration_block_only():
    Qs = np.arange(49.0).reshape(7, 7)
    Qs = Qs + Qs.T
    Qm, q = ca.MX.sym("Q", 7, 7), ca.MX.sym("q", 2)
    out = np.asarray(ca.Function("f", [Qm, q], [with_walk(Qm, q)])(Qs, [0.3, 0.7]))
    ref = Qs.copy()
    ref[2:4, :] = 0.0
    ref[:, 2:4] = 0.0
    ref[2, 2], ref[3, 3] = 0.3, 0.7
    np.testing.assert_array_equal(out, ref)


@pytest.mark.parametrize("bad", [dict(forgetting=0.0), dict(forgetting=1.0),
                                 dict(floor=0.0), dict(floor=2.0, ceiling=1.0),
                                 dict(ceiling=float("nan")), dict(sample_max=0.5),
                                 dict(prior_samples=-1.0)])
def test_walk_adaptation_refuses_bad_constants(bad):
    with pytest.raises(ShapeError, match="walk adaptation"):
        WalkAdaptation(**bad)

"""Chi-square innovation gating of measurement groups (estimation.core.InnovationGate,
estimation.linalg.make_innovation_gate): the test statistic and thresholds against hand
computation, the group a glitch hits, the lock-out guard, and the gated filters."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from scipy.stats import chi2

from ballbot_casadi.errors import BallbotTypeError, ShapeError
from ballbot_casadi.estimation import DEFAULT_TUNING, make_qekf, make_qukf, make_vekf, make_vukf
from ballbot_casadi.estimation.attitude import ATTITUDE_GATE, qekf_initial_covariance
from ballbot_casadi.estimation.core import FilterModel, InnovationGate, make_filter
from ballbot_casadi.estimation.manifold import euclidean
from ballbot_casadi.estimation.tuning import (
    GATE_MAX_REJECTIONS,
    GATE_PROBABILITY,
    GATE_SCALE_ATTITUDE,
    GATE_SCALE_VELOCITY,
)
from ballbot_casadi.estimation.velocity import VELOCITY_GATE
from ballbot_casadi.core.params import load_params
from ballbot_casadi.model.dynamics import make_wheel_speeds

RNG = np.random.default_rng(2302)
P_VEC = load_params().to_vector()
G = load_params().g


def _spd(n: int, scale: float = 1.0) -> np.ndarray:
    A = RNG.standard_normal((n, n))
    return scale * (A @ A.T + 0.5 * np.eye(n))


# ----------------------------------------------------------------- the gate Function
def test_thresholds_are_scaled_chi_square_quantiles_per_valid_count():
    gate = InnovationGate((("a", (0, 1, 2)), ("b", (3,))), probability=0.99, scale=2.5)
    thr = gate.thresholds()
    np.testing.assert_allclose(thr[0], [2.5 * chi2.ppf(0.99, k) for k in (1, 2, 3)], rtol=1e-14)
    np.testing.assert_allclose(thr[1], [2.5 * 6.6348966010212145], rtol=1e-12)  # chi2(1) 99 %
    # the shipped gates: 1 - 1e-6 with 3 dof is 30.66 (textbook table value)
    assert GATE_PROBABILITY == 1.0 - 1e-6
    np.testing.assert_allclose(ATTITUDE_GATE.thresholds()[1][2], GATE_SCALE_ATTITUDE * 30.6648,
                               rtol=1e-5)
    np.testing.assert_allclose(VELOCITY_GATE.thresholds()[0][2], GATE_SCALE_VELOCITY * 30.6648,
                               rtol=1e-5)


def _gate_fn(prob=0.99, K=3):
    gate = InnovationGate((("a", (0, 1, 2)), ("b", (3, 4))), probability=prob, max_rejections=K)
    return gate, gate.function(5)


def test_statistic_is_the_groups_own_normalised_innovation_at_the_threshold():
    gate, f = _gate_fn()
    S = _spd(5)
    zp = RNG.standard_normal(5)
    thr_a = chi2.ppf(0.99, 3)
    # innovation of group a along a direction, scaled to put d just below / above the limit
    v = RNG.standard_normal(3)
    d_unit = v @ np.linalg.solve(S[:3, :3], v)
    for factor, rejected in ((0.999, 0.0), (1.001, 1.0)):
        z = zp.copy()
        z[:3] += v * np.sqrt(factor * thr_a / d_unit)
        z_g, rej, n_next = (np.asarray(o, float).ravel() for o in f(S, z, zp, np.zeros(2)))
        np.testing.assert_array_equal(rej, [rejected, 0.0])
        np.testing.assert_array_equal(n_next, [rejected, 0.0])
        np.testing.assert_array_equal(np.isnan(z_g[:3]), [bool(rejected)] * 3)
        np.testing.assert_array_equal(z_g[3:], z[3:])
    # the statistic uses the group's block only: a huge correlation to group b's innovation
    # does not enter (the joint d would differ)
    z = zp.copy()
    z[3:] += 1e3
    _, rej, _ = f(S, z, zp, np.zeros(2))
    np.testing.assert_array_equal(np.asarray(rej).ravel(), [0.0, 1.0])


def test_missing_components_lower_the_degrees_of_freedom():
    _, f = _gate_fn()
    S = np.diag([1.0, 1.0, 1.0, 1.0, 1.0])
    zp = np.zeros(5)
    # one valid component of group a with nu^2 between chi2(1) and chi2(3) quantiles:
    # rejected with 1 dof (6.63), it would pass with the 3-dof limit (11.34)
    z = np.array([np.sqrt(9.0), np.nan, np.nan, 0.0, 0.0])
    _, rej, _ = f(S, z, zp, np.zeros(2))
    assert np.asarray(rej).ravel()[0] == 1.0
    z = np.array([np.sqrt(9.0), 0.0, 0.0, 0.0, 0.0])
    _, rej, _ = f(S, z, zp, np.zeros(2))
    assert np.asarray(rej).ravel()[0] == 0.0
    # an all-missing group is never rejected; an infinite innovation always is
    z = np.array([np.nan, np.nan, np.nan, 1e200, 1e200])
    z_g, rej, _ = f(S, z, zp, np.zeros(2))
    np.testing.assert_array_equal(np.asarray(rej).ravel(), [0.0, 1.0])


def test_counters_and_the_lock_out_guard():
    _, f = _gate_fn(K=3)
    S, zp = np.eye(5), np.zeros(5)
    bad = np.array([100.0, 0, 0, 0, 0])
    good = np.zeros(5)
    n = np.zeros(2)
    seen = []
    for z in (bad, bad, bad, bad, bad, good, bad):
        _, rej, n = f(S, z, zp, n)
        seen.append((float(np.asarray(rej).ravel()[0]), float(np.asarray(n).ravel()[0])))
    # rejected 3 times, then the gate is open (used, counter held at K) until a reading
    # passes, which resets it; the next outlier is rejected again
    assert seen == [(1, 1), (1, 2), (1, 3), (0, 3), (0, 3), (0, 0), (1, 1)]


def test_gate_definition_is_checked():
    with pytest.raises(ShapeError):
        InnovationGate((("a", (0, 1)), ("b", (1, 2))))  # overlapping
    with pytest.raises(ShapeError):
        InnovationGate((("a", (0,)),), probability=1.0)
    with pytest.raises(ShapeError):
        InnovationGate((("a", (0,)),), max_rejections=0)
    with pytest.raises(ShapeError):
        InnovationGate((("a", (0,)),), scale=-1.0)
    with pytest.raises(BallbotTypeError):
        InnovationGate((("a", [0]),))
    with pytest.raises(ShapeError):
        InnovationGate((("a", (0, 7)),)).function(3)
    with pytest.raises(ShapeError, match="index beyond the 3 measurements"):
        InnovationGate((("a", (0, 3)),)).function(3)  # one past the last (indices 0..2)
    assert InnovationGate((("a", (0, 2)),)).function(3).size1_in(1) == 3  # the last is fine


# ----------------------------------------------------------------- the generic core
def _random_walk_filter(kind: str, K: int = 5):
    """1-D random walk measured directly (z = x), gate on the single component."""
    x, u, dt, p = ca.SX.sym("x"), ca.SX.sym("u"), ca.SX.sym("dt"), ca.SX.sym("p")
    f = ca.Function("f", [x, u, dt, p], [x])
    h = ca.Function("h", [x, u, dt, p], [x])
    gate = InnovationGate((("z", (0,)),), max_rejections=K)
    return make_filter("rw", FilterModel(euclidean(1), f, h, "additive"), kind, 0.0, gate)


@pytest.mark.parametrize("kind", ["ukf", "ekf"])
def test_lock_out_guard_follows_a_real_step_and_a_glitch_is_ignored(kind):
    K = 5
    F = _random_walk_filter(kind, K)
    Qn, R = np.array([[1e-3]]), np.array([[1e-2]])

    def run(zs):
        xh, P, n, out = np.zeros(1), np.array([[1e-2]]), np.zeros(1), []
        for z in zs:
            r = F(xh, P, np.array([z]), 0, Qn, R, 1.0, 0, n)
            xh, P, n = np.asarray(r[0]).ravel(), np.asarray(r[1]), np.asarray(r[7]).ravel()
            out.append((xh[0], float(r[6])))
        return np.array(out)

    base = [0.0] * 50
    # one glitch: rejected, the estimate does not move
    glitch = run(base[:20] + [50.0] + base[21:])
    np.testing.assert_array_equal(glitch[:, 1], [0] * 20 + [1] + [0] * 29)
    np.testing.assert_allclose(glitch[:, 0], 0.0, atol=1e-12)
    # a real step of 5 (50 sigma of R): rejected K times, then followed (the filter's own
    # gain, about 0.27 here)
    step = run(base[:20] + [5.0] * 80)
    assert step[:, 1].sum() == K and np.all(step[20:20 + K, 1] == 1)
    assert abs(step[-1, 0] - 5.0) < 0.05
    # without the guard (a huge K) the filter would stay locked on the old value
    F_locked = _random_walk_filter(kind, 10**6)
    xh, P, n = np.zeros(1), np.array([[1e-2]]), np.zeros(1)
    for _ in range(80):
        r = F_locked(xh, P, np.array([5.0]), 0, Qn, R, 1.0, 0, n)
        xh, P, n = np.asarray(r[0]).ravel(), np.asarray(r[1]), np.asarray(r[7]).ravel()
    assert abs(xh[0]) < 1e-12


@pytest.mark.parametrize("kind", ["ukf", "ekf"])
def test_lock_out_guard_after_a_long_dropout(kind):
    """The truth moves while the readings are missing by more than the filter's model
    allows: the first readings back fail the gate, the guard lets them in."""
    K = 5
    F = _random_walk_filter(kind, K)
    Qn, R = np.array([[1e-4]]), np.array([[1e-2]])
    xh, P, n = np.zeros(1), np.array([[1e-3]]), np.zeros(1)
    zs = [0.0] * 10 + [np.nan] * 500 + [5.0] * 60  # P grows to 0.05 only; 5 is 20 sigma
    rej = []
    for z in zs:
        r = F(xh, P, np.array([z]), 0, Qn, R, 1.0, 0, n)
        xh, P, n = np.asarray(r[0]).ravel(), np.asarray(r[1]), np.asarray(r[7]).ravel()
        rej.append(float(r[6]))
    assert sum(rej) == K and np.all(np.array(rej[510:510 + K]) == 1)
    assert abs(xh[0] - 5.0) < 0.01


# ----------------------------------------------------------------- the package's filters
def _attitude_run(F, P0, z):
    t = DEFAULT_TUNING["qukf"]
    x0 = np.array([1.0, 0, 0, 0, 0.1, -0.05, 0.02])
    return F(xhat=x0, P=P0, z=z, Q=t.Q, R=t.R, dt=0.005, p=P_VEC, a=np.zeros(3), n_rej=np.zeros(2))


@pytest.mark.parametrize("make,P0", [(make_qukf, DEFAULT_TUNING["qukf"].P0),
                                     (make_qekf, qekf_initial_covariance())])
def test_attitude_filter_rejects_the_glitching_sensor_only(make, P0):
    F = make(compensate_acceleration=True, gate=True)
    z = np.array([0.3, -0.2, G, 0.1, -0.05, 0.02])
    clean = _attitude_run(F, P0, z)
    np.testing.assert_array_equal(np.asarray(clean["rejected"]).ravel(), [0, 0])
    # ungated filter gives the same result on a clean reading
    plain = make(compensate_acceleration=True)(xhat=[1.0, 0, 0, 0, 0.1, -0.05, 0.02], P=P0, z=z,
                                                Q=DEFAULT_TUNING["qukf"].Q, R=DEFAULT_TUNING["qukf"].R,
                                                dt=0.005, p=P_VEC, a=np.zeros(3))
    np.testing.assert_allclose(np.asarray(clean["xhat_next"]), np.asarray(plain["xhat_next"]),
                               rtol=0, atol=1e-15)
    for cols, value, expected in ((slice(3, 6), 1000.0, [0, 1]), (slice(0, 3), 1e20, [1, 0])):
        zg = z.copy()
        zg[cols.start] += value
        out = _attitude_run(F, P0, zg)
        np.testing.assert_array_equal(np.asarray(out["rejected"]).ravel(), expected)
        np.testing.assert_array_equal(np.asarray(out["n_rej_next"]).ravel(), expected)
        # exactly the predict-only step for that sensor
        zn = z.copy()
        zn[cols] = np.nan
        ref = _attitude_run(F, P0, zn)
        np.testing.assert_allclose(np.asarray(out["xhat_next"]), np.asarray(ref["xhat_next"]),
                                   rtol=0, atol=1e-15)
        np.testing.assert_allclose(np.asarray(out["P_next"]), np.asarray(ref["P_next"]),
                                   rtol=0, atol=1e-18)


@pytest.mark.parametrize("make", [make_vukf, make_vekf])
def test_velocity_filter_rejects_the_glitching_sensor_only(make):
    F = make(make_wheel_speeds(), midpoint=True, gate=True)
    t = DEFAULT_TUNING["vukf"]
    att = np.array([1.0, 0, 0, 0, 0, 0, 0])
    x0 = np.array([0.1, 0.0, 0.0, 0.0, 0, 0, 0])
    enc = np.asarray(make_vukf(make_wheel_speeds(), midpoint=True)(
        xhat=x0, P=t.P0, z=np.full(6, np.nan), att=att, P_att=1e-6 * np.eye(3), Q=t.Q, R=t.R,
        dt=0.005, p=P_VEC)["nu"]).ravel()  # all missing: nu = 0; use a plausible reading below
    assert np.all(enc == 0)
    z = np.array([3.0, -1.0, -2.0, 0.0, 0.0, G])

    def run(zz):
        return F(xhat=x0, P=t.P0, z=zz, att=att, P_att=1e-6 * np.eye(3), Q=t.Q, R=t.R, dt=0.005,
                 p=P_VEC, n_rej=np.zeros(2))

    np.testing.assert_array_equal(np.asarray(run(z)["rejected"]).ravel(), [0, 0])
    for cols, value, expected in ((slice(0, 3), 5000.0, [1, 0]), (slice(3, 6), 1e20, [0, 1])):
        zg = z.copy()
        zg[cols.start] += value
        out = run(zg)
        np.testing.assert_array_equal(np.asarray(out["rejected"]).ravel(), expected)
        zn = z.copy()
        zn[cols] = np.nan
        np.testing.assert_allclose(np.asarray(out["xhat_next"]), np.asarray(run(zn)["xhat_next"]),
                                   rtol=0, atol=1e-15)


def test_default_max_rejections_is_a_tenth_of_a_second_at_the_thesis_period():
    assert GATE_MAX_REJECTIONS * 0.005 == pytest.approx(0.1)


def test_group_names_label_the_sensor_whose_reading_glitched():
    """The groups' names are what the logs, metrics and FMU outputs report: a glitch of
    the accelerometer (z[0:3] of the attitude filter, z[3:6] of the velocity filter) must
    be reported under "acc", of the gyroscope under "gyro", of the encoders under "enc"."""
    F = make_qukf(compensate_acceleration=True, gate=True)
    P0 = DEFAULT_TUNING["qukf"].P0
    z = np.array([0.3, -0.2, G, 0.1, -0.05, 0.02])
    for sensor, col, value in (("acc", 0, 1e20), ("gyro", 4, 1000.0)):
        zg = z.copy()
        zg[col] += value
        rej = np.asarray(_attitude_run(F, P0, zg)["rejected"]).ravel()
        assert rej[ATTITUDE_GATE.names.index(sensor)] == 1 and rej.sum() == 1, sensor
    V = make_vukf(make_wheel_speeds(), midpoint=True, gate=True)
    t = DEFAULT_TUNING["vukf"]
    zv = np.array([3.0, -1.0, -2.0, 0.0, 0.0, G])
    for sensor, col, value in (("enc", 1, 5000.0), ("acc", 5, 1e20)):
        zg = zv.copy()
        zg[col] += value
        rej = np.asarray(V(xhat=[0.1, 0, 0, 0, 0, 0, 0], P=t.P0, z=zg, att=[1.0, 0, 0, 0, 0, 0, 0],
                           P_att=1e-6 * np.eye(3), Q=t.Q, R=t.R, dt=0.005, p=P_VEC,
                           n_rej=np.zeros(2))["rejected"]).ravel()
        assert rej[VELOCITY_GATE.names.index(sensor)] == 1 and rej.sum() == 1, sensor

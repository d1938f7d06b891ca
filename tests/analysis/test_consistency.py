"""Filter consistency metrics: chi-square bands, NIS/NEES on a linear Kalman filter."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

from ballbot_casadi.analysis.consistency import (
    chi2_band,
    check_consistency,
    ensemble_average,
    nees,
    nis,
    time_average,
)
from ballbot_casadi.errors import ShapeError


@pytest.mark.parametrize("dim, n, conf", [(1, 1, 0.95), (6, 1, 0.95), (2, 50, 0.95),
                                          (6, 2000, 0.99), (3, 25, 0.9)])
def test_band_matches_scipy(dim, n, conf):
    lo, hi = chi2_band(dim, n, conf)
    assert lo == pytest.approx(chi2.ppf((1 - conf) / 2, n * dim) / n, rel=1e-12)
    assert hi == pytest.approx(chi2.ppf((1 + conf) / 2, n * dim) / n, rel=1e-12)


def test_band_textbook_values_and_coverage():
    # Bar-Shalom et al. 2001 §5.4: N = 50 runs, n_x = 2 -> 95 % region [1.5, 2.6]
    lo, hi = chi2_band(2, 50)
    assert (round(lo, 1), round(hi, 1)) == (1.5, 2.6)
    lo, hi = chi2_band(1, 1)  # classic table: 0.000982, 5.024
    assert lo == pytest.approx(0.000982, rel=1e-3) and hi == pytest.approx(5.024, rel=1e-3)
    # independent check by sampling: the mean of N chi2(dim) lies inside 95 % of the time
    rng = np.random.default_rng(7)
    dim, n = 3, 20
    means = (rng.standard_normal((20000, n, dim)) ** 2).sum(axis=2).mean(axis=1)
    lo, hi = chi2_band(dim, n)
    assert np.mean((means >= lo) & (means <= hi)) == pytest.approx(0.95, abs=0.006)


def test_bad_arguments_are_one_clear_error():
    with pytest.raises(ShapeError, match="dim must be an integer >= 1"):
        chi2_band(0)
    with pytest.raises(ShapeError, match=r"confidence must be a number in \(0, 1\)"):
        chi2_band(2, 10, 1.5)
    with pytest.raises(ShapeError, match="NEES: errors must be"):
        nees(np.zeros((4, 2)), np.zeros((4, 3, 3)))
    with pytest.raises(ShapeError, match="no finite samples"):
        time_average([1.0, 2.0], skip=2)


def test_quadratic_forms():
    P = np.array([[4.0, 1.0], [1.0, 2.0]])
    e = np.array([1.0, -2.0])
    assert nees(e, P)[0] == pytest.approx(e @ np.linalg.inv(P) @ e, rel=1e-12)
    assert nis(np.ones((3, 1)), np.full((3, 1, 1), 4.0)) == pytest.approx([0.25] * 3)


# ----------------------------------------------------------------- linear Kalman filter
DT, QV, R_TRUE, STEPS = 0.1, 0.05, 0.2**2, 400
F = np.array([[1.0, DT], [0.0, 1.0]])
G = np.array([[DT**2 / 2], [DT]])
Q = QV * G @ G.T  # white-acceleration (discretised) process noise, exactly as simulated
H = np.array([[1.0, 0.0]])


def _kalman_run(seed: int, r_filter: float):
    """Simulate the constant-velocity target and filter it; returns (NEES, NIS) per step."""
    rng = np.random.default_rng(seed)
    x = np.array([0.0, 1.0])
    xh, P = x + rng.multivariate_normal(np.zeros(2), np.eye(2)), np.eye(2)
    e_nees, e_nis = [], []
    for _ in range(STEPS):
        x = F @ x + G[:, 0] * rng.normal(0, np.sqrt(QV))
        z = H @ x + rng.normal(0, np.sqrt(R_TRUE), 1)
        xh, P = F @ xh, F @ P @ F.T + Q
        S = H @ P @ H.T + r_filter
        nu = z - H @ xh
        K = P @ H.T / S
        xh, P = xh + (K @ nu), (np.eye(2) - K @ H) @ P
        e_nis.append(nis(nu, S)[0])
        e_nees.append(nees(xh - x, P)[0])
    return np.array(e_nees), np.array(e_nis)


def test_matched_kalman_filter_is_consistent():
    runs = [_kalman_run(s, R_TRUE) for s in range(30)]
    E_nees = np.array([r[0] for r in runs])
    E_nis = np.array([r[1] for r in runs])
    # ensemble NEES over 30 seeds after the transient: inside the band at ~95 % of instants
    avg = ensemble_average(E_nees)[50:]
    lo, hi = chi2_band(2, 30)
    assert np.mean((avg >= lo) & (avg <= hi)) >= 0.9
    # time-averaged NIS of every run: inside its band for (almost) every seed
    verdicts = [check_consistency(r, 1, skip=50).inside for r in E_nis]
    assert sum(verdicts) >= 27
    assert check_consistency(E_nees.mean(axis=0), 2, skip=50).mean == pytest.approx(2.0, rel=0.1)


@pytest.mark.parametrize("factor, verdict", [(10.0, "underconfident"), (0.1, "overconfident")])
def test_mistuned_R_is_outside_the_band(factor, verdict):
    for seed in range(5):
        e_nees, e_nis = _kalman_run(seed, factor * R_TRUE)
        res = check_consistency(e_nis, 1, skip=50)
        assert not res.inside and res.verdict == verdict
        assert check_consistency(e_nees, 2, skip=50).verdict == verdict


def test_skip_drops_exactly_the_first_samples_and_non_finite_ones():
    eps = np.array([10.0, 1.0, 2.0, np.nan, 3.0])
    assert time_average(eps, skip=1) == pytest.approx(2.0, rel=1e-15)  # (1 + 2 + 3) / 3
    assert time_average(eps) == pytest.approx(4.0, rel=1e-15)
    res = check_consistency(eps, dim=2, skip=1)
    assert (res.mean, res.n_samples, res.dim) == (pytest.approx(2.0), 3, 2)
    assert (res.lo, res.hi) == pytest.approx(chi2_band(2, 3))
    np.testing.assert_allclose(ensemble_average(np.array([[1.0, 2.0, 3.0], [3.0, 4.0, 5.0]])),
                               [2.0, 3.0, 4.0], rtol=1e-15)


def test_verdict_at_the_band_edges():
    """The band is closed: a mean on either edge is consistent, the next float outside is
    over- (above) or underconfident (below); the study's verdicts read ``verdict``."""
    from ballbot_casadi.analysis.consistency import ConsistencyResult

    lo, hi = chi2_band(6, 3800)
    for mean, verdict in ((lo, "consistent"), (hi, "consistent"), (6.0, "consistent"),
                          (np.nextafter(hi, np.inf), "overconfident"),
                          (np.nextafter(lo, -np.inf), "underconfident")):
        r = ConsistencyResult(float(mean), lo, hi, 6, 3800, 0.95)
        assert r.verdict == verdict and r.inside == (verdict == "consistent")


def test_the_ensemble_average_is_over_runs_of_a_runs_by_time_array():
    np.testing.assert_array_equal(ensemble_average([[1.0, 2.0, 3.0], [3.0, 4.0, 9.0]]), [2.0, 3.0, 6.0])
    for bad in ([1.0, 2.0], np.zeros((2, 2, 2))):
        with pytest.raises(ShapeError, match=r"^ensemble_average needs a \(runs, time\) array, got shape"):
            ensemble_average(bad)

"""Filter consistency: chi-square bands and time/ensemble averages of NIS and NEES.

A Kalman filter is *consistent* when its errors have the covariance it reports
(Bar-Shalom, Li & Kirubarajan 2001, "Estimation with Applications to Tracking and
Navigation", §5.4).  Two statistics test it:

* NEES ``eps_k = e_k^T P_k^-1 e_k`` (state error ``e = x_hat - x``, dimension ``n_x``),
  computable only where the truth is known (simulation, Monte Carlo);
* NIS ``eps_nu,k = nu_k^T S_k^-1 nu_k`` (innovation ``nu``, its covariance ``S``,
  dimension ``n_z``), computable from the filter alone.

For a consistent linear-Gaussian filter each is chi-square with ``n`` degrees of freedom.
Averaging ``N`` independent values (over ``N`` Monte Carlo runs at one instant, or over
``N`` time steps of one run: innovations of an optimal filter are white) gives
``N * mean ~ chi2(N n)``, so the two-sided ``confidence`` band of the *mean* is
(Bar-Shalom et al. (5.4.2-7), (5.4.2-8))::
    [chi2.ppf((1 - c)/2, N n) / N,  chi2.ppf((1 + c)/2, N n) / N]

:func:`chi2_band` computes it; :func:`nees`, :func:`nis` the per-sample statistics;
:func:`time_average`, :func:`ensemble_average` the averages; :func:`check_consistency`
puts them together.  A mean above the band means the filter is overconfident (its
covariance too small), below it underconfident.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2

from ballbot_casadi.errors import ShapeError

__all__ = [
    "ConsistencyResult",
    "chi2_band",
    "nees",
    "nis",
    "time_average",
    "ensemble_average",
    "check_consistency",
]


def _positive_int(name: str, v: object) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or int(v) < 1:
        raise ShapeError(f"{name} must be an integer >= 1, got {v!r}")
    return int(v)


def chi2_band(dim: int, n_samples: int = 1, confidence: float = 0.95) -> tuple[float, float]:
    """Two-sided ``confidence`` band of the mean of ``n_samples`` chi2(``dim``) values.

    Parameters
    ----------
    dim
        Degrees of freedom of one statistic (state size for NEES, measurement size for NIS).
    n_samples
        Number of independent values averaged (runs, or time steps).
    confidence
        Probability mass inside the band, in (0, 1).

    Returns
    -------
    (lo, hi)
        ``chi2.ppf((1 -+ confidence)/2, n_samples dim) / n_samples``.
    """
    dim, n = _positive_int("dim", dim), _positive_int("n_samples", n_samples)
    if not (isinstance(confidence, (float, int)) and 0.0 < float(confidence) < 1.0):
        raise ShapeError(f"confidence must be a number in (0, 1), got {confidence!r}")
    c = float(confidence)
    return (float(chi2.ppf((1 - c) / 2, n * dim)) / n, float(chi2.ppf((1 + c) / 2, n * dim)) / n)


def _quadratic(e: np.ndarray, P: np.ndarray, what: str) -> np.ndarray:
    e = np.asarray(e, dtype=float)
    P = np.asarray(P, dtype=float)
    if e.ndim == 1:
        e, P = e[None, :], P[None, :, :]
    if e.ndim != 2 or P.shape != (e.shape[0], e.shape[1], e.shape[1]):
        raise ShapeError(
            f"{what}: errors must be (N, n) and covariances (N, n, n); got {e.shape} and {P.shape}"
        )
    return np.einsum("ki,ki->k", e, np.linalg.solve(P, e[:, :, None])[:, :, 0])


def nees(err: np.ndarray, P: np.ndarray) -> np.ndarray:
    """NEES ``e_k^T P_k^-1 e_k`` per sample: ``err`` (N, n) or (n,), ``P`` (N, n, n) or (n, n)."""
    return _quadratic(err, P, "NEES")


def nis(nu: np.ndarray, S: np.ndarray) -> np.ndarray:
    """NIS ``nu_k^T S_k^-1 nu_k`` per sample: ``nu`` (N, m) or (m,), ``S`` (N, m, m) or (m, m)."""
    return _quadratic(nu, S, "NIS")


def time_average(eps: np.ndarray, skip: int = 0) -> float:
    """Mean of one run's statistic over time, after ``skip`` initial samples (transient)."""
    e = np.asarray(eps, dtype=float).ravel()[int(skip):]
    e = e[np.isfinite(e)]
    if e.size == 0:
        raise ShapeError("time_average: no finite samples after the skipped transient")
    return float(e.mean())


def ensemble_average(eps: np.ndarray) -> np.ndarray:
    """Mean over runs at each instant: ``eps`` (runs, time) -> (time,)."""
    e = np.asarray(eps, dtype=float)
    if e.ndim != 2:
        raise ShapeError(f"ensemble_average needs a (runs, time) array, got shape {e.shape}")
    return e.mean(axis=0)


@dataclass(frozen=True)
class ConsistencyResult:
    """Mean statistic, its band, and the verdict (``inside``; else over/underconfident)."""

    mean: float
    lo: float
    hi: float
    dim: int
    n_samples: int
    confidence: float

    @property
    def inside(self) -> bool:
        return self.lo <= self.mean <= self.hi

    @property
    def verdict(self) -> str:
        if self.inside:
            return "consistent"
        return "overconfident" if self.mean > self.hi else "underconfident"


def check_consistency(eps: np.ndarray, dim: int, confidence: float = 0.95,
                      skip: int = 0) -> ConsistencyResult:
    """Time-average of one run's NIS or NEES against the chi2 band of its dimension.

    ``skip`` drops the initial transient; the band uses the number of samples averaged
    (valid when the samples are independent, as the innovations of a matched filter).
    """
    e = np.asarray(eps, dtype=float).ravel()[int(skip):]
    e = e[np.isfinite(e)]
    mean = time_average(e)
    lo, hi = chi2_band(dim, e.size, confidence)
    return ConsistencyResult(mean, lo, hi, int(dim), int(e.size), float(confidence))

"""Quaternion mean: Karcher (the filters') vs the thesis' sweep (4.20), against references.

References: the Karcher mean iterated to convergence in extended precision
(``np.longdouble``) and the exact minimiser of the thesis' own Frobenius objective (the
principal eigenvector of ``sum w q q^T``).
"""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.estimation.quaternion_mean import (
    chordal_mean,
    karcher_mean,
    make_karcher_mean,
    sweep_mean,
)


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    """Rotation angle between two unit quaternions (sign-invariant), in float64."""
    d = abs(float(np.dot(np.asarray(a, dtype=float), np.asarray(b, dtype=float))))
    return 2.0 * float(np.arccos(min(1.0, d))) if d < 1 - 1e-8 else 2.0 * float(
        np.linalg.norm(Q.vee(Q.mul(Q.conj(np.asarray(a, float)), np.asarray(b, float)))))


def _cloud(rng: np.random.Generator, centre_rpy_deg, spread: float, n: int = 13):
    """Asymmetric cluster of n unit quaternions around a centre, random positive weights."""
    c = Q.from_rpy(*np.radians(centre_rpy_deg))
    rot = spread * rng.standard_normal((n, 3))
    qs = np.array([Q.mul(c, Q.from_rotation_vector(r)) for r in rot])
    w = rng.uniform(0.5, 1.5, n)
    return qs, w / w.sum()


def _reference(qs, w):
    return karcher_mean(qs.astype(np.longdouble), w.astype(np.longdouble), iterations=60)


@pytest.mark.parametrize("spread,iterations", [(1e-3, 3), (1e-2, 3), (0.1, 6), (0.3, 12)])
def test_karcher_mean_reaches_the_extended_precision_reference(spread, iterations):
    rng = np.random.default_rng(int(spread * 1e4))
    qs, w = _cloud(rng, (2.0, -1.5, 30.0), spread)
    qs[::3] *= -1  # the double cover must not matter
    mean = make_karcher_mean(len(w), iterations)
    # Start from one of the points (an O(spread) initial error).
    m = np.array(mean(qs.T, w, qs[1])).ravel()
    ref = _reference(qs, w)
    assert _angle(m, ref) < 2e-15
    assert abs(np.linalg.norm(m) - 1) < 3e-16  # unit by construction, never normalised


def test_karcher_beats_the_thesis_sweep():
    """Thesis (4.20) grid sweep is accurate to its grid; the Karcher mean to rounding."""
    rng = np.random.default_rng(42)
    qs, w = _cloud(rng, (1.3, -0.7, 2.2), 5e-3)
    ref_karcher = _reference(qs, w)
    ref_chordal = chordal_mean(qs, w)
    # Both references agree to O(spread^3) for such a cluster.
    assert _angle(ref_karcher, ref_chordal) < (5e-3) ** 3
    step = 0.2
    sweep = sweep_mean(qs, w, step_deg=step, span_deg=4.0)
    karcher = np.array(make_karcher_mean(len(w))(qs.T, w, qs[0])).ravel()
    err_sweep = _angle(sweep, ref_chordal)  # against the minimiser of its own objective
    err_karcher = _angle(karcher, ref_karcher)
    assert 1e-5 < err_sweep < np.radians(step)  # grid-limited, and the sweep is working
    assert err_karcher < 1e-15
    assert err_karcher * 1e9 < err_sweep
    # The sweep's objective value is also worse than the Karcher mean's.
    M = (w[:, None, None] * qs[:, :, None] * qs[:, None, :]).sum(0)
    assert karcher @ M @ karcher > sweep @ M @ sweep


def test_weighted_mean_of_a_symmetric_set_is_its_centre():
    c = Q.from_rpy(0.3, -0.2, 1.0)
    r = np.array([0.05, -0.02, 0.03])
    qs = np.array([Q.mul(c, Q.from_rotation_vector(s * r)) for s in (1, -1)] + [c])
    m = np.array(make_karcher_mean(3)(qs.T, [0.25, 0.25, 0.5], qs[0])).ravel()
    assert _angle(m, c) < 1e-15

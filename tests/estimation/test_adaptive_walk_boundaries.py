"""adapt_walk at its boundaries, per axis: a sample of exactly the largest finite double
enters (clipped to sample_max), a non-finite one on either axis leaves the state as it
was, and the count saturates at 1 / lambda."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.estimation.adaptive_walk import WalkAdaptation, adapt_walk
from ballbot_casadi.estimation.linalg import FINITE_MAX

ADAPT = WalkAdaptation()


def _step(q, s, valid, n):
    ws, qs, ss, vs = ca.MX.sym("w", 3), ca.MX.sym("q", 2), ca.MX.sym("s", 2), ca.MX.sym("v")
    f = ca.Function("f", [ws, qs, ss, vs], [adapt_walk(ws, qs, ss, vs > 0.5, ADAPT)])
    return np.asarray(f(np.r_[q, n], q, s, valid)).ravel()


@pytest.mark.parametrize("axis", [0, 1])
def test_the_largest_finite_sample_enters_on_either_axis(axis):
    lam, n_max = ADAPT.forgetting, 1.0 / ADAPT.forgetting
    s = np.zeros(2)
    s[axis] = FINITE_MAX
    out = _step([0.02, 0.05], s, 1, n=1e9)
    want = (1 - lam) * np.array([0.02, 0.05])
    want[axis] += lam * ADAPT.sample_max
    np.testing.assert_allclose(out, np.r_[np.minimum(want, ADAPT.ceiling), n_max], rtol=1e-14)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("axis", [0, 1])
def test_a_non_finite_sample_on_either_axis_changes_nothing(axis, bad):
    s = np.array([0.01, 0.03])
    s[axis] = bad
    np.testing.assert_array_equal(_step([0.02, 0.05], s, 1, n=7), [0.02, 0.05, 7])


def test_the_count_saturates_and_a_negative_count_starts_at_zero():
    lam, n_max = ADAPT.forgetting, 1.0 / ADAPT.forgetting
    assert _step([0.02, 0.05], [0.01, 0.01], 1, n=n_max - 1)[2] == n_max
    assert _step([0.02, 0.05], [0.01, 0.01], 1, n=n_max)[2] == n_max
    out = _step([0.02, 0.05], [0.01, 0.01], 1, n=-4)
    w = max(lam, 1.0 / (ADAPT.prior_samples + 0 + 1))
    np.testing.assert_allclose(out, [(1 - w) * 0.02 + w * 0.01, (1 - w) * 0.05 + w * 0.01, 1],
                               rtol=1e-14)

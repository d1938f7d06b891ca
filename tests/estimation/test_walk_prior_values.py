"""The walk a period of the adaptive velocity filter uses (``prior_walk``): the state's
``q_i`` where it is positive, the configured ``Q``'s acceleration entry at power-on
(``0``) or for a non-positive entry, per axis independently; and the sample of a walk
against the scalar hand value when ``S`` is given unsymmetrised."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.estimation.adaptive_walk import make_walk_sample, prior_walk

QN = np.diag([1.0, 2.0, 0.03, 0.05, 6.0, 7.0, 8.0])


def _prior(walk):
    w, Qm = ca.MX.sym("w", 3), ca.MX.sym("Q", 7, 7)
    return np.asarray(ca.Function("f", [w, Qm], [prior_walk(w, Qm)])(walk, QN)).ravel()


@pytest.mark.parametrize("walk,want", [
    ([0.0, 0.0, 0.0], [0.03, 0.05]),  # power-on: the configured walk
    ([0.2, 0.0, 5.0], [0.2, 0.05]),
    ([0.0, 0.4, 5.0], [0.03, 0.4]),
    ([1e-300, 2e-300, 1.0], [1e-300, 2e-300]),
    ([-0.1, 0.7, 1.0], [0.03, 0.7]),
])
def test_prior_walk_per_axis(walk, want):
    np.testing.assert_array_equal(_prior(walk), want)


def test_the_sample_uses_the_symmetric_part_of_s():
    # scalar-like case on two measurements, h_x = e_0, h_y = e_1, S diagonal plus a skew part
    S = np.array([[0.3, 0.1], [-0.1, 0.5]])  # symmetric part diag(0.3, 0.5)
    nu, q = np.array([0.5, -0.2]), np.array([0.1, 0.2])
    s, ok = make_walk_sample(2)(nu, S, np.eye(2), q)
    # s_i = q_i + (a_i^2 - b_i) / b_i^2 with a_i = nu_i / S_ii, b_i = 1 / S_ii: nu_i^2 - (S_ii - q_i)
    np.testing.assert_allclose(np.asarray(s).ravel(), [0.25 - 0.2, 0.04 - 0.3], rtol=1e-12)
    assert float(ok) == 1.0

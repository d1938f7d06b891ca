"""The covariance repair against the ladder's hand-computed first rung: the smallest
shift ``-min pivot + jitter`` on an indefinite matrix (not merely *some* PD result)."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.estimation.linalg import JITTER, make_spd_repair


@pytest.mark.parametrize("A,shift", [
    # pivots 1, 1 - 4 = -3, 1; mean diagonal 1
    (np.array([[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]]), 3.0 + JITTER),
    # pivots -1, -1, -1; |trace| / 3 = 1
    (-np.eye(3), 1.0 + JITTER),
    # one negative variance among positive ones: pivots 2, -0.5, 4; mean diagonal 5.5 / 3
    (np.diag([2.0, -0.5, 4.0]), 0.5 + JITTER * 5.5 / 3),
])
def test_an_indefinite_covariance_gets_the_smallest_pivot_shift(A, shift):
    out, flag = make_spd_repair(3)(A)
    assert float(flag) == 1
    np.testing.assert_allclose(np.array(out), A + shift * np.eye(3), rtol=0, atol=1e-15)


def test_an_asymmetric_pd_matrix_is_only_symmetrised():
    A = np.array([[2.0, 0.3, 0.0], [0.1, 1.0, 0.2], [0.0, 0.0, 3.0]])
    out, flag = make_spd_repair(3)(A)
    assert float(flag) == 0
    np.testing.assert_allclose(np.array(out), 0.5 * (A + A.T), rtol=0, atol=0)


def test_when_the_pivot_shift_is_not_enough_the_gershgorin_shift_is_taken():
    # the first pivot -1.266 fails; shifted by 1.266 the first diagonal entry is ~0 beside
    # an off-diagonal -1.655: still indefinite, so the second rung is used.  Gershgorin
    # row bounds A_ii - sum_j |A_ij|: -1.266 - 1.858 = -3.124, 1.261 - 1.828 = -0.567,
    # 3.378 - 0.376 = 3.002; the shift is 3.124 + JITTER * |trace| / 3 (trace 3.373).
    A = np.array([[-1.266, -1.655, 0.203], [-1.655, 1.261, -0.173], [0.203, -0.173, 3.378]])
    first = A + (1.266 + JITTER * 3.373 / 3) * np.eye(3)
    assert np.min(np.linalg.eigvalsh(first)) < 0  # the first rung alone would not do
    out, flag = make_spd_repair(3)(A)
    assert float(flag) == 1
    shift = 3.124 + JITTER * 3.373 / 3
    np.testing.assert_allclose(np.array(out), A + shift * np.eye(3), rtol=0, atol=1e-12)
    assert np.min(np.linalg.eigvalsh(np.array(out))) > 0


def test_the_cholesky_factor_is_lower_triangular_by_structure_and_guarded_when_not_pd():
    """``L`` has no entry above the diagonal (the generated C computes none); on an
    indefinite matrix the failing pivot is replaced by ``max(|A_jj|, floor)`` in ``L``:
    ``A = [[4, 2, 0], [2, -3, 1], [0, 1, 5]]``: ``L_00 = 2``, ``L_10 = 1``, pivot
    ``d_1 = -3 - 1 = -4`` fails, so ``L_11 = sqrt(3)``; ``L_21 = 1 / sqrt(3)`` and
    ``d_2 = 5 - 1/3``."""
    from ballbot_casadi.estimation.linalg import make_cholesky
    f = make_cholesky(3)
    Ls = f(ca.SX.sym("A", 3, 3))[0]
    assert [Ls[i, j].is_zero() for i, j in ((0, 1), (0, 2), (1, 2))] == [True] * 3
    A = np.array([[4.0, 2.0, 0.0], [2.0, -3.0, 1.0], [0.0, 1.0, 5.0]])
    L, pd = f(A)
    assert float(pd) == 0.0
    s3 = np.sqrt(3.0)
    want = np.array([[2.0, 0, 0], [1.0, s3, 0], [0.0, 1 / s3, np.sqrt(5.0 - 1 / 3)]])
    np.testing.assert_allclose(np.array(L), want, rtol=1e-15, atol=0)

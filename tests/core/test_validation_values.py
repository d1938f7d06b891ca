"""Input checks at their limits: shapes that hold the right number of values but are not
vectors, the quaternion-norm tolerance on both sides (issue 23, test strength)."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.core.validation import QUAT_TOL, as_vector, check_state
from ballbot_casadi.errors import ShapeError, StateError


@pytest.mark.parametrize("shape", [(12,), (12, 1), (1, 12)])
def test_vectors_row_and_column_are_accepted(shape):
    assert as_vector(np.arange(12.0).reshape(shape), 12, "x").shape == (12,)


@pytest.mark.parametrize("shape", [(3, 4), (2, 6), (1, 1, 12), (11,)])
def test_other_shapes_are_refused_even_with_twelve_values(shape):
    with pytest.raises(ShapeError, match=r"must have shape \(12,\)"):
        as_vector(np.zeros(int(np.prod(shape))).reshape(shape) if np.prod(shape) else [], 12, "x")


def _state(norm: float) -> np.ndarray:
    x = np.zeros(12)
    x[2] = norm
    return x


def test_quaternion_norm_tolerance_on_both_sides():
    check_state(_state(1 + 0.5 * QUAT_TOL))
    check_state(_state(1 - 0.5 * QUAT_TOL))
    for bad in (1 + 2 * QUAT_TOL, 1 - 2 * QUAT_TOL):
        with pytest.raises(StateError, match="norm"):
            check_state(_state(bad))
    assert QUAT_TOL == 1e-6

"""sampled_loop_model on a random closed loop by hand: the state outputs select their own
loop coordinates (v 0:2, tilt 2:4, tilt rate 4:6), the composed step is T A1^m L with the
held input's sum, the output rows are mapped by the lift."""

from __future__ import annotations

import numpy as np

from ballbot_casadi.guidance.prediction import NXL
from ballbot_casadi.guidance.prediction_full import sampled_loop_model


def test_a_random_loop_by_hand():
    rng = np.random.default_rng(31)
    n = NXL + 3
    A1 = 0.2 * rng.standard_normal((n, n)) + 0.5 * np.eye(n)
    B1 = rng.standard_normal((n, 2))
    T = np.hstack([np.eye(NXL), 0.1 * rng.standard_normal((NXL, 3))])
    L = np.vstack([np.eye(NXL), np.zeros((3, NXL))])  # T L = I
    Cw = {"acc": rng.standard_normal((2, n)), "tilt_acc": rng.standard_normal((2, n))}
    Dw = {"acc": rng.standard_normal((2, 2)), "tilt_acc": rng.standard_normal((2, 2))}
    m = 3
    model = sampled_loop_model(A1, B1, T, L, Cw, Dw, 0.005, m * 0.005)
    np.testing.assert_allclose(model.A, T @ A1 @ A1 @ A1 @ L, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(model.B, T @ (A1 @ A1 @ B1 + A1 @ B1 + B1), rtol=1e-12, atol=1e-12)
    X = rng.standard_normal(NXL)
    v = rng.standard_normal(2)
    for key, i in (("v", 0), ("tilt", 2), ("tilt_rate", 4)):
        np.testing.assert_array_equal(model.C[key] @ X + model.D[key] @ v, X[i:i + 2])
    for key in ("acc", "tilt_acc"):
        np.testing.assert_allclose(model.C[key], Cw[key] @ L, rtol=1e-14)
        np.testing.assert_array_equal(model.D[key], Dw[key])
    assert model.dt == m * 0.005


def test_each_bad_output_shape_is_refused_alone():
    import pytest

    from ballbot_casadi.errors import ShapeError

    n = NXL
    A1, B1, T, L = np.eye(n), np.zeros((n, 2)), np.eye(n), np.eye(n)
    good_C = {"acc": np.zeros((2, n)), "tilt_acc": np.zeros((2, n))}
    good_D = {"acc": np.zeros((2, 2)), "tilt_acc": np.zeros((2, 2))}
    sampled_loop_model(A1, B1, T, L, good_C, good_D, 0.005, 0.1)
    for C, D in (({**good_C, "acc": np.zeros((2, n + 1))}, good_D),
                 (good_C, {**good_D, "tilt_acc": np.zeros((2, 3))})):
        with pytest.raises(ShapeError, match="rows must be 2 x"):
            sampled_loop_model(A1, B1, T, L, C, D, 0.005, 0.1)

"""The sampled-loop LoopModel: composition and reduction against brute force on a small system."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.errors import ShapeError
from ballbot_casadi.guidance.prediction import NXL
from ballbot_casadi.guidance.prediction_full import reduction_residual, sampled_loop_model


def _system(rng: np.random.Generator, n: int = 17):
    """A random stable period map whose first 14 coordinates are invariant (T = [I 0])."""
    A1 = 0.3 * rng.standard_normal((n, n)) / np.sqrt(n)
    A1[NXL:, :NXL] = 0.0  # the extra coordinates are not driven by the loop coordinates
    B1 = rng.standard_normal((n, 2))
    B1[NXL:] = 0.0
    T = np.eye(n)[:NXL]
    return A1, B1, T, T.T.copy()


def test_composition_equals_period_by_period_simulation() -> None:
    rng = np.random.default_rng(18)
    A1, B1, T, L = _system(rng)
    Cw = {"acc": rng.standard_normal((2, 17)), "tilt_acc": rng.standard_normal((2, 17))}
    Dw = {"acc": rng.standard_normal((2, 2)), "tilt_acc": rng.standard_normal((2, 2))}
    m = 4
    model = sampled_loop_model(A1, B1, T, L, Cw, Dw, 0.005, 0.005 * m)
    X0 = rng.standard_normal(NXL)
    v = rng.standard_normal((3, 2))
    w = L @ X0
    for k in range(3):  # brute force: period by period with v held for m periods
        for _ in range(m):
            w = A1 @ w + B1 @ v[k]
    np.testing.assert_allclose(model.simulate(X0, v)[-1], T @ w, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(model.C["acc"] @ X0 + model.D["acc"] @ v[0],
                               Cw["acc"] @ (L @ X0) + Dw["acc"] @ v[0], rtol=1e-12, atol=1e-12)
    assert reduction_residual(A1, T, L) == 0.0


def test_reduction_residual_sees_a_coupled_extra_state() -> None:
    A1, _, T, L = _system(np.random.default_rng(1))
    A1[NXL, 0] = 0.25  # the loop drives an extra (heading) coordinate
    assert reduction_residual(A1, T, L) == pytest.approx(0.25, abs=1e-15)


def test_bad_shapes_and_steps_are_refused() -> None:
    A1, B1, T, L = _system(np.random.default_rng(2))
    C = {"acc": np.zeros((2, 17)), "tilt_acc": np.zeros((2, 17))}
    D = {"acc": np.zeros((2, 2)), "tilt_acc": np.zeros((2, 2))}
    with pytest.raises(ShapeError, match="integer multiple"):
        sampled_loop_model(A1, B1, T, L, C, D, 0.005, 0.0123)
    with pytest.raises(ShapeError, match="right inverse"):
        sampled_loop_model(A1, B1, T, 2 * L, C, D, 0.005, 0.1)
    with pytest.raises(ShapeError, match="A1, B1, T, L"):
        sampled_loop_model(A1, B1[:3], T, L, C, D, 0.005, 0.1)

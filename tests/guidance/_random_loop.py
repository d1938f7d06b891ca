"""A random stable velocity-loop model for MPC tests that need a model, not the robot's
(:func:`~ballbot_casadi.guidance.prediction.closed_velocity_loop` of a random plant with
a dominant -I, random input and gain matrices, Ts = 0.05 s)."""

from __future__ import annotations

import numpy as np

from ballbot_casadi.guidance.prediction import closed_velocity_loop


def random_velocity_loop(seed: int, dt: float):
    """The closed loop model sampled at ``dt`` (seeded: the same model every run)."""
    rng = np.random.default_rng(seed)
    Ac = 0.3 * rng.normal(size=(12, 12)) - np.eye(12)
    Bc = rng.normal(size=(12, 2))
    K = 0.2 * rng.normal(size=(2, 12))
    return closed_velocity_loop(Ac, Bc, K, 0.05, dt)

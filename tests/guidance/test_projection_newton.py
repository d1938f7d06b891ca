"""The path projection's Newton refinement converges to the foot point: the tangent is
orthogonal to ``P(s) - p`` to rounding, for points far enough off a curved path that the
Newton denominator ``|T|^2 + r . P''`` is far from 1 (a wrongly scaled step still
converges, but not within the three iterations), and the foot point is the arc's own
angle (the spline's arc-length parametrisation to 1e-6)."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.guidance.paths import arc_path

RADIUS = 2.0


@pytest.mark.parametrize("theta, rho", [(0.7, 2.9), (1.9, 1.2), (0.3337, 2.5), (2.6, 0.9)])
def test_projection_is_the_foot_point(theta, rho):
    path = arc_path((0.0, 0.0), RADIUS, 0.0, np.pi)
    p = rho * np.array([np.cos(theta), np.sin(theta)])
    s = path.project(p)
    t, r = path.spline(s, 1), path.spline(s) - p
    assert abs(float(t @ r)) <= 1e-12 * max(1.0, float(np.linalg.norm(r)))
    assert s == pytest.approx(RADIUS * theta, abs=1e-6)
    assert s == pytest.approx(path.project(p, s_guess=s + 0.05, reach=0.3), abs=1e-12)

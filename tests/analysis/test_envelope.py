"""Envelope bisection on a case whose recovery limit is known in closed form."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.analysis.envelope import envelope, largest_recovered
from ballbot_casadi.errors import ScenarioError

OMEGA, U_MAX, H = 3.74, 2.0, 1e-3  # unstable pole like the ballbot's tilt (rad/s)


def _pendulum_recovers(v0: float) -> bool:
    """Linear inverted pendulum ddx = omega^2 x + u, |u| <= U_MAX, pushed to dx = v0 at x = 0,
    under the saturated feedback on its unstable mode z = x + dx / omega.

    dz/dt = omega z + u / omega: with |u| <= U_MAX, z returns iff |z0| < U_MAX / omega^2, so
    the largest recoverable push is exactly v0* = U_MAX / omega (also for the ZOH map,
    whose unstable fixed point under u = -U_MAX is the same z*)."""
    e = math.exp(OMEGA * H)
    z, z_star = v0 / OMEGA, U_MAX / OMEGA**2
    for _ in range(200000):
        u = -U_MAX * float(np.clip(1e3 * z, -1, 1))
        z = e * z + (e - 1) / OMEGA**2 * u
        if abs(z) > 2 * z_star:
            return False
        if abs(z) < 1e-3 * z_star:
            return True
    return False


def test_bisection_finds_the_known_limit():
    res = largest_recovered(_pendulum_recovers, 0.0, 2.0, 1e-5)
    assert res.bracketed
    limit = U_MAX / OMEGA
    assert res.value <= limit <= res.failed  # never optimistic
    assert res.failed - res.value <= 1e-5
    assert res.n_evals <= 2 + math.ceil(math.log2(2.0 / 1e-5))


def test_envelope_per_direction_and_unbracketed():
    # a disc of radius 0.7 stretched x2 along x: limits 1.4 and 0.7
    rec = lambda d, a: (a * d[0] / 1.4) ** 2 + (a * d[1] / 0.7) ** 2 <= 1  # noqa: E731
    res = envelope(rec, [(1, 0), (0, 1)], 0.0, 3.0, 1e-6)
    assert [r.value for r in res] == pytest.approx([1.4, 0.7], abs=1e-6)
    r = largest_recovered(lambda a: True, 0.0, 1.0, 1e-3)
    assert not r.bracketed and r.value == 1.0 and r.failed == math.inf


def test_bad_search_is_one_clear_error():
    with pytest.raises(ScenarioError, match="not even the smallest disturbance"):
        largest_recovered(lambda a: False, 0.0, 1.0, 1e-3)
    with pytest.raises(ScenarioError, match="0 <= lo < hi"):
        largest_recovered(lambda a: True, 1.0, 1.0, 1e-3)
    with pytest.raises(ScenarioError, match="tolerance"):
        largest_recovered(lambda a: True, 0.0, 1.0, 0.0)


def test_a_bracket_exactly_as_wide_as_the_tolerance_is_done():
    """Widths 1, 1/2, 1/4 (exact binary fractions): with tol = 1/4 the search stops after two
    bisections, at the bracket [1/2, 3/4] around the limit 0.6."""
    res = largest_recovered(lambda a: a <= 0.6, 0.0, 1.0, 0.25)
    assert (res.value, res.failed, res.n_evals, res.bracketed) == (0.5, 0.75, 4, True)

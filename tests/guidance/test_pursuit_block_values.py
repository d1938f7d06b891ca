"""The generated pure-pursuit sample (guidance.blocks.make_pursuit_sample, the Function the
firmware and the path FMU run) against the Python law (guidance.pure_pursuit.PurePursuit,
itself checked by hand in test_pure_pursuit.py) and one hand computation: the pull towards
the look-ahead point, the lateral pull towards the path (its sign), the speed limit and the
end-of-path ramp; its next state is the reference it gave and the projected arc length."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.guidance.blocks import make_pursuit_sample, pursuit_initial_state, pursuit_parameters
from ballbot_casadi.guidance.paths import arc_path, line_path
from ballbot_casadi.guidance.pure_pursuit import PurePursuit


@pytest.fixture(scope="module")
def sample():
    return make_pursuit_sample()


def _x(px, py):
    x = np.zeros(14)
    x[12:14] = px, py  # the loop state ends with the position
    return x


def _run(sample, path, X, lookahead, k_lat, g=None):
    g = pursuit_initial_state(path, X) if g is None else g
    v, g_next = (np.asarray(a, float).ravel() for a in sample(X, g, pursuit_parameters(path, lookahead, k_lat)))
    return v, g_next


def test_the_lateral_pull_by_hand(sample):
    """0.1 m left of a line along x at 0.5 m/s, look-ahead 0.3 m, no speed limit reached:
    towards (1.3, 0) at 0.5 m/s plus k_lat times the offset back to the line."""
    path = line_path([0.0, 0.0], [4.0, 0.0], speed=0.5)
    d = np.array([0.3, -0.1]) / math.sqrt(0.1)
    for k_lat in (0.0, 0.2):
        v, g_next = _run(sample, path, _x(1.0, 0.1), 0.3, k_lat)
        want = 0.5 * d + k_lat * np.array([0.0, -0.1])
        want *= min(1.0, 0.5 / np.linalg.norm(want))
        np.testing.assert_allclose(v, want, rtol=0, atol=1e-12)
        np.testing.assert_allclose(g_next, [*v, 1.0], rtol=0, atol=1e-9)   # [v, s]
    # the pull points back to the line from either side
    assert _run(sample, path, _x(1.0, -0.1), 0.3, 0.2)[0][1] > 0 > _run(sample, path, _x(1.0, 0.1), 0.3, 0.2)[0][1]


@pytest.mark.parametrize("which", ["line", "arc"])
def test_the_block_is_the_python_law(sample, which):
    if which == "line":
        path, atol, atol_next = line_path([0.0, 0.0], [4.0, 0.0], speed=0.5), 1e-12, 1e-12
    else:  # the block reads the path from its sampled table (and projects by a few Newton
        # steps from its last arc length): agreement to the sampling
        path, atol, atol_next = arc_path((0.0, 0.0), 1.5, 0.0, 2.0, speed=0.4), 1e-6, 5e-5
    for pos in [(1.0, 0.1), (1.1, 0.0), (3.9, 0.0), (2.0, -0.2), (1.2, 0.9)]:
        pp = PurePursuit(path, lookahead=0.3, k_lat=0.5)
        want = pp.step(_x(*pos))
        v, g_next = _run(sample, path, _x(*pos), 0.3, 0.5)
        np.testing.assert_allclose(v, want, rtol=0, atol=atol, err_msg=str(pos))
        assert g_next[2] == pytest.approx(pp.progress(), abs=max(atol, 1e-9))
        # the next sample starts from the arc length this one found
        v2, _ = _run(sample, path, _x(pos[0] + 0.05, pos[1]), 0.3, 0.5, g=g_next)
        np.testing.assert_allclose(v2, pp.step(_x(pos[0] + 0.05, pos[1])), rtol=0, atol=atol_next)


@pytest.mark.parametrize("bad", [0.0, -0.3, float("nan"), float("inf"), -float("inf")])
def test_a_look_ahead_that_is_not_a_positive_distance_is_refused(bad):
    from ballbot_casadi.errors import ScenarioError

    path = line_path([0.0, 0.0], [4.0, 0.0], speed=0.5)
    with pytest.raises(ScenarioError, match=r"^lookahead must be > 0 m, got "):
        pursuit_parameters(path, bad, 1.0)
    assert pursuit_parameters(path, 1e-3, 1.0).size == pursuit_parameters(path, 0.3, 1.0).size

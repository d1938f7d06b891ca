"""The path table evaluated on symbols: values of the interpolation and its work memory."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.guidance.path_table import PATH_SAMPLES, PathSymbols, pack_path, path_eval, path_table_layout
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.guidance.paths import figure_eight, line_path


def _eval_function(n_nodes: int) -> ca.Function:
    k = ca.MX.sym("k", path_table_layout(0).size)
    s = ca.MX.sym("s", n_nodes)
    ev = path_eval(PathSymbols(k, 0), s)
    return ca.Function("f", [k, s], [ev["point"], ev["tangent"]])


def test_path_eval_at_many_nodes_shares_the_table():
    # 21 nodes (the MPC's horizon): the interpolant's map must read the one table, not a
    # copy per node (21 x 2 x 4096 doubles of work: 1.4 MB on the Cortex-M7)
    f = _eval_function(21)
    assert f.sz_w() < 3 * 2 * 2 * PATH_SAMPLES


def test_path_eval_matches_the_path():
    path = figure_eight(4.0, 2.0, speed=0.5)
    s = np.linspace(0.0, path.length, 21)
    point, tangent = _eval_function(21)(pack_path(path, 0), s)
    np.testing.assert_allclose(np.asarray(point).T, path.spline(s), rtol=0, atol=1e-4)
    np.testing.assert_allclose(np.asarray(tangent).T, path.tangent(s), rtol=0, atol=1e-3)


def test_tangents_between_the_samples_are_unit_vectors():
    """The tangent linearly interpolated between two unit samples is renormalised: unit to
    round-off half-way between samples, where the chord is shortest."""
    path = figure_eight(4.0, 2.0, speed=0.5)
    h = path.length / (PATH_SAMPLES - 1)
    s = (np.arange(21) * 97 + 0.5) * h   # half-way between samples along the whole path
    _, tangent = _eval_function(21)(pack_path(path, 0), s)
    np.testing.assert_allclose(np.linalg.norm(np.asarray(tangent), axis=0), 1.0, rtol=0, atol=1e-13)


def test_a_table_holds_at_most_its_guidance_blocks_obstacles():
    path = line_path((0.0, 0.0), (3.0, 0.0), 0.5, obstacles=[(1.0, 0.3, 0.1), (2.0, -0.3, 0.1)])
    assert pack_path(path, 2).size == path_table_layout(2).size
    with pytest.raises(ScenarioError, match=r"^obstacles: at most 1 allowed by this guidance "
                                            r"block, got 2$"):
        pack_path(path, 1)
    assert pack_path(path, 1, obstacles=False).size == path_table_layout(1).size

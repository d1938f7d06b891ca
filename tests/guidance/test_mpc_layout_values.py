"""MPC bookkeeping that needs no solver build, against hand counts: the row and parameter
layout, the warm-start index of the multipliers, the octagon, the workspace formula and
the configuration checks."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.errors import ScenarioError, ShapeError
from ballbot_casadi.guidance.mpc import (
    MpcConfig,
    MpcLayout,
    dual_shift_index,
    polygon,
    workspace_bytes,
)


def test_row_and_parameter_counts_of_a_small_layout():
    L = MpcLayout(N=3, M=2, n_u=6, nodes=(1, 3))
    assert L.n_c == 3 * 6 + 2 * 14 == 46
    assert L.n_rows == 46 + 2 * 2
    shapes = L.params
    assert list(shapes) == ["v_prev", "path_p", "path_t", "s_bar", "v_s", "w_lat", "obs_n",
                            "obs_b", "s_max"]
    assert shapes["path_p"] == (4, 2) and shapes["obs_n"] == (2, 4, 2) and shapes["obs_b"] == (2, 4)
    assert L.n_p == 2 + 8 + 8 + 4 + 4 + 4 + 16 + 8 + 1


def test_pack_is_row_major_in_order_and_unpack_inverts_it():
    L = MpcLayout(N=2, M=1, n_u=3, nodes=(2,))
    blocks = {name: np.arange(int(np.prod(s)), dtype=float).reshape(s) + 100 * i
              for i, (name, s) in enumerate(L.params.items())}
    p = L.pack(**blocks)
    assert p.size == L.n_p
    np.testing.assert_array_equal(p[:2], [0.0, 1.0])                 # v_prev
    np.testing.assert_array_equal(p[2:8], [100, 101, 102, 103, 104, 105])  # path_p rows
    assert p[-1] == 800.0                                           # s_max last
    back = L.unpack(p)
    for name, s in L.params.items():
        np.testing.assert_array_equal(np.asarray(back[name]).reshape(s), blocks[name])
    bad = dict(blocks, path_t=np.zeros((2, 2)))
    with pytest.raises(ShapeError, match="path_t"):
        L.pack(**bad)


def test_dual_shift_index_by_hand():
    """N = 3, nodes (1, 3), one obstacle: step rows of node k from node k + 1 (the last
    repeated); node 1's rows from the node nearest 2 (node 1, the first of a tie), node 3's
    from node 3; obstacle rows likewise."""
    L = MpcLayout(N=3, M=1, n_u=6, nodes=(1, 3))
    idx = dual_shift_index(L)
    want = (list(range(6, 12)) + list(range(12, 18)) + list(range(12, 18))
            + list(range(18, 32)) + list(range(32, 46)) + [46, 47])
    np.testing.assert_array_equal(idx, want)
    assert idx.size == L.n_rows


def test_dual_shift_moves_node_rows_to_the_next_node():
    L = MpcLayout(N=4, M=2, n_u=9, nodes=(1, 2, 3, 4))
    idx = dual_shift_index(L)
    base = L.N * 6
    node_part = idx[base:base + 4 * 14].reshape(4, 14)
    np.testing.assert_array_equal(node_part[:, 0], base + np.array([1, 2, 3, 3]) * 14)
    obs = idx[L.n_c:]
    np.testing.assert_array_equal(obs, L.n_c + np.array([1, 2, 3, 3, 5, 6, 7, 7]))


def test_octagon_directions_and_apothem():
    d, f = polygon(8)
    ang = np.arange(4) * math.pi / 4
    np.testing.assert_allclose(d, np.column_stack([np.cos(ang), np.sin(ang)]), atol=1e-15)
    assert f == pytest.approx(math.cos(math.pi / 8), rel=1e-15)
    d6, f6 = polygon(6)
    assert d6.shape == (3, 2) and f6 == pytest.approx(math.cos(math.pi / 6))


def test_workspace_counts_every_work_vector_in_doubles():
    A = ca.MX.sym("A", ca.Sparsity.lower(4))  # a sparse transpose needs integer work too
    y = ca.MX.sym("y", 3)
    f = ca.Function("f", [A, y], [A.T, ca.sin(y) * ca.sumsqr(y), ca.sumsqr(A)])
    sizes = (f.sz_w(), f.sz_iw(), f.sz_arg(), f.sz_res())
    assert all(v > 0 for v in sizes)
    assert workspace_bytes(f) == 8 * sum(sizes)


@pytest.mark.parametrize("kw,key", [
    ({"N": 1, "blocks": (1,), "nodes": (1,)}, "N must"),
    ({"dt": 0.0}, "dt must"),
    ({"dt": float("nan")}, "dt must"),
    ({"acc_margin": 0.0}, "acc_margin"),
    ({"margin": 1.0000001}, "margin"),
    ({"blocks": (0, 20)}, "blocks"),
    ({"nodes": (2, 1, 20)}, "nodes"),
    ({"nodes": (1, 21)}, "nodes"),
    ({"nodes": ()}, "nodes"),
    ({"iterations": 2.0}, "iterations"),
])
def test_configuration_checks(kw, key):
    with pytest.raises(ScenarioError, match=key):
        MpcConfig(**kw)


def test_boundary_configurations_are_accepted():
    MpcConfig(margin=1.0, acc_margin=1.0, N=2, blocks=(2,), nodes=(2,), iterations=1)
    MpcConfig(nodes=(1, 20))

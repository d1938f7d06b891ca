"""Nested layouts by hand: a dotted field that is not the first of its nested layout, two
levels deep, in every accessor (issue 23, fresh mutants: ``s.start + inner.start`` with a
sign flipped survived because every nested field looked at started at 0)."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.core.layout import Layout

INNER = Layout("inner", [("a", 2), ("s", 1), ("b", 3)])          # a 0:2, s 2, b 3:6
OUTER = Layout("outer", [("h", 1), ("c", INNER), ("t", 2)])        # h 0, c 1:7, t 7:9
DEEP = Layout("deep", [("p", 2), ("d", Layout("d", [("z", 1), ("c", INNER)]))])  # d 2:9, d.c 3:9


def test_dotted_slices_offsets_and_indices_by_hand():
    assert OUTER["c"] == slice(1, 7) and OUTER["t"] == slice(7, 9)
    assert OUTER["c.a"] == slice(1, 3)
    assert OUTER["c.s"] == slice(3, 4) and OUTER.index("c.s") == 3
    assert OUTER["c.b"] == slice(4, 7) and OUTER.offset("c.b") == 4 and OUTER.size_of("c.b") == 3
    assert DEEP["d.c"] == slice(3, 9)
    assert DEEP["d.c.b"] == slice(6, 9) and DEEP.index("d.c.s") == 5 and DEEP.index("d.z") == 2
    with pytest.raises(KeyError, match="not one"):
        OUTER.index("c.b")
    with pytest.raises(KeyError, match="no field 'q'"):
        OUTER["c.q"]


def test_names_flat_and_pack_agree_with_the_slices():
    assert OUTER.names == ("h", "c.a0", "c.a1", "c.s", "c.b0", "c.b1", "c.b2", "t0", "t1")
    assert OUTER.flat() == (("h", 0, 1), ("c", 1, 6), ("c.a", 1, 2), ("c.s", 3, 1), ("c.b", 4, 3),
                            ("t", 7, 2))
    v = OUTER.pack({"h": 9, "c.a": [1, 2], "c.s": 3, "c.b": [4, 5, 6], "t": [7, 8]})
    np.testing.assert_array_equal(v, [9, 1, 2, 3, 4, 5, 6, 7, 8])
    np.testing.assert_array_equal(v[OUTER["c.b"]], [4, 5, 6])
    np.testing.assert_array_equal(OUTER.pack({"h": 0, "c": np.arange(6), "t": [0, 0]})[OUTER["c.b"]], [3, 4, 5])
    with pytest.raises(ValueError, match="not given exactly once"):
        OUTER.pack({"h": 0, "c": np.arange(6), "c.s": 1, "t": [0, 0]})

"""``flat_function``: one SX graph with the called Functions inlined and common
subexpressions shared - a repeated sub-expression is computed once - with the names
and the values of the plain Function."""

from __future__ import annotations

import casadi as ca
import numpy as np

from ballbot_casadi.estimation.core import flat_function


def test_repeated_work_is_done_once_and_the_values_are_unchanged():
    x = ca.MX.sym("x", 2)
    inner = ca.Function("inner", [x], [ca.sin(x[0]) * ca.cos(x[1])])
    # the same value built three times as separate nodes (two calls, one inline copy)
    y = inner(x) + inner(x) * (ca.sin(x[0]) * ca.cos(x[1]))
    f = flat_function("flat", [x], [y, 2 * inner(x)], ["x"], ["y", "w"])
    assert f.name() == "flat" and f.name_in() == ["x"] and f.name_out() == ["y", "w"]
    assert f.is_a("SXFunction")
    plain = ca.Function("plain", [x], [y, 2 * inner(x)]).expand()
    assert f.n_instructions() < plain.n_instructions()
    ops = [f.instruction_id(k) for k in range(f.n_instructions())]
    assert ops.count(ca.OP_SIN) == 1 and ops.count(ca.OP_COS) == 1
    v = np.sin(0.3) * np.cos(-1.2)
    out = f([0.3, -1.2])
    np.testing.assert_allclose(float(out[0]), v + v * v, rtol=1e-15)
    np.testing.assert_allclose(float(out[1]), 2 * v, rtol=1e-15)

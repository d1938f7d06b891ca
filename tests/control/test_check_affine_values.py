"""check_affine: the model Function accepted only as affine(x[12], p) -> (f[6], g[6x3]),
each condition broken alone and refused with the whole message, the sizes returned in order."""

from __future__ import annotations

import casadi as ca
import pytest

from ballbot_casadi.control.decoupling import check_affine
from ballbot_casadi.errors import BallbotTypeError

MESSAGE = ("affine must be the model's CasADi Function affine(x[12], p) -> (f[6], g[6x3]) "
           "(e.g. make_model_functions()['affine'])")


def _fake(nx=12, np_=7, f_shape=(6, 1), g_shape=(6, 3), extra_in=False, drop_g=False):
    x, p = ca.SX.sym("x", nx), ca.SX.sym("p", np_)
    ins = [x, p] + ([ca.SX.sym("u")] if extra_in else [])
    outs = [ca.SX.zeros(*f_shape)] + ([] if drop_g else [ca.SX.zeros(*g_shape)])
    return ca.Function("affine", ins, outs)


def test_the_sizes_come_back_state_first(model_functions):
    assert check_affine(_fake()) == (12, 7)
    assert check_affine(model_functions["affine"]) == (12, model_functions["affine"].size1_in(1))


@pytest.mark.parametrize("bad", [
    dict(extra_in=True),  # three inputs, the outputs right
    dict(drop_g=True),  # one output
    dict(nx=11), dict(nx=13),
    dict(f_shape=(5, 1)), dict(f_shape=(6, 2)),
    dict(g_shape=(6, 2)), dict(g_shape=(5, 3)),
])
def test_each_broken_condition_alone_is_refused_with_the_message(bad):
    with pytest.raises(BallbotTypeError) as err:
        check_affine(_fake(**bad))
    assert str(err.value) == MESSAGE


def test_a_python_callable_is_refused():
    with pytest.raises(BallbotTypeError) as err:
        check_affine(lambda x, p: (x, p))
    assert str(err.value) == MESSAGE

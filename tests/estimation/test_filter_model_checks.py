"""A filter model's definition is checked condition by condition: each variant below breaks
exactly one requirement (of the process, the measurement or the measurement-noise
Function) and must be refused; the well-formed model is accepted."""

from __future__ import annotations

import casadi as ca
import pytest

from ballbot_casadi.errors import BallbotTypeError, ShapeError
from ballbot_casadi.estimation.core import FilterModel
from ballbot_casadi.estimation.manifold import euclidean

NX, NU, NP, NZ = 3, 2, 4, 2


def _fn(name, sizes, out):
    args = [ca.SX.sym(f"a{i}", *s) for i, s in enumerate(sizes)]
    return ca.Function(name, args, [ca.SX.zeros(*out) + sum(ca.sum1(ca.vec(a)) for a in args)])


def _f(x=NX, u=NU, dt=1, p=NP, out=NX):
    return _fn("f", [(x, 1), (u, 1), (dt, 1), (p, 1)], (out, 1))


def _h(x=NX, u=NU, dt=1, p=NP, out=NZ):
    return _fn("h", [(x, 1), (u, 1), (dt, 1), (p, 1)], (out, 1))


def _r(x=NX, u=NU, p=NP, R=NZ, out=NZ):
    return _fn("r", [(x, 1), (u, 1), (p, 1), (R, R)], (out, out))


def test_a_well_formed_model_is_accepted():
    m = FilterModel(euclidean(NX), _f(), _h(), "additive", _r())
    assert (m.nz, m.nu, m.np, m.nd) == (NZ, NU, NP, NX)
    FilterModel(euclidean(NX), _f(), _h(), "pre")


@pytest.mark.parametrize("r", [
    _r(x=NX + 1), _r(u=NU + 1), _r(p=NP + 1), _r(R=NZ + 1),
    _fn("r3", [(NX, 1), (NU, 1), (NP, 1)], (NZ, NZ)),
    _fn("r5", [(NX, 1), (NU, 1), (NP, 1), (NZ, NZ), (1, 1)], (NZ, NZ)),
], ids=["x", "u", "p", "R", "three_inputs", "five_inputs"])
def test_measurement_noise_with_one_wrong_input_is_refused(r):
    with pytest.raises(ShapeError, match="measurement_noise"):
        FilterModel(euclidean(NX), _f(), _h(), "additive", r)


def test_measurement_noise_with_a_wrong_output_is_refused():
    with pytest.raises(ShapeError, match="measurement_noise"):
        FilterModel(euclidean(NX), _f(), _h(), "additive", _r(out=NZ + 1))


@pytest.mark.parametrize("f,h,err", [
    (_f(x=NX + 1), _h(), ShapeError),
    (_f(out=NX + 1), _h(), ShapeError),
    (_f(), _h(x=NX + 1), ShapeError),
    (_f(), _h(u=NU + 1), ShapeError),
    (_f(), _h(p=NP + 1), ShapeError),
    (_f(dt=2), _h(), ShapeError),
    (_f(), _h(dt=2), ShapeError),
    (_fn("f3", [(NX, 1), (NU, 1), (1, 1)], (NX, 1)), _h(), BallbotTypeError),
], ids=["f_x", "f_out", "h_x", "u", "p", "f_dt", "h_dt", "f_three_inputs"])
def test_process_or_measurement_with_one_wrong_size_is_refused(f, h, err):
    with pytest.raises(err):
        FilterModel(euclidean(NX), f, h, "additive")


def test_unknown_noise_kind_is_refused():
    with pytest.raises(BallbotTypeError, match="noise"):
        FilterModel(euclidean(NX), _f(), _h(), "multiplicative")

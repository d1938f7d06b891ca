"""The velocity filter reads only the symmetric part of each covariance input (``P``,
``P_att``, ``Q``, ``R``, ``P_rate``): a skew part added to any of them changes no output.
And the default is the closed form (the sigma-point form is the same arithmetic with
more operations)."""

from __future__ import annotations

import numpy as np
import pytest

import ballbot_casadi.estimation as E
from ballbot_casadi import load_params
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.estimation.adaptive_walk import WalkAdaptation
from ballbot_casadi.estimation.velocity import make_vukf
from ballbot_casadi.model.dynamics import make_model_functions

PV = load_params().to_vector()
TUN = E.DEFAULT_TUNING["vukf"]
DT = 0.005


@pytest.fixture(scope="module")
def ws():
    return make_model_functions()["wheel_speeds"]


def _skew(n, seed):
    A = np.random.default_rng(seed).standard_normal((n, n))
    return A - A.T


def _args():
    q = Q.from_rpy(0.04, -0.03, 0.9)
    att = np.r_[q, 0.3, -0.2, 0.4]
    x = np.array([0.2, -0.1, 0.3, 0.1, 0.01, 0.0, -0.02])
    z = np.r_[np.array([3.0, -2.0, 1.0]), Q.rotate_inv(q, [0.3, 0.1, 9.81])]
    rng = np.random.default_rng(3)
    A = rng.standard_normal((7, 7))
    P = 1e-3 * A @ A.T + 1e-4 * np.eye(7)
    Qn = np.diag([1e-6, 1e-6, 5e-2, 7e-2, 1e-8, 1e-8, 1e-8]) + 1e-3 * np.outer(np.arange(7), np.arange(7)) * 1e-3
    return dict(xhat=x, P=P, z=z, att=att, P_att=np.diag([1e-4, 2e-4, 3e-4]) + 1e-5,
                Q=Qn, R=np.array(TUN.R), dt=DT, p=PV,
                P_rate=np.diag([4e-4, 1e-4, 9e-4]) + 5e-5, walk=np.array([0.05, 0.08, 30.0]),
                n_rej=np.zeros(2))


@pytest.mark.parametrize("kw", [dict(), dict(matched=True, gate=True, adaptive=WalkAdaptation())])
def test_skew_parts_of_the_covariance_inputs_change_nothing(ws, kw):
    f = make_vukf(ws, midpoint=True, **kw)
    args = _args()
    base = f(**{k: v for k, v in args.items() if k in f.name_in()})
    for i, name in enumerate(("P", "P_att", "Q", "R", "P_rate")):
        if name not in f.name_in():
            continue
        a = dict(args)
        n = a[name].shape[0]
        a[name] = a[name] + 1e-3 * np.abs(a[name]).max() * _skew(n, i)
        out = f(**{k: v for k, v in a.items() if k in f.name_in()})
        for k in f.name_out():
            np.testing.assert_allclose(np.asarray(out[k]), np.asarray(base[k]), rtol=1e-10,
                                       atol=1e-14, err_msg=f"{name} -> {k}")


def test_the_default_is_the_closed_form(ws):
    default, closed = make_vukf(ws), make_vukf(ws, closed_form=True)
    sigma = make_vukf(ws, closed_form=False)
    assert default.n_instructions() == closed.n_instructions() < sigma.n_instructions()

"""The closed-form unscented step (``ukf_step(closed_form=True)``, issue 22's cost) equals
the sigma-point step: on a random affine model of the generic core (additive and "pre"
noise, a negative centre weight) and on the shipped velocity filter in every variant
(thesis model, matched, adaptive, gated), at random operating points.  A model that is
not affine is refused when the step is built.

The tolerance is the sigma-point form's own rounding: per output ``1e-12`` relative, with
an absolute floor of ``1e-12`` times the output's largest entry (a covariance entry that is
a difference of larger ones carries the absolute rounding of those); the velocity filter's
NIS to ``1e-10`` (:data:`RTOL_NIS`)."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from _estimation_synthetic import DT

import ballbot_casadi.estimation as E
from ballbot_casadi import load_params
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.errors import ShapeError
from ballbot_casadi.estimation.adaptive_walk import WalkAdaptation
from ballbot_casadi.estimation.core import OUTPUT_NAMES, FilterModel, ukf_step
from ballbot_casadi.estimation.manifold import attitude, euclidean
from ballbot_casadi.estimation.velocity import make_velocity_model, make_vukf

PAR = load_params()
PV = PAR.to_vector()
TUN = E.DEFAULT_TUNING["vukf"]
RTOL = 1e-12
#: The NIS ``nu^T S^-1 nu`` of the velocity filter carries ``cond(S) eps``: the encoders'
#: variance (1/9 tick^2) against the predicted one makes ``cond(S) ~ 1e7`` on these random
#: cases, and both forms are a few 1e-12 (relative) off the exact value (measured against a
#: long-double Kalman filter: closed 2e-12, sigma points 5e-12 on the worst case).
RTOL_NIS = 1e-10


def _assert_same(got, ref, what, nis_index=None):
    for i, (a, b) in enumerate(zip(got, ref)):
        a, b = np.asarray(a, float), np.asarray(b, float)
        scale = max(np.max(np.abs(b)), 1e-300)
        rtol = RTOL_NIS if i == nis_index else RTOL
        np.testing.assert_allclose(a, b, rtol=rtol, atol=rtol * scale, err_msg=f"{what} output {i}")


def _spd(rng, n, scale):
    A = rng.standard_normal((n, n))
    return scale * (A @ A.T / n + 0.1 * np.eye(n))


def _generic(noise: str, closed_form: bool) -> ca.Function:
    """A 4-state affine model with a 3-component measurement (fixed random matrices)."""
    rng = np.random.default_rng(7)
    F, B = rng.standard_normal((4, 4)) * 0.5 + np.eye(4), rng.standard_normal((4, 2))
    H, D = rng.standard_normal((3, 4)), rng.standard_normal((3, 2))
    x, u, dt, p = ca.SX.sym("x", 4), ca.SX.sym("u", 2), ca.SX.sym("dt"), ca.SX.sym("p", 1)
    f = ca.Function("f", [x, u, dt, p], [ca.mtimes(ca.DM(F), x) + dt * ca.mtimes(ca.DM(B), u)])
    h = ca.Function("h", [x, u, dt, p], [ca.mtimes(ca.DM(H), x) + p * ca.mtimes(ca.DM(D), u)])
    model = FilterModel(euclidean(4), f, h, noise)
    sym = [ca.MX.sym("xhat", 4), ca.MX.sym("P", 4, 4), ca.MX.sym("z", 3), ca.MX.sym("u", 2),
           ca.MX.sym("Q", 4, 4), ca.MX.sym("R", 3, 3), ca.MX.sym("dt"), ca.MX.sym("p")]
    out = ukf_step(model, *sym, kappa=-1.0, closed_form=closed_form)  # w_0 = -1/3 < 0
    return ca.Function("g", sym, [out[k] for k in OUTPUT_NAMES])


@pytest.mark.parametrize("noise", ["additive", "pre"])
def test_closed_form_equals_the_sigma_points_on_a_random_affine_model(noise):
    closed, sigma = _generic(noise, True), _generic(noise, False)
    rng = np.random.default_rng(22)
    for _ in range(5):
        args = [rng.standard_normal(4), _spd(rng, 4, 0.3), rng.standard_normal(3),
                rng.standard_normal(2), _spd(rng, 4, 0.01), _spd(rng, 3, 0.05), 0.005, 1.3]
        _assert_same(closed(*args), sigma(*args), f"generic {noise}")


@pytest.fixture(scope="module")
def ws(model_functions):
    return model_functions["wheel_speeds"]


VARIANTS = {
    "thesis": {},
    "midpoint_gated": {"midpoint": True, "gate": True},
    "matched": {"midpoint": True, "matched": True, "gate": True},
    "adaptive": {"midpoint": True, "matched": True, "gate": True, "adaptive": WalkAdaptation()},
}


def ws_model(ws):
    return make_velocity_model(ws, midpoint=True)


def _velocity_args(f: ca.Function, ws, rng) -> list:
    q = Q.from_rpy(*(0.05 * rng.standard_normal(2)), rng.uniform(-3, 3))
    att = np.r_[q, 0.3 * rng.standard_normal(3)]
    x = np.r_[0.3 * rng.standard_normal(4), 0.02 * rng.standard_normal(3)]
    P = np.asarray(TUN.P0) * 0.1 + _spd(rng, 7, 1e-4)
    # readings about the prediction (x advanced by a period), spread by R's deviations
    x_pred = np.r_[x[:2] + DT * x[2:4], x[2:]]
    z = np.asarray(ws_model(ws).measurement(x_pred, np.r_[att, np.zeros(9)], DT, PV)).ravel()
    z = z + np.sqrt(np.diag(TUN.R)) * rng.standard_normal(6)
    values = {"xhat": x, "P": P, "z": z, "att": att, "P_att": _spd(rng, 3, 1e-5),
              "Q": TUN.Q, "R": TUN.R, "dt": DT, "p": PV, "P_rate": _spd(rng, 3, 1e-4),
              "walk": [0.05, 0.07, 50.0], "n_rej": [0.0, 0.0]}
    return [values[n] for n in f.name_in()]


@pytest.mark.parametrize("variant", list(VARIANTS))
def test_the_shipped_velocity_filter_equals_its_sigma_point_form(ws, variant):
    closed = make_vukf(ws, **VARIANTS[variant])
    sigma = make_vukf(ws, **VARIANTS[variant], closed_form=False)
    assert closed.name_out() == sigma.name_out() and closed.name_in() == sigma.name_in()
    rng = np.random.default_rng(2022)
    for k in range(4):
        args = _velocity_args(closed, ws, rng)
        if k == 3:  # a dropout: a missing encoder and a missing accelerometer component
            args[closed.index_in("z")] = np.r_[np.nan, 10.0, -5.0, 0.1, np.nan, PAR.g]
        _assert_same(closed(*args), sigma(*args), f"{variant} case {k}",
                     closed.name_out().index("nis"))


def test_closed_form_refuses_a_model_that_is_not_affine():
    x, u, dt, p = ca.SX.sym("x", 2), ca.SX.sym("u", 1), ca.SX.sym("dt"), ca.SX.sym("p", 1)
    f = ca.Function("f", [x, u, dt, p], [x + dt * u])
    h = ca.Function("h", [x, u, dt, p], [ca.vertcat(x[0] * x[1], x[1])])
    sym = [ca.MX.sym(n, *s) for n, s in (("xhat", (2, 1)), ("P", (2, 2)), ("z", (2, 1)),
                                          ("u", (1, 1)), ("Q", (2, 2)), ("R", (2, 2)),
                                          ("dt", (1, 1)), ("p", (1, 1)))]
    with pytest.raises(ShapeError, match="affine.*nonlinear: measurement"):
        ukf_step(FilterModel(euclidean(2), f, h), *sym, closed_form=True)
    # on the attitude manifold the retraction itself is not affine
    xq = ca.SX.sym("x", 7)
    fa = ca.Function("fa", [xq, u, dt, p], [xq])
    ha = ca.Function("ha", [xq, u, dt, p], [xq[4:]])
    sym_a = [ca.MX.sym(n, *s) for n, s in (("xhat", (7, 1)), ("P", (6, 6)), ("z", (3, 1)),
                                            ("u", (1, 1)), ("Q", (6, 6)), ("R", (3, 3)),
                                            ("dt", (1, 1)), ("p", (1, 1)))]
    with pytest.raises(ShapeError, match="retraction"):
        ukf_step(FilterModel(attitude(), fa, ha), *sym_a, closed_form=True)

"""The VUKF's mid-period encoder prediction, settled on a constant-acceleration case.

At the update of period k the filter's state stands at ``t_k`` (it was predicted from
``t_{k-1}``, thesis 5.9), while the encoder increment is ``phi(t_k) - phi(t_{k-1})``
(``sim.embedded.sense``).  With the ball accelerating uniformly the increment is exactly
``Ts`` times the wheel speed at ``t_k - Ts/2``, i.e. at ``v_k - Ts/2 a``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import ballbot_casadi.estimation as E
from ballbot_casadi import load_params
from ballbot_casadi.core.constants import TS_CONTROL as TS

PAR = load_params()
PV = PAR.to_vector()
A = np.array([0.6, -0.4])  # m/s^2, inside the thesis §7.1 limit of 1 m/s^2
V0 = np.array([0.05, 0.1])
N = 400


def _v(t):
    return V0[:, None] + A[:, None] * np.atleast_1d(t)[None, :]


@pytest.fixture(scope="module")
def case(model_functions):
    """Exact (unquantised) tick increments and accelerometer readings, upright at rest."""
    ws = model_functions["wheel_speeds"]

    def dphi(v):
        return np.asarray(ws(np.r_[0, 0, 1, 0, 0, 0, v, 0, 0, 0, 0], PV)).ravel()

    t0 = np.arange(N) * TS
    # Simpson's rule is exact here: the wheel speed is linear in v, v linear in t
    ticks = np.array([PAR.n_ticks / (2 * math.pi) * TS / 6 * (
        dphi(_v(a)[:, 0]) + 4 * dphi(_v(a + TS / 2)[:, 0]) + dphi(_v(a + TS)[:, 0])) for a in t0]).T
    z = np.vstack([ticks, np.tile(np.r_[A, PAR.g][:, None], (1, N))])
    att = np.tile(np.r_[1.0, 0, 0, 0, 0, 0, 0][:, None], (1, N))
    return ws, z, att


def _velocity_error(ws, z, att, midpoint):
    tun = E.DEFAULT_TUNING["vukf"]
    x0, P0 = E.initial_state("vukf")
    x0 = np.array(x0, dtype=float).ravel()
    x0[0:2], x0[2:4] = V0, A
    F = E.make_vukf(ws, midpoint=midpoint)
    X = np.asarray(F.mapaccum("v", N, 2)(x0, P0, z, att, np.zeros((3, 3 * N)), tun.Q, tun.R,
                                         TS, PV)[0])
    return X[:2] - _v(np.arange(1, N + 1) * TS)


def test_midpoint_prediction_is_exact_under_constant_acceleration(case):
    err = _velocity_error(*case, midpoint=True)
    assert np.abs(err).max() <= 1e-9  # measured 4e-16 m/s


def test_end_of_period_prediction_lags_half_a_period(case):
    """The thesis's (5.17) at the period's end: the estimate lags by Ts/2 a."""
    err = _velocity_error(*case, midpoint=False)
    np.testing.assert_allclose(err[:, 200:], -TS / 2 * A[:, None] * np.ones((1, N - 200)),
                               rtol=0, atol=1e-6)

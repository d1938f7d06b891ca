"""The outputs of ``ballbot_mpc`` read back against its own plan: ``v_ref`` is the first
block's ``(vx, vy)`` (blocks of different plans, so taking another step's or the progress
input shows), and ``r_prim`` is ``||A u - z||_inf`` with ``A = [A_c; N G]`` formed here
from the QP data (a wrong sign, factor or norm shows)."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from _random_loop import random_velocity_loop

from ballbot_casadi.guidance.mpc import MpcConfig, make_mpc_parts
from ballbot_casadi.guidance.prediction import NXL

CFG = MpcConfig(N=4, blocks=(1, 1, 2), nodes=(1, 2, 4), iterations=3, n_obstacles=1)


@pytest.fixture(scope="module")
def mpc():
    model = random_velocity_loop(81, CFG.dt)
    return make_mpc_parts(model, CFG)


def _p(rng, L):
    N = L.N
    ang = rng.uniform(0, 2 * np.pi, N + 1)
    obs_n = rng.normal(size=(L.M, N + 1, 2))
    return L.pack(v_prev=rng.normal(size=2), path_p=rng.normal(size=(N + 1, 2)),
                  path_t=np.column_stack([np.cos(ang), np.sin(ang)]), s_bar=rng.normal(size=N + 1),
                  v_s=rng.uniform(0, 0.5, N + 1), w_lat=rng.uniform(0.1, 1.0, N + 1),
                  obs_n=obs_n, obs_b=rng.normal(size=(L.M, N + 1)), s_max=[10.0])


def test_v_ref_is_the_first_blocks_velocity_and_r_prim_the_rows_residual(mpc):
    f, L, parts = mpc
    rng = np.random.default_rng(5)
    for _ in range(2):
        x0 = 0.3 * rng.normal(size=NXL + 2)
        p = _p(rng, L)
        u0 = rng.normal(size=L.n_u)
        z0, y0 = 0.1 * rng.normal(size=L.n_rows), 0.1 * rng.normal(size=L.n_rows)
        v_ref, u, z, y, r_prim = (np.asarray(v, float).ravel() for v in f(x0, p, u0, z0, y0))
        steps = parts["cond"].inputs(u)
        assert v_ref.shape == (2,)
        np.testing.assert_array_equal(v_ref, u[0:2])
        np.testing.assert_array_equal(v_ref, steps[0, 0:2])
        assert np.max(np.abs(u[3:5] - u[0:2])) > 1e-6   # the second block plans otherwise
        # r_prim by hand: A = [A_c; N G], N of the obstacle rows from the QP's own data
        _, _, _, _, nobs = parts["qp_data"](x0, p)
        Nm = np.array(ca.DM(parts["N_sp"], ca.DM(nobs)))
        Au = np.concatenate([parts["A_c"] @ u, Nm @ (parts["G"] @ u)])
        assert z.shape == (L.n_rows,) and Au.shape == (L.n_rows,)
        assert r_prim[0] == pytest.approx(np.max(np.abs(Au - z)), rel=1e-9, abs=1e-12)
        assert r_prim[0] > 1e-6                           # 3 iterations: not converged

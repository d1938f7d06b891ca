"""The MPC's cost ``J(u, x0, p)`` of a small configuration against the sum of its weighted
residuals written here from the module docstring: the change of ``v_ref`` (from the
previous one), ``dds``, the lateral and longitudinal errors in the frame of the linearised
path window (lateral weight per node times ``w_lat``, the last node times
``w_terminal``), and the progress-speed error.  The predicted positions and progress come
from the condensed model (tested on its own)."""

from __future__ import annotations

import numpy as np
import pytest
from _random_loop import random_velocity_loop

from ballbot_casadi.guidance.condensed import NU_MPC
from ballbot_casadi.guidance.mpc import MpcConfig, make_mpc_parts, polygon
from ballbot_casadi.guidance.prediction import NXL

CFG = MpcConfig(N=4, blocks=(1, 1, 2), nodes=(1, 2, 4), iterations=2, n_obstacles=1,
                w_lat=300.0, w_lon=70.0, w_speed=15.0, w_dds=2.0, w_dv=11.0, w_terminal=3.0)


@pytest.fixture(scope="module")
def parts():
    model = random_velocity_loop(8, CFG.dt)
    _, L, extra = make_mpc_parts(model, CFG)
    return L, extra


def _inputs(rng, L):
    N = L.N
    x0 = rng.normal(size=NXL + 2)
    u = rng.normal(size=L.n_u)
    ang = rng.uniform(0, 2 * np.pi, N + 1)
    blocks = dict(v_prev=rng.normal(size=2), path_p=rng.normal(size=(N + 1, 2)),
                  path_t=np.column_stack([np.cos(ang), np.sin(ang)]),
                  s_bar=rng.normal(size=N + 1), v_s=rng.uniform(0, 0.5, N + 1),
                  w_lat=rng.uniform(0.1, 1.0, N + 1), obs_n=np.zeros((L.M, N + 1, 2)),
                  obs_b=-np.ones((L.M, N + 1)), s_max=[10.0])
    return x0, u, blocks


def _hand_cost(cond, x0, u, b):
    X = cond.states(x0, u)          # (N+1, 16): position at 12:14, progress and its rate after
    U = cond.inputs(u)              # (N, 3): v_ref (2), dds
    J, v_before = 0.0, b["v_prev"]
    N = U.shape[0]
    for k in range(N):
        J += CFG.w_dv * np.sum((U[k, :2] - v_before) ** 2) + CFG.w_dds * U[k, 2] ** 2
        v_before = U[k, :2]
        k1 = k + 1
        t = b["path_t"][k1]
        n = np.array([-t[1], t[0]])
        e = X[k1, 12:14] - b["path_p"][k1] - t * (X[k1, NXL] - b["s_bar"][k1])
        wt = CFG.w_terminal if k1 == N else 1.0
        J += wt * b["w_lat"][k1] * CFG.w_lat * (n @ e) ** 2 + wt * CFG.w_lon * (t @ e) ** 2
        J += CFG.w_speed * (X[k1, NXL + 1] - b["v_s"][k1]) ** 2
    return J


@pytest.mark.parametrize("seed", [1, 2])
def test_cost_is_the_sum_of_the_weighted_residuals(parts, seed):
    L, extra = parts
    rng = np.random.default_rng(seed)
    x0, u, blocks = _inputs(rng, L)
    J = float(extra["cost"](u, x0, L.pack(**blocks)))
    want = _hand_cost(extra["cond"], x0, u, blocks)
    assert J == pytest.approx(want, rel=1e-10)
    assert extra["cond"].n_u == 3 * NU_MPC  # three blocks


def test_each_weight_moves_the_cost(parts):
    """Zero every residual but one by construction and read that weight back."""
    L, extra = parts
    cond = extra["cond"]
    N = L.N
    x0 = np.zeros(NXL + 2)
    u = np.zeros(L.n_u)
    X = cond.states(x0, u)
    base = dict(v_prev=np.zeros(2), path_p=X[:, 12:14].copy(),
                path_t=np.tile([1.0, 0.0], (N + 1, 1)), s_bar=X[:, NXL].copy(),
                v_s=X[:, NXL + 1].copy(), w_lat=np.ones(N + 1), obs_n=np.zeros((1, N + 1, 2)),
                obs_b=-np.ones((1, N + 1)), s_max=[10.0])
    cost = lambda b: float(extra["cost"](u, x0, L.pack(**b)))  # noqa: E731
    assert cost(base) == pytest.approx(0.0, abs=1e-14)
    b = dict(base, v_prev=np.array([0.5, 0.0]))
    assert cost(b) == pytest.approx(CFG.w_dv * 0.25, rel=1e-12)
    # a lateral offset of 0.1 m at the last node only (tangent +x: lateral = -y)
    pp = base["path_p"].copy()
    pp[N, 1] += 0.1
    w = np.ones(N + 1)
    w[N] = 0.5
    assert cost(dict(base, path_p=pp, w_lat=w)) == pytest.approx(
        CFG.w_terminal * 0.5 * CFG.w_lat * 0.01, rel=1e-12)
    # the same offset at node 2 (not terminal), along the path: longitudinal, unit weight
    pp = base["path_p"].copy()
    pp[2, 0] += 0.1
    assert cost(dict(base, path_p=pp)) == pytest.approx(CFG.w_lon * 0.01, rel=1e-12)
    vs = base["v_s"].copy()
    vs[1] += 0.2
    assert cost(dict(base, v_s=vs)) == pytest.approx(CFG.w_speed * 0.04, rel=1e-12)


def test_step_rows_read_speed_progress_rate_and_progress_of_each_node(parts):
    """Per node k = 1..N: four speed-octagon rows ``D8 v_k / (v_max margin cos(pi/8))``,
    then ``ds_k >= 0`` and ``s_k - s_max <= 0`` (hard), as rows of the blocked inputs plus
    the initial state's part in the bounds."""
    from ballbot_casadi.core.constants import THESIS_LIMITS
    from ballbot_casadi.guidance.mpc import polygon

    L, extra = parts
    cond, A_c = extra["cond"], np.asarray(extra["A_c"])
    d8, f8 = polygon(8)
    vmax = THESIS_LIMITS["v_max"] * CFG.margin
    rng = np.random.default_rng(4)
    x0, _, blocks = _inputs(rng, L)
    _, _, lo, hi, _ = (np.asarray(v, float).ravel() for v in
                       extra["qp_data"](x0, L.pack(**blocks)))
    for k in range(1, L.N + 1):
        r = (k - 1) * 6
        Gk, Pk = cond.Gamma[k], cond.Phi[k]
        np.testing.assert_allclose(A_c[r:r + 4], d8 @ Gk[0:2] / (vmax * f8), rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(A_c[r + 4], Gk[NXL + 1], rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(A_c[r + 5], Gk[NXL], rtol=1e-9, atol=1e-12)
        # bounds: the rows' x0 parts moved to the bounds
        np.testing.assert_allclose(lo[r + 4], -Pk[NXL + 1] @ x0, rtol=1e-9, atol=1e-12)
        assert np.isinf(hi[r + 4]) and np.isinf(lo[r + 5])
        np.testing.assert_allclose(hi[r + 5], 10.0 - Pk[NXL] @ x0, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(hi[r:r + 4], 1.0 - d8 @ Pk[0:2] @ x0 / (vmax * f8), rtol=1e-9,
                                   atol=1e-12)


def test_node_rows_read_tilt_rate_acceleration_and_tilt_acceleration_at_each_node(parts):
    """Per constraint node k, after the 6 N step rows: four tilt-octagon rows
    ``D8 theta_k / (tilt_max margin cos(pi/8))``, four tilt-rate rows (``tilt_rate_max``,
    ``margin``), four acceleration rows of the step before the node ``D8 (C_a x_{k-1} +
    D_a v_{k-1}) / (a_max acc_margin cos(pi/8))`` and two tilt-acceleration rows
    ``/ (tilt_acc_max margin)``; the initial state's part moved to the bounds +-1."""
    L, extra = parts
    model = random_velocity_loop(8, CFG.dt)
    cond, A_c = extra["cond"], np.asarray(extra["A_c"])
    d8, f8 = polygon(8)
    lim, mg = CFG.limits, CFG.margin
    rng = np.random.default_rng(5)
    x0, _, blocks = _inputs(rng, L)
    _, _, lo, hi, _ = (np.asarray(v, float).ravel() for v in extra["qp_data"](x0, L.pack(**blocks)))
    steps = np.stack([cond.inputs(e) for e in np.eye(L.n_u)])        # (n_u, N, 3): linear in ub
    scale = {"tilt": lim["tilt_max"] * mg * f8, "tilt_rate": lim["tilt_rate_max"] * mg * f8,
             "acc": lim["a_max"] * CFG.acc_margin * f8}
    assert scale["acc"] != lim["a_max"] * mg * f8 and CFG.margin != 1.0
    for i, k in enumerate(CFG.nodes):
        r = 6 * L.N + 14 * i
        Gk, Gp, Pk, Pp = cond.Gamma[k][:NXL], cond.Gamma[k - 1][:NXL], cond.Phi[k][:NXL], cond.Phi[k - 1][:NXL]
        S = steps[:, k - 1, 0:2].T                                      # d v_{k-1} / d ub
        want = {
            "tilt": (d8 @ model.C["tilt"] @ Gk / scale["tilt"], d8 @ model.C["tilt"] @ Pk @ x0 / scale["tilt"]),
            "tilt_rate": (d8 @ model.C["tilt_rate"] @ Gk / scale["tilt_rate"],
                          d8 @ model.C["tilt_rate"] @ Pk @ x0 / scale["tilt_rate"]),
            "acc": (d8 @ (model.C["acc"] @ Gp + model.D["acc"] @ S) / scale["acc"],
                    d8 @ model.C["acc"] @ Pp @ x0 / scale["acc"]),
            "tilt_acc": ((model.C["tilt_acc"] @ Gp + model.D["tilt_acc"] @ S) / (CFG.tilt_acc_max * mg),
                         model.C["tilt_acc"] @ Pp @ x0 / (CFG.tilt_acc_max * mg)),
        }
        for name, n in (("tilt", 4), ("tilt_rate", 4), ("acc", 4), ("tilt_acc", 2)):
            rows, part = want[name]
            np.testing.assert_allclose(A_c[r:r + n], rows, rtol=1e-9, atol=1e-12, err_msg=f"{name} {k}")
            np.testing.assert_allclose(hi[r:r + n], 1.0 - part, rtol=1e-9, atol=1e-12, err_msg=f"{name} {k}")
            np.testing.assert_allclose(lo[r:r + n], -1.0 - part, rtol=1e-9, atol=1e-12, err_msg=f"{name} {k}")
            r += n
        assert np.abs(A_c[r - 14:r]).max() > 0      # the rows read something
    assert A_c.shape[0] == 6 * L.N + 14 * len(CFG.nodes)

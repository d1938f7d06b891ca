"""The log a mission returns (sim.closed_loop.ClosedLoop.simulate) on a symbolic toy step
whose outputs name their inputs: each period's row, the state log's final row, the
controller state from the initial one, the references used, the time column, the packing
of the initial state and of every constant, and the refusals of bad inputs with the key
they name (issue 23: a row off by one, a log from the wrong output, a constant packed in
the wrong slot must show)."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.core.params import PARAM_NAMES
from ballbot_casadi.errors import ScenarioError, ShapeError
from ballbot_casadi.sim.closed_loop import ClosedLoop

NP = len(PARAM_NAMES)
NZ = 8
N = 4


def _toy_step() -> ca.Function:
    """xz_next = [x + v_ref[0] + w[3], z + Ts * k_vel[0]]; x output = x + p_plant[0];
    tau_cmd = [k_bal[0], cascade, feedforward]; tau = w[3:6] + p_ctrl[1];
    q_ref_used = q_ref + dq_ref[0]; dq_ref_used = dq_ref; ddq_ref_used = 2 ddq_ref; diag = [x[0]]."""
    S = ca.MX.sym
    xz, q, dq, ddq, v, w = S("xz", 12 + NZ), S("q_ref", 4), S("dq_ref", 4), S("ddq_ref", 4), S("v_ref", 3), S("w", 6)
    pp, pc, kb, kv, Ts, cas, ff = S("p_plant", NP), S("p_ctrl", NP), S("k_bal", 5), S("k_vel", 26), S("Ts"), \
        S("cascade"), S("feedforward")
    x, z = xz[:12], xz[12:]
    ins = [xz, q, dq, ddq, v, w, pp, pc, kb, kv, Ts, cas, ff]
    outs = [ca.vertcat(x + v[0] + w[3], z + Ts * kv[0]), x + pp[0], ca.vertcat(kb[0], cas, ff), w[3:6] + pc[1],
            q + dq[0], dq, 2 * ddq, x[0]]
    return ca.Function("ballbot_cl_step_toy", ins, outs,
                       ["xz", "q_ref", "dq_ref", "ddq_ref", "v_ref", "w", "p_plant", "p_ctrl", "k_bal",
                        "k_vel", "Ts", "cascade", "feedforward"],
                       ["xz_next", "x", "tau_cmd", "tau", "q_ref_used", "dq_ref_used", "ddq_ref_used",
                        "diag"])


@pytest.fixture(scope="module")
def sim():
    return ClosedLoop(compiled=False, steps={"toy": _toy_step()})


def _inputs():
    k = np.arange(N, dtype=float)[:, None]
    w = np.zeros((N, 6))
    w[:, 3] = 0.01 * (k[:, 0] + 1)
    w[:, 4] = -1.0
    p_plant, p_ctrl = np.zeros(NP), np.zeros(NP)
    p_plant[0], p_ctrl[1] = 100.0, 0.5
    return dict(x0=np.arange(12.0), p_plant=p_plant, p_ctrl=p_ctrl, k_bal=np.array([3.0, 0, 0, 0, 0]),
                k_vel=np.r_[2.0, np.zeros(25)], z0=np.arange(NZ) + 0.5,
                q_ref=np.hstack([k, k + 0.1, k + 0.2, k + 0.3]), dq_ref=np.hstack([k * 10, k, k, k]),
                ddq_ref=np.tile([1.0, 2.0, 3.0, 4.0], (N, 1)), v_ref=np.hstack([k + 1, -k, k * 0]),
                w=w, Ts=0.01, cascade=True, feedforward=False)


def test_log_rows_by_hand(sim):
    inp = _inputs()
    log = sim.simulate("toy", **inp)
    np.testing.assert_allclose(log["time"], [0.0, 0.01, 0.02, 0.03, 0.04], rtol=1e-15)
    # x_k = x0 + sum_{j<k} (v_ref[j, 0] + w[j, 3]) = x0 + sum (j + 1 + 0.01 (j + 1))
    steps = np.cumsum(np.r_[0.0, 1.01 * (np.arange(N) + 1)])
    x = inp["x0"][None, :] + steps[:, None]
    np.testing.assert_allclose(log["state"][:N], x[:N] + 100.0, rtol=1e-14)  # the step's x output
    np.testing.assert_allclose(log["state"][N], x[N], rtol=1e-14)            # the final state
    np.testing.assert_allclose(log["z"], inp["z0"][None, :] + 0.02 * np.arange(N + 1)[:, None], rtol=1e-14)
    np.testing.assert_allclose(log["xz_final"], np.r_[x[N], inp["z0"] + 0.02 * N], rtol=1e-14)
    np.testing.assert_array_equal(log["tau_cmd"], np.tile([3.0, 1.0, 0.0], (N, 1)))
    np.testing.assert_allclose(log["tau"], inp["w"][:, 3:6] + 0.5, rtol=1e-15)
    np.testing.assert_allclose(log["q_ref"], inp["q_ref"] + inp["dq_ref"][:, :1], rtol=1e-15)
    np.testing.assert_array_equal(log["dq_ref"], inp["dq_ref"])
    np.testing.assert_array_equal(log["ddq_ref"], 2 * inp["ddq_ref"])
    np.testing.assert_array_equal(log["v_ref"], inp["v_ref"])
    np.testing.assert_array_equal(log["w"], inp["w"])
    np.testing.assert_allclose(log["diag"][:, 0], x[:N, 0], rtol=1e-14)
    assert "x_hat" not in log and "guide" not in log and "com_hat" not in log


def test_a_segment_continues_from_xz0(sim):
    inp = _inputs()
    whole = sim.simulate("toy", **inp)
    first = sim.simulate("toy", **{**inp, **{k: inp[k][:2] for k in ("q_ref", "dq_ref", "ddq_ref", "v_ref", "w")}})
    rest = sim.simulate("toy", **{**inp, **{k: inp[k][2:] for k in ("q_ref", "dq_ref", "ddq_ref", "v_ref", "w")}},
                        xz0=first["xz_final"])
    np.testing.assert_allclose(rest["xz_final"], whole["xz_final"], rtol=1e-15)
    np.testing.assert_allclose(rest["state"], whole["state"][2:], rtol=1e-15)


@pytest.mark.parametrize("change, error, needle", [
    ({"q_ref": np.zeros((N, 3))}, ShapeError, r"q_ref must have shape \(N, 4\)"),
    ({"w": np.zeros((N + 1, 6))}, ShapeError, "w has 5 rows, the other sequences 4"),
    ({"v_ref": np.full((N, 3), np.nan)}, ScenarioError, "v_ref contains NaN"),
    ({"k_bal": np.zeros(4)}, ShapeError, "k_bal has 4 entries, expected 5"),
    ({"xz0": np.zeros(12 + NZ + 1)}, ShapeError, "initial state has 21 entries, expected 20"),
    ({"z0": np.zeros(NZ + 1)}, ShapeError, "initial state has 21 entries, expected 20"),
    ({"n_sub": 0}, ScenarioError, "n_sub must be an int >= 1"),
    ({"n_sub": 3}, ScenarioError, "these custom steps integrate with n_sub = 5"),
    ({"estimator": "ukf"}, ScenarioError, "custom steps integrate"),
    ({"com_observer": True}, ScenarioError, "com_observer = true needs steps with the COM observer"),
])
def test_bad_inputs_are_refused(sim, change, error, needle):
    with pytest.raises(error, match=needle):
        sim.simulate("toy", **{**_inputs(), **change})


def test_unknown_controller_and_constructor_checks(sim):
    with pytest.raises(ScenarioError, match="unknown controller 'flc'; allowed: toy"):
        sim.simulate("flc", **_inputs())
    assert sim.controllers == ("toy",)
    for bad in (0, True, 1.5):
        with pytest.raises(ScenarioError, match="n_sub must be an int >= 1"):
            ClosedLoop(compiled=False, n_sub=bad, steps={"toy": _toy_step()})

"""The embedded software's period against its filters called one by one (an oracle of the
wiring): which state slices and readings each filter gets (the gate counters, the
acceleration compensation, the encoder increments, the matched velocity filter's rate
input), the estimate the controllers read (position = previous position + Ts times the
*new* velocity estimate, ``dq = 1/2 q o [0, omega]``), and the next state, repairs and
rejections.  The state is perturbed so that every slice differs from its neighbours."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import ATTITUDE_FILTER_STATE as XA, VELOCITY_FILTER_STATE as XV
from ballbot_casadi.core.layout import STATE, STATE_DXY, STATE_XY
from ballbot_casadi.core.params import load_params
from ballbot_casadi.sim.closed_loop import power_on_inputs
from ballbot_casadi.sim.embedded import (
    GATE_GROUPS,
    MEAS,
    embedded_software,
    software_blocks,
    software_layout,
)
from ballbot_casadi.studies.registry import study_scenarios

G = load_params().g


def _case(estimator: str, gyro_x: float):
    sc = study_scenarios("sine", "flc")[0].replace(duration=0.05, estimator=estimator, seed=3)
    inp = power_on_inputs(estimator, sc.inputs())
    f = embedded_software("flc", estimator)
    L = software_layout(f, estimator)
    c = np.zeros(L.size)
    c[L["z"]] = inp["z0"]
    c[L["obs"]] = inp["o0"]
    e0 = inp["estimation"]["e0"]
    c[L.offset("xa"):L.offset("xa") + e0.size] = e0
    q = Q.from_rpy(0.03, -0.02, 0.4)
    c[L["xa"]] = np.r_[q, 0.05, -0.03, 0.2]
    c[L["xv"]] = [0.3, -0.2, 0.8, 0.5, 0.01, -0.02, 0.03]  # v, a, b_acc all different
    c[L["pos"]] = [1.5, -0.7]
    c[L["gate"]] = [0.0, 3.0, 7.0, 0.0]  # attitude [acc, gyro], velocity [enc, acc]
    if L.has("walk"):  # the adapted acceleration random walk [q_x, q_y, n]
        c[L["walk"]] = [0.03, 0.08, 12.0]
    Pv = np.diag([1e-2, 1e-2, 1e-3, 1e-3, 1e-9, 1e-9, 1e-9])
    Pv[0, 1] = Pv[1, 0] = 0.5  # indefinite: the velocity filter repairs it
    c[L["Pv"]] = Pv.ravel(order="F")
    meas = np.r_[Q.rotate_inv(q, [0.4, -0.1, G]), [0.06, gyro_x, 0.21], [40.0, -25.0, 12.0]]
    est = inp["estimation"]
    args = {"c": c, "meas": meas, "q_ref": inp["q_ref"][0], "dq_ref": inp["dq_ref"][0],
            "ddq_ref": inp["ddq_ref"][0], "v_ref": [0.2, -0.1, 0.05], "p_ctrl": inp["p_ctrl"],
            "p_est": est["p_est"], "k_bal": inp["k_bal"], "k_vel": inp["k_vel"], "Ts": inp["Ts"],
            "cascade": 1.0, "feedforward": 1.0, "com_observer": 0.0, "k_obs": inp["k_obs"],
            **{k: np.ravel(est[k], order="F") for k in ("Qa", "Ra", "Qv", "Rv")}}
    return f, L, args, est


@pytest.mark.parametrize("gyro_x", [-0.04, 1000.0])  # a clean reading, a gyro glitch
@pytest.mark.parametrize("estimator", ["ukf", "ukf_consistent", "ukf_adaptive"])
def test_embedded_period_equals_its_filters_called_one_by_one(estimator, gyro_x):
    f, L, a, est = _case(estimator, gyro_x)
    out = {k: np.asarray(v, float).ravel() for k, v in f.call(a).items()}
    _, blocks = software_blocks("flc", estimator)
    c, Ts, meas = a["c"], a["Ts"], a["meas"]
    acc, gyro, enc = meas[MEAS["acc"]], meas[MEAS["gyro"]], meas[MEAS["enc"]]
    xv = c[L["xv"]]
    att = blocks.attitude(xhat=c[L["xa"]], P=c[L["Pa"]].reshape(6, 6, order="F"),
                          z=np.r_[acc, gyro], Q=est["Qa"], R=est["Ra"], dt=Ts, p=est["p_est"],
                          a=np.r_[xv[XV["a"]], 0.0], n_rej=c[L["gate"]][:2])
    att = {k: np.asarray(v, float) for k, v in att.items()}
    xa = att["xhat_next"].ravel()
    extra, att_v = {}, xa
    if estimator in ("ukf_consistent", "ukf_adaptive"):  # the gyro reading and its noise +
        extra = {"P_rate": est["Ra"][3:6, 3:6] + est["Qa"][3:6, 3:6] / 3}  # a third of Q_rate
        att_v = np.r_[xa[XA["q"]], gyro]
    if estimator == "ukf_adaptive":  # the walk state goes in, its next value comes out
        extra["walk"] = c[L["walk"]]
    vel = blocks.velocity(xhat=xv, P=c[L["Pv"]].reshape(7, 7, order="F"), z=np.r_[enc * Ts, acc],
                          att=att_v, P_att=att["P_att"], Q=est["Qv"], R=est["Rv"], dt=Ts,
                          p=est["p_est"], n_rej=c[L["gate"]][2:], **extra)
    vel = {k: np.asarray(v, float) for k, v in vel.items()}
    xv_next = vel["xhat_next"].ravel()
    q_c = np.asarray(blocks.tilt_correction(q=xa[XA["q"]], a=xv_next[XV["a"]],
                                            b_acc=xv_next[XV["b_acc"]], p=est["p_est"])["q_c"]).ravel()
    v = xv_next[XV["v"]]
    w = xa[XA["omega"]]
    pos = c[L["pos"]] + Ts * v  # the new velocity estimate, not the previous one
    dq = 0.5 * Q.mul(q_c, np.r_[0.0, w])  # body rate: q o [0, omega]
    x_hat = out["x_hat"]
    np.testing.assert_allclose(x_hat[STATE["q"]], q_c, rtol=0, atol=1e-12)
    np.testing.assert_allclose(x_hat[STATE_DXY], v,
                               rtol=0, atol=1e-12)
    np.testing.assert_allclose(x_hat[STATE_XY], pos, rtol=0, atol=1e-12)
    np.testing.assert_allclose(x_hat[STATE["dq"]], dq, rtol=0, atol=1e-12)
    # a gyro glitch is rejected, counted on from the state's 3; a clean reading passes
    rej = np.r_[att["rejected"].ravel(), vel["rejected"].ravel()]
    glitch = float(gyro_x > 100)
    np.testing.assert_array_equal(rej[GATE_GROUPS["attitude_gyro"]], [glitch])
    np.testing.assert_array_equal(out["rejections"], rej)
    n_next = np.r_[att["n_rej_next"].ravel(), vel["n_rej_next"].ravel()]
    assert n_next[GATE_GROUPS.index("attitude_gyro")] == 4.0 * glitch
    cn = out["c_next"]
    np.testing.assert_array_equal(cn[L["gate"]], n_next)
    np.testing.assert_allclose(cn[L["xa"]], xa, rtol=0, atol=1e-12)
    np.testing.assert_allclose(cn[L["Pa"]], att["P_next"].ravel(order="F"), rtol=0, atol=1e-15)
    np.testing.assert_allclose(cn[L["xv"]], xv_next, rtol=0, atol=1e-12)
    np.testing.assert_allclose(cn[L["Pv"]], vel["P_next"].ravel(order="F"), rtol=0, atol=1e-15)
    np.testing.assert_allclose(cn[L["pos"]], pos, rtol=0, atol=1e-12)
    if estimator == "ukf_adaptive":
        np.testing.assert_allclose(cn[L["walk"]], vel["walk_next"].ravel(), rtol=0, atol=1e-15)
        if not glitch:  # every reading used: it adapted (n 12 -> 13)
            assert cn[L["walk"]][2] == 13.0 and not np.allclose(cn[L["walk"]], c[L["walk"]])
    # repairs: both filters' (the velocity filter repaired the indefinite covariance)
    assert vel["n_repair"].item() >= 1
    assert out["repairs"][0] == att["n_repair"].item() + vel["n_repair"].item()
    np.testing.assert_allclose(out["nis"], [att["nis"].item(), vel["nis"].item()], rtol=1e-12)

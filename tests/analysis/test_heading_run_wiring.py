"""``heading_run``'s bookkeeping around the compiled filter chunk, with a recording
stand-in chunk: the filter starts aligned with the true attitude at t = 0 (roll 0, pitch
1 deg, yaw 0: the synthetic run's start, written here by hand) with its tuning's rate, bias,
covariance and noise; each chunk starts from the last column of the one before (state and
covariance block); the unaided filter gets no heading reading; the logs keep every
``log_every``-th period at its time, the true yaw, the estimate's yaw and bias."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.analysis import heading as H
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.sensor_params import load_sensor_params
from ballbot_casadi.estimation import DEFAULT_TUNING
from ballbot_casadi.estimation.heading import HEADING_FILTER_STATE, HEADING_MEAS, heading_tuning

TS = 0.005
N = H.HEADING_CHUNK


def _stand_in(calls):
    def chunk(aided):
        def run(x, P, z, Qn, R, Ts, p, u):
            calls.append({"aided": aided, "x": np.array(x, float), "P": np.array(P, float),
                          "z": np.array(z, float), "Q": np.array(Qn, float), "R": np.array(R, float),
                          "Ts": Ts, "u": np.array(u, float)})
            x = np.array(x, float)
            X = np.repeat(x[:, None], N, axis=1)
            X[-1, :] = x[-1] + np.arange(1, N + 1)         # the last state counts the periods
            Pn = np.hstack([np.array(P, float) * (j + 2) for j in range(N)])
            return X, Pn
        return run
    return chunk


@pytest.mark.parametrize("aided", [True, False])
def test_heading_run_wiring(monkeypatch, aided):
    calls = []
    monkeypatch.setattr(H, "_chunk", _stand_in(calls))
    run = H.heading_run(1.5 * N * TS, seed=4, aided=aided, log_every=700, Ts=TS, bias0=(0.01, 0.02, 0.03))
    assert len(calls) == 2                                  # 1.5 chunks: rounded up
    first, second = calls
    q0 = Q.from_rpy(0.0, np.radians(1.0), 0.0)
    np.testing.assert_allclose(first["x"][:4], q0, rtol=0, atol=1e-15)
    sp = load_sensor_params()
    if aided:
        tun = heading_tuning(sp.heading_noise_var[0], sp.gyro_bias_rw[2], TS)
        want = {"Q": tun["Q"], "R": tun["R"], "P": tun["P0"]}
        np.testing.assert_array_equal(first["x"][4:], np.asarray(tun["x0"])[4:])
        assert first["z"].shape[0] == HEADING_MEAS.size
    else:
        t = DEFAULT_TUNING["qukf"]
        want = {"Q": t.Q, "R": t.R, "P": t.P0}
        np.testing.assert_array_equal(first["x"][4:], np.asarray(t.x0)[4:])
        assert first["z"].shape[0] == HEADING_MEAS.offset("yaw")    # no heading reading
    for k, v in want.items():
        np.testing.assert_array_equal(first[k], np.asarray(v, float), err_msg=k)
    np.testing.assert_array_equal(second["Q"], first["Q"])
    assert first["z"].shape[1] == N and first["Ts"] == TS
    np.testing.assert_array_equal(first["u"], np.zeros(3))
    # the second chunk starts from the first's last column and last covariance block
    np.testing.assert_array_equal(second["x"][:-1], first["x"][:-1])
    assert second["x"][-1] == first["x"][-1] + N
    np.testing.assert_allclose(second["P"], first["P"] * (N + 1), rtol=1e-15, atol=0)
    # logs: every 700th period of 2 chunks, the true yaw there, the stand-in's yaw (0)
    k = np.arange(0, 2 * N, 700)
    np.testing.assert_allclose(run.time, k * TS, rtol=0, atol=1e-12)
    q_true, _ = H.heading_truth(0, 2 * N, TS)
    yaw = np.array([Q.to_rpy(q)[2] for q in q_true[k]])
    np.testing.assert_allclose(run.yaw, yaw, rtol=0, atol=1e-12)
    assert np.all(np.abs(run.yaw[1:]) > 1e-3)               # the truth turns
    assert run.bias[0] == 0.03 and np.all(np.abs(run.bias - 0.03) < 1e-3)  # the z bias, walking
    assert len(set(run.bias.tolist())) == len(k)
    np.testing.assert_allclose(run.yaw_hat, 0.0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(run.error, -yaw, rtol=0, atol=1e-12)
    if aided:
        b = HEADING_FILTER_STATE["b_z"].start
        assert b == len(first["x"]) - 1
        np.testing.assert_allclose(run.bias_hat, first["x"][-1] + (k % N) + 1 + N * (k // N),
                                   rtol=0, atol=1e-9)
    else:
        assert np.all(np.isnan(run.bias_hat))


def test_heading_run_keeps_every_period_with_log_every_one(monkeypatch):
    """The smallest logging step is allowed and keeps each period, in order."""
    monkeypatch.setattr(H, "_chunk", _stand_in([]))
    run = H.heading_run(0.5 * N * TS, seed=4, aided=True, log_every=1, Ts=TS)
    np.testing.assert_allclose(run.time, np.arange(N) * TS, rtol=0, atol=1e-12)
    assert run.yaw.shape == run.bias.shape == (N,)

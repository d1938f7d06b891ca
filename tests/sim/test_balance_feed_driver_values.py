"""The balance feed's Python driver (run_balance_path) with a recording simulator and a
constant-output MPC: how many samples it runs, and the quaternion references it feeds
each period, against the tilt reference integrated by hand."""

from __future__ import annotations

import numpy as np

from ballbot_casadi.control.velocity import tilt_heading_reference
from ballbot_casadi.core.layout import STATE_DXY, STATE_XY
from ballbot_casadi.core.layout import VELOCITY_CONTROLLER_STATE as Z
from ballbot_casadi.guidance.paths import line_path
from ballbot_casadi.sim.balance_feed import run_balance_path

A = np.array([0.1, -0.2])
EVERY, TS = 4, 0.005


class FakeMPC:
    solve_s: list = []

    def __init__(self):
        self.samples = []

    def step(self, Xs):
        self.samples.append(np.array(Xs, float))
        return A

    def progress(self):
        return 0.0

    def prediction(self):
        return np.zeros((3, 2))


class FakeSim:
    def __init__(self):
        self.calls, self.finals = [], []

    def simulate(self, controller, xz0=None, **seq):
        self.calls.append(seq)
        x, z = np.asarray(seq["x0"], float), np.asarray(seq["z0"], float)
        n = seq["q_ref"].shape[0]
        state = np.tile(x, (n + 1, 1))
        state[-1, STATE_XY] += (0.1, -0.05)   # each chunk moves the ball, at its own speed
        state[-1, STATE_DXY] = (0.3 * len(self.calls), -0.2)
        self.finals.append(state[-1].copy())
        return {"time": np.arange(n + 1) * TS, "state": state,
                "z": np.tile(z, (n + 1, 1)), "tau": np.zeros((n, 3)), "xz_final": None}


def test_samples_and_fed_references_by_hand(monkeypatch):
    import ballbot_casadi.sim.balance_feed as BF

    th_eq = np.array([0.01, -0.02])  # as a COM offset would give (read at the start heading)
    asked = []
    monkeypatch.setattr(BF, "equilibrium_tilt", lambda p, psi: asked.append(psi) or th_eq)
    sim, mpc = FakeSim(), FakeMPC()
    run = run_balance_path(line_path((0.0, 0.0), (2.0, 0.0)), mpc, 3 * EVERY * TS, sim,
                           every=EVERY)
    assert len(sim.calls) == 3 and run.v_ref.shape == (3, 2)
    np.testing.assert_allclose(run.t_guidance, [0.0, EVERY * TS, 2 * EVERY * TS], rtol=1e-12)
    z0 = np.asarray(sim.calls[0]["z0"], float)
    th, dth = z0[Z["theta_r"]].copy(), z0[Z["dtheta_r"]].copy()
    psi, r = float(z0[Z.index("psi_r")]), float(z0[Z.index("r_r")])
    ref = tilt_heading_reference()
    starts = [np.asarray(sim.calls[0]["x0"], float), *sim.finals[:-1]]  # where each sample starts
    for call, Xs, x0 in zip(sim.calls, mpc.samples, starts):
        # the sample's state: ball velocity, tilt reference about the equilibrium tilt and
        # its rate, the tilt and velocity-controller states zero, position
        assert Xs.shape == (14,)
        np.testing.assert_allclose(Xs, np.r_[x0[STATE_DXY], th - th_eq, dth, np.zeros(6), x0[STATE_XY]],
                                   rtol=1e-12, atol=1e-15)
        assert not call["cascade"]
        for k in range(EVERY):
            q, dq, ddq = (np.asarray(v, float).ravel()
                          for v in ref(np.r_[th, psi], np.r_[dth, r], np.r_[A, 0.0]))
            np.testing.assert_allclose(call["q_ref"][k], q, rtol=1e-12, atol=1e-15)
            np.testing.assert_allclose(call["dq_ref"][k], dq, rtol=1e-12, atol=1e-15)
            np.testing.assert_allclose(call["ddq_ref"][k], ddq, rtol=1e-12, atol=1e-15)
            th, dth = th + TS * dth + 0.5 * TS ** 2 * A, dth + TS * A
        assert call["v_ref"].shape == (EVERY, 3)
    assert run.log["state"].shape[0] == 3 * EVERY + 1
    assert asked == [psi]

"""The balance feed's Python driver runs the NEAREST whole number of guidance samples to
``duration / (every Ts)``: 0.58 s at 4 periods of 5 ms is 28.999999999999996 in floating
point and 29 samples, not 28 (issue 23: truncation for rounding must show)."""

from __future__ import annotations

import numpy as np

from ballbot_casadi.guidance.paths import line_path
from ballbot_casadi.sim.balance_feed import run_balance_path


class _MPC:
    solve_s: list = []

    def step(self, Xs):
        return np.zeros(2)

    def progress(self):
        return 0.0

    def prediction(self):
        return np.zeros((3, 2))


class _Sim:
    calls = 0

    def simulate(self, controller, xz0=None, **seq):
        self.calls += 1
        n = seq["q_ref"].shape[0]
        x, z = np.asarray(seq["x0"], float), np.asarray(seq["z0"], float)
        return {"time": np.arange(n + 1) * 0.005, "state": np.tile(x, (n + 1, 1)),
                "z": np.tile(z, (n + 1, 1)), "tau": np.zeros((n, 3)), "xz_final": None}


def test_samples_are_rounded_not_truncated():
    assert 0.58 / (4 * 0.005) < 29
    sim = _Sim()
    run = run_balance_path(line_path((0.0, 0.0), (2.0, 0.0)), _MPC(), 0.58, sim, every=4)
    assert sim.calls == 29 and run.t_guidance.size == 29
    np.testing.assert_allclose(run.t_guidance[-1], 28 * 4 * 0.005, rtol=1e-12)
    assert run.log["state"].shape[0] == 29 * 4 + 1

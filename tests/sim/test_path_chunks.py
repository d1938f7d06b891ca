"""The chunked log of the Python path-following drivers (:func:`simulate_chunk`,
:func:`chunks_log`): one sample's periods at a time, joined without repeating the rows a
chunk shares with the next."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.sim.path_following import chunks_log, simulate_chunk


class _FakeLoop:
    """Periods of a counter: state and z rows k..k+n (n + 1 rows), per-period rows k..k+n-1."""

    def __init__(self, n: int) -> None:
        self.n, self.calls = n, []

    def simulate(self, controller, xz0, **seq):
        self.calls.append((controller, xz0, seq))
        k = int(xz0)
        rows = np.arange(k, k + self.n + 1, dtype=float)
        return {"time": rows * 0.5, "state": np.c_[rows, -rows], "z": np.c_[10 * rows],
                "tau": np.c_[rows[:-1], rows[:-1], rows[:-1]], "xz_final": k + self.n}


def test_chunks_join_without_repeating_the_shared_rows():
    sim, parts, xz = _FakeLoop(4), {}, 0
    for _ in range(3):
        xz, x, z = simulate_chunk(sim, "flc", {"v_ref": 1}, xz, parts)
    assert xz == 12
    assert [c[:2] for c in sim.calls] == [("flc", 0), ("flc", 4), ("flc", 8)]
    assert sim.calls[0][2] == {"v_ref": 1}
    log = chunks_log(parts, x, z, Ts=0.25)
    k = np.arange(13.0)
    np.testing.assert_array_equal(log["state"], np.c_[k, -k])
    np.testing.assert_array_equal(log["z"], np.c_[10 * k])
    np.testing.assert_array_equal(log["tau"][:, 0], k[:-1])
    np.testing.assert_allclose(log["time"], k * 0.25, rtol=0, atol=0)
    assert log["tau"].shape == (12, 3)


def test_the_default_period_is_the_control_period():
    from ballbot_casadi.core.constants import TS_CONTROL
    parts = {}
    _, x, z = simulate_chunk(_FakeLoop(2), "lqr", {}, 0, parts)
    assert chunks_log(parts, x, z)["time"][-1] == pytest.approx(2 * TS_CONTROL, rel=1e-12)

"""The mission builders (sim.mission) on a toy step with hand values: a one-period mission,
the period-count refusal read back, a chunk's last state and its broadcast constants, and
a composed mission (whole chunks plus a remainder, chunks only, remainder only) equal to
the plain ``mapaccum`` (mutant classes: off-by-one in a bound or a slice, a dropped
remainder)."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.sim.mission import compose_mission, make_chunk, make_mission


def _toy_step() -> ca.Function:
    """xz+ = [0.5 xz0 + Ts v0, xz1 - 2 Ts v1]; also outputs tau = v0 + 10 k (k the step's
    constant): a sequence input (v_ref) and two constants (Ts, k)."""
    xz, v, Ts, k = ca.SX.sym("xz", 2), ca.SX.sym("v_ref", 3), ca.SX.sym("Ts"), ca.SX.sym("k")
    nxt = ca.vertcat(0.5 * xz[0] + Ts * v[0], xz[1] - 2 * Ts * v[1])
    return ca.Function("ballbot_cl_step_toy", [xz, v, Ts, k], [nxt, v[0] + 10 * k],
                       ["xz", "v_ref", "Ts", "k"], ["xz_next", "tau"])


def _by_hand(v: np.ndarray, Ts: float, k: float, xz0=(1.0, -1.0)):
    xz, rows, tau = np.array(xz0, float), [], []
    for vk in v:
        xz = np.array([0.5 * xz[0] + Ts * vk[0], xz[1] - 2 * Ts * vk[1]])
        rows.append(xz)
        tau.append(vk[0] + 10 * k)
    return np.array(rows).T, np.array(tau)


V = np.array([[0.1 * (i + 1), -0.03 * i ** 2, 7.0] for i in range(7)])


def test_one_period_and_the_refusals():
    assert make_mission(_toy_step(), 2).name() == "ballbot_mission_toy"
    m = make_mission(_toy_step(), 1)
    out = m([1.0, -1.0], V[:1].T, 0.2, 0.5)
    want, tau = _by_hand(V[:1], 0.2, 0.5)
    np.testing.assert_allclose(np.asarray(out[0]), want, rtol=0, atol=1e-15)
    np.testing.assert_allclose(np.asarray(out[1]).ravel(), tau, rtol=0, atol=1e-15)
    for bad in (0, -2, 2.5):
        for build in (lambda n: make_mission(_toy_step(), n),
                      lambda n: compose_mission(_toy_step(), make_chunk(_toy_step(), 3), 3, n)):
            with pytest.raises(ScenarioError) as e:
                build(bad)
            assert str(e.value) == f"number of control periods must be an int >= 1, got {bad!r}"


def test_a_chunk_returns_its_last_state_first_and_broadcasts_its_constants():
    step = _toy_step()
    chunk = make_chunk(step, 3)
    assert chunk.name() == "ballbot_cl_chunk_toy"
    assert chunk.name_out() == ["xz_last", "xz_next", "tau"]
    assert (chunk.size1_in(1), chunk.size2_in(1), chunk.size2_in(2), chunk.size2_in(3)) == (3, 3, 1, 1)
    last, xz, tau = (np.asarray(o) for o in chunk([1.0, -1.0], V[:3].T, 0.2, 0.5))
    want, want_tau = _by_hand(V[:3], 0.2, 0.5)
    np.testing.assert_allclose(xz, want, rtol=0, atol=1e-15)
    np.testing.assert_allclose(last.ravel(), want[:, -1], rtol=0, atol=1e-15)
    np.testing.assert_allclose(tau.ravel(), want_tau, rtol=0, atol=1e-15)


@pytest.mark.parametrize("n", [7, 6, 2, 3, 1])
def test_a_composed_mission_is_the_plain_one(n):
    """Chunks of 3: 7 = 2 chunks + 1, 6 = 2 chunks, 2 = the remainder only, 3 = one chunk."""
    step = _toy_step()
    mission = compose_mission(step, make_chunk(step, 3), 3, n)
    assert mission.name() == "ballbot_mission_toy" and mission.size2_in(1) == n
    xz, tau = (np.asarray(o) for o in mission([1.0, -1.0], V[:n].T, 0.2, 0.5))
    want, want_tau = _by_hand(V[:n], 0.2, 0.5)
    assert xz.shape == (2, n)
    np.testing.assert_allclose(xz, want, rtol=0, atol=1e-15)
    np.testing.assert_allclose(tau.ravel(), want_tau, rtol=0, atol=1e-15)

"""The estimation package's defaults read back: each builder's default signature, the
default tuning of every registered filter entry by entry, and the initial-state
helper's limits (the quaternion norm tolerance exactly inside and outside)."""

from __future__ import annotations

import numpy as np
import pytest

import ballbot_casadi.estimation as E
from ballbot_casadi.errors import ShapeError, StateError
from ballbot_casadi.estimation import tuning as T
from ballbot_casadi.estimation.attitude import INPUT_NAMES, make_qekf, make_qukf, qekf_initial_covariance
from ballbot_casadi.estimation.core import InnovationGate
from ballbot_casadi.estimation.heading import HEADING_P0_BIAS


def test_attitude_builders_default_to_the_thesis_filters():
    for f, name in ((make_qukf(), "ballbot_qukf"), (make_qekf(), "ballbot_qekf")):
        assert f.name() == name
        assert f.name_in() == list(INPUT_NAMES)
        assert f.n_out() == 7
    assert make_qukf(renormalise=True).name() == "ballbot_qukf_renorm"
    assert make_qukf(compensate_acceleration=True).name_in() == [*INPUT_NAMES, "a"]
    assert make_qukf(gate=True).name_in() == [*INPUT_NAMES, "n_rej"]
    assert make_qekf(gate=True, compensate_acceleration=True).name_in() == [*INPUT_NAMES, "a", "n_rej"]


def test_gate_defaults():
    g = InnovationGate((("a", (0, 1)),))
    assert (g.probability, g.max_rejections, g.scale, g.name) == (
        T.GATE_PROBABILITY, T.GATE_MAX_REJECTIONS, 1.0, "innovation_gate")
    assert g.names == ("a",)


def test_heading_filters_default_tuning_entry_by_entry():
    dt, rw, hv = 0.005, 2e-5, np.radians(0.2) ** 2
    t = E.DEFAULT_TUNING["qekf_heading"]
    Qn = np.zeros((10, 10))
    Qn[4:7, 4:7] = 1e-5 * np.eye(3)
    Qn[7:, 7:] = rw ** 2 * dt * np.eye(3)
    np.testing.assert_allclose(t.Q, Qn, rtol=1e-4, atol=0)
    np.testing.assert_array_equal(t.R[:6, :6], T.QUKF_R)
    assert t.R[6, 6] == pytest.approx(hv, rel=1e-4) and t.R.shape == (7, 7)
    np.testing.assert_array_equal(t.P0[:7, :7], qekf_initial_covariance([1.0, 0, 0, 0]))
    np.testing.assert_array_equal(t.P0[7:, 7:], HEADING_P0_BIAS * np.eye(3))
    np.testing.assert_array_equal(t.P0[:7, 7:], 0.0)
    np.testing.assert_array_equal(t.x0, [1.0, 0, 0, 0, 0, 0, 0, 0, 0, 0])
    h = E.DEFAULT_TUNING["qukf_heading"]
    np.testing.assert_array_equal(h.P0[:6, :6], T.QUKF_P0)
    assert h.P0[6, 6] == HEADING_P0_BIAS and h.P0.shape == (7, 7)
    for name in ("vukf", "vekf"):
        v = E.DEFAULT_TUNING[name]
        np.testing.assert_array_equal(v.Q, T.VUKF_Q)
        np.testing.assert_array_equal(v.R, T.VUKF_R)
    q = E.DEFAULT_TUNING["qekf"]
    np.testing.assert_array_equal(q.Q, T.QUKF_Q)
    np.testing.assert_array_equal(q.P0, qekf_initial_covariance([1.0, 0, 0, 0]))


def test_qekf_initial_covariance_by_hand_upright():
    # upright: G = [[0, 0, 0], 1/2 I3] on q, so the q block is diag(1e-7, 1e-7/4, 1e-7/4, 1e-9/4)
    P = qekf_initial_covariance([1.0, 0, 0, 0])
    np.testing.assert_allclose(np.diag(P), [1e-7, 0.25e-7, 0.25e-7, 0.25e-9, 1e-7, 1e-7, 1e-9],
                               rtol=1e-12)
    assert np.count_nonzero(P - np.diag(np.diag(P))) == 0


def test_initial_state_limits():
    x, P = E.initial_state("qukf", [1.0 + 5e-10, 0, 0, 0, 0.1, 0.2, 0.3])
    assert x[0] == 1.0 + 5e-10 and x[6] == 0.3
    with pytest.raises(StateError, match="quaternion norm .* must be 1 \\(within 1e-9\\)"):
        E.initial_state("qukf_heading", [1.0 + 2e-9, 0, 0, 0, 0, 0, 0, 0])
    x, _ = E.initial_state("vukf", [5.0] * 7)  # no quaternion in the velocity filter's state
    np.testing.assert_array_equal(x, [5.0] * 7)
    with pytest.raises(ShapeError, match="x0 of 'vekf' must have 7 entries, got 8"):
        E.initial_state("vekf", np.zeros(8))
    x, P = E.initial_state("qekf_heading", np.r_[0.0, 1.0, 0, 0, np.zeros(6)])
    np.testing.assert_array_equal(P[:7, :7], qekf_initial_covariance([0.0, 1.0, 0, 0]))
    np.testing.assert_array_equal(P[7:, 7:], HEADING_P0_BIAS * np.eye(3))
    _, P = E.initial_state("qukf_heading", np.r_[0.0, 1.0, 0, 0, np.zeros(4)])
    np.testing.assert_array_equal(P, E.DEFAULT_TUNING["qukf_heading"].P0)

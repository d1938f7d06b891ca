"""Transition lag of step references, up and down, against hand-computed crossing
instants (the reference crosses 50 % at one sample, the angle at a later one)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.analysis.metrics import crossing_lag, transition_metrics

TS = 0.01


def _qx(deg):
    a = np.radians(deg) / 2
    return np.column_stack([np.cos(a), np.sin(a), np.zeros_like(a), np.zeros_like(a)])


def _log(ref_deg, roll_deg):
    n = ref_deg.size
    state = np.zeros((n + 1, 12))
    state[:-1, 2:6] = _qx(roll_deg)
    state[-1] = state[-2]
    return {"time": np.arange(n + 1) * TS, "state": state, "q_ref": _qx(ref_deg)}


def test_crossing_lag_counts_from_the_references_first_crossing():
    t = np.arange(60) * TS
    ref = np.where(np.arange(60) >= 10, 1.0, 0.0)
    y = np.clip((np.arange(60) - 12) / 20.0, 0.0, 1.0)   # reaches 0.5 at k = 22
    assert crossing_lag(t, y, ref, 0.5) == pytest.approx(12 * TS, abs=1e-12)
    assert crossing_lag(t, np.zeros(60), ref, 0.5) == math.inf
    with pytest.raises(ValueError):
        crossing_lag(t, y, np.zeros(60), 0.5)


@pytest.mark.parametrize("start,end", [(1.0, 4.0), (2.0, -2.0)])
def test_transition_lag_up_and_down(start, end):
    k = np.arange(80)
    ref = np.where(k >= 10, end, start)
    # the angle follows linearly from k = 14 to k = 34: halfway at k = 24
    frac = np.clip((k - 14) / 20.0, 0.0, 1.0)
    roll = start + frac * (end - start)
    m = transition_metrics(_log(ref.astype(float), roll), "roll")
    assert m["roll_lag_s"] == pytest.approx(14 * TS, abs=1e-9)


@pytest.mark.parametrize("ref_deg", [np.full(80, 1.5),                                  # no step
                                     np.where((np.arange(80) >= 10) & (np.arange(80) < 50), 2.0, 0.0)])
def test_a_reference_ending_where_it_starts_has_no_lag(ref_deg):
    """No transition to time: the lag is undefined (nan), whichever way the angle moves,
    and a spec on it fails rather than passing on a made-up number."""
    from ballbot_casadi.core.specs import spec_ok

    k = np.arange(80)
    for roll in (np.clip((k - 14) / 20.0, 0.0, 1.0) * 3.0, -np.clip((k - 14) / 20.0, 0.0, 1.0) * 3.0):
        lag = transition_metrics(_log(ref_deg, roll), "roll")["roll_lag_s"]
        assert math.isnan(lag)
        assert not spec_ok(lag, "<=", 0.1)

"""COM-observer and position-hold metrics of a synthetic log built so each number is known.

Ts = 0.1 s, 200 periods.  The velocity command is (0.2, 0) m/s for the first 30 periods,
so the standstill starts at 3 s and the commanded position is ``x0 + (0.6, 0)``.  The
estimate is 10 mm off the observable offset until 6 s, then 1 mm (and 3 mm off in y while
moving); the robot stands 5 cm from the commanded position for the last 2 s (elsewhere
before); the true roll alternates 0.5 and 1.5 deg over the last 10 s (5 deg before) with a
heading the reference does not have, the estimate reads 0.2 deg.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from ballbot_casadi.analysis.com_observer import com_observer_metrics
from ballbot_casadi.core import quaternion as Q

TS, N = 0.1, 200


def _q(roll_deg, yaw_deg=0.0):
    return np.asarray(Q.from_rpy(math.radians(roll_deg), 0.0, math.radians(yaw_deg)), float).reshape(4)


@pytest.fixture(scope="module")
def log():
    k = np.arange(N + 1)
    t = k * TS
    v_ref = np.zeros((N, 3))
    v_ref[:30, 0] = 0.2
    com_true = np.array([0.01, -0.005])
    com_obs = com_true * 0.32 / 0.4
    com_hat = np.tile(com_obs, (N, 1))
    com_hat[:, 0] += np.where(t[:N] < 6.0 - 1e-9, 0.01, 0.001)
    com_hat[:30, 1] -= 0.003                         # y off while moving only (final value kept)
    x0 = np.zeros(12)
    x0[[0, 1]] = [1.0, 2.0]
    x0[2] = 1.0
    state = np.zeros((N + 1, 12))
    state[:, [0, 1]] = [1.0, 0.0]                    # far away before the hold window
    state[180:, [0, 1]] = [1.6 + 0.03, 2.0 - 0.04]   # 5 cm off for the last 2 s (+ final row)
    roll = np.where(k >= 100, np.where(k % 2 == 0, 0.5, 1.5), 5.0)
    state[:, 2:6] = [_q(r, 20.0) for r in roll]
    x_hat = np.zeros((N, 12))
    x_hat[:, 2:6] = _q(0.2)
    x_hat[:100, 2:6] = _q(3.0)
    arrays = {"time": t, "q_ref": np.tile(_q(0.0), (N, 1)), "v_ref": v_ref, "com_hat": com_hat,
              "state": state, "x_hat": x_hat}
    return SimpleNamespace(arrays=arrays,
                           params=SimpleNamespace(com_x=0.01, com_y=-0.005, l=0.4),
                           ctrl_params=SimpleNamespace(l=0.32),
                           scenario={"Ts": TS, "x0": x0.tolist()})


def test_estimate_metrics_by_hand(log):
    m = com_observer_metrics(log)
    assert m["standstill_start_s"] == pytest.approx(3.0)
    assert m["com_observable_x_mm"] == pytest.approx(8.0) and m["com_observable_y_mm"] == pytest.approx(-4.0)
    assert m["com_hat_x_mm"] == pytest.approx(9.0) and m["com_hat_y_mm"] == pytest.approx(-4.0)
    assert m["com_estimate_error_mm"] == pytest.approx(1.0, rel=1e-9)
    assert m["com_estimate_error_max_mm"] == pytest.approx(1.0, rel=1e-9)   # from 13 s on
    assert m["com_estimate_settle_s"] == pytest.approx(3.0, abs=1e-9)       # within 2 mm from 6 s
    assert m["com_estimate_raw_error_mm"] == pytest.approx(math.sqrt(2.0), rel=1e-9)
    assert m["com_height_error_mm"] == pytest.approx(80.0)


def test_position_hold_metrics_by_hand(log):
    m = com_observer_metrics(log)
    assert m["final_position_error_m"] == pytest.approx(0.05, rel=1e-9)
    assert m["hold_position_error_m"] == pytest.approx(0.05, rel=1e-9)


def test_standing_tilt_errors_by_hand(log):
    m = com_observer_metrics(log)
    s = 0.5 * (math.sin(math.radians(0.5)) + math.sin(math.radians(1.5)))
    assert m["standing_tilt_error_deg"] == pytest.approx(math.degrees(math.asin(s)), rel=1e-9)
    assert m["standing_tilt_error_rms_deg"] == pytest.approx(math.sqrt(1.25), rel=1e-9)
    assert m["standing_tilt_error_est_deg"] == pytest.approx(0.2, rel=1e-9)


def test_an_estimate_within_tolerance_from_the_standstill_on_settles_at_once(log):
    """Outside the tolerance only while moving (before 3 s): settled at the command, 0 s."""
    a = dict(log.arrays)
    a["com_hat"] = log.arrays["com_hat"].copy()
    a["com_hat"][30:, 0] = log.arrays["com_hat"][-1, 0]    # 1 mm off from the standstill on
    m = com_observer_metrics(SimpleNamespace(**{**vars(log), "arrays": a}))
    assert m["com_estimate_settle_s"] == 0.0


def test_an_estimate_settling_at_the_last_sample(log):
    """Outside the tolerance up to the second-to-last sample, inside at the last: settled at
    the last sample's time, 19.9 - 3 s (not never)."""
    a = dict(log.arrays)
    a["com_hat"] = log.arrays["com_hat"].copy()
    a["com_hat"][:-1, 0] += 0.01
    m = com_observer_metrics(SimpleNamespace(**{**vars(log), "arrays": a}))
    assert m["com_estimate_settle_s"] == pytest.approx((N - 1) * TS - 3.0, abs=1e-9)


def test_an_estimate_that_never_settles_and_a_short_run(log):
    a = dict(log.arrays)
    a["com_hat"] = log.arrays["com_hat"].copy()
    a["com_hat"][-1, 0] += 0.01  # outside the tolerance at the very end
    m = com_observer_metrics(SimpleNamespace(**{**vars(log), "arrays": a}))
    assert m["com_estimate_settle_s"] == math.inf
    short = {key: v[:101] for key, v in log.arrays.items()}
    short["state"] = log.arrays["state"][:101]
    short["time"] = log.arrays["time"][:101]
    for key in ("q_ref", "v_ref", "com_hat", "x_hat"):
        short[key] = log.arrays[key][:100]
    m = com_observer_metrics(SimpleNamespace(**{**vars(log), "arrays": short}))
    assert math.isnan(m["com_estimate_error_max_mm"])  # the run ends before 13 s


def test_the_hold_window_includes_the_final_state(log):
    """The hold mean is over the states of the last 2 s and the final state (the one after
    the last period): moving only the final state moves the mean by 1/21 of it."""
    state = log.arrays["state"].copy()
    state[-1, 0] += 0.21                             # final: (0.24, -0.04) off; window mean (0.04, -0.04)
    moved = SimpleNamespace(**{**vars(log), "arrays": {**log.arrays, "state": state}})
    m = com_observer_metrics(moved)
    assert m["final_position_error_m"] == pytest.approx(math.hypot(0.24, 0.04), rel=1e-9)
    assert m["hold_position_error_m"] == pytest.approx(0.04 * math.sqrt(2.0), rel=1e-9)

"""The envelope study's measures and predicates on hand-built logs (issue 23, test strength):
the final window's first sample included and the one before it not, the body rate from
``2 q* dq`` (horizontal part for the tilt rate, vertical for the heading rate), the peak
from the disturbance on, and each allowance at and just past its bound."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.control import default_balance_gains
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import STATE
from ballbot_casadi.studies import envelope as E

DT = 0.125  # exact in binary: the window edges fall on samples


def _log(roll_deg, yaw_deg, w_body, vxy, pitch_deg=None):
    n = len(roll_deg)
    pitch_deg = np.zeros(n) if pitch_deg is None else pitch_deg
    x = np.zeros((n, 12))
    for i in range(n):
        q = np.asarray(Q.from_rpy(math.radians(roll_deg[i]), math.radians(pitch_deg[i]),
                                  math.radians(yaw_deg[i])), float).ravel()
        x[i, STATE["q"]] = q
        x[i, STATE["dq"]] = 0.5 * np.asarray(Q.mul(q, np.r_[0.0, w_body[i]]), float).ravel()
        x[i, STATE.index("dx")], x[i, STATE.index("dy")] = vxy[i]
    return {"state": x, "time": np.arange(n) * DT}


def _final_case():
    n = 17                                   # t = 0 .. 2 s; the last 0.5 s: samples 12..16
    roll = np.full(n, 1.0)
    roll[11], roll[12] = 10.0, 3.0           # just before the window, its first sample
    yaw = np.zeros(n)
    yaw[14] = -7.0
    yaw[10] = 40.0
    w = np.zeros((n, 3))
    w[12:] = [0.03, -0.04, 0.2]             # horizontal 0.05 rad/s
    w[5] = [1.0, 1.0, 0.0]
    return _log(roll, yaw, w, np.zeros((n, 2)))


def test_final_motion_over_the_last_half_second():
    tilt, rate, yaw = E.final_motion(_final_case())
    assert tilt == pytest.approx(3.0, rel=1e-9)
    assert rate == pytest.approx(math.degrees(0.05), rel=1e-9)
    assert yaw == pytest.approx(7.0, rel=1e-9)
    bad = _final_case()
    bad["state"][3, 0] = np.nan
    assert E.final_motion(bad) == (math.inf, math.inf, math.inf)


def test_tilt_of_a_roll_and_a_pitch_together_is_the_body_axis_angle_from_the_vertical():
    """cos(tilt) = cos(roll) cos(pitch) (ZYX): 3 deg of roll with -4 deg of pitch tilt the
    body axis by 4.998 deg, not by either angle, nor by their difference or sum."""
    n = 17
    roll, pitch = np.full(n, 3.0), np.full(n, -4.0)
    log = _log(roll, np.full(n, 25.0), np.zeros((n, 3)), np.zeros((n, 2)), pitch)
    want = math.degrees(math.acos(math.cos(math.radians(3.0)) * math.cos(math.radians(4.0))))
    assert 4.99 < want < 5.0
    assert E.final_motion(log)[0] == pytest.approx(want, rel=1e-9)
    assert E.peak_motion(log)["tilt_deg"] == pytest.approx(want, rel=1e-9)


def test_peak_motion_from_the_disturbance_on():
    n = 17                                   # t_from 0.5 s: sample 4 on
    roll = np.full(n, 1.0)
    roll[3], roll[4] = 20.0, 6.0
    w = np.zeros((n, 3))
    w[3] = [5.0, 5.0, 5.0]
    w[6] = [0.3, 0.4, 0.0]                   # 0.5 rad/s horizontal
    w[7] = [0.0, 0.1, -0.7]
    v = np.full((n, 2), 0.1)
    v[3], v[4] = [3.0, 3.0], [0.3, -0.4]
    p = E.peak_motion(_log(roll, np.zeros(n), w, v))
    assert p["tilt_deg"] == pytest.approx(6.0, rel=1e-9)
    assert p["tilt_rate_deg_s"] == pytest.approx(math.degrees(0.5), rel=1e-9)
    assert p["speed_mps"] == pytest.approx(0.5, rel=1e-12)
    assert p["yaw_rate_rad_s"] == pytest.approx(0.7, rel=1e-9)
    assert E.peak_motion(_log(roll, np.zeros(n), w, v), t_from=0.375)["tilt_deg"] == pytest.approx(20.0)


@pytest.mark.parametrize("motion, base, ok", [
    ((0.5, 2.0, 5.0), (0.0, 0.0), True),          # every bound met exactly
    ((0.51, 2.0, 5.0), (0.0, 0.0), False),
    ((0.5, 2.01, 5.0), (0.0, 0.0), False),
    ((0.5, 2.0, 5.01), (0.0, 0.0), False),
    ((0.8, 2.0, 0.0), (0.4, 0.0), True),          # twice the undisturbed run's
    ((0.81, 2.0, 0.0), (0.4, 0.0), False),
    ((0.0, 3.0, 0.0), (0.0, 1.5), True),
    ((0.0, 3.01, 0.0), (0.0, 1.5), False),
    ((0.0, 0.0, 5.01), (9.0, 9.0), False),        # the heading bound does not widen
])
def test_recovered_at_and_past_each_bound(monkeypatch, motion, base, ok):
    monkeypatch.setattr(E, "final_motion", lambda log: motion)
    assert E.recovered(None, (*base, 0.0)) is ok


LIM = dict(E.LIMITS)


@pytest.mark.parametrize("peak, base_peak, push, ok", [
    (LIM, None, 0.0, True),
    ({**LIM, "tilt_deg": 5.01}, None, 0.0, False),
    ({**LIM, "tilt_rate_deg_s": 20.01}, None, 0.0, False),
    ({**LIM, "speed_mps": 0.51}, None, 0.0, False),
    ({**LIM, "yaw_rate_rad_s": 1.01}, None, 0.0, False),
    ({**LIM, "speed_mps": 0.6}, {**dict.fromkeys(LIM, 0.0), "speed_mps": 0.3}, 0.0, True),
    ({**LIM, "speed_mps": 0.61}, {**dict.fromkeys(LIM, 0.0), "speed_mps": 0.3}, 0.0, False),
    ({**LIM, "tilt_rate_deg_s": 30.0}, {**dict.fromkeys(LIM, 0.0), "tilt_rate_deg_s": 15.0}, 0.0, True),
    ({**LIM, "tilt_deg": 8.0}, {**dict.fromkeys(LIM, 0.0), "tilt_deg": 0.5}, 7.0, True),   # push + 2 base
    ({**LIM, "tilt_deg": 8.01}, {**dict.fromkeys(LIM, 0.0), "tilt_deg": 0.5}, 7.0, False),
    ({**LIM, "tilt_deg": 6.0}, {**dict.fromkeys(LIM, 0.0), "tilt_deg": 3.0}, 0.0, True),     # 2 base
    ({**LIM, "tilt_deg": 6.01}, {**dict.fromkeys(LIM, 0.0), "tilt_deg": 3.0}, 0.0, False),
])
def test_within_limits_at_and_past_each_allowance(monkeypatch, peak, base_peak, push, ok):
    monkeypatch.setattr(E, "recovered", lambda log, base: True)
    monkeypatch.setattr(E, "peak_motion", lambda log: peak)
    assert E.within_limits(None, (0.0, 0.0, 0.0), base_peak, push) is ok
    monkeypatch.setattr(E, "recovered", lambda log, base: False)
    assert E.within_limits(None, (0.0, 0.0, 0.0), base_peak, push) is False


def test_the_scenario_of_a_push_and_of_a_torque_step():
    sc = E._scenario("smc", "ukf", tuple(default_balance_gains("smc")), push_deg=(2.0, -3.0))
    assert sc.pushes == ((0.5, 2.0, -3.0, 0.0),) and sc.torque_disturbances == ()
    assert (sc.controller, sc.estimator, sc.duration, sc.cascade, sc.seed) == ("smc", "ukf", 4.0, True, 0)
    sc = E._scenario("flc", "true", tuple(default_balance_gains("flc")), torque=1.5)
    assert sc.torque_disturbances == ((0.5, 1.0, 1.5, 0.0, 0.0),) and sc.pushes == ()
    assert sc.name == "envelope_flc"


def _rows(base: float, changes: dict[str, float]) -> dict[str, dict[str, float]]:
    keys = [E._key(c, kind) for kind in ("", "_limits") for c, _, _ in E.COLUMNS]
    flc = {k: base + i for i, k in enumerate(keys)}
    return {"flc": flc, "flc_dob": {k: v + changes.get(k, 0.0) for k, v in flc.items()}}


def test_dob_verdict_differences_and_tolerances_by_hand():
    """Each column's difference is FLC + DOB minus FLC; it counts when beyond that column's
    tolerance (the torque pulse's own, the pushes' otherwise), strictly; the verdict follows
    from which way the counted columns went."""
    push = E._key(E.COLUMNS[0][0], "")
    push_lim = E._key(E.COLUMNS[1][0], "_limits")
    torque = E._key("torque_step", "")
    assert torque == "torque_step_nm" and push.endswith("_deg") and push_lim.endswith("_limits_deg")
    v = E.dob_verdict(_rows(2.0, {push: 0.5, torque: -0.25}), push_tol=0.25, torque_tol=0.5)
    assert v["columns"][push] == {"flc": 2.0, "flc_dob": 2.5, "diff": 0.5}
    assert v["columns"][torque]["diff"] == -0.25
    assert (v["raised"], v["lowered"], v["verdict"]) == ([push], [], "raises")  # torque within its 0.5
    v = E.dob_verdict(_rows(2.0, {push: 0.5, torque: -0.75}), push_tol=0.25, torque_tol=0.5)
    assert (v["raised"], v["lowered"], v["verdict"]) == ([push], [torque], "mixed")
    v = E.dob_verdict(_rows(2.0, {push_lim: -0.5}), push_tol=0.25, torque_tol=0.5)
    assert (v["raised"], v["lowered"], v["verdict"]) == ([], [push_lim], "lowers")
    v = E.dob_verdict(_rows(2.0, {push: 0.25, push_lim: -0.25, torque: 0.5}), push_tol=0.25, torque_tol=0.5)
    assert (v["raised"], v["lowered"], v["verdict"]) == ([], [], "same")  # at the tolerance: not counted
    assert len(v["columns"]) == 2 * len(E.COLUMNS)

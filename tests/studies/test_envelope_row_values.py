"""One controller's envelope row by stand-in runs (no simulation): each push direction's
push along its unit vector at the disturbance time, the torque step as a pulse, both
bisected to the largest recovered size within the tolerance for the recovery predicate
and the §7.1 limits predicate separately; a robot that is already outside a predicate
undisturbed gets an all-zero, bracketed column and says so; peak motion of a run that
is not finite is infinite."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.studies import envelope as E

# the stand-in robot: recovers pushes up to 6 deg along roll, 4 along pitch, and torque
# steps up to 3 N m; within the limits up to half of that
RECOVER = {"push": (6.0, 4.0), "torque": 3.0}


def _size(sc):
    if sc.torque_disturbances:
        (t0, t1, tx, ty, tz), = sc.torque_disturbances
        assert (t0, t1 - t0, ty, tz) == (0.5, 0.5, 0.0, 0.0)
        return "torque", tx
    if sc.pushes:
        (t, r, p, y), = sc.pushes
        assert (t, y) == (0.5, 0.0)
        return "push", (r, p)
    return "none", 0.0


def _ok(sc, scale, undisturbed=True):
    kind, a = _size(sc)
    if kind == "none":
        return undisturbed
    if kind == "torque":
        return a <= RECOVER["torque"] * scale
    r, p = a   # an ellipse: the diagonal recovers sqrt(1 / (0.5/36 + 0.5/16)) deg
    return (r / (RECOVER["push"][0] * scale)) ** 2 + (p / (RECOVER["push"][1] * scale)) ** 2 <= 1.0


@pytest.fixture
def stand_in(monkeypatch):
    seen = []
    monkeypatch.setattr(E, "run_scenario", lambda sc, sim: seen.append(sc) or sc)
    return seen


def _row(monkeypatch, limits_undisturbed=True):
    monkeypatch.setattr(E, "recovered", lambda sc, base: _ok(sc, 1.0))
    monkeypatch.setattr(E, "within_limits", lambda sc, base, peak, a: _ok(sc, 0.5, limits_undisturbed))
    return E._envelope_row(None, "flc", "true", (1.0,) * 6, (0.1, 0.2, 0.3), {"tilt_deg": 0.0},
                           push_max=20.0, push_tol=0.01, torque_max=10.0, torque_tol=0.01)


def test_each_envelope_is_bisected_to_its_predicate(stand_in, monkeypatch):
    row = _row(monkeypatch)
    diag = 1.0 / math.sqrt(0.5 / 36 + 0.5 / 16)
    for kind, scale in (("", 1.0), ("_limits", 0.5)):
        assert row[f"undisturbed_within{kind}"] is True
        for d, want in (("roll", 6.0), ("pitch", 4.0), ("diagonal", diag)):
            assert row[f"push_{d}{kind}_deg"] == pytest.approx(want * scale, abs=0.01), (d, kind)
            assert row[f"push_{d}{kind}_deg"] <= want * scale + 1e-12
            assert row[f"push_{d}{kind}_bracketed"] is True
        assert row[f"torque_step{kind}_nm"] == pytest.approx(3.0 * scale, abs=0.01)
    sc = stand_in[0]
    assert (sc.controller, sc.estimator, sc.cascade, sc.seed, sc.duration) == ("flc", "true", True, 0, 4.0)
    assert sc.k_bal == (1.0,) * 6


def test_a_robot_outside_a_predicate_undisturbed_gets_a_zero_column(stand_in, monkeypatch):
    row = _row(monkeypatch, limits_undisturbed=False)
    assert row["undisturbed_within"] is True and row["push_roll_deg"] == pytest.approx(6.0, abs=0.01)
    assert row["undisturbed_within_limits"] is False
    for d in E.PUSH_DIRECTIONS:
        assert row[f"push_{d}_limits_deg"] == 0.0 and row[f"push_{d}_limits_bracketed"] is True
    assert row["torque_step_limits_nm"] == 0.0 and row["torque_limits_bracketed"] is True


def test_peak_motion_of_a_run_that_is_not_finite_is_infinite():
    x = np.zeros((5, 12))
    x[:, 2] = 1.0
    x[3, 7] = np.nan
    assert E.peak_motion({"state": x, "time": np.arange(5) * 0.25}) == {k: math.inf for k in E.LIMITS}

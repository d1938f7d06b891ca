"""The envelope study's definitions against the thesis by hand: the push directions are unit
vectors along roll, pitch and the 45 deg diagonal, and the limits are §7.1's (5 deg, 20 deg/s,
0.5 m/s, 1 rad/s)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.studies.envelope import LIMITS, PUSH_DIRECTIONS


def test_push_directions_are_unit_vectors_along_roll_pitch_and_the_diagonal():
    assert set(PUSH_DIRECTIONS) == {"roll", "pitch", "diagonal"}
    assert PUSH_DIRECTIONS["roll"] == (1.0, 0.0) and PUSH_DIRECTIONS["pitch"] == (0.0, 1.0)
    np.testing.assert_allclose(PUSH_DIRECTIONS["diagonal"], [0.5 ** 0.5] * 2, rtol=1e-15)
    for d, v in PUSH_DIRECTIONS.items():
        assert math.hypot(*v) == pytest.approx(1.0, rel=1e-15), d


def test_limits_are_the_thesis_section_7_1_values():
    want = {"tilt_deg": 5.0, "tilt_rate_deg_s": 20.0, "speed_mps": 0.5, "yaw_rate_rad_s": 1.0}
    assert set(LIMITS) == set(want)
    for k, v in want.items():
        assert LIMITS[k] == pytest.approx(v, rel=1e-12), k


def test_dob_gain_sweep_sets_each_observer_bandwidth_from_the_flc_pole(monkeypatch):
    """Default sweep 3, 6, 10, 20 x each channel's FLC pole ``omega = Kd / 2`` (critically
    damped error dynamics): the k vectors handed to the runs, read back from stand-in runs
    whose torques differ by run, and each row's keys."""
    from ballbot_casadi.control.disturbance_observer import DOB_GAIN_NAMES
    from ballbot_casadi.control.flc import FLC_GAIN_NAMES
    from ballbot_casadi.sim.scenario import Scenario
    from ballbot_casadi.studies import envelope as env

    assert env.DOB_SWEEP == (3.0, 6.0, 10.0, 20.0)
    seen = []

    def fake_run(sc, sim):
        seen.append(sc)
        n = len(seen)
        tau = np.zeros((5, 3))
        tau[2, 0] = n  # total variation 2 n over the run
        return {"tau_cmd": tau, "run": n}

    monkeypatch.setattr(env, "run_scenario", fake_run)
    monkeypatch.setattr(env, "peak_motion", lambda log: {"tilt_deg": 0.1 * log["run"]})
    rows = env.dob_gain_sweep(sim=None, estimator="ukf")
    assert [r["controller"] for r in rows] == ["flc"] + ["flc_dob"] * 4
    assert [r["separation"] for r in rows] == [None, 3.0, 6.0, 10.0, 20.0]
    np.testing.assert_allclose([r["tilt_deg"] for r in rows], [0.1, 0.2, 0.3, 0.4, 0.5], rtol=1e-15)
    np.testing.assert_allclose([r["torque_tv_nm_per_s"] for r in rows],
                               [2 * n / env._DURATION for n in range(1, 6)], rtol=1e-15)
    assert all(sc.estimator == "ukf" for sc in seen)
    k_flc = np.array(Scenario(name="k", controller="flc", duration=0.01).inputs()["k_bal"], float)
    k_dob = np.array(Scenario(name="k", controller="flc_dob", duration=0.01).inputs()["k_bal"], float)
    np.testing.assert_array_equal(seen[0].k_bal, k_flc)
    Kd = k_dob[[FLC_GAIN_NAMES.index(f"Kd{i}") for i in (1, 2, 3)]]
    L = [DOB_GAIN_NAMES.index(f"L{i}") for i in (1, 2, 3)]
    others = [i for i in range(k_dob.size) if i not in L]
    for sc, sep in zip(seen[1:], env.DOB_SWEEP):
        k = np.array(sc.k_bal, float)
        np.testing.assert_allclose(k[L], sep * Kd / 2, rtol=1e-15)
        np.testing.assert_array_equal(k[others], k_dob[others])


def test_the_polar_plot_draws_each_controllers_push_envelope_mirrored_into_four_quadrants(monkeypatch, tmp_path,
                                                                                          saved):
    """Stand-in runs and rows (no simulation): each controller's curve is closed, its angles
    ascend, and every point's radius is the push of the direction it points along (roll on
    the x axis, pitch on the y axis, the diagonal between), per estimator panel."""
    from _figures import assert_style

    from ballbot_casadi.studies import envelope as env

    pushes = {("true", "flc"): (12.0, 9.0, 7.5), ("true", "smc"): (6.0, 5.0, 4.0),
              ("ukf", "flc"): (11.0, 8.0, 6.5), ("ukf", "smc"): (3.0, 2.5, 2.0)}
    x = np.zeros((5, 12))
    x[:, 2] = 1.0
    monkeypatch.setattr(env, "run_scenario", lambda sc, sim: {"state": x, "time": np.arange(5) * 0.25})
    monkeypatch.setattr(env, "_envelope_row", lambda sim, c, est, *a: dict(zip(
        ("push_roll_deg", "push_pitch_deg", "push_diagonal_deg"), pushes[(est, c)])))
    monkeypatch.setattr(env, "envelope_report_lines", lambda m: [])  # the report reads more columns
    env.run_envelope_study(tmp_path, controllers=("flc", "smc"), estimators=("true", "ukf"), sim=object())
    panels = saved["envelope.png"]
    assert [p["title"] for p in panels] == ["largest push recovered (deg), true",
                                            "largest push recovered (deg), ukf"]
    for panel, est in zip(panels, ("true", "ukf")):
        assert [lab for lab, *_ in panel["lines"]] == ["flc", "smc"]
        for lab, a, r in panel["lines"]:
            roll, pitch, diag = pushes[(est, lab)]
            assert a.size == r.size == 13 and a[0] == a[-1] and r[0] == r[-1]
            assert np.all(np.diff(a[:-1]) >= 0)
            for ang, rad in zip(a[:-1], r[:-1]):
                c, s = abs(math.cos(ang)), abs(math.sin(ang))
                want = roll if c > 0.99 else pitch if s > 0.99 else diag
                assert rad == want, (est, lab, ang)
            assert sorted({round(math.degrees(v) % 360, 6) for v in a}) == [0, 45, 90, 135, 180, 225, 270, 315]
    assert_style(saved, "envelope.png")

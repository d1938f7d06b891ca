"""The lag, velocity and full_cascade studies' bookkeeping on hand-built runs (issue 23, test
strength): each lag under its run's name and judged against its own bound, the velocity
study's first run at the thesis's acceleration limit, and the cascade sine's keyframes (the
sine's velocity, reached at the next keyframe) and its error window."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import STATE
from ballbot_casadi.studies import cascade_sine as CS
from ballbot_casadi.studies import lag as LAG
from ballbot_casadi.studies import velocity as VEL


def test_each_lag_under_its_runs_name(monkeypatch):
    lags = {"lag_step": 0.31, "lag_step_smooth": 0.002, "lag_ramp": -0.04, "lag_sine_no_rate": 0.7, "other": 9.0}
    monkeypatch.setattr(LAG, "run_metrics", lambda log: {"roll_lag_s": lags[log.scenario["name"]]})
    m = LAG.lag_study_metrics([SimpleNamespace(scenario={"name": n}) for n in lags])
    assert m == {"step_lag_none_s": 0.31, "step_lag_exact_s": 0.002, "ramp_lag_none_s": -0.04,
                 "sine_no_rate_lag_s": 0.7}


def test_the_lag_table_judges_each_against_its_bound():
    lines = LAG.lag_report_lines({"step_lag_none_s": 0.1, "step_lag_exact_s": 0.0999, "ramp_lag_none_s": -0.05,
                                  "sine_no_rate_lag_s": 0.999})
    assert lines[4] == "| ideal 3° step | none (thesis) | 0.100 s | < 0.1 s | FAILS the thesis spec |"
    assert lines[5] == "| 3° step, 0.2 s quintic rise | exact (ours) | 0.100 s | < 0.1 s | pass |"
    assert lines[6] == "| 3°/s ramp | none (thesis) | -0.050 s | < 0.1 s | pass |"
    assert lines[7] == "| 0.5 Hz sine | no rate reference | 0.999 s | < 1 s | pass |"
    assert LAG.lag_report_lines({})[4] == "| ideal 3° step | none (thesis) | — | < 0.1 s | — |"
    assert LAG.lag_report_lines({"ramp_lag_none_s": -0.2})[6].endswith("| FAILS the thesis spec |")


def test_the_velocity_study_reads_the_run_at_the_acceleration_limit(monkeypatch):
    runs = [{k: 10.0 * i + j for j, k in enumerate(VEL._KEYS)} for i in range(2)]
    logs = [SimpleNamespace(i=0), SimpleNamespace(i=1)]
    monkeypatch.setattr(VEL, "run_metrics", lambda log: runs[log.i])
    m = VEL.velocity_study_metrics(logs)
    assert m == {f"accel_limit_{k}": runs[0][k] for k in VEL._KEYS}
    tables = [{"name": "v", "velocity": [{"t_s": 0.0, "vx_mps": 0.5, "accel_mps2": 0.25},
                                         {"t_s": 5.0, "vy_mps": 0.5, "accel_mps2": 0.25}]}]
    fast, main = VEL.accel_limit_expand(tables)
    assert main == tables[0] and fast["name"] == "v_accel_limit" and VEL.THESIS_ACCEL_LIMIT == 1.0
    assert [r["accel_mps2"] for r in fast["velocity"]] == [1.0, 1.0]
    assert [r.get("vx_mps") for r in fast["velocity"]] == [0.5, None]


def test_the_cascade_sine_keyframes():
    main = {"name": "full_sine", "duration_s": 1.0, "seed": 3, "spec": [{"metric": "x"}], "initial": {"roll_deg": 1},
            "attitude": {"roll": {"frequency_hz": 0.5, "amplitude_deg": 3.0}}}
    (out,) = CS.cascade_sine_expand([{"name": "other"}, main])
    assert out["name"] == "full_sine_cascade" and out["cascade"] is True and out["seed"] == 3
    assert not {"attitude", "initial", "spec"} & set(out)
    rows = out["velocity"]
    t = np.arange(0.0, 1.0 - 0.025, 0.05)
    assert [r["t_s"] for r in rows] == pytest.approx(t.tolist(), abs=1e-12) and len(rows) == 20
    A = 9.81 * math.tan(math.radians(3.0)) / (2 * math.pi * 0.5)
    v = A * (1 - np.cos(2 * math.pi * 0.5 * (t + 0.05)))
    assert [r["vy_mps"] for r in rows] == pytest.approx(v.tolist(), rel=1e-12)
    assert rows[0]["accel_mps2"] == pytest.approx(max(v[0] / 0.05 * 1.001, 1e-3), rel=1e-12)
    assert rows[7]["accel_mps2"] == pytest.approx(abs(v[7] - v[6]) / 0.05 * 1.001, rel=1e-12)
    assert CS.KEYFRAME_S == 0.05 and CS.SETTLE_S == 2.0


def test_the_cascade_sine_errors_after_the_settling(monkeypatch):
    t = np.arange(9) * 0.5                       # 0 .. 4 s; the window: t >= 2 s, samples 4..8
    roll = np.array([9.0, 9.0, 9.0, -9.0, 2.0, -1.0, 3.0, 0.0, -2.0])
    pitch = np.array([5.0, 0, 0, 5.0, 0.5, -0.75, 0, 0, 0.25])
    yaw = np.array([9.0, 0, 0, 0, 0.1, 0, -0.3, 0, 0.2])
    q = np.array([Q.from_rpy(*np.radians([r, p, y])) for r, p, y in zip(roll, pitch, yaw)])
    state = np.zeros((10, 12))
    state[:9, STATE["q"]] = q
    q_ref = np.tile([1.0, 0.0, 0.0, 0.0], (9, 1))
    log = SimpleNamespace(arrays={"q_ref": q_ref, "time": np.arange(10) * 0.5, "state": state})
    monkeypatch.setattr(CS, "run_metrics", lambda lg: {"tilt_error_max_deg": 1.5, "heading_error_max_deg": 2.5})
    m = CS.cascade_sine_metrics([None, log])
    assert m["roll_amplitude_deg"] == pytest.approx((3.0 - (-2.0)) / 2, rel=1e-9)
    assert m["pitch_error_max_deg"] == pytest.approx(0.75, rel=1e-9)
    assert m["yaw_error_max_deg"] == pytest.approx(0.3, rel=1e-9)
    assert m["yaw_error_final_deg"] == pytest.approx(0.2, rel=1e-9)
    assert (m["tilt_error_max_deg"], m["heading_error_max_deg"]) == (1.5, 2.5)
    assert t[4] == 2.0

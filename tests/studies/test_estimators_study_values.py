"""The estimator studies' bookkeeping on hand-built runs (issue 23, test strength): which run
each ``full`` / ``thesis_tuning`` / ``yaw_seeds`` metric is read from, the worse of two runs
taken as their maximum, the expand hooks' order and names, the standing window's first
sample, the seed spread's sample standard deviation, and the report tables' cells.

Every run's metrics are distinct numbers (run ``i``, key ``j``: ``100 (i + 1) + j``), so a
metric read from a neighbouring run, another key or the better of two runs changes."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import STATE
from ballbot_casadi.studies import estimators as E

KEYS = ("tilt_error_rms_deg", "tilt_error_max_deg", "heading_error_max_deg", "velocity_error_rms_mps",
        "velocity_error_rms_delayed_mps", "position_drift_m", "quat_norm_max_dev", "estimator_tilt_rms_deg",
        "estimator_roll_rms_deg", "estimator_pitch_rms_deg", "estimator_velocity_rms_mps",
        "estimator_heading_drift_deg", "peak_tilt_deg", "peak_tilt_rate_deg_s", "nis_velocity_mean",
        "covariance_repairs", "gate_rejections", "estimator_heading_max_deg", "yaw_error_mean_deg")


def _run(i: int) -> dict:
    return {k: 100.0 * (i + 1) + j for j, k in enumerate(KEYS)}


def _logs(names):
    return [SimpleNamespace(scenario={"name": n}) for n in names]


@pytest.fixture()
def full(monkeypatch):
    # full's order (thesis_filter_expand with the SMC+EKF baseline): baseline, thesis's, shipped
    names = ["s_smc_ekf", "v_smc_ekf", "s_ukf", "v_ukf", "s", "v"]
    runs = {n: _run(i) for i, n in enumerate(names)}
    # the thesis's sine run worse than its velocity run in one key, the reverse in another
    runs["s_ukf"]["peak_tilt_deg"] = 999.0
    runs["v"]["tilt_error_max_deg"] = 50.0  # the shipped sine run (500 + 1) is the worse one
    monkeypatch.setattr(E, "by_run", lambda _logs: runs)
    monkeypatch.setattr(E, "norm_probe_metrics", lambda log: {"probe_run": log.scenario["name"]})
    return E.full_metrics(_logs(names)), runs


def test_full_reads_the_shipped_runs_and_the_thesis_filters_runs(full):
    m, runs = full
    s, v, ts, tv = runs["s"], runs["v"], runs["s_ukf"], runs["v_ukf"]
    for k in ("tilt_error_rms_deg", "heading_error_max_deg", "quat_norm_max_dev"):
        assert m[k] == max(s[k], v[k]) == v[k], k
    assert m["tilt_error_max_deg"] == s["tilt_error_max_deg"] == 501.0  # the max, not the last
    for k in ("velocity_error_rms_mps", "velocity_error_rms_delayed_mps", "position_drift_m",
              "estimator_velocity_rms_mps", "estimator_heading_drift_deg", "nis_velocity_mean"):
        assert m[k] == v[k], k
    for k in ("estimator_tilt_rms_deg", "estimator_roll_rms_deg", "estimator_pitch_rms_deg"):
        assert m[k] == s[k], k
    assert m["thesis_filter_tilt_error_max_deg"] == tv["tilt_error_max_deg"]
    assert m["thesis_filter_heading_error_max_deg"] == tv["heading_error_max_deg"]
    assert m["thesis_filter_peak_tilt_deg_all"] == 999.0  # the thesis's sine run
    assert m["thesis_filter_peak_tilt_rate_deg_s_all"] == tv["peak_tilt_rate_deg_s"]
    for k in ("estimator_velocity_rms_mps", "nis_velocity_mean", "position_drift_m"):
        assert m[f"thesis_filter_{k}"] == tv[k], k
    assert m["shipped_vs_thesis_velocity_rms_ratio"] == pytest.approx(
        v["estimator_velocity_rms_mps"] / tv["estimator_velocity_rms_mps"], rel=1e-15)
    assert m["peak_tilt_deg_all"] == v["peak_tilt_deg"] and m["peak_tilt_rate_deg_s_all"] == v["peak_tilt_rate_deg_s"]
    assert m["probe_run"] == "s"  # the norm probe on the shipped sine run
    assert ts["estimator_tilt_rms_deg"] not in (m["estimator_tilt_rms_deg"],)


def test_full_counts_repairs_and_rejections_over_all_runs(full):
    m, runs = full
    assert m["covariance_repairs"] == sum(int(r["covariance_repairs"]) for r in runs.values())
    assert m["gate_rejections"] == sum(int(r["gate_rejections"]) for r in runs.values())
    assert m["by_run"] is runs



def test_full_counts_nothing_for_a_run_without_repair_or_rejection_counts(monkeypatch):
    names = ["s_smc_ekf", "v_smc_ekf", "s_ukf", "v_ukf", "s", "v"]
    runs = {n: _run(i) for i, n in enumerate(names)}
    for n in ("s_smc_ekf", "v_smc_ekf"):  # e.g. runs whose estimator keeps no such counts
        del runs[n]["covariance_repairs"], runs[n]["gate_rejections"]
    monkeypatch.setattr(E, "by_run", lambda _logs: runs)
    monkeypatch.setattr(E, "norm_probe_metrics", lambda log: {})
    m = E.full_metrics(_logs(names))
    rest = [runs[n] for n in names[2:]]
    assert m["covariance_repairs"] == sum(int(r["covariance_repairs"]) for r in rest)
    assert m["gate_rejections"] == sum(int(r["gate_rejections"]) for r in rest)


def test_the_expand_hooks_order_and_name_the_runs():
    tables = [{"name": "a", "estimator": "ukf_adaptive"}, {"name": "b"}]
    out = E.comparison_expand({"controller": "smc", "estimator": "ekf"})(tables)
    assert [t["name"] for t in out] == ["a_smc_ekf", "b_smc_ekf", "a", "b"]
    assert (out[0]["controller"], out[0]["estimator"]) == ("smc", "ekf") and out[2] == tables[0]
    out = E.thesis_filter_expand({"controller": "smc", "estimator": "ekf"})(tables)
    assert [t["name"] for t in out] == ["a_smc_ekf", "b_smc_ekf", "a_ukf", "b_ukf", "a", "b"]
    assert [t.get("estimator") for t in out] == ["ekf", "ekf", "ukf", "ukf", "ukf_adaptive", None]
    assert [t["name"] for t in E.thesis_filter_expand()(tables)] == ["a_ukf", "b_ukf", "a", "b"]
    assert E.comparison_expand({"estimator": "ekf"})([{}]) == [{"estimator": "ekf", "name": "run_ekf"}, {}]
    out = E.thesis_tuning_expand(tables)
    assert [t["name"] for t in out] == ["a_thesis_tuning", "b_thesis_tuning"]
    assert out[1]["estimator"] == E.THESIS_ESTIMATOR
    assert out[0]["estimator_tuning"]["rate_process_var"] == E.THESIS_RATE_PROCESS_VAR == 1e-5
    out = E.seeds_expand([{"name": "x", "seed": 9}, {"name": "full_velocity", "seed": 2}])
    assert [(t["name"], t["seed"]) for t in out] == [(f"full_velocity_seed{s}", s) for s in (1, 2, 3, 4, 5, 6)]


def test_thesis_tuning_reads_the_standing_window_of_the_velocity_run(monkeypatch):
    # velocity run: t = 0 .. 30 s by 0.5 s; the last 20 s (t >= 10, 41 samples) at 1 deg of
    # roll, except the window's first sample (t = 10) at 4 deg; before it 7 deg
    t = np.arange(61) * 0.5
    deg = np.where(t < 10.0, 7.0, 1.0)
    deg[20] = 4.0
    q = np.array([Q.from_rpy(math.radians(d), 0.0, 0.0) for d in deg])
    state = np.zeros((62, 12))
    state[:61, STATE["q"]] = q
    q_ref = np.tile([1.0, 0.0, 0.0, 0.0], (61, 1))
    vel_log = SimpleNamespace(scenario={"name": "v"}, arrays={"q_ref": q_ref, "time": t, "state": state})
    sine_log = SimpleNamespace(scenario={"name": "s"}, arrays={})
    runs = {"s": _run(0), "v": _run(1)}
    runs["s"]["heading_error_max_deg"] = 999.0
    monkeypatch.setattr(E, "by_run", lambda _logs: runs)
    m = E.thesis_tuning_metrics([sine_log, vel_log])
    expected = math.sqrt((40 * 1.0 + 16.0) / 41)
    assert m["standing_tilt_error_rms_deg"] == pytest.approx(expected, rel=1e-9)
    assert m["tilt_error_max_deg"] == runs["v"]["tilt_error_max_deg"]
    assert m["heading_error_max_deg"] == 999.0
    assert m["estimator_heading_max_deg"] == runs["v"]["estimator_heading_max_deg"]
    assert m["rate_process_var"] == E.THESIS_RATE_PROCESS_VAR
    text = "\n".join(E.thesis_tuning_report_lines(m))
    assert f"{expected:.3g}°" in text and "up to 217°" in text and "error 999°" in text


def test_the_yaw_spread_uses_the_sample_standard_deviation(monkeypatch):
    means = {1: -1.0, 2: 0.5, 3: 2.0, 4: -0.5, 5: 1.0, 6: 0.0}   # mean 1/3
    logs = [SimpleNamespace(scenario={"seed": s}, yaw=y) for s, y in means.items()]
    monkeypatch.setattr(E, "run_metrics", lambda log: {"yaw_error_mean_deg": log.yaw})
    m = E.yaw_spread_metrics(logs)
    v = np.array(list(means.values()))
    mu = v.sum() / 6
    sd = math.sqrt(((v - mu) ** 2).sum() / 5)
    assert m["yaw_mean_over_seeds_deg"] == pytest.approx(mu, rel=1e-12)
    assert m["yaw_mean_std_deg"] == pytest.approx(sd, rel=1e-12)
    assert m["thesis_yaw_mean_z"] == pytest.approx((-0.2 - mu) / sd, rel=1e-12)
    assert m["shipped_seed_yaw_mean_z"] == pytest.approx((0.5 - mu) / sd, rel=1e-12)
    assert m["yaw_mean_by_seed_deg"] == {str(s): y for s, y in means.items()}
    lines = E.yaw_spread_report_lines(m)
    assert "| 3 | 2.000 |" in lines and "| 4 | -0.500 |" in lines
    text = "\n".join(lines)
    assert f"{mu:.2f}° ± {sd:.2f}°" in text
    assert f"lies {(-0.2 - mu) / sd:+.1f}σ" in text and f"seed {(0.5 - mu) / sd:+.1f}σ" in text
    assert E.THESIS_MEAN_YAW_DEG == -0.2 and E.YAW_SEEDS == (1, 2, 3, 4, 5, 6)


def test_the_runs_side_by_side_table_has_each_runs_cell_under_its_name():
    m = {"by_run": {"a": {"tilt_error_max_deg": 1.23456, "covariance_repairs": 3},
                    "b": {"tilt_error_max_deg": 0.5, "gate_rejections": 7}}}
    lines = E.report_lines(m)
    assert lines[2] == "| metric | `a` | `b` |" and lines[3] == "| --- | --- | --- |"
    assert "| `tilt_error_max_deg` | 1.235 | 0.5 |" in lines
    assert "| `covariance_repairs` | 3 | — |" in lines
    assert "| `gate_rejections` | — | 7 |" in lines
    rows = [ln.split(" | ")[0] for ln in lines if ln.startswith("| `")]
    assert len(rows) == 14 and rows[0] == "| `tilt_error_max_deg`" and rows[-1] == "| `peak_tilt_rate_deg_s`"

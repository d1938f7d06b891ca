"""The estimators study's bookkeeping around the shipped filter (issue 22): the shipped
filters are held to the same attitude bounds as the thesis's, and the metrics of each
filter are read from that filter's own runs (EKF, thesis's, shipped; sine then velocity
profile, :func:`studies.estimators.thesis_filter_expand` order)."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from ballbot_casadi.sim.embedded import DEFAULT_ESTIMATOR, THESIS_ESTIMATOR
from studies import estimators as E
from studies.registry import get_study


def test_the_shipped_filters_meet_the_thesis_filters_attitude_bounds():
    specs = {s.metric: s for s in get_study("estimators").specs}
    for axis in ("roll", "pitch"):
        thesis = specs[f"{THESIS_ESTIMATOR}_{axis}_rms_deg"]
        shipped = specs[f"{DEFAULT_ESTIMATOR}_{axis}_rms_deg"]
        assert (shipped.op, shipped.threshold) == (thesis.op, thesis.threshold) == ("<=", 0.1)
    ratio = specs["shipped_vs_thesis_velocity_rms_ratio"]
    assert (ratio.op, ratio.threshold) == ("<=", 1.0)  # no worse than the thesis's


def _run(i: int) -> dict:
    # every metric of run i distinct from every other run's
    keys = ("estimator_roll_rms_deg", "estimator_pitch_rms_deg", "estimator_velocity_rms_mps",
            "quat_norm_max_dev", "estimator_heading_drift_deg", "position_drift_m",
            "estimator_q2_error_max", "estimator_q3_error_max", "estimator_rate_rms_dps",
            "estimator_vx_drift_mps", "estimator_vx_error_rms_mps", "estimator_vy_error_rms_mps",
            "estimator_x_error_final_m", "nis_attitude_mean", "nis_velocity_mean")
    return {k: 100.0 * (i + 1) + j for j, k in enumerate(keys)}


def test_each_filters_metrics_come_from_its_own_runs(monkeypatch):
    names = ["ekf_sine", "ekf_velocity", "ukf_sine", "ukf_velocity", "ad_sine", "ad_velocity"]
    logs = [SimpleNamespace(scenario={"name": n}) for n in names]
    runs = {n: _run(i) for i, n in enumerate(names)}
    monkeypatch.setattr(E, "by_run", lambda _logs: runs)
    monkeypatch.setattr(E, "renormalisation_metrics", lambda _log: {})
    m = E.estimators_metrics(logs)
    for f, (sine, vel) in (("ekf", (0, 1)), (THESIS_ESTIMATOR, (2, 3)),
                           (DEFAULT_ESTIMATOR, (4, 5))):
        assert m[f"{f}_roll_rms_deg"] == _run(sine)["estimator_roll_rms_deg"]
        assert m[f"{f}_q3_error_max"] == _run(sine)["estimator_q3_error_max"]
        assert m[f"{f}_velocity_rms_mps"] == _run(vel)["estimator_velocity_rms_mps"]
        assert m[f"{f}_x_error_final_m"] == _run(vel)["estimator_x_error_final_m"]
        assert m[f"{f}_quat_norm_max_dev"] == max(_run(sine)["quat_norm_max_dev"],
                                                  _run(vel)["quat_norm_max_dev"])
        if f != "ekf":
            assert m[f"{f}_nis_attitude_mean"] == _run(sine)["nis_attitude_mean"]
            assert m[f"{f}_nis_velocity_mean"] == _run(vel)["nis_velocity_mean"]
    assert m["shipped_vs_thesis_velocity_rms_ratio"] == pytest.approx(
        _run(5)["estimator_velocity_rms_mps"] / _run(3)["estimator_velocity_rms_mps"], rel=1e-15)
    # the repairs and rejections of every run that counts them; a run without counts adds none
    assert (m["covariance_repairs"], m["gate_rejections"]) == (0, 0)
    runs["ukf_sine"].update(covariance_repairs=2, gate_rejections=5)
    runs["ad_velocity"].update(gate_rejections=3)
    m = E.estimators_metrics(logs)
    assert (m["covariance_repairs"], m["gate_rejections"]) == (2, 8)

"""The predecessor and robustness studies' bookkeeping on hand-built runs (issue 23, test
strength): each system's metrics from its own two runs (sine for the attitude, velocity
profile for the rest), the heading error's magnitude, the ratios' numerator and
denominator, the expand hook's order and names, and the report cells read back."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from ballbot_casadi.studies import predecessor as PRE
from ballbot_casadi.studies import robustness as ROB

KEYS = (*PRE._SINE_KEYS, *PRE._VEL_KEYS)


def _run(i: int) -> dict:
    m = {k: 10.0 * (i + 1) + j for j, k in enumerate(KEYS)}
    m["estimator_heading_max_deg"] = -m["estimator_heading_max_deg"]   # signed in the run
    return m


@pytest.fixture()
def metrics(monkeypatch):
    tags = list(PRE.SYSTEMS)
    names = [f"{f}_{t}" for t in tags for f in ("sine", "velocity")]
    idx = {n: i for i, n in enumerate(names)}
    monkeypatch.setattr(PRE, "run_metrics", lambda log: _run(idx[log.scenario["name"]]))
    return PRE.predecessor_metrics([SimpleNamespace(scenario={"name": n}) for n in names])


def test_each_systems_metrics_from_its_own_runs(metrics):
    for i, tag in enumerate(PRE.SYSTEMS):
        sine, vel = _run(2 * i), _run(2 * i + 1)
        assert metrics[f"{tag}_roll_rms_deg"] == sine["estimator_roll_rms_deg"]
        assert metrics[f"{tag}_tilt_rms_deg"] == sine["estimator_tilt_rms_deg"]
        assert metrics[f"{tag}_vy_error_rms_mps"] == vel["estimator_vy_error_rms_mps"]
        assert metrics[f"{tag}_position_drift_m"] == vel["position_drift_m"]
        assert metrics[f"{tag}_heading_max_deg"] == -vel["estimator_heading_max_deg"] > 0


def test_the_ratios_are_ours_over_the_ekf_with_heading(metrics):
    for a in ("ukf", "ukfh"):
        for k, short in (("roll_rms_deg", "roll_rms"), ("pitch_rms_deg", "pitch_rms"),
                         ("heading_max_deg", "heading_max"), ("vy_error_rms_mps", "vy_rms")):
            assert metrics[f"{a}_vs_ekfh_{short}_ratio"] == pytest.approx(
                metrics[f"{a}_{k}"] / metrics[f"ekfh_{k}"], rel=1e-15), (a, k)
    assert metrics["ukf_vs_ekfh_roll_rms_ratio"] == pytest.approx(70.0 / 10.0)


def test_the_systems_and_the_expand_hook():
    assert PRE.SYSTEMS == {"ekfh": ("ekf_heading", True), "ekf": ("ekf", False),
                           "ukfh": ("ukf_heading", True), "ukf": ("ukf", False)}
    out = PRE.predecessor_expand([{"name": "s"}, {"name": "v", "seed": 2}])
    assert [t["name"] for t in out] == ["s_ekfh", "v_ekfh", "s_ekf", "v_ekf", "s_ukfh", "v_ukfh", "s", "v"]
    assert [t["estimator"] for t in out] == ["ekf_heading"] * 2 + ["ekf"] * 2 + ["ukf_heading"] * 2 + ["ukf"] * 2
    assert [t.get("heading_sensor", False) for t in out] == [True, True, False, False, True, True, False, False]
    assert out[-1] == {"name": "v", "seed": 2, "estimator": "ukf"}


def test_the_report_table_reads_back(metrics):
    lines = PRE.predecessor_report_lines(metrics)
    assert lines[2] == ("| metric | QEKF+heading+bias, VEKF (V2019) | QEKF, VEKF (no heading) | "
                        "QUKF+heading+bias, VUKF (ours) | QUKF, VUKF (thesis) |")
    assert lines[3] == "| --- | --- | --- | --- | --- |"
    assert "| `roll_rms_deg` | 10 | 30 | 50 | 70 |" in lines
    assert "| `position_drift_m` | 28 | 48 | 68 | 88 |" in lines
    text = "\n".join(lines)
    assert "roll RMS ratio UKF / EKF-with-heading 7, pitch 6.45" in text
    assert f"({metrics['ukf_heading_max_deg']:.3g}° against {metrics['ekfh_heading_max_deg']:.3g}°)" in text
    assert f"y-velocity error RMS {metrics['ukf_vs_ekfh_vy_rms_ratio']:.3g} (> 1" in text
    assert f"the ratio is {metrics['ukfh_vs_ekfh_vy_rms_ratio']:.3g}:" in text


def test_robustness_compares_the_last_run_with_the_first(monkeypatch):
    monkeypatch.setattr(ROB, "robustness_metrics", lambda nominal, changed: (nominal, changed))
    assert ROB.robustness_study_metrics(["a", "b", "c"]) == ("a", "c")


def test_robustness_report_cells():
    m = {"deviation_roll_deg": 0.5, "deviation_pitch_deg": 0.25, "deviation_yaw_deg": 0.125,
         "relative_deviation_roll": 0.1, "relative_deviation_pitch": 0.2, "relative_deviation_yaw": 0.9,
         "yaw_affected_most": False, "yaw_affected_most_relative": True, "most_affected_axis": "roll",
         "most_affected_axis_relative": "yaw", "settling_time_s": 1.5, "nominal_settling_time_s": 0.75,
         "settling_time_ratio": 2.0}
    lines = ROB.robustness_report_lines(m)
    assert lines[4:7] == ["| roll | 0.5 | 0.1 |", "| pitch | 0.25 | 0.2 |", "| yaw | 0.125 | 0.9 |"]
    text = "\n".join(lines)
    assert "most affected axis is **roll**: the observation is **refuted** in absolute terms" in text
    assert "the most affected is **yaw**: **confirmed** in relative terms" in text
    assert "Settling into 0.1°: 1.5 s against 0.75 s nominal (ratio 2;" in text

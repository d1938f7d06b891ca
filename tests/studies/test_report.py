"""The demo report collects the step outputs without recomputing them."""

import json

from ballbot_casadi.studies.report import write_report


def test_report_lists_every_section_and_uses_step_numbers(tmp_path):
    (tmp_path / "analysis").mkdir()
    (tmp_path / "analysis" / "analysis.json").write_text(json.dumps({
        "n_states_reduced": 10, "controllability_rank": 10, "unstable_poles": [3.75, 3.74],
        "rhp_zeros_position": [2.9, 2.9], "bandwidth_inner_hz": 1.0, "bandwidth_outer_hz": 5.0,
        "bandwidth_sensitivity_inner_hz": 0.64, "bandwidth_sensitivity_outer_hz": 0.15,
        "bandwidth_sensitivity_ratio": 4.2, "cascade_rule_ok": True}))
    (tmp_path / "study_sine").mkdir()
    (tmp_path / "study_sine" / "metrics.json").write_text(json.dumps({"roll_lag_s": 0.0123}))
    bench = tmp_path / "bench.json"
    bench.write_text(json.dumps({"ode_ns": 271.5}))
    text = write_report(tmp_path, bench).read_text()
    for fragment in ("## Model", "controllability rank 10", "0.0123", "## COM offset", "not run",
                     "| `ode_ns` | 271.5 |", "3× rule (thesis §7.1): yes", "`beta`"):
        assert fragment in text, fragment


def test_report_intro_says_what_the_runs_feed_back(tmp_path):
    """The intro must not claim true-state feedback only: the complete system runs the
    estimators (issue 20)."""
    text = write_report(tmp_path, tmp_path / "no_bench.json").read_text()
    intro = text.split("\n## ")[0]
    assert "QUKF + VUKF" in intro and "true state" in intro
    assert "ballbot study thesis" in intro

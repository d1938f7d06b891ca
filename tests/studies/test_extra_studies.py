"""The issue-22 studies (envelope, consistency, heading) on shortened settings, and their CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ballbot_casadi.analysis.consistency import chi2_band
from ballbot_casadi.cli import main
from ballbot_casadi.estimation.velocity import MATCHED_ACC_PROCESS_VAR
from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario
from ballbot_casadi.studies.consistency import NIS_DIM, run_consistency_study
from ballbot_casadi.studies.envelope import _scenario, recovered, run_envelope_study
from ballbot_casadi.studies.heading import run_heading_study


@pytest.fixture(scope="module")
def sim() -> ClosedLoop:
    return ClosedLoop()


def test_recovery_predicate_on_a_small_and_a_large_push(sim):
    from ballbot_casadi.sim.scenario import Scenario

    k = Scenario(name="k", controller="flc", duration=0.01).inputs()["k_bal"]
    assert recovered(run_scenario(_scenario("flc", "true", k, (2.0, 0.0)), sim))
    assert not recovered(run_scenario(_scenario("flc", "true", k, (40.0, 0.0)), sim))


def test_envelope_study_writes_table_and_polar_plot(sim, tmp_path):
    m = run_envelope_study(tmp_path, controllers=("flc", "flc_dob"), estimators=("true",),
                           push_max=16.0, push_tol=4.0, torque_max=4.0, torque_tol=0.25, sim=sim)
    rows = m["table"]["true"]
    for c in ("flc", "flc_dob"):
        # the thesis's 4 deg roll jump (§8.4.3) is inside every envelope
        assert rows[c]["push_roll_deg"] >= 4.0 and rows[c]["push_roll_bracketed"]
        assert 0.0 < rows[c]["torque_step_limits_nm"] <= rows[c]["torque_step_nm"]
    # the observer rejects the wheel-torque pulse: inside the §7.1 limits it recovers from
    # a larger one (measured 0.94 -> 1.80 N m at 0.05 N m resolution)
    v = m["dob"]["true"]
    assert "torque_step_limits_nm" in v["raised"] and v["verdict"] in ("raises", "mixed")
    assert v["columns"]["torque_step_limits_nm"]["diff"] > 0.5
    assert (tmp_path / "envelope.png").stat().st_size > 0
    text = (tmp_path / "report.md").read_text()
    assert "| flc_dob |" in text and "Fig. 8.14" in text and "§7.1 limits" in text
    assert "raise the FLC's envelope?" in text
    assert json.loads((tmp_path / "metrics.json").read_text())["table"]["true"]["flc"] == rows["flc"]


def test_consistency_study_reports_the_band_and_the_overconfident_thesis_filter(sim, tmp_path):
    m = run_consistency_study(tmp_path, names=["full_sine"], duration=3.0, sim=sim)
    r = m["scenarios"]["full_sine"]
    for f in ("attitude", "velocity"):
        np.testing.assert_allclose(r[f]["band"], chi2_band(NIS_DIM, r[f]["n"]), rtol=1e-12)
    # the thesis's velocity filter (estimator "ukf") beside the shipped one: overconfident
    t = r["velocity_thesis"]
    assert t["verdict"] == "overconfident" and t["mean_nis"] > 50
    assert t["acc_process_var"][0] == t["acc_process_var"][1] < 1e-3  # the thesis's walk (1e-5)
    # the shipped filter (the file's ukf_adaptive: the verdict row, with the walk it ended
    # with and the one measured from the truth), and the matched filter with the constant pair
    a, v = r["velocity"], r["velocity_matched"]
    assert v["acc_process_var"] == list(MATCHED_ACC_PROCESS_VAR)
    assert len(a["acc_process_var"]) == 2 and len(a["acc_walk_truth"]) == 2
    assert all(1e-3 <= q <= 1.0 for q in a["acc_process_var"])  # the adaptation's bounds
    for x in (a, v):
        assert 4.5 < x["mean_nis"] < 7.5
        assert x["velocity_rms_mps"] < t["velocity_rms_mps"]
    assert not m["thesis_passed"]
    text = (tmp_path / "report.md").read_text()
    assert (tmp_path / "nis.png").is_file() and "| full_sine | velocity_matched |" in text
    assert "| full_sine | velocity_thesis |" in text and "adaptive_passed" in text


def test_consistency_of_the_shipped_velocity_filter_on_full_sine(sim, tmp_path):
    """The whole full_sine run (20 s) as shipped.  The matched filter adapting its
    acceleration random walk online (estimator ukf_adaptive, no truth) has its mean NIS
    inside the chi2 95 % band of 3800 samples (measured 5.92 in [5.89, 6.11]) and ends with
    a walk close to the one measured from the truth on the same run (0.0098/0.0112 against
    0.0103/0.0129 (m/s^2)^2 x/y).  With the constant pair MATCHED_ACC_PROCESS_VAR
    (0.057/0.073, the mean over five scenarios, pulled up by the COM robots' 0.08-0.12) it
    assumes five times this profile's acceleration jitter: NIS below the band (measured
    4.39, underconfident).  The velocity error does not depend on it (1.42 mm/s either way
    against 2.16 with the thesis's ukf)."""
    m = run_consistency_study(tmp_path, plot=False, names=["full_sine"], sim=sim)
    r = m["scenarios"]["full_sine"]
    a, v, t = r["velocity"], r["velocity_matched"], r["velocity_thesis"]
    assert a["verdict"] == "consistent", a
    assert m["adaptive_passed"] and not m["matched_passed"] and not m["thesis_passed"]
    np.testing.assert_allclose(a["acc_process_var"], a["acc_walk_truth"], rtol=0.3)
    assert v["verdict"] == "underconfident" and 3.5 < v["mean_nis"] < a["mean_nis"], v
    np.testing.assert_allclose(a["velocity_rms_mps"], v["velocity_rms_mps"], rtol=0.02)
    assert a["velocity_rms_mps"] < 0.8 * t["velocity_rms_mps"]


def test_heading_study_short(tmp_path):
    m = run_heading_study(tmp_path, plot=False, duration=240.0, seeds=(0, 1))
    assert m["passed"] and m["aided_error_max_deg"] <= 0.5
    assert len(m["unaided_drift_per_hour_deg"]) == 2
    assert "thesis" in (tmp_path / "report.md").read_text()


def test_cli_extra_study_rejects_scenario_options(capsys):
    assert main(["study", "heading", "--seed", "3"]) == 2
    assert "do not apply" in capsys.readouterr().err


def test_dob_gain_sweep_trades_standing_motion_for_torque_activity(sim):
    """With the UKFs in the cascade a slow observer (3x the FLC pole) makes the standing
    robot wander more than a fast one (20x), which moves the torque more."""
    from ballbot_casadi.studies.envelope import dob_gain_sweep

    rows = dob_gain_sweep(sim, "ukf", separations=(3.0, 20.0))
    assert [r["controller"] for r in rows] == ["flc", "flc_dob", "flc_dob"]
    flc, slow, fast = rows
    assert slow["tilt_deg"] > 1.5 * fast["tilt_deg"]  # measured 0.54 vs 0.19 deg
    assert fast["torque_tv_nm_per_s"] > 2 * flc["torque_tv_nm_per_s"] > 0  # measured 226 vs 48

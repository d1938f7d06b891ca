"""Helpers of ``ballbot study path``: which predicted horizons are drawn, the per-sample
table of the report from given metrics, the Monte Carlo note beside it, the per-sample
metrics of an MPC run and their refusal when the re-evaluation differs from the log."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from ballbot_casadi.analysis.guidance_samples import sample_residuals
from ballbot_casadi.errors import ScenarioError, SolverError
from ballbot_casadi.sim.guided import GUIDANCE_EVERY, run_path_scenario, scenario_law
from ballbot_casadi.sim.scenario import Scenario
from ballbot_casadi.sim.scenario.file import parse_scenario
from ballbot_casadi.studies.path import (
    FEED_POINT_COLUMNS,
    FEED_POINT_RUNS,
    FEED_POINTS,
    MONTE_CARLO_NOTE,
    SAMPLES_KEY,
    feed_point_lines,
    guidance_sample_metrics,
    horizon_samples,
    path_report_lines,
)


def test_horizon_samples_evenly_spaced_after_the_cold_start():
    np.testing.assert_array_equal(horizon_samples(270, 5), [1, 68, 135, 202, 269])
    np.testing.assert_array_equal(horizon_samples(3, 5), [1, 2])
    np.testing.assert_array_equal(horizon_samples(1), [0])
    assert horizon_samples(0).size == 0


def test_report_has_the_sample_table_and_the_peers_row_from_the_metrics():
    m = {"fig8_mpc_samples": 270.0, "fig8_mpc_sample_us_median": 554.8,
         "fig8_mpc_sample_us_p99": 1270.4, "fig8_mpc_sample_us_max": 16673.4,
         "fig8_mpc_sample_cpu_us_median": 556.1, "fig8_mpc_sample_cpu_us_p99": 790.0,
         "fig8_mpc_sample_cpu_us_max": 2891.8, "fig8_mpc_r_prim_median": 0.0016784,
         "fig8_mpc_r_prim_max": 0.0217872, "fig8_mpc_sample_load_avg": 4.26}
    lines = path_report_lines(m)
    text = "\n".join(lines)
    assert "| fig8_mpc | 270 | 555 / 1270 / 16673 | 556 / 790 / 2892 | 0.0017 / 0.022 | 4.3 |" in lines
    assert "fig8_mpc_ukf |" not in text  # no metrics, no row
    assert "555 µs median, 1270 µs p99 wall-clock (790 µs p99 CPU)" in text
    assert "fixed-iteration ADMM" in text and "r_prim" in text
    assert all(line in lines for line in MONTE_CARLO_NOTE)
    assert "## MPC samples" not in "\n".join(path_report_lines({}))


def test_the_sample_table_has_a_row_per_sampled_run_in_the_study_order():
    tags = ("fig8_mpc", "fig8_mpc_ukf", "obstacles_mpc", "fig8_mpc_balance", "fig8_mpc_balance_ukf",
            "obstacles_mpc_balance", "mc", "mc_ukf")
    m = {f"{t}_samples": float(10 + i) for i, t in enumerate(tags)}
    m.update({f"{t}_sample_us_median": float(100 * i) for i, t in enumerate(tags)})
    m["other_samples"] = 99.0   # a run the study does not sample: not a row
    lines = path_report_lines(m)
    i = lines.index("| --- | --- | --- | --- | --- | --- |")
    rows = lines[i + 1:i + 1 + len(tags)]
    assert [r.split(" | ")[0:2] for r in rows] == [[f"| {t}", f"{10 + k}"] for k, t in enumerate(tags)]
    assert rows[2].startswith("| obstacles_mpc | 12 | 200 / — / — | — / — / — | — / — | — |")
    assert lines[i + 1 + len(tags)] == "" and "| other |" not in "\n".join(lines)


def test_feed_point_table_has_a_row_per_run_and_feed_from_the_metrics():
    """Rows: each course x feed point (velocity LQR, balance controller); cells: the
    run's metrics under ``<course>_<law>[_ukf]_<metric>``; a missing metric is a dash."""
    m = {}
    for i, (_, course, suffix) in enumerate(FEED_POINT_RUNS):
        for j, (_, law) in enumerate(FEED_POINTS):
            tag = f"{course}_{law}{suffix}"
            m.update({f"{tag}_path_lateral_rms_settled_m": 0.001 * (1 + i + 3 * j),
                      f"{tag}_path_lateral_max_m": 0.0123, f"{tag}_path_min_clearance_m": 0.149,
                      f"{tag}_path_completed": 1.0, f"{tag}_peak_tilt_deg": 3.54,
                      f"{tag}_peak_tilt_rate_deg_s": 9.96, f"{tag}_peak_torque_nm": 0.57,
                      f"{tag}_sample_cpu_us_median": 612.4, f"{tag}_sample_cpu_us_p99": 1500.6,
                      f"{tag}_sample_us_median": 9.0,
                      f"{tag}_solver_workspace_bytes": 40000.0,
                      f"{tag}_block_workspace_bytes": 470000.0})
    del m["fig8_mpc_balance_ukf_peak_torque_nm"]
    lines = feed_point_lines(m)
    rows = [line for line in lines if line.startswith("| ") and "---" not in line][1:]
    assert len(rows) == len(FEED_POINT_RUNS) * len(FEED_POINTS) == 6
    header = next(line for line in lines if line.startswith("| run | feeds |"))
    assert header.count("|") == len(FEED_POINT_COLUMNS) + 3
    assert rows[0] == ("| figure-eight, true state | velocity LQR (v_ref) | 0.10 | 1.23 | 0.149 | "
                       "1 | 3.54 | 10.0 | 0.57 | 612 / 1501 | 40000 / 470000 |")
    assert rows[1].startswith("| figure-eight, true state | balance controller") and "| 0.40 |" in rows[1]
    assert rows[3].startswith("| figure-eight, noise + UKFs | balance controller")
    assert "| — |" in rows[3] and "| — |" not in rows[2]
    assert "lateral RMS 0.10 cm (velocity feed) against 0.40 cm (balance feed)" in "\n".join(lines)
    assert any(line == "## Feed point: velocity LQR (shipped) or balance controller (Kugle's)"
               for line in path_report_lines(m))


@pytest.fixture(scope="module")
def mpc_log():
    sc = parse_scenario({"duration_s": 1.0, "cascade": True, "guidance": "mpc",
                         "path": {"type": "line", "start": [0.0, 0.0], "end": [3.0, 0.0],
                                  "speed": 0.4}}, "line").scenario
    return run_path_scenario(sc)


def test_sample_metrics_of_an_mpc_run(mpc_log):
    """The uncompiled guidance block stands in for the compiled one (same Function)."""
    log = copy.deepcopy(mpc_log)
    law = scenario_law(Scenario.from_dict(log.scenario))
    m = guidance_sample_metrics(log, {law.function.name(): law.function})
    r = sample_residuals(law, log["guide"])
    assert m["samples"] == 10 and r.shape == (10,)
    assert m["r_prim_median"] == np.median(r) and m["r_prim_max"] == r.max()
    assert 0 < m["sample_us_median"] <= m["sample_us_p99"] <= m["sample_us_max"]
    d = log.extra[SAMPLES_KEY]
    np.testing.assert_allclose(d["t_s"], 0.1 * np.arange(10), rtol=0, atol=1e-12)
    assert len(d["wall_us"]) == len(d["cpu_us"]) == 10 and d["r_prim"] == r.tolist()
    # the saved samples are the summarised ones, both in microseconds
    for k, pre in (("wall_us", "sample_us"), ("cpu_us", "sample_cpu_us")):
        assert max(d[k]) == pytest.approx(m[f"{pre}_max"], rel=1e-12)
        assert float(np.median(d[k])) == pytest.approx(m[f"{pre}_median"], rel=1e-12)
    # the solver's static memory (the 64 KiB target) inside the block's
    assert 0 < m["solver_workspace_bytes"] <= 64 * 1024 < m["block_workspace_bytes"]


def test_sample_metrics_refuse_a_replay_that_differs_from_the_log(mpc_log):
    log = copy.deepcopy(mpc_log)
    law = scenario_law(Scenario.from_dict(log.scenario))
    log.arrays["guide"][GUIDANCE_EVERY + 1, 1] += 1e-3  # the state after the second sample
    with pytest.raises(SolverError, match="differs from the logged state"):
        guidance_sample_metrics(log, {law.function.name(): law.function})


def test_sample_metrics_of_a_run_without_samples_say_so(mpc_log):
    """A log cut before the first period has no guidance sample: one line saying so (not a
    replay mismatch, not a numpy error)."""
    log = copy.deepcopy(mpc_log)
    log.arrays = {k: v[:1] for k, v in log.arrays.items()}
    law = scenario_law(Scenario.from_dict(log.scenario))
    with pytest.raises(ScenarioError, match="the log has no control period, so no guidance sample"):
        guidance_sample_metrics(log, {law.function.name(): law.function})

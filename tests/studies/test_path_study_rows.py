"""The path study's per-run metrics and its main table on hand-built values (issue 23, test
strength): each run's metrics under its own tag, the per-sample figures of the MPC runs
only, and every cell of the course x law table under its column in its unit."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from ballbot_casadi.studies import path as P


def _log(name, guidance, i):
    return SimpleNamespace(scenario={"name": name, **({"guidance": guidance} if guidance else {})},
                           params=SimpleNamespace(tau_max=10.0 + i), i=i)


def test_each_runs_metrics_under_its_tag(monkeypatch):
    monkeypatch.setattr(P, "path_metrics", lambda log: {k: 100.0 * log.i + j for j, k in
                                                        enumerate(P.PATH_RUN_METRICS[:4])})
    monkeypatch.setattr(P, "limit_metrics", lambda log, tau: {"peak_tilt_deg": tau, "peak_tilt_rate_deg_s": 2 * tau,
                                                              "peak_torque_nm": 3 * tau, "other": 0.0})
    sampled = []
    monkeypatch.setattr(P, "guidance_sample_metrics",
                        lambda log, libs: sampled.append(log.i) or {"samples": 5.0 + log.i})
    logs = [_log("path_fig8_mpc", None, 0), _log("path_fig8_pursuit", "pursuit", 1),
            _log("path_obstacles_mpc_balance", "mpc_balance", 2)]
    m = P.path_study_metrics(logs)
    assert m["fig8_mpc_path_lateral_rms_settled_m"] == 0.0 and m["fig8_mpc_path_completed"] == 3.0
    assert m["fig8_pursuit_path_lateral_max_m"] == 101.0 and m["fig8_pursuit_peak_tilt_deg"] == 11.0
    assert m["obstacles_mpc_balance_path_min_clearance_m"] == 202.0
    assert m["obstacles_mpc_balance_peak_torque_nm"] == 36.0
    assert m["fig8_mpc_peak_tilt_rate_deg_s"] == 20.0
    assert sampled == [0, 2]     # the default law is the MPC; pursuit has no samples
    assert m["fig8_mpc_samples"] == 5.0 and m["obstacles_mpc_balance_samples"] == 7.0
    assert "fig8_pursuit_samples" not in m and not any(k.endswith("_other") for k in m)
    assert len(m) == 3 * len(P.PATH_RUN_METRICS) + 2


def test_the_course_by_law_table_cells():
    m = {"fig8_mpc_path_lateral_rms_settled_m": 0.01234, "fig8_mpc_path_lateral_max_m": 0.0456,
         "fig8_mpc_path_min_clearance_m": 0.1499, "fig8_mpc_path_completed": 1.0,
         "fig8_mpc_peak_tilt_deg": 3.294, "fig8_mpc_peak_tilt_rate_deg_s": 12.34, "fig8_mpc_peak_torque_nm": 1.234,
         "fig8_pursuit_ukf_path_lateral_rms_settled_m": 0.05, "obstacles_pursuit_path_completed": 0.0,
         "fig8_mpc_ukf_path_lateral_rms_settled_m": float("nan")}
    lines = P.path_report_lines(m)
    assert "| fig8 | mpc | 1.2 | 4.6 | 0.150 | 1 | 3.29 | 12.3 | 1.23 |" in lines
    assert "| fig8_ukf | pursuit | 5.0 | — | — | — | — | — | — |" in lines
    assert "| fig8_ukf | mpc | — | — | — | — | — | — | — |" in lines
    assert "| obstacles | pursuit | — | — | — | 0 | — | — | — |" in lines
    rows = [ln for ln in lines if ln.startswith("| fig8 |") or ln.startswith("| fig8_ukf |")
            or ln.startswith("| obstacles |")]
    assert [r.split(" | ")[:2] for r in rows] == [["| fig8", "mpc"], ["| fig8", "pursuit"], ["| fig8_ukf", "mpc"],
                                                   ["| fig8_ukf", "pursuit"], ["| obstacles", "mpc"],
                                                   ["| obstacles", "pursuit"]]
    assert "Limits (thesis §7.1): tilt 5 deg, tilt rate 20 deg/s, speed 0.5 m/s." in "\n".join(lines)


def test_the_feed_point_columns_scale_to_their_units():
    cols = {metric: (scale, fmt) for _, metric, scale, fmt in P.FEED_POINT_COLUMNS}
    assert cols["path_lateral_rms_settled_m"] == (100, ".2f") and cols["path_lateral_max_m"] == (100, ".2f")
    for k in ("path_min_clearance_m", "path_completed", "peak_tilt_deg", "peak_tilt_rate_deg_s", "peak_torque_nm",
              "sample_cpu_us_median|sample_cpu_us_p99", "solver_workspace_bytes|block_workspace_bytes"):
        assert cols[k][0] == 1, k
    assert [h for h, *_ in P.FEED_POINT_COLUMNS][0] == "lateral RMS after 2 s (cm)"
    assert P.FEED_POINTS == (("velocity LQR (v_ref)", "mpc"), ("balance controller (q_ref, dq_ref, ddq_ref)",
                                                                "mpc_balance"))
    assert P.FEED_POINT_RUNS == (("figure-eight, true state", "fig8", ""),
                                 ("figure-eight, noise + UKFs", "fig8", "_ukf"),
                                 ("obstacle course, true state", "obstacles", ""))
    line = P.feed_point_lines({"fig8_mpc_sample_cpu_us_median": 12.4, "fig8_mpc_sample_cpu_us_p99": 99.6,
                               "fig8_mpc_solver_workspace_bytes": 2048.0})
    row = next(ln for ln in line if ln.startswith("| figure-eight, true state | velocity LQR"))
    assert row.endswith("| 12 / 100 | 2048 / — |")
    assert P.MPC_LAWS == ("mpc", "mpc_balance") and P.SHOWN_HORIZONS == 5


@pytest.mark.parametrize("n, want", [(2, [1]), (6, [1, 2, 3, 4, 5]), (7, [1, 2, 4, 5, 6])])
def test_horizons_drawn_at_the_small_counts(n, want):
    assert P.horizon_samples(n).tolist() == want

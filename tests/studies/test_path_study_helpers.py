"""Helpers of ``ballbot study path``: which predicted horizons are drawn, the per-sample
table of the report from given metrics, the Monte Carlo note beside it."""

from __future__ import annotations

import numpy as np

from ballbot_casadi.studies.path import MONTE_CARLO_NOTE, horizon_samples, path_report_lines


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

"""Monte Carlo statistics leave a run's NaN (or missing) metric out of *every* statistic,
and the success rate is over the runs given (issue 23: a fresh mutant took the minimum
over the NaN too)."""

from __future__ import annotations

import math

import pytest

from ballbot_casadi.analysis.dispersion_stats import summarize
from ballbot_casadi.sim.scenario import parse_scenario
from ballbot_casadi.sim.scenario.dispersions import draw_runs


def test_nan_and_missing_values_are_left_out_of_every_statistic():
    sf = parse_scenario({"name": "n", "duration_s": 0.1}, "n.toml")
    vals = [math.nan, 4.0, 1.0, None, 3.0]   # None: the metric is missing in that run
    results = [{"ok": i % 2 == 0, "spec_ok": [i % 2 == 0], "error": None, "failure": None,
                "metrics": {} if v is None else {"m": v}} for i, v in enumerate(vals)]
    s = summarize(sf, draw_runs(sf, 5), results)
    st = s["metric_stats"]["m"]
    assert (st["min"], st["max"]) == (1.0, 4.0)
    assert st["mean"] == pytest.approx(8.0 / 3.0, rel=1e-15)
    assert st["std"] == pytest.approx(math.sqrt(14.0 / 9.0), rel=1e-12)   # population std of 1, 3, 4
    assert st["p95"] == pytest.approx(3.9, rel=1e-12)                     # 3 + 0.9 * (4 - 3)
    assert s["n"] == 5 and s["success_rate"] == pytest.approx(0.6, abs=1e-15) and s["n_failed"] == 2

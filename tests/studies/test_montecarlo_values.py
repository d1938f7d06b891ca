"""Monte Carlo outputs against hand-computed values: the set seed reported, the ranking of
the worst runs, the success rate against ``--min-success`` (issue 23, test strength)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi import cli
from ballbot_casadi.sim.closed_loop import ClosedLoop
from ballbot_casadi.studies import montecarlo_report as mc


@pytest.fixture(scope="module")
def sim() -> ClosedLoop:
    return ClosedLoop()


def test_the_report_names_the_set_seed_the_runs_were_drawn_with(tmp_path, sim):
    doc = mc.run_montecarlo("zero", 2, tmp_path / "mc", workers=0, quiet=True, seed=7,
                            overrides=[("duration_s", 0.05)], sim=sim)
    assert [r["seed"] for r in doc["runs"]] == [int(np.random.default_rng([7, i]).integers(0, 2**32))
                                                for i in range(2)]
    assert doc["seed"] == 7  # not the file's montecarlo seed
    assert "set seed 7 " in (tmp_path / "mc" / "report.md").read_text()


def _res(spec_ok, tilt, error=None, failure=None):
    return {"ok": all(spec_ok) and not error and not failure, "spec_ok": list(spec_ok),
            "metrics": {"peak_tilt_deg": tilt, "settling_time_s": 1.0}, "error": error, "failure": failure}


def test_worst_runs_rank_failed_specs_then_usage_then_tilt():
    specs = [{"metric": "peak_tilt_deg", "op": "<=", "threshold": 10.0}]
    results = [_res([True], 2.0),            # 20 % of the allowance
               _res([False], 12.0),          # fails its spec
               _res([True], 9.0),            # 90 %
               _res([True], 1.0, failure="the robot fell"),  # a failure counts as a failed spec
               _res([True], 5.0)]            # 50 %
    assert mc._rank(results, specs) == [1, 3, 2, 4, 0]
    assert mc._worst_usage(specs, results[2]["metrics"]) == (pytest.approx(0.9), "peak_tilt_deg")


def test_run_ranges_are_written_short():
    assert mc._ranges([0, 1, 2, 3, 7, 9, 10]) == "0-3, 7, 9-10"
    assert mc._ranges([4]) == "4"


@pytest.mark.parametrize("rate, min_success, code", [(0.5, 0.5, 0), (0.5, 0.75, 1), (1.0, 1.0, 0)])
def test_min_success_is_a_fraction_and_the_boundary_passes(tmp_path, monkeypatch, capsys, rate, min_success, code):
    doc = {"name": "z", "n": 4, "success_rate": rate, "specs": [], "worst": []}
    monkeypatch.setattr("ballbot_casadi.cli.montecarlo.run_montecarlo", lambda *a, **k: doc)
    assert cli.main(["montecarlo", "zero", "--n", "4", "--workers", "0", "--quiet",
                     "--min-success", str(min_success), "--out", str(tmp_path / "o")]) == code
    assert cli.main(["montecarlo", "zero", "--n", "4", "--min-success", "50",
                     "--out", str(tmp_path / "o")]) == 2  # a percentage is refused
    assert "--min-success" in capsys.readouterr().err
    assert not math.isnan(rate)


@pytest.mark.parametrize("argv, needle", [(["--n", "0"], "--n must be >= 1"), (["--n", "2", "--workers", "-1"], "--workers"),
                                          (["--n", "2", "--min-success", "-0.1"], "--min-success")])
def test_bad_numbers_name_the_option_typed(tmp_path, capsys, argv, needle):
    assert cli.main(["montecarlo", "zero", *argv, "--quiet", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert needle in err and err.count("\n") == 0

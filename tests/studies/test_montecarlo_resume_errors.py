"""A Monte Carlo run that raised an error stays an errored run through ``montecarlo.json``
and ``--resume`` (issue 23, faults): ``ok`` false, every spec false, the error kept, and
the report marks it errored instead of listing every spec as missed by its (absent)
metrics.  A fall keeps its reason too.  No simulation: the results are built by hand."""

from __future__ import annotations

import json

import pytest

from ballbot_casadi.core.specs import run_failure, spec_ok, specs_or_default
from ballbot_casadi.sim.scenario import load_scenario_file
from ballbot_casadi.sim.scenario.dispersions import draw_runs
from ballbot_casadi.studies import montecarlo_report as mr
from ballbot_casadi.studies.registry import shipped_scenarios


def _result(metrics, specs, error=None):
    if error:
        return {"ok": False, "spec_ok": [False] * len(specs), "metrics": {}, "error": error, "failure": None}
    oks = [spec_ok(metrics.get(s["metric"]), s["op"], s["threshold"]) for s in specs]
    failure = run_failure(metrics)
    return {"ok": all(oks) and failure is None, "spec_ok": oks, "metrics": metrics, "error": None,
            "failure": failure}


@pytest.fixture
def written(tmp_path):
    path = shipped_scenarios()["zero"]
    source = load_scenario_file(path)
    specs = specs_or_default(source.specs)
    runs = draw_runs(source, 4, 5)
    good = {"finite": True, "peak_tilt_deg": 0.2, "steady_state_error_deg": 0.001}
    fell = {"finite": True, "peak_tilt_deg": 95.0, "steady_state_error_deg": 0.001}
    finished = {0: _result(good, specs), 1: _result({}, specs, error="run zero_mc0001: plant.Mb = -1 | must be > 0"),
                3: _result(fell, specs)}
    out = tmp_path / "mc"
    doc = mr._write(out, path, source, runs, finished, missing=[2], seed=5)
    return out, runs, specs, finished, doc


def test_an_errored_run_keeps_its_error_status_through_save_and_resume(written):
    out, runs, specs, finished, doc = written
    saved = {r["index"]: r for r in json.loads((out / "montecarlo.json").read_text())["runs"]}
    assert saved[1]["error"] == finished[1]["error"] and saved[1]["ok"] is False
    back = mr._resumable(out, runs, specs)
    assert sorted(back) == [0, 1, 3]
    for k in back:  # exactly what the runs returned, the error and the fall included
        assert back[k] == finished[k], k
    assert back[1]["spec_ok"] == [False, False] and back[1]["error"].startswith("run zero_mc0001")
    assert back[0]["ok"] is True and back[3]["ok"] is False and "fell" in back[3]["failure"]
    assert doc["errors"] == [finished[1]["error"]] and doc["n_failed"] == 2


def test_the_report_marks_the_errored_run_and_the_fall_not_their_specs(written):
    out, *_ = written
    text = (out / "report.md").read_text()
    rows = {int(line.split("|")[1]): line for line in text.splitlines()
            if line.startswith("| ") and line.split("|")[1].strip().isdigit() and "worst/" in line}
    assert set(rows) == {0, 1, 3}
    assert "**error**: run zero_mc0001: plant.Mb = -1 \\| must be > 0" in rows[1]
    assert "steady_state_error_deg" not in rows[1] and "finite" not in rows[1]
    assert "**the robot fell" in rows[3]
    assert rows[0].split("|")[3].strip() == "none"
    assert "1 run(s) raised an error" in text

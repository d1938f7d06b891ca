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


def test_no_file_nothing_to_resume(tmp_path):
    assert mr._resumable(tmp_path / "empty", [], []) == {}


@pytest.mark.parametrize("text, kind", [
    ("not json", "JSONDecodeError"),
    ('{"runs": []}', "KeyError"),                             # neither n_planned nor n
    ('{"n": 4, "runs": [{"seed": 1}]}', "KeyError"),          # a run without its index
    ('{"n": 4, "runs": [{"index": "two"}]}', "ValueError"),
    ('{"n": 4, "runs": 7}', "TypeError"),
])
def test_a_file_that_is_not_a_result_is_refused(written, text, kind):
    out, runs, specs, *_ = written
    (out / "montecarlo.json").write_text(text)
    with pytest.raises(mr.ArgumentError, match=rf"^--resume: {out / 'montecarlo.json'} is not a Monte "
                                              rf"Carlo result \({kind}\)$"):
        mr._resumable(out, runs, specs)


@pytest.mark.parametrize("change", ["fewer", "more", "planned", "seed", "values"])
def test_a_result_of_another_set_is_refused(written, change):
    out, runs, specs, *_ = written
    # a run missing from the file (run 2) may differ: it has not run yet
    same = [dict(r) for r in runs]
    same[2]["seed"] = same[2]["seed"] + 1
    assert sorted(mr._resumable(out, same, specs)) == [0, 1, 3]
    runs = [dict(r) for r in runs]
    if change == "fewer":
        runs = runs[:3]
    elif change == "more":
        runs = runs + [dict(runs[0])]
    elif change == "planned":   # the file planned one run more than this set has
        f = out / "montecarlo.json"
        f.write_text(json.dumps({**json.loads(f.read_text()), "n_planned": len(runs) + 1}))
    elif change == "seed":
        runs[3]["seed"] = runs[3]["seed"] + 1          # run 3 is in the file
    else:
        runs[0]["values"] = {**runs[0]["values"], "extra": 1.0}
    with pytest.raises(mr.ArgumentError, match=r"^--resume: .* holds another Monte Carlo set \(other "
                                              r"scenario, --n, --seed or --set\); give another --out"):
        mr._resumable(out, runs, specs)

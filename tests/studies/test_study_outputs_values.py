"""The study driver's written outputs on hand-built results (issue 23, test strength): JSON of
numpy and non-finite values, the summary's lines, the report's spec and limit rows, the
``--duration`` bounds, ``study all``'s table (each controller's cell under its column) and
``study thesis``'s verdict counts and missing rows."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.sim.scenario import load_scenario_file
from ballbot_casadi.sim.scenario.sections import MAX_PERIODS
from ballbot_casadi.studies import study as ST
from ballbot_casadi.studies import thesis as TH
from ballbot_casadi.studies.registry import shipped_scenarios


def test_jsonable():
    v = {"a": np.float64(1.5), "b": [np.int64(3), np.bool_(True), (float("nan"), -math.inf)],
         "c": {"d": np.float32(0.25), "e": math.inf}, "f": "x", "g": None, "h": 2}
    out = ST.jsonable(v)
    assert out == {"a": 1.5, "b": [3, True, ["nan", "-inf"]], "c": {"d": 0.25, "e": "inf"}, "f": "x", "g": None,
                   "h": 2}
    assert type(out["a"]) is float and type(out["b"][0]) is int and type(out["b"][1]) is bool
    json.dumps(out, allow_nan=False)


SPEC = [{"metric": "m1", "value": 0.123456, "op": "<=", "threshold": 0.2, "ok": True, "source": "s1",
         "thesis": "± 1°"},
        {"metric": "m2", "value": 7, "op": ">", "threshold": 9, "ok": False, "source": "s2", "thesis": None}]
LIMITS = [{"metric": "peak_tilt_deg", "value": 6.5, "limit": 5.0, "exceeded": True, "by_scenario": True},
          {"metric": "peak_torque_nm", "value": 1.25, "limit": 10.0, "exceeded": False, "by_scenario": False}]


def test_format_summary_lines():
    r = {"study": "sine", "controller": "smc", "passed": False, "spec": SPEC, "limits": LIMITS,
         "failure": "the robot fell"}
    assert ST.format_summary(r).splitlines() == [
        "study sine (smc): FAIL",
        "  [ok] m1 = 0.1235 (spec <= 0.2; s1; thesis ± 1°)",
        "  [FAIL] m2 = 7 (spec > 9; s2)",
        "  [FAIL] the robot fell",
        "  [limit EXCEEDED] peak_tilt_deg = 6.5 (limit 5) (the scenario itself is beyond it)",
        "  [limit within] peak_torque_nm = 1.25 (limit 10)"]
    s = {"scenario": "x", "controller": "flc", "passed": True, "spec": []}
    assert ST.format_summary(s) == "scenario x (flc): PASS"


def test_report_rows(tmp_path):
    r = {"controller": "flc", "passed": False, "spec": SPEC, "limits": LIMITS,
         "metrics": {"m1": 0.123456, "by_run": {"a": 1}, "n": 3}}
    lines = ST._report(tmp_path, "T", r, ["p.png"], ["- intro"], ["## Extra", ""]).read_text().splitlines()
    assert lines[:3] == ["# T", "", "- intro"]
    assert "**Verdict: FAIL** (1/2 specs met; controller `flc`)." in lines
    assert "| ✅ pass | `m1` | 0.1235 | <= 0.2 | ± 1° | s1 |" in lines
    assert "| ❌ FAIL | `m2` | 7 | > 9 | — | s2 |" in lines
    assert "| ⚠️ EXCEEDED | `peak_tilt_deg` | 6.5 | 5 | yes |" in lines
    assert "| within | `peak_torque_nm` | 1.25 | 10 | no |" in lines
    assert any(ln.startswith("- `peak_tilt_deg` exceeds its limit: the scenario itself") for ln in lines)
    assert lines.index("## Extra") < lines.index("## Plots") and "![p.png](p.png)" in lines
    assert lines[-2:] == ["| `m1` | 0.1235 |", "| `n` | 3 |"]


def test_with_duration_bounds():
    src = load_scenario_file(shipped_scenarios()["zero"])
    Ts = src.scenario.Ts
    assert ST.with_duration(src, 7.5).scenario.duration == 7.5
    assert ST.with_duration(src, 7.5).table["duration_s"] == 7.5
    edge = MAX_PERIODS * Ts
    assert ST.with_duration(src, edge).scenario.n_periods == MAX_PERIODS       # at the bound
    with pytest.raises(ScenarioError, match=r"add --log-every 2 \(or more\)"):
        ST.with_duration(src, edge + Ts)
    assert ST.with_duration(src, edge + Ts, 2).scenario.n_periods == MAX_PERIODS + 1
    assert ST.with_duration(src, ST.MAX_LONG_RUN_S, 1000).scenario.duration == 360_000.0
    for bad in (0.0, -1.0, math.nan, math.inf, ST.MAX_LONG_RUN_S * (1 + 1e-12)):
        with pytest.raises(ScenarioError, match=r"^--duration must be within \(0, 360000\] s"):
            ST.with_duration(src, bad, 10**6)


def _res(values, oks, lim_values, exceeded):
    return {"passed": all(oks), "spec": [{"metric": "m", "op": "<=", "threshold": 1.0, "thesis": "t",
                                          "value": v, "ok": ok} for v, ok in zip(values, oks)],
            "limits": [{"metric": "peak_tilt_deg", "limit": 5.0, "value": v, "exceeded": e}
                       for v, e in zip(lim_values, exceeded)]}


def test_study_all_table(monkeypatch, tmp_path):
    res = {("a", "flc"): _res([0.5], [True], [1.5], [False]), ("a", "smc"): _res([2.5], [False], [6.0], [True]),
           ("b", "flc"): _res([0.25], [True], [2.0], [False])}
    monkeypatch.setattr(ST, "STUDY_NAMES", ("a", "b", "c"))
    ctrl = {"a": ("flc", "smc"), "b": ("flc",), "c": ("flc",)}
    monkeypatch.setattr(ST, "get_study", lambda n: type("S", (), {"controllers": ctrl[n]}))

    plots = []

    def run_study(name, c, out, sim, plot):
        plots.append(plot)
        if name == "c":
            raise ST.SolverError("no convergence")
        return res[(name, c)]

    monkeypatch.setattr(ST, "run_study", run_study)
    monkeypatch.setattr(ST, "ClosedLoop", lambda: None)
    ST.run_all(tmp_path / "new" / "no_plots", plot=False)  # makes its folder and the parents
    assert plots == [False] * 4
    assert (tmp_path / "new" / "no_plots" / "summary.json").is_file()
    plots.clear()
    table = ST.run_all(tmp_path)
    assert plots == [True] * 4  # plots by default
    assert set(table) == {"a", "b"} and set(table["a"]) == {"flc", "smc"}
    md = (tmp_path / "summary.md").read_text().splitlines()
    assert md[2] == "| c | run stopped: no convergence | | | ✗ | |"
    assert "| a | m | <= 1.0 | t | 0.5 | 2.5 ✗ |" in md
    assert "| a | peak_tilt_deg (§7.1 limit) | <= 5 | | 1.5 | 6 ⚠ |" in md
    assert "| b | m | <= 1.0 | t | 0.25 | — |" in md
    assert "| b | peak_tilt_deg (§7.1 limit) | <= 5 | | 2 | — |" in md
    saved = json.loads((tmp_path / "summary.json").read_text())
    assert saved["stopped"] == {"c": "no convergence"} and saved["a"]["smc"]["passed"] is False


def test_study_thesis_counts_and_missing(monkeypatch, tmp_path):
    r1 = TH.ThesisResult("r1", "§9.1", "c", "1", TH.Col("s1", "a"), None, "<=", 1.0, "w")
    r2 = TH.ThesisResult("r2", "§9.1", "c", "1", TH.Col("s1", "b"), None, "<=", 1.0, "w")
    r3 = TH.ThesisResult("r3", "§9.1", "c", "1", TH.Col("s2", "a"), None, "<=", 1.0, "w")
    r4 = TH.ThesisResult("r4", "§9.1", "c", "1", None, None, "<=", None, "nothing of ours measures it")
    needed, table = TH.needed_runs, TH.thesis_table
    monkeypatch.setattr(TH, "needed_runs", lambda: needed((r1, r2, r3, r4)))
    monkeypatch.setattr(TH, "thesis_table", lambda runs: table(runs, (r1, r2, r3, r4)))
    monkeypatch.setattr(ST, "STUDY_NAMES", ("s1", "s2"))
    (tmp_path / "s1" / "flc").mkdir(parents=True)
    (tmp_path / "s1" / "flc" / "metrics.json").write_text(json.dumps({"metrics": {"a": 0.5, "b": 2.0}}))
    ran = []
    monkeypatch.setattr(ST, "run_study", lambda n, c, out, plot: ran.append((n, c, out, plot)) or {"metrics": {}})
    res = ST.run_thesis(tmp_path / "t", root=tmp_path)
    assert ran == [("s2", "flc", tmp_path / "s2" / "flc", False)]
    assert res["counts"] == {"pass": 1, "differs": 1, "not reproducible": 2}
    assert res["missing"] == ["r3"] and res["passed"] is False
    saved = json.loads((tmp_path / "t" / "metrics.json").read_text())
    assert saved["missing"] == ["r3"] and saved["passed"] is False
    assert [r["verdict"] for r in saved["rows"]] == ["pass", "differs", "not reproducible", "not reproducible"]
    report = (tmp_path / "t" / "report.md").read_text()
    assert "4 results: 1 pass, 1 differ, 2 not reproducible." in report
    assert f"- `s1` (flc): read from `{tmp_path / 's1' / 'flc' / 'metrics.json'}`" in report
    assert f"- `s2` (flc): run now into `{tmp_path / 's2' / 'flc'}`" in report
    (tmp_path / "s2" / "flc").mkdir(parents=True)
    (tmp_path / "s2" / "flc" / "metrics.json").write_text(json.dumps({"metrics": {"a": 0.5}}))
    ran.clear()
    res = ST.run_thesis(tmp_path / "t", root=tmp_path)
    assert ran == [] and res["passed"] is True and res["missing"] == []
    ST.run_thesis(tmp_path / "t", root=tmp_path, rerun=True, plot=True)
    assert [(n, p) for n, _, _, p in ran] == [("s1", True), ("s2", True)]


def test_a_limit_within_is_never_said_to_be_exceeded_by_the_scenario():
    """A reference peaking beyond the limit (``by_scenario``) that the robot does not reach
    (within), and a limit exceeded by the run alone: neither gets the scenario's suffix."""
    limits = [{"metric": "peak_tilt_deg", "value": 4.5, "limit": 5.0, "exceeded": False, "by_scenario": True},
              {"metric": "peak_tilt_rate_deg_s", "value": 40.0, "limit": 30.0, "exceeded": True,
               "by_scenario": False}]
    r = {"study": "sine", "controller": "flc", "passed": True, "spec": [], "limits": limits}
    assert ST.format_summary(r).splitlines()[1:] == [
        "  [limit within] peak_tilt_deg = 4.5 (limit 5)",
        "  [limit EXCEEDED] peak_tilt_rate_deg_s = 40 (limit 30)"]

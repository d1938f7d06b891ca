"""``run_sil``'s bookkeeping on a stand-in co-simulation (the engines themselves are run by
the slow tests): the SIL block of metrics.json (master, steps, step, duration, wall time,
connections, signals, the mission difference without its per-signal arrays), the files it
writes, the plots asked for, the specs judged on the run's metrics and the report's lines."""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest

from ballbot_casadi.core.layout import STATE
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.studies import sil as SIL


def _stand_in(monkeypatch, tmp_path, scenario=True):
    calls = {}
    sc = SimpleNamespace(name="sine", controller="flc", description="a sine", Ts=0.005)
    signals = {f"plant.{n}": np.zeros(3) for n in STATE.names}
    run = SimpleNamespace(scenario=sc if scenario else None, signals=signals, master="gauss-seidel",
                          wall_s=1.25, connections=["a", "b", "c"], specs=[{"row": 1}],
                          write_connections=lambda p: p.write_text("connections\n"))

    def run_ssp(ssp, duration, master, allow_long):
        calls["run_ssp"] = (ssp.name, duration, master, allow_long)
        return run

    log = SimpleNamespace(arrays={"tau": np.zeros((7, 3)), "time": np.arange(8) * 0.005})
    monkeypatch.setattr(SIL, "run_ssp", run_ssp)
    monkeypatch.setattr(SIL, "sil_log", lambda r: log)
    monkeypatch.setattr(SIL, "run_metrics", lambda lg: {"peak_tilt_deg": 1.5})
    monkeypatch.setattr(SIL.Spec, "from_row", staticmethod(lambda r: ("spec", r["row"])))
    def evaluate_specs(specs, m):
        calls["specs"] = (specs, m)
        return [{"metric": "peak_tilt_deg", "value": m["peak_tilt_deg"], "op": "<=", "threshold": 2.0,
                 "ok": True, "source": "s"}]

    monkeypatch.setattr(SIL, "evaluate_specs", evaluate_specs)
    monkeypatch.setattr(SIL, "save_log", lambda lg, p: p.write_bytes(b"npz"))
    monkeypatch.setattr(SIL, "mission_difference", lambda r, a: {
        "reference": "compiled mission", "state_max": 0.004, "tau_max": 0.02, "state_diff": np.ones(3)})
    def png(p):
        p.write_bytes(b"png")
        return p

    def plot_run(title, logs, p):
        calls["plot_run"] = title
        return png(p)

    monkeypatch.setattr(SIL, "plot_run", plot_run)
    monkeypatch.setattr(SIL, "plot_compare", lambda t, d, p: png(p))
    return run, calls


@pytest.mark.parametrize("plot, compare", [(True, True), (False, True), (True, False)])
def test_the_sil_block_files_and_report(monkeypatch, tmp_path, plot, compare):
    run, calls = _stand_in(monkeypatch, tmp_path)
    out = tmp_path / "out"
    res = SIL.run_sil(tmp_path / "s.ssp", out, duration=0.035, master="gauss-seidel", plot=plot, compare=compare)
    assert calls["run_ssp"] == ("s.ssp", 0.035, "gauss-seidel", False)
    assert calls["specs"] == ([("spec", 1)], {"peak_tilt_deg": 1.5})
    want = {"ssp": str(tmp_path / "s.ssp"), "master": "gauss-seidel", "steps": 7, "step_s": 0.005,
            "duration_s": pytest.approx(0.035, rel=1e-12), "wall_s": 1.25, "connections": 3, "signals": 12}
    if compare:
        want["vs_mission"] = {"reference": "compiled mission", "state_max": 0.004, "tau_max": 0.02}
    assert res["sil"] == want
    assert res["sil"] == json.loads((out / "metrics.json").read_text())["sil"]
    assert res["passed"] is True and res["controller"] == "flc" and res["sil"] != res.get("study")
    names = sorted(p.name for p in out.iterdir() if not p.name.startswith("."))  # not the ownership mark
    pngs = (["plot.png"] + (["sil_compare.png"] if compare else [])) if plot else []
    assert names == sorted(["connections.csv", "metrics.json", "report.md", "run.npz", *pngs])
    if plot:
        assert calls["plot_run"] == "SIL sine (gauss-seidel)"
    report = (out / "report.md").read_text()
    assert report.startswith("# Software in the loop `sine`")
    assert ("- SSP: `" + str(tmp_path / "s.ssp") + "`; master `gauss-seidel`, 7 steps of 0.005 s, 1.25 s wall "
            "time, 3 connections logged (`connections.csv`)") in report
    assert ("- against the compiled mission: states within 0.004, torques within 0.02 N m" in report) is compare


def test_an_ssp_without_a_scenario_is_refused(monkeypatch, tmp_path):
    _stand_in(monkeypatch, tmp_path, scenario=False)
    with pytest.raises(ScenarioError, match=r"carries no scenario \(resources/scenario.json\); write it "
                                            r"with 'ballbot fmu ssp'"):
        SIL.run_sil(tmp_path / "s.ssp", tmp_path / "out")

"""The FLC/SMC comparison on stand-in runs (issue 23, test strength): the stiffness ratio
``(eta/eps) K / K_p`` of the named axis, the FLC over SMC ratios per set-up and axis, the
roll judged both ways, the integral-action ratios, the verdict (ours only) and the report."""

from __future__ import annotations

import json
from types import SimpleNamespace

import pytest

from ballbot_casadi.studies import flc_smc as FS

# errors (roll, pitch, yaw) of each (set-up feed-forward, controller)
ERR = {("none", "flc"): (0.6, 0.3, 0.01), ("none", "smc"): (0.2, 0.15, 0.02),
       ("exact", "flc"): (0.05, 0.36, 0.01), ("exact", "smc"): (0.1, 0.2, 0.01),
       ("exact", "sta"): (0.01, 0.018, 0.001), ("none", "sta"): (1.0, 1.0, 1.0)}


def test_stiffness_ratio_of_each_axis():
    k_smc = [1.0, 2.0, 3.0, 10.0, 20.0, 30.0, 0.5, 0.25, 0.125]   # K, eta, eps per axis
    k_flc = [4.0, 8.0, 16.0, 1.0, 1.0, 1.0]                       # Kp, Kd per axis
    assert FS.stiffness_ratio(k_smc, k_flc) == pytest.approx(20.0 / 0.25 * 2.0 / 8.0)   # pitch
    assert FS.stiffness_ratio(k_smc, k_flc, axis=0) == pytest.approx(10.0 / 0.5 * 1.0 / 4.0)
    assert FS.stiffness_ratio(k_smc, k_flc, axis=2) == pytest.approx(30.0 / 0.125 * 3.0 / 16.0)


@pytest.fixture()
def study(monkeypatch, tmp_path):
    monkeypatch.setattr(FS, "get_study", lambda name: SimpleNamespace(
        scenarios=lambda c, over: [None, (dict(over)["feedforward"], c)]))
    monkeypatch.setattr(FS, "run_scenario", lambda key, sim: key)
    monkeypatch.setattr(FS, "run_metrics", lambda key: dict(zip(FS._ERRORS, ERR[key])))
    monkeypatch.setattr(FS, "stiffness_ratio", lambda: 1.8)
    out = tmp_path / "new" / "flc_smc"  # the study makes its folder and the parents
    return FS.run_flc_smc_study(out, controllers=("flc", "smc", "sta"), sim=object()), out


def test_ratios_specs_and_verdict(study):
    m, out = study
    r = m["ratio_flc_over_smc"]
    assert r["thesis"] == pytest.approx({"roll": 3.0, "pitch": 2.0, "yaw": 0.5})
    assert r["ours"] == pytest.approx({"roll": 0.5, "pitch": 1.8, "yaw": 1.0})
    assert m["table"]["ours"]["sta"] == dict(zip(FS._ERRORS, ERR[("exact", "sta")]))
    assert m["integral_action_ratio"] == pytest.approx({"sta": 0.36 / 0.018})
    s = {sp["name"]: sp for sp in m["specs"]}
    pitch = s["thesis: pitch error FLC / SMC (thesis's set-up)"]
    assert (pitch["value"], pitch["op"], pitch["threshold"], pitch["ok"]) == (pytest.approx(2.0), ">=", 10.0, False)
    roll = s["thesis: roll error FLC / SMC within 3x (thesis's set-up)"]
    assert roll["value"] == pytest.approx(3.0) and roll["ok"] is True          # at the bound
    ours = s["ours: pitch ratio / stiffness ratio 1.80 (ours set-up)"]
    assert ours["value"] == pytest.approx(0.0, abs=1e-12) and ours["ok"] and ours["threshold"] == 0.15
    th = s["ours: pitch ratio / stiffness ratio 1.80 (thesis set-up)"]
    assert th["value"] == pytest.approx(2.0 / 1.8 - 1) and th["ok"] is True   # 0.111 <= 0.15
    assert m["passed"] is True                     # the thesis's rows do not decide
    assert json.loads((out / "metrics.json").read_text())["passed"] is True
    report = (out / "report.md").read_text().splitlines()
    assert "| flc | thesis | 0.6000 | 0.3000 | 0.0100 |" in report
    assert "| sta | ours | 0.0100 | 0.0180 | 0.0010 |" in report
    assert "| pitch error FLC / SMC | ≥ 10 ('one order of magnitude') | 2.00 | 1.80 |" in report
    assert "| roll error FLC / SMC | ≈ 1 ('quite similar') | 3.00 | 0.50 |" in report
    text = "\n".join(report)
    assert "- thesis: pitch error FLC / SMC (thesis's set-up): 2 >= 10 -> **differs**" in text
    assert "-> **PASS** (inside the boundary layer" in text and "sta 20.0 (our set-up)" in text


def test_the_roll_ratio_is_judged_both_ways(monkeypatch, tmp_path):
    err = dict(ERR)
    err[("none", "flc")] = (0.05, 0.3, 0.01)          # FLC / SMC roll 0.25: 4x the other way
    monkeypatch.setattr(FS, "get_study", lambda name: SimpleNamespace(
        scenarios=lambda c, over: [(dict(over)["feedforward"], c)]))
    monkeypatch.setattr(FS, "run_scenario", lambda key, sim: key)
    monkeypatch.setattr(FS, "run_metrics", lambda key: dict(zip(FS._ERRORS, err[key])))
    monkeypatch.setattr(FS, "stiffness_ratio", lambda: 3.0)
    m = FS.run_flc_smc_study(tmp_path, controllers=("flc", "smc"), sim=object())
    roll = next(sp for sp in m["specs"] if sp["name"].startswith("thesis: roll"))
    assert roll["value"] == pytest.approx(4.0) and roll["ok"] is False
    assert m["passed"] is False                        # ours: 1.8 / 3 - 1 = -0.4
    assert m["integral_action_ratio"] == {}

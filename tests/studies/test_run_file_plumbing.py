"""``ballbot simulate`` and ``ballbot study`` on another robot (``--params``) and the runs
a scenario file routes: every run rebased on the new parameters (plant and controller
model alike, the file's own changes on top), a [path] scenario to the guided mission and
refused with decimated logging, a chirp's bandwidth metrics merged, a study refused with a
controller it has no thesis experiment for.  The simulation itself is a stand-in."""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest

import ballbot_casadi.studies.registry as REG
import studies.study as ST
from ballbot_casadi.core.params import load_params
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.sim.scenario import load_scenario_file, parse_scenario
from studies.registry import shipped_scenarios

HEAVY = load_params().replace(Mb=21.5, l=0.6)   # another robot: body mass and COM height


def _upright_metrics(log):
    return {"peak_tilt_deg": 1.0, "finite": True}


@pytest.fixture
def runs(monkeypatch):
    seen = []

    def fake(sc, sim=None, log_every=1):
        seen.append(("mission", sc, log_every))
        return SimpleNamespace(name=sc.name)

    def fake_path(sc):
        seen.append(("guided", sc, 1))
        return SimpleNamespace(name=sc.name)

    monkeypatch.setattr(ST, "run_scenario", fake)
    monkeypatch.setattr(ST, "run_path_scenario", fake_path)
    monkeypatch.setattr(ST, "run_metrics", _upright_metrics)
    monkeypatch.setattr(ST, "save_log", lambda log, path: None)
    return seen


def test_simulate_rebases_the_file_on_the_new_robot(runs, tmp_path):
    src = parse_scenario({"name": "heavy", "duration_s": 0.1, "plant": {"Mb": {"scale": 1.1}}})
    ST.run_file(src, tmp_path / "o", plot=False, params=HEAVY)
    (_, sc, _), = runs
    plant, ctrl = sc.plant_params(), sc.controller_params()
    assert plant.Mb == pytest.approx(21.5 * 1.1, rel=1e-12)   # the file's scale on the new value
    assert plant.l == pytest.approx(0.6, rel=1e-12) and ctrl.l == pytest.approx(0.6, rel=1e-12)
    assert ctrl.Mb == pytest.approx(21.5, rel=1e-12)           # the controller model unscaled
    ST.run_file(src, tmp_path / "p", plot=False)              # without --params: the thesis robot
    assert runs[1][1].plant_params().Mb == pytest.approx(load_params().Mb * 1.1, rel=1e-12)


def test_a_path_file_runs_the_guided_mission_and_keeps_every_period(runs, tmp_path):
    src = load_scenario_file(shipped_scenarios()["path_fig8_pursuit"])
    ST.run_file(src, tmp_path / "o", plot=False)
    assert [r[0] for r in runs] == ["guided"]
    with pytest.raises(ScenarioError, match=r"^a scenario with a \[path\] keeps every period \(log_every 1\)$"):
        ST.run_file(src, tmp_path / "p", plot=False, log_every=2)
    plain = parse_scenario({"name": "plain", "duration_s": 0.1})
    ST.run_file(plain, tmp_path / "q", plot=False, log_every=2)
    assert runs[-1][0] == "mission" and runs[-1][2] == 2


def test_a_chirp_file_adds_the_bandwidth_metrics(runs, tmp_path, monkeypatch):
    monkeypatch.setattr(ST, "chirp_metrics", lambda log: {"bandwidth_hz": 1.7, "response": np.zeros(3)})
    res = ST.run_file(load_scenario_file(shipped_scenarios()["chirp"]), tmp_path / "o", plot=False)
    assert res["metrics"]["bandwidth_hz"] == 1.7 and "response" not in res["metrics"]
    ok = {r["metric"]: r["ok"] for r in res["spec"]}
    assert ok["bandwidth_hz"] is True
    res = ST.run_file(parse_scenario({"name": "still", "duration_s": 0.1}), tmp_path / "p", plot=False)
    assert "bandwidth_hz" not in res["metrics"]


def test_a_study_on_another_robot_rebases_every_run(runs, tmp_path, monkeypatch):
    real = ST.get_study
    monkeypatch.setattr(REG, "run_metrics", _upright_metrics)
    monkeypatch.setattr(ST, "get_study", lambda n: dataclasses.replace(
        real(n), metrics=lambda logs: {"runs": len(logs)}, report=None, plot=None))
    res = ST.run_study("robustness", "flc", tmp_path / "o", plot=False, params=HEAVY)
    assert res["metrics"]["runs"] == len(runs) == len(real("robustness").files) >= 2
    for _, sc, _ in runs:
        assert sc.controller_params().Mb == pytest.approx(21.5, rel=1e-12)
        assert sc.plant_params().l == pytest.approx(0.6, rel=1e-12)
    # the perturbed run's own change applies on top of the new robot, not the thesis's
    base = {sc.name: sc for _, sc, _ in runs}
    runs.clear()
    ST.run_study("robustness", "flc", tmp_path / "p", plot=False)
    for _, sc, _ in runs:
        ratio = base[sc.name].plant_params().Mb / sc.plant_params().Mb
        assert ratio == pytest.approx(21.5 / load_params().Mb, rel=1e-12)


def test_a_study_refuses_a_controller_without_its_experiment(tmp_path):
    with pytest.raises(ScenarioError, match=r"^study 'lag' runs with flc only \(a thesis experiment of "
                                            r"its FLC\), not with 'smc'$"):
        ST.run_study("lag", "smc", tmp_path / "o", plot=False)

"""``run_sil`` on a system whose plant exposes no state outputs: no metrics or plots, a
passed result with the run's facts read from the run, and the connections written
(stand-in run: no engine needed)."""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest

from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.studies import sil


def _run(scenario, signals):
    def write(path):
        path.write_text("time,plant.tau0\n0,0\n")
    return SimpleNamespace(scenario=scenario, signals=signals, master="gauss_seidel", wall_s=0.75,
                           time=np.arange(7) * 0.005, connections=[("a", "b"), ("c", "d"), ("e", "f")],
                           write_connections=write)


def test_a_plant_without_state_outputs_gives_the_connections_and_facts_only(monkeypatch, tmp_path):
    signals = {"plant.tau0": 0, "plant.x": 1, "ctrl.tau0": 2, "plant.roll": 3}  # no plant.y and the rest
    monkeypatch.setattr(sil, "run_ssp", lambda ssp, duration, master, allow_long: _run(object(), signals))
    result = sil.run_sil(tmp_path / "s.ssp", tmp_path / "out")
    assert result["passed"] is True and result["metrics"] == {}
    assert result["sil"] == {"master": "gauss_seidel", "steps": 6, "wall_s": 0.75, "connections": 3,
                             "signals": 4}
    assert result["note"].startswith("the plant FMU has no state outputs")
    assert json.loads((tmp_path / "out" / "metrics.json").read_text()) == result
    assert (tmp_path / "out" / "connections.csv").read_text().startswith("time,plant.tau0")
    assert not (tmp_path / "out" / "plot.png").exists()


def test_a_system_without_its_scenario_is_refused_naming_the_tool_that_writes_it(monkeypatch, tmp_path):
    monkeypatch.setattr(sil, "run_ssp", lambda ssp, duration, master, allow_long: _run(None, {}))
    with pytest.raises(ScenarioError, match=r"s\.ssp carries no scenario .*'ballbot fmu ssp'"):
        sil.run_sil(tmp_path / "s.ssp", tmp_path / "out")


def test_the_comparison_plot_draws_both_differences_floored_against_1e_9(saved, tmp_path):
    from _figures import assert_style, hlines, line

    time = np.arange(5) * 0.005
    diff = {"state_diff": np.array([0.0, 1e-12, 3e-10, 2e-9, 0.0]), "tau_diff": np.array([0.0, 4e-11, 5e-8, 0.0]),
            "reference": "compiled mission"}
    assert sil.plot_compare(time, diff, tmp_path / "c.png") == tmp_path / "c.png"
    ax, = saved["c.png"]
    x, y = line(ax, "max |state - mission|")
    np.testing.assert_array_equal(x, time)
    np.testing.assert_array_equal(y, [1e-18, 1e-12, 3e-10, 2e-9, 1e-18])
    x, y = line(ax, "max |tau - mission| (N m)")
    np.testing.assert_array_equal(x, time[:4])
    np.testing.assert_array_equal(y, [1e-18, 4e-11, 5e-8, 1e-18])
    assert hlines(ax) == [1e-9] and ax["yscale"] == "log"
    assert ax["title"] == "SIL vs compiled mission" and ax["xlabel"] == "time (s)"
    assert_style(saved, "c.png")

"""The metric list that [[spec]] rows are checked against equals what runs report, and a
misspelled metric is refused before simulating (one line, exit 2)."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi import cli
from ballbot_casadi.analysis.bandwidth import chirp_metrics
from ballbot_casadi.analysis.metric_names import METRIC_NAMES, check_spec_metrics
from ballbot_casadi.analysis.metrics import run_metrics
from ballbot_casadi.errors import ScenarioFileError
from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario
from ballbot_casadi.sim.scenario import load_scenario_file
from ballbot_casadi.studies import montecarlo_report as study_mc
from ballbot_casadi.studies import study as study_mod
from ballbot_casadi.studies.registry import shipped_scenarios


def test_every_shipped_spec_metric_is_known():
    for name, path in shipped_scenarios().items():
        check_spec_metrics(load_scenario_file(path).specs, name)


@pytest.mark.parametrize("name", ["zero", "full_sine", "com_observer", "chirp", "push", "velocity"])
def test_every_metric_a_run_reports_is_known(name):
    sc = load_scenario_file(shipped_scenarios()[name]).scenario
    d = min(sc.duration, 1.5)
    sc = sc.replace(duration=d, pushes=tuple(p for p in sc.pushes if p[0] < d))
    with np.errstate(all="ignore"):
        log = run_scenario(sc, ClosedLoop())
        keys = set(run_metrics(log)) | (set(chirp_metrics(log)) if name == "chirp" else set())
    assert keys <= METRIC_NAMES, keys - METRIC_NAMES


def test_a_misspelled_metric_is_refused_with_suggestions():
    with pytest.raises(ScenarioFileError, match=r"key 'spec\[1\].metric': unknown metric "
                                                r"'max_tilt_dg'; did you mean max_tilt_deg"):
        check_spec_metrics([{"metric": "finite"}, {"metric": "max_tilt_dg"}], "f.toml")


def _never(*_a, **_k):
    pytest.fail("simulated before checking the spec metrics")


@pytest.mark.parametrize("command", ["simulate", "montecarlo"])
def test_cli_refuses_a_misspelled_metric_before_simulating(tmp_path, capsys, monkeypatch, command):
    monkeypatch.setattr(study_mod, "run_scenario", _never)
    monkeypatch.setattr(study_mc, "execute", _never)
    scen = tmp_path / "typo.toml"
    scen.write_text("duration_s = 1\n[[spec]]\nmetric = 'peak_tilt_dg'\nop = '<'\nthreshold = 5\n")
    argv = [command, str(scen), "--out", str(tmp_path / "o")] + (
        ["--n", "2", "--workers", "0"] if command == "montecarlo" else [])
    assert cli.main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith(f"ballbot {command}: error:"), err
    assert "unknown metric 'peak_tilt_dg'" in err and "peak_tilt_deg" in err

"""The SIL comparison and the Monte Carlo run evaluation on stand-ins (issue 23, test
strength): which compiled mission each master is compared with (Jacobi: one period of
actuation delay), over the periods the run covers, the largest differences per signal;
one run's verdict from its specs, a fall or NaN, and an error."""

from __future__ import annotations

from dataclasses import dataclass, replace
from types import SimpleNamespace

import numpy as np
import pytest

from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.studies import montecarlo_runner as MR
from ballbot_casadi.studies import sil as SIL


@dataclass(frozen=True)
class _Sc:
    duration: float = 1.0
    Ts: float = 0.005

    @property
    def n_periods(self):
        return int(round(self.duration / self.Ts))

    @property
    def route(self):
        return SimpleNamespace(build=lambda: None)

    def replace(self, **kw):
        return replace(self, **kw)


def _arrays(n, shift=0.0):
    return {"state": np.zeros((n + 1, 12)) + shift, "tau": np.zeros((n, 3)), "tau_cmd": np.zeros((n, 3)),
            "x_hat": np.zeros((n, 12))}


@pytest.mark.parametrize("master, delay", [("libcosim", True), ("gauss-seidel", False)])
def test_each_master_against_its_mission(monkeypatch, master, delay):
    seen = []
    ref = _arrays(4)

    def run(sc, sim, actuation_delay):
        seen.append((sc.duration, actuation_delay))
        return SimpleNamespace(arrays=ref)

    monkeypatch.setattr(SIL, "run_scenario", run)
    monkeypatch.setattr(SIL, "ClosedLoop", lambda: None)
    log = _arrays(4)
    log["state"][2, 5] = -0.25
    log["state"][3, 0] = 0.1
    log["tau"][1] = [0.0, 0.3, -0.5]
    log["tau_cmd"][0, 2] = 0.7
    log["x_hat"][3, 7] = -0.9
    d = SIL.mission_difference(SimpleNamespace(scenario=_Sc(), master=master), log)
    assert seen == [(4 * 0.005, delay)]                       # the 4 periods the run covers
    assert d["reference"] == ("compiled mission with one period of actuation delay (Jacobi)" if delay
                              else "compiled mission")
    assert (d["state_max"], d["tau_max"], d["tau_cmd_max"], d["x_hat_max"]) == (0.25, 0.5, 0.7, 0.9)
    np.testing.assert_array_equal(d["state_diff"], [0, 0, 0.25, 0.1, 0])
    np.testing.assert_array_equal(d["tau_diff"], [0, 0.5, 0, 0])


def test_no_scenario_no_comparison():
    with pytest.raises(ScenarioError, match="carries no scenario"):
        SIL.mission_difference(SimpleNamespace(scenario=None, master="libcosim"), _arrays(2))


def test_a_run_is_judged_by_its_specs_its_fall_and_its_error(monkeypatch):
    monkeypatch.setattr(MR, "parse_scenario", lambda table, where: SimpleNamespace(
        scenario=SimpleNamespace(path=None, name=table["name"])))
    monkeypatch.setattr(MR, "run_scenario", lambda sc, sim: sc.name)
    metrics = {"good": {"a": 1.0, "b": np.float64(2.5), "finite": True, "n": 3, "s": "x", "v": [1]},
               "bad": {"a": 3.0, "b": 2.5, "finite": True}, "fell": {"a": 1.0, "b": 2.5, "finite": False}}
    monkeypatch.setattr(MR, "run_metrics", lambda log: metrics[log])
    specs = [{"metric": "a", "op": "<=", "threshold": 2.0}, {"metric": "b", "op": ">", "threshold": 2.0}]
    good = MR.evaluate_run({"name": "good"}, specs, sim=object())
    assert good == {"ok": True, "spec_ok": [True, True], "metrics": {"a": 1.0, "b": 2.5, "finite": True, "n": 3.0},
                    "error": None, "failure": None}
    assert type(good["metrics"]["b"]) is float and good["metrics"]["finite"] is True
    bad = MR.evaluate_run({"name": "bad"}, specs, sim=object())
    assert (bad["ok"], bad["spec_ok"], bad["failure"]) == (False, [False, True], None)
    fell = MR.evaluate_run({"name": "fell"}, specs, sim=object())
    assert fell["ok"] is False and fell["spec_ok"] == [True, True] and fell["failure"]

    def refuse(table, where):
        raise ScenarioError("run x: bad key")

    monkeypatch.setattr(MR, "parse_scenario", refuse)
    err = MR.evaluate_run({"name": "e"}, specs, sim=object())
    assert err == {"ok": False, "spec_ok": [False, False], "metrics": {}, "error": "run x: bad key", "failure": None}

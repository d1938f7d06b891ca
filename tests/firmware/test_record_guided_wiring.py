"""record_guided_log's wiring, with the mission run and the firmware Function replaced by
recorders (the slow tests run them for real): the scenario it runs (duration of
n periods, seed, estimator, guidance), the latency given to the mission's law and to the
split interrupt step's law, and the log's rows taken from the run."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from ballbot_casadi.core.constants import TS_CONTROL
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.firmware import replay as R
from ballbot_casadi.sim.embedded import DEFAULT_ESTIMATOR
from ballbot_casadi.guidance.paths import line_path


@pytest.fixture()
def recorded(monkeypatch):
    calls: dict = {"law": []}

    def law(sc, latency, split=False):
        calls["law"].append((latency, split))
        return SimpleNamespace(latency=latency, split=split)

    def run_guided(path, law_, duration, scenario):
        calls["run"] = (path, law_, duration, scenario)
        n = int(round(duration / TS_CONTROL))
        return {"meas": np.arange(n * 9.0).reshape(n, 9), "tau": np.ones((n, 3)),
                "v_ref_used": np.full((n, 3), 2.0)}

    def firmware_function(controller, estimator, guidance=None, latency=0):
        calls["f"] = (controller, estimator, guidance, latency)
        return "f"

    def scenario_values(f, sc, law_, path):
        calls["values"] = (f, law_, path)
        return "values"

    monkeypatch.setattr(R, "scenario_law", law)
    monkeypatch.setattr(R, "run_guided", run_guided)
    monkeypatch.setattr(R, "firmware_function", firmware_function)
    monkeypatch.setattr(R, "scenario_values", scenario_values)
    return calls


@pytest.mark.parametrize("latency", [0, 3])
def test_the_run_and_the_laws(recorded, latency):
    path = line_path((0.0, 0.0), (2.0, 0.0), 0.5)
    rec = R.record_guided_log(7, seed=11, path=path, latency=latency)
    p, law, duration, sc = recorded["run"]
    assert p is path and duration == pytest.approx(7 * TS_CONTROL, rel=1e-12)
    assert sc.duration == pytest.approx(7 * TS_CONTROL, rel=1e-12)
    assert (sc.seed, sc.estimator, sc.guidance) == (11, DEFAULT_ESTIMATOR, "mpc")
    assert (law.latency, law.split) == (latency, False)  # the mission runs the whole law
    assert recorded["f"] == (sc.controller, DEFAULT_ESTIMATOR, "mpc", latency)
    fw_law = recorded["values"][1]
    assert (fw_law.latency, fw_law.split) == ((latency, True) if latency else (0, False))
    assert recorded["values"][2] is path
    assert rec.n == 7 and rec.values == "values"
    np.testing.assert_array_equal(rec.meas, np.arange(63.0).reshape(7, 9))
    np.testing.assert_array_equal(rec.tau_mission, np.ones((7, 3)))
    np.testing.assert_array_equal(rec.v_ref_mission, np.full((7, 3), 2.0))
    assert rec.refs.shape[1] == 15 and rec.balance_only == (not sc.cascade)


@pytest.mark.parametrize("bad", [0, -1, 2.0, "5"])
def test_bad_period_counts_refused(bad):
    with pytest.raises(ScenarioError, match="n_periods must be an int >= 1"):
        R.record_guided_log(bad)


def test_one_period_is_the_shortest_recording(recorded):
    rec = R.record_guided_log(1, path=line_path((0.0, 0.0), (2.0, 0.0), 0.5))
    assert rec.n == 1 and recorded["run"][2] == pytest.approx(TS_CONTROL, rel=1e-12)
    np.testing.assert_array_equal(rec.meas, np.arange(9.0).reshape(1, 9))

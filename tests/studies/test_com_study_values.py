"""The ``com`` study's bookkeeping on hand-built runs (issue 23, test strength): the run-away
of the balance-only run from its last state, each run's metrics under its own prefix
(standing keys for standing runs, velocity keys for the velocity profile), the shipped over
the thesis's velocity ratio, the thesis-filter twin's place, and the side-by-side table."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from ballbot_casadi.studies import com as C

KEYS = (*C._STANDING, *C._VELOCITY, "peak_tilt_deg", "estimator_velocity_rms_mps", "nis_velocity_mean",
        "estimator_only_key")


def _metrics(i: int) -> dict:
    m = {k: 100.0 * (i + 1) + j for j, k in enumerate(KEYS)}
    m["finite"] = True
    return m


def _log(name: str, i: int, velocity: bool = False, com_hat: bool = True):
    x = np.zeros((3, 12))
    x[-1, [0, 1, 6, 7]] = [3.0, -4.0, 0.6, -0.8]   # x, y, dx, dy at the end
    x[0, [0, 1, 6, 7]] = [9.0, 9.0, 9.0, 9.0]
    arrays = {"state": x, **({"com_hat": np.zeros((2, 2))} if com_hat else {})}
    sc = {"name": name, **({"velocity_keyframes": [[0, 0, 0]]} if velocity else {})}
    return SimpleNamespace(scenario=sc, arrays=arrays, i=i)


@pytest.fixture()
def metrics(monkeypatch):
    monkeypatch.setattr(C, "run_metrics", lambda log: _metrics(log.i))
    monkeypatch.setattr(C, "com_observer_metrics", lambda log: {"observer_of": log.scenario["name"]})
    logs = [_log("com_balance_only", 0), _log("com", 1), _log("com_observer_true", 2),
            _log("com_ukf", 3), _log("com_observer_velocity", 4, velocity=True),
            _log("com_observer_centred", 5), _log("extra", 6, com_hat=False),
            _log(C.THESIS_RUN, 7), _log("com_observer", 8)]
    return C.com_study_metrics(logs)


def test_the_runaway_is_the_balance_only_runs_last_speed_and_distance(metrics):
    assert metrics["runaway_speed_mps"] == pytest.approx(1.0, rel=1e-15)      # hypot(0.6, -0.8)
    assert metrics["runaway_distance_m"] == pytest.approx(5.0, rel=1e-15)     # hypot(3, -4)
    assert "com_balance_only" not in metrics["by_run"]


def test_each_runs_metrics_under_its_prefix(metrics):
    for name, i in (("com", 1), ("com_observer_true", 2), ("com_ukf", 3), ("com_observer_centred", 5),
                    (C.THESIS_RUN, 7)):
        prefix = C.RUN_PREFIX[name]
        for k in C._STANDING:
            assert metrics[prefix + k] == _metrics(i)[k], (name, k)
        assert prefix + "max_abs_roll_pitch_deg" not in metrics
    pv = C.RUN_PREFIX["com_observer_velocity"]
    assert pv == "observer_velocity_"
    for k in C._VELOCITY:
        assert metrics[pv + k] == _metrics(4)[k], k
    assert pv + "final_position_error_m" not in metrics
    # the main run: by_run only (its standing metrics are the study's own, from run_study)
    assert metrics["by_run"]["com_observer"] == {**_metrics(8), "observer_of": "com_observer"}
    assert not any(k.startswith("extra") for k in metrics)
    assert metrics["by_run"]["extra"] == _metrics(6)   # no com_hat: no observer metrics


def test_the_prefixes_and_the_thesis_run(metrics):
    assert C.RUN_PREFIX == {"com": "no_observer_", "com_observer_true": "observer_true_",
                            "com_ukf": "no_observer_ukf_", "com_observer_velocity": "observer_velocity_",
                            "com_observer_centred": "observer_centred_",
                            "com_observer_ukf": "observer_thesis_filter_"}
    assert C.THESIS_RUN == "com_observer_ukf"
    assert metrics["shipped_vs_thesis_velocity_rms_ratio"] == pytest.approx(
        _metrics(8)["estimator_velocity_rms_mps"] / _metrics(7)["estimator_velocity_rms_mps"], rel=1e-15)


def test_no_ratio_without_the_thesis_twin_or_with_a_zero_denominator(monkeypatch):
    monkeypatch.setattr(C, "com_observer_metrics", lambda log: {})
    monkeypatch.setattr(C, "run_metrics", lambda log: _metrics(log.i))
    assert "shipped_vs_thesis_velocity_rms_ratio" not in C.com_study_metrics([_log("com_observer", 1)])
    zero = _metrics(2)
    zero["estimator_velocity_rms_mps"] = 0.0
    monkeypatch.setattr(C, "run_metrics", lambda log: zero if log.i == 2 else _metrics(log.i))
    out = C.com_study_metrics([_log(C.THESIS_RUN, 2), _log("com_observer", 1)])
    assert "shipped_vs_thesis_velocity_rms_ratio" not in out


def test_a_fallen_run_gets_no_observer_metrics(monkeypatch):
    fallen = {**_metrics(1), "finite": False}
    monkeypatch.setattr(C, "run_metrics", lambda log: dict(fallen))
    monkeypatch.setattr(C, "com_observer_metrics", lambda log: {"observer_of": "x"})
    out = C.com_study_metrics([_log("com", 1)])
    assert "observer_of" not in out["by_run"]["com"]


def test_the_thesis_twin_is_the_main_run_with_the_thesis_filters_just_before_it():
    tables = [{"name": "a"}, {"name": "b", "estimator": "ukf_adaptive", "seed": 3}]
    out = C.thesis_filter_expand(tables)
    assert [t["name"] for t in out] == ["a", C.THESIS_RUN, "b"]
    assert out[1] == {"name": C.THESIS_RUN, "estimator": "ukf", "seed": 3} and out[2] == tables[1]


def test_the_side_by_side_table_leaves_out_the_velocity_run():
    runs = {"com": {"final_position_error_m": 1.29518, "peak_tilt_deg": 2}, "com_observer_velocity": {},
            "com_observer": {"nis_velocity_mean": 5.5}}
    lines = C.com_report_lines({"by_run": runs})
    assert lines[2] == "| metric | `com` | `com_observer` |" and lines[3] == "| --- | --- | --- |"
    assert "| `final_position_error_m` | 1.295 | — |" in lines
    assert "| `peak_tilt_deg` | 2 | — |" in lines
    assert "| `nis_velocity_mean` | — | 5.5 |" in lines
    rows = [ln for ln in lines if ln.startswith("| `")]
    assert [r.split("`")[1] for r in rows] == list(C._TABLE)
    assert math.isclose(len(C._TABLE), 10)

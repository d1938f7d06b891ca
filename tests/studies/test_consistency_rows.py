"""The consistency study's rows on stand-in runs (issue 23, test strength): which run (the
file's own, the shipped, the thesis's, the matched filter's) each row is measured on, the
1 s transient skipped, the verdicts' aggregation, and what ``metrics.json`` says.

``run_scenario`` is replaced by a stand-in whose NIS is a constant that names the filter
(attitude 6 everywhere; velocity 6 for the shipped, 40 for the thesis's, 3 for the matched
filter's), so a row taken from the wrong run reads a wrong mean and a wrong verdict."""

from __future__ import annotations

import json
from dataclasses import dataclass, replace

import numpy as np
import pytest

from ballbot_casadi.studies import consistency as C

VEL_NIS = {C.ADAPTIVE: 6.0, C.THESIS_ESTIMATOR: 40.0, C.MATCHED: 3.0, "ekf": 6.0}
VEL_RMS = {C.ADAPTIVE: 0.001, C.THESIS_ESTIMATOR: 0.004, C.MATCHED: 0.002, "ekf": 0.003}
N = 600  # periods of 5 ms: 3 s, the first 200 (1 s) skipped


@dataclass(frozen=True)
class _Sc:
    estimator: str
    duration: float = 3.0
    Ts: float = 0.005

    def replace(self, **kw):
        return replace(self, **kw)


@pytest.fixture()
def study(monkeypatch, tmp_path):
    files = {"a_shipped": C.ADAPTIVE, "b_thesis": C.THESIS_ESTIMATOR, "c_ekf": "ekf"}
    ran = []

    def run(sc, sim):
        ran.append((sc.estimator, sc.duration))
        nis = np.full((N, 2), 6.0)
        nis[:, 1] = VEL_NIS[sc.estimator]
        nis[:200, :] = 1e6  # the transient: left out of every mean
        return {"nis": nis, "time": np.arange(N + 1) * sc.Ts, "estimator": sc.estimator,
                "state": np.zeros((N + 1, 12))}

    monkeypatch.setattr(C, "shipped_scenarios", lambda: {n: n for n in files})
    monkeypatch.setattr(C, "load_scenario_file", lambda p: type("F", (), {"scenario": _Sc(files[p])}))
    monkeypatch.setattr(C, "run_scenario", run)
    monkeypatch.setattr(C, "estimation_metrics",
                        lambda log: {"estimator_velocity_rms_mps": VEL_RMS[log["estimator"]]})
    monkeypatch.setattr(C, "final_walk", lambda log, est: [0.01 if log["estimator"] == est else -1.0, 0.02])
    monkeypatch.setattr(C, "acceleration_random_walk",
                        lambda log, Ts: (0.5 if log["estimator"] == C.ADAPTIVE else -1.0, Ts))
    monkeypatch.setattr(C, "_acc_process_var", lambda sc: [{C.THESIS_ESTIMATOR: 1e-5, C.MATCHED: 0.05}[sc.estimator]])
    m = C.run_consistency_study(tmp_path, plot=False, names=list(files), duration=2.0)
    return m, ran, tmp_path


def test_each_row_is_measured_on_its_own_filters_run(study):
    m, ran, _ = study
    rows = m["scenarios"]
    a, b, c = rows["a_shipped"], rows["b_thesis"], rows["c_ekf"]
    # the shipped file: its own run is the "velocity" row, the thesis's and the matched beside
    assert a["velocity"]["mean_nis"] == pytest.approx(6.0) and a["velocity"]["velocity_rms_mps"] == 0.001
    assert a["velocity"]["acc_process_var"] == [0.01, 0.02]           # the adaptive run's final walk
    assert a["velocity"]["acc_walk_truth"] == [0.5, 0.005]            # ... and its truth, Ts = 5 ms
    assert a["velocity_thesis"]["mean_nis"] == pytest.approx(40.0)
    assert a["velocity_thesis"]["velocity_rms_mps"] == 0.004 and a["velocity_thesis"]["acc_process_var"] == [1e-5]
    assert a["velocity_matched"]["mean_nis"] == pytest.approx(3.0)
    assert a["velocity_matched"]["acc_process_var"] == [0.05]
    assert "velocity_adaptive" not in a
    # the thesis's file: its own run is "velocity", the shipped filter's run "velocity_adaptive"
    assert b["velocity"]["mean_nis"] == pytest.approx(40.0) and b["velocity"]["velocity_rms_mps"] == 0.004
    assert b["velocity_adaptive"]["mean_nis"] == pytest.approx(6.0)
    assert b["velocity_adaptive"]["acc_process_var"] == [0.01, 0.02]
    assert "velocity_thesis" not in b and b["velocity_matched"]["mean_nis"] == pytest.approx(3.0)
    # an EKF file: its own rows only
    assert set(c) == {"attitude", "velocity"} and c["velocity"]["velocity_rms_mps"] == 0.003
    for r in rows.values():
        assert r["attitude"]["mean_nis"] == pytest.approx(6.0) and r["attitude"]["n"] == N - 200
    # the runs: each file once, the shipped file's thesis and matched twins, the thesis
    # file's shipped and matched twins; every one shortened to 2 s
    assert sorted(ran) == sorted([(C.ADAPTIVE, 2.0), (C.THESIS_ESTIMATOR, 2.0), (C.MATCHED, 2.0),
                                  (C.THESIS_ESTIMATOR, 2.0), (C.ADAPTIVE, 2.0), (C.MATCHED, 2.0), ("ekf", 2.0)])


def test_the_verdicts_and_the_written_metrics(study):
    m, _, out = study
    assert m["scenarios"]["a_shipped"]["velocity"]["verdict"] == "consistent"
    assert m["scenarios"]["a_shipped"]["velocity_thesis"]["verdict"] != "consistent"
    assert m["scenarios"]["b_thesis"]["velocity"]["verdict"] != "consistent"
    assert m["passed"] is False                 # the thesis's file's own velocity filter
    assert m["adaptive_passed"] is True         # the shipped filter on both files
    assert m["thesis_passed"] is False and m["matched_passed"] is False
    assert (m["dim"], m["confidence"], m["skip_s"]) == (6, 0.95, 1.0)
    assert json.loads((out / "metrics.json").read_text()) == json.loads(json.dumps(m))
    assert (out / "report.md").read_text() == "\n".join(C.consistency_report_lines(m)) + "\n"

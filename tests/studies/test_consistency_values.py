"""The consistency study's helpers against hand-built inputs: the acceleration random walk
measured from a truth whose acceleration walks with known, different steps per axis, the
adapted walk read from a final controller state, the scenario selection, and the report
read back."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.control.velocity import VELOCITY_NZ
from ballbot_casadi.core.layout import STATE
from ballbot_casadi.sim.embedded import controller_layout
from ballbot_casadi.sim.scenario import load_scenario_file
from ballbot_casadi.studies import consistency as C
from ballbot_casadi.studies.registry import shipped_scenarios


def test_acceleration_random_walk_per_axis_from_the_velocity():
    """v integrates an acceleration whose per-period change is +-0.1 on x and +-0.3 on y
    (alternating signs: variance 0.01 and 0.09 exactly); Ts = 5 ms."""
    Ts, n = 0.005, 402
    steps = np.where(np.arange(n) % 2 == 0, 1.0, -1.0)
    a = np.stack([0.2 + 0.1 * np.cumsum(steps), -0.5 + 0.3 * np.cumsum(steps)], axis=1)
    v = np.vstack([[0.3, -0.1], [0.3, -0.1] + Ts * np.cumsum(a[:-1], axis=0)])
    x = np.zeros((n, STATE.size))
    x[:, STATE["dx"]] = v[:, :1]
    x[:, STATE["dy"]] = v[:, 1:]
    qx, qy = C.acceleration_random_walk({"state": x}, Ts)
    assert qx == pytest.approx(0.01, rel=1e-6) and qy == pytest.approx(0.09, rel=1e-6)


def test_final_walk_reads_the_walk_field_of_the_final_controller_state():
    L = controller_layout(C.ADAPTIVE, VELOCITY_NZ)
    c = np.arange(L.size, dtype=float) * 1e-3
    walk = np.asarray(c[L["walk"]], float)
    assert C.final_walk({"c_final": c.reshape(-1, 1)}, C.ADAPTIVE) == pytest.approx(walk[:2].tolist())
    assert walk[0] != walk[1]


def test_estimator_scenarios_are_the_estimating_ones_without_a_path():
    names = C.estimator_scenarios()
    files = shipped_scenarios()
    assert "full_sine" in names
    for n, p in files.items():
        sc = load_scenario_file(p).scenario
        assert (n in names) == (sc.estimator != "true" and not sc.path), n


def test_report_reads_back_each_row():
    m = {"dim": 6, "confidence": 0.95, "skip_s": 1.0, "adaptive_passed": True,
         "scenarios": {"full_sine": {
             "attitude": {"mean_nis": 6.012, "band": [5.89, 6.11], "n": 3800,
                          "verdict": "consistent"},
             "velocity_adaptive": {"mean_nis": 5.92, "band": [5.89, 6.11], "n": 3800,
                                   "verdict": "consistent", "velocity_rms_mps": 0.00142,
                                   "acc_process_var": [0.0098, 0.0112],
                                   "acc_walk_truth": [0.0103, 0.0129]}}}}
    lines = C.consistency_report_lines(m)
    assert "| full_sine | attitude | 6.01 | [5.89, 6.11] | consistent |  |  |  |" in lines
    assert ("| full_sine | velocity_adaptive | 5.92 | [5.89, 6.11] | consistent | 1.42 mm/s | "
            "0.0098/0.0112 | 0.0103/0.0129 |") in lines
    text = "\n".join(lines)
    assert "after a 1.0 s transient" in text and "95% chi2 band" in text
    assert "(`adaptive_passed`: passed)" in text
    assert "(`adaptive_passed`: NOT passed)" in "\n".join(C.consistency_report_lines(
        {**m, "adaptive_passed": False}))

"""The prediction-model study's own runs, short: a variant's predictor against the closed loop
after a velocity step (small step: the linear design model is exact; large step: the velocity
controller's clip, which only the nonlinear model has), a 3 s run of the shipped variant, the
decision at its boundaries and the step table read back from the report."""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

from ballbot_casadi.core.constants import THESIS_LIMITS
from ballbot_casadi.guidance.mpc import MpcConfig
from ballbot_casadi.sim.scenario.file import load_scenario_file
from ballbot_casadi.studies import mpc_models as MM
from ballbot_casadi.studies.registry import shipped_scenarios

pytestmark = pytest.mark.needs_cc


@functools.lru_cache(maxsize=None)
def _course():
    return load_scenario_file(shipped_scenarios()["path_fig8_mpc"]).scenario


@functools.lru_cache(maxsize=None)
def _shipped():
    sc = _course()
    inp = sc.inputs(periods=(0, MM.HORIZON_SAMPLES * MM._EVERY))
    variant = next(v for v in MM.MPC_MODEL_VARIANTS if v.name == "shipped")
    return inp, variant.build(inp, sc.route.build(), MpcConfig())


def test_the_shipped_predictor_from_rest_moves_back_first_then_along_the_step():
    """From rest, a held v_ref = (0.1, 0) m/s for 2 s (20 samples): the positions at the
    21 nodes start at the robot's, the ball first rolls back (the robot leans forward by
    rolling the ball backwards, a non-minimum-phase start), then forward, short of the 0.2 m
    an instant step would reach; nothing moves sideways."""
    _, (_, predict, qp_size) = _shipped()
    X0 = np.zeros(14)
    X0[12:14] = [1.0, -2.0]
    p = predict(X0, np.tile([0.1, 0.0], (MM.HORIZON_SAMPLES, 1)))
    assert p.shape == (MM.HORIZON_SAMPLES + 1, 2)
    np.testing.assert_allclose(p[0], [1.0, -2.0], rtol=0, atol=1e-12)
    assert p[1, 0] < 1.0 and 1.1 < p[-1, 0] < 1.2
    np.testing.assert_allclose(p[:, 1], -2.0, rtol=0, atol=1e-9)
    # at rest with zero references the prediction stays put
    np.testing.assert_allclose(predict(X0, np.zeros((MM.HORIZON_SAMPLES, 2))), np.tile(X0[12:14], (21, 1)),
                               rtol=0, atol=1e-12)
    assert qp_size == {"variables": 30, "rows": 310}  # the condensed QP (N = 20)


def test_step_prediction_error_small_step_exact_large_step_clipped():
    """Against the compiled closed loop: 0.1 m/s keeps every limit of the velocity
    controller inactive, so the linear design model predicts the 2 s to under a
    millimetre (measured 0.40 mm); at 0.4 m/s its tilt-acceleration clip acts, which the
    linear model does not have (measured 2.6 cm)."""
    inp, (_, predict, _) = _shipped()
    small = MM.step_prediction_error(inp, predict, 0.1)
    large = MM.step_prediction_error(inp, predict, 0.4)
    assert 0.0 < small < 1e-3 and large > 30 * small
    assert 0.01 < large < 0.05


def test_a_short_run_of_the_shipped_variant():
    """3 s of the figure-eight (of 27 s): not completed, no obstacles (clearance inf), on the
    path within millimetres, inside the §7.1 limits, and the row's bookkeeping."""
    sc = _course().replace(duration=3.0)
    row = MM.run_variant(MM.MPC_MODEL_VARIANTS[0], sc)
    assert set(row) == set(MM.VARIANT_METRICS)
    assert row["completed"] == 0.0 and row["min_clearance_m"] == math.inf
    assert 0.0 < row["lateral_rms_cm"] <= row["lateral_max_cm"] < 0.5
    assert 0.5 < row["peak_tilt_deg"] < math.degrees(THESIS_LIMITS["tilt_max"])
    assert 0.0 < row["peak_torque_nm"] <= sc.plant_params().tau_max
    # 30 samples, 10 of them with a full 2 s horizon left: the model predicts them to < 2 mm
    assert 0.0 < row["pred_err_2s_rms_cm"] <= row["pred_err_2s_max_cm"] < 0.2
    assert 0.0 < row["step_ms_median"] <= row["step_ms_p99"]
    assert row["failures"] == 0.0
    assert row["qp_variables"] == 30.0 and row["qp_rows"] == 310.0


def _metrics(**over: float) -> dict:
    tilt, rate = math.degrees(THESIS_LIMITS["tilt_max"]), math.degrees(THESIS_LIMITS["tilt_rate_max"])
    m = {}
    for c in MM.COURSES:
        for v in ("shipped", "full", "nmpc"):
            m.update({f"{c}_{v}_lateral_rms_cm": 1.0, f"{c}_{v}_peak_tilt_deg": tilt,
                      f"{c}_{v}_peak_tilt_rate_deg_s": rate, f"{c}_{v}_completed": 1.0,
                      f"{c}_{v}_min_clearance_m": 0.15})
    m.update(over)
    return m


def test_decision_at_its_boundaries():
    """Exactly at the §7.1 limits is inside; exactly the margin (0.9 x) is better; zero
    clearance is a collision; the better of two is the one with the smaller figure-eight RMS;
    a missing metric does not make a variant better."""
    both = {f"{c}_{v}_lateral_rms_cm": 0.9 for c in MM.COURSES for v in ("full", "nmpc")}
    assert MM.decide(_metrics(**{**both, "fig8_nmpc_lateral_rms_cm": 0.5}))[0] == "nmpc"
    assert MM.decide(_metrics(**{**both, "fig8_full_lateral_rms_cm": 0.5}))[0] == "full"
    only_full = {f"{c}_full_lateral_rms_cm": 0.9 for c in MM.COURSES}
    assert MM.decide(_metrics(**only_full))[0] == "full"
    assert MM.decide(_metrics(**{**only_full, "obstacles_full_lateral_rms_cm": 0.9001}))[0] == "shipped"
    assert MM.decide(_metrics(**only_full, fig8_full_min_clearance_m=0.0))[0] == "shipped"
    assert MM.decide(_metrics(**only_full, fig8_full_peak_tilt_deg=5.0001))[0] == "shipped"
    assert MM.decide(_metrics(**only_full, obstacles_full_peak_tilt_rate_deg_s=20.001))[0] == "shipped"
    assert MM.decide(_metrics(**only_full, obstacles_full_completed=0.0))[0] == "shipped"
    m = _metrics(**only_full)
    del m["obstacles_full_peak_tilt_deg"]
    assert MM.decide(m)[0] == "shipped"
    name, reason = MM.decide(_metrics())
    assert name == "shipped" and "10 %" in reason


def test_report_reads_back_the_step_table_and_the_decision():
    m = _metrics(**{f"{c}_full_lateral_rms_cm": 0.9 for c in MM.COURSES})
    m.update({"step0.1_shipped_pred_err_max_cm": 0.0396, "step0.4_shipped_pred_err_max_cm": 2.648,
              "step0.1_nmpc_pred_err_max_cm": 0.00705, "step0.4_nmpc_pred_err_max_cm": 0.0674})
    lines = MM.mpc_models_report_lines(m)
    assert "| model | step 0.1 m/s | step 0.4 m/s |" in lines
    assert "| --- | --- | --- |" in lines
    assert "| shipped | 0.040 | 2.648 |" in lines
    assert "| nmpc | 0.007 | 0.067 |" in lines and "| full | — | — |" in lines
    assert any(line.startswith("**Decision (from the numbers below): `full`**") for line in lines)
    head = next(line for line in lines if line.startswith("| course | model |"))
    sep = lines[lines.index(head) + 1]
    assert sep.count("---") == len(MM.VARIANT_METRICS) + 2 == head.count("|") - 1
    rows = [line for line in lines if line.startswith(("| obstacles |", "| fig8 |"))]
    assert [r.split(" | ")[:2] for r in rows] == [[f"| {c}", v.name] for c in MM.COURSES
                                                   for v in MM.MPC_MODEL_VARIANTS]
    fig8_full = next(r for r in rows if r.startswith("| fig8 | full |"))
    assert fig8_full.split(" | ")[2:5] == ["0.90", "—", "0.150"]

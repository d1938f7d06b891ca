"""The prediction-model comparison's variant table and its row, computed by hand."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from ballbot_casadi.core.layout import STATE
from ballbot_casadi.studies import mpc_models as MM
from ballbot_casadi.studies.registry import STUDIES


def test_variant_table_is_defined_once_with_the_shipped_default_first() -> None:
    names = [v.name for v in MM.MPC_MODEL_VARIANTS]
    assert names[0] == "shipped" and len(set(names)) == len(names)
    assert {"full", "nmpc"} <= set(names)
    assert all(callable(v.build) and v.description for v in MM.MPC_MODEL_VARIANTS)
    units = ("_cm", "_m", "_deg", "_deg_s", "_nm", "_ms_median", "_ms_p99")
    counts = ("completed", "qp_variables", "qp_rows", "failures")
    assert all(k.endswith(units) or k in counts for k in MM.VARIANT_METRICS)
    study = STUDIES["mpc_models"]
    assert study.files == ("path_obstacles_mpc", "path_fig8_mpc")
    lines = MM.mpc_models_report_lines({"fig8_shipped_lateral_rms_cm": 1.234})
    row = next(line for line in lines if line.startswith("| fig8 | shipped |"))
    assert "| 1.23 |" in row and row.count("|") == len(MM.VARIANT_METRICS) + 3


def _tiny_log():
    """4 s on a 2 m line at 0.5 m/s, 1 cm to the left of it, upright, 0.5 N m commanded."""
    n = 801
    t = np.arange(n) * 0.005
    x = np.zeros((n, STATE.size))
    x[:, STATE["x"]] = (0.5 * t)[:, None]
    x[:, STATE["y"]] = 0.01
    x[:, STATE["dx"]] = 0.5
    x[:, STATE["q"].start] = 1.0
    log = {"time": t, "state": x, "z": np.zeros((n, 8)),
           "tau_cmd": np.tile([0.5, -0.25, 0.0], (n - 1, 1)),
           "q_ref": np.tile([1.0, 0, 0, 0], (n - 1, 1)), "dq_ref": np.zeros((n - 1, 4))}
    scenario = {"path": {"type": "line", "start": [0.0, 0.0], "end": [2.0, 0.0], "speed": 0.5},
                "obstacles": [[1.0, 0.31, 0.1]]}
    return scenario, log


def test_a_row_by_hand() -> None:
    scenario, log = _tiny_log()
    v_ref = np.tile([0.5, 0.0], (40, 1))
    step_s = np.linspace(0.001, 0.040, 40)  # 1 .. 40 ms
    stay = lambda X0, v: np.tile(X0[12:14], (len(v) + 1, 1))  # noqa: E731 - predicts no motion
    row = MM.variant_metrics(scenario, log, 2.0, v_ref, step_s, stay,
                             {"variables": 30, "rows": 530}, 3)
    assert set(row) == set(MM.VARIANT_METRICS)
    hand = {"lateral_rms_cm": 1.0, "lateral_max_cm": 1.0,
            "min_clearance_m": 0.31 - 0.01 - 0.1,  # the obstacle 0.30 m beside the trace
            "completed": 1.0, "peak_tilt_deg": 0.0, "peak_tilt_rate_deg_s": 0.0,
            "peak_torque_nm": 0.5,
            "pred_err_2s_rms_cm": 100.0, "pred_err_2s_max_cm": 100.0,  # 2 s at 0.5 m/s
            "step_ms_median": 20.5, "step_ms_p99": 39.61,
            "qp_variables": 30.0, "qp_rows": 530.0, "failures": 3.0}
    for k, v in hand.items():
        assert row[k] == pytest.approx(v, rel=1e-9, abs=1e-9), k


def test_prediction_errors_use_the_applied_references() -> None:
    X = np.zeros((5, 14))
    X[:, 12] = [0.0, 0.1, 0.2, 0.3, 0.4]
    v = np.ones((4, 2))
    moved = lambda X0, vs: X0[12:14] + np.outer(np.arange(len(vs) + 1), 0.1 * vs[0, :1].repeat(2) * [1, 0])  # noqa: E731
    err = MM.prediction_errors(X, v, moved, horizon=2)
    np.testing.assert_allclose(err, [0.0, 0.0, 0.0], atol=1e-15)
    # a sample whose horizon runs past the applied references has no error
    assert MM.prediction_errors(X, v[:3], moved, horizon=2).shape == (2,)
    assert MM.prediction_errors(X, v[:2], moved, horizon=2).shape == (1,)


def _metrics(rms: dict, tilt: float = 3.0, completed: float = 1.0) -> dict:
    m = {}
    for c in MM.COURSES:
        for v in ("shipped", "full", "nmpc"):
            m.update({f"{c}_{v}_lateral_rms_cm": rms[v], f"{c}_{v}_peak_tilt_deg": 3.0,
                      f"{c}_{v}_peak_tilt_rate_deg_s": 5.0, f"{c}_{v}_completed": 1.0,
                      f"{c}_{v}_min_clearance_m": 0.15})
    m.update({f"{c}_nmpc_peak_tilt_deg": tilt for c in MM.COURSES})
    m.update({f"{c}_nmpc_completed": completed for c in MM.COURSES})
    return m


def test_decision_keeps_the_default_unless_a_variant_is_clearly_better() -> None:
    assert MM.decide(_metrics({"shipped": 1.0, "full": 0.95, "nmpc": 0.95}))[0] == "shipped"
    assert MM.decide(_metrics({"shipped": 1.0, "full": 0.95, "nmpc": 0.5}))[0] == "nmpc"
    # better tracking bought with a §7.1 excess or a lost completion does not count
    assert MM.decide(_metrics({"shipped": 1.0, "full": 1.0, "nmpc": 0.5}, tilt=5.5))[0] == "shipped"
    assert MM.decide(_metrics({"shipped": 1.0, "full": 1.0, "nmpc": 0.5}, completed=0.0))[0] == "shipped"


def test_a_variant_without_a_completion_number_has_not_completed() -> None:
    """A missing ``{course}_{variant}_completed`` counts as 0 (nothing completed), so a variant
    whose runs left no completion number cannot win against a default that completed; a missing
    tilt counts as failing its bound the same way, a missing clearance as no obstacle."""
    m = _metrics({"shipped": 1.0, "full": 1.0, "nmpc": 0.5})
    assert MM.decide(m)[0] == "nmpc"
    for key in ("completed", "peak_tilt_deg", "peak_tilt_rate_deg_s"):
        for c in MM.COURSES:
            short = dict(m)
            del short[f"{c}_nmpc_{key}"]
            assert MM.decide(short)[0] == "shipped", (key, c)
    # with no completion number for the default either, completion no longer decides
    none = {k: v for k, v in m.items() if not k.endswith("_completed")}
    assert MM.decide(none)[0] == "nmpc"
    assert MM.decide({k: v for k, v in m.items() if not k.endswith("_clearance_m")})[0] == "nmpc"


def test_the_nonlinear_variant_predicts_by_stepping_its_model_from_each_new_state(monkeypatch) -> None:
    """The nmpc variant's predictor rolls its loop model forward one sample at a time, each
    step from the state the last one reached, and returns the 14-state's position rows
    (12:14); a stand-in model whose step doubles the position and adds the reference tells a
    step from the start state (or from any other) apart."""
    made = {}

    class Loop:
        def __init__(self, inp, dt):
            made["loop"] = (inp, dt)

        def step(self, x, v):
            y = np.array(x, float)
            y[12:14] = 2.0 * y[12:14] + v
            y[0] += 1.0
            return y

    class Mpc:
        def __init__(self, model, path, config):
            made["mpc"] = (model, path, config)
            self.qp_size = {"variables": 3, "rows": 4, "other": 5}

    monkeypatch.setattr(MM, "ClippedLoop", Loop)
    monkeypatch.setattr(MM, "NonlinearPathMPC", Mpc)
    config = type("Config", (), {"dt": 0.1})()
    variant = next(v for v in MM.MPC_MODEL_VARIANTS if v.name == "nmpc")
    mpc, predict, size = variant.build({"k": 1}, "path", config)
    assert made["loop"] == ({"k": 1}, 0.1) and made["mpc"][1:] == ("path", config) and mpc.qp_size
    assert size == {"variables": 3, "rows": 4}
    X0 = np.zeros(14)
    X0[12:14] = [1.0, -1.0]
    v = np.array([[0.5, 0.0], [0.0, 1.0], [1.0, 1.0]])
    expected = [[1.0, -1.0], [2.5, -2.0], [5.0, -3.0], [11.0, -5.0]]
    np.testing.assert_array_equal(predict(X0, v), expected)


def test_a_variant_run_hands_its_metrics_every_sample_after_the_first(monkeypatch) -> None:
    """run_variant follows the scenario's course with the variant's guidance and measures the
    run: the log, the plant's own torque limit, the applied references, the QP sizes and the
    guidance's failures; the solve times of every sample but the first (the cold start
    re-linearises several times: not a sample's time)."""
    seen = {}

    def inputs(periods):
        seen["periods"] = periods
        return {"inp": 1}

    def build(inp, path, config):
        seen["build"] = (inp, path, config)
        return guidance, "predict", {"rows": 7}

    scenario = SimpleNamespace(
        route=SimpleNamespace(build=lambda: "path"), duration=2.5, inputs=inputs,
        to_dict=lambda: {"name": "course"}, plant_params=lambda: SimpleNamespace(tau_max=3.25))
    guidance = SimpleNamespace(failures=4)
    variant = SimpleNamespace(build=build)
    run = SimpleNamespace(log={"time": np.zeros(3)}, v_ref=np.ones((3, 2)),
                          solve_s=np.array([9.0, 0.1, 0.2]))

    def run_path(path, g, duration):
        seen["run_path"] = (path, g, duration)
        return run

    def metrics(*args):
        seen["metrics"] = args
        return {"row": 1.0}

    monkeypatch.setattr(MM, "run_path", run_path)
    monkeypatch.setattr(MM, "variant_metrics", metrics)
    assert MM.run_variant(variant, scenario) == {"row": 1.0}
    assert seen["periods"] == (0, 1) and seen["run_path"] == ("path", guidance, 2.5)
    assert seen["build"] == ({"inp": 1}, "path", MM.MpcConfig())
    sc, log, tau_max, v_ref, step_s, predictor, qp_size, failures = seen["metrics"]
    assert (sc, log, tau_max, predictor, qp_size, failures) == (
        {"name": "course"}, run.log, 3.25, "predict", {"rows": 7}, 4)
    assert v_ref is run.v_ref
    np.testing.assert_array_equal(step_s, [0.1, 0.2])
    # a guidance without a failure count has none
    guidance.__dict__.pop("failures")
    MM.run_variant(variant, scenario)
    assert seen["metrics"][-1] == 0

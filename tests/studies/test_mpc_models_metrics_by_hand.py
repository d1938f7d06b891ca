"""The MPC-models study's bookkeeping (studies.mpc_models.mpc_models_metrics) with stand-in
variants, runs and step errors: each variant's predictor built once from the last run's
inputs at the horizon, its step error at each speed in cm, and each course (the run's
name without ``path_`` and ``_mpc``) run once per variant under ``<course>_<variant>_<k>``."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

import studies.mpc_models as MM


def test_every_variant_on_every_course_and_speed(monkeypatch):
    built, ran, stepped = [], [], []

    class FakeScenario:
        @staticmethod
        def from_dict(d):
            return SimpleNamespace(name=d["name"], inputs=lambda periods: {"periods": periods, "of": d["name"]},
                                   route=SimpleNamespace(build=lambda: f"route of {d['name']}"))

    def variant(name, scale):
        def build(inp, path, config):
            built.append((name, inp["of"], inp["periods"], path, type(config).__name__))
            return None, (name, scale), None
        return SimpleNamespace(name=name, build=build)

    def step_error(inp, predictor, speed, sim):
        stepped.append((predictor[0], speed, sim))
        return predictor[1] * speed

    def run_variant(v, sc):
        ran.append((v.name, sc.name))
        return {"lateral_rms_cm": len(v.name) + len(sc.name), "completed": 1.0}

    monkeypatch.setattr(MM, "Scenario", FakeScenario)
    monkeypatch.setattr(MM, "ClosedLoop", lambda: "SIM")
    monkeypatch.setattr(MM, "step_prediction_error", step_error)
    monkeypatch.setattr(MM, "run_variant", run_variant)
    logs = [SimpleNamespace(scenario={"name": "path_obstacles_mpc"}), SimpleNamespace(scenario={"name": "path_fig8_mpc"})]
    out = MM.mpc_models_metrics(logs, [variant("a", 0.01), variant("bb", 0.02)])
    n = MM.HORIZON_SAMPLES * 20  # the horizon in control periods (a guidance sample is 20)
    assert built == [("a", "path_fig8_mpc", (0, n), "route of path_fig8_mpc", "MpcConfig"),
                     ("bb", "path_fig8_mpc", (0, n), "route of path_fig8_mpc", "MpcConfig")]
    assert stepped == [(v, s, "SIM") for v in ("a", "bb") for s in MM.STEP_SPEEDS]
    assert ran == [("a", "path_obstacles_mpc"), ("bb", "path_obstacles_mpc"),
                   ("a", "path_fig8_mpc"), ("bb", "path_fig8_mpc")]
    want = {f"step{s:g}_{v}_pred_err_max_cm": pytest.approx(100 * k * s, rel=1e-12)
            for v, k in (("a", 0.01), ("bb", 0.02)) for s in MM.STEP_SPEEDS}
    for course, full in (("obstacles", "path_obstacles_mpc"), ("fig8", "path_fig8_mpc")):
        for v in ("a", "bb"):
            want[f"{course}_{v}_lateral_rms_cm"] = len(v) + len(full)
            want[f"{course}_{v}_completed"] = 1.0
    assert out == want
    assert MM.STEP_SPEEDS == (0.1, 0.4)

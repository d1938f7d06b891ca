"""Monte Carlo statistics and draws against values computed by hand: a percentile on a
small set, relative against absolute dispersions of plant and initial-state values."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.analysis.dispersion_stats import summarize
from ballbot_casadi.sim.scenario import parse_scenario
from ballbot_casadi.sim.scenario.dispersions import draw_runs

TABLE = {
    "duration_s": 1.0,
    "name": "mc_values",
    "initial": {"roll_deg": 2.0, "pitch_deg": -1.5, "yaw_deg": 10.0},
    "plant": {"com_x": -0.02},
    "spec": [{"metric": "max_tilt_deg", "op": "<=", "threshold": 5.0},
             {"metric": "final_speed_mps", "op": "<", "threshold": 1.0}],
    "montecarlo": {"seed": 7, "dispersion": [
        {"param": "initial.roll_deg", "dist": "uniform", "low": -0.5, "high": 0.5, "relative": True},
        {"param": "initial.pitch_deg", "dist": "normal", "sd": 0.3, "relative": False},
        {"param": "initial.yaw_deg", "dist": "uniform", "low": 1.0, "high": 2.0},
        {"param": "plant.Mb", "dist": "normal", "sd": 0.1, "relative": True},
        {"param": "plant.com_x", "dist": "uniform", "low": 0.01, "high": 0.02, "relative": False},
    ]},
}


def test_draws_apply_relative_dispersions_as_fractions_and_absolute_ones_as_offsets():
    sf = parse_scenario(TABLE)
    mb = sf.scenario.plant_params().Mb
    runs = draw_runs(sf, 5)
    for i, run in enumerate(runs):
        rng = np.random.default_rng([7, i])           # the documented per-run stream
        assert run["seed"] == int(rng.integers(0, 2**32))
        d_roll = rng.uniform(-0.5, 0.5)
        d_pitch = rng.normal(0.0, 0.3)
        d_yaw = rng.uniform(1.0, 2.0)
        d_mb = rng.normal(0.0, 0.1)
        d_cx = rng.uniform(0.01, 0.02)
        expected = {"initial.roll_deg": 2.0 * (1 + d_roll), "initial.pitch_deg": -1.5 + d_pitch,
                    "initial.yaw_deg": 10.0 + d_yaw, "plant.Mb": mb * (1 + d_mb),
                    "plant.com_x": -0.02 + d_cx}
        assert run["values"] == pytest.approx(expected, rel=1e-14, abs=1e-15)
        assert run["table"]["initial"]["roll_deg"] == pytest.approx(expected["initial.roll_deg"], rel=1e-14)
        assert run["table"]["plant"]["com_x"] == pytest.approx(expected["plant.com_x"], rel=1e-14)
        assert run["table"]["name"] == f"mc_values_mc{i:04d}"
        x0 = parse_scenario(run["table"]).scenario.x0
        q = np.array(x0[2:6])
        # roll of the ZYX quaternion, hand formula
        roll = math.degrees(math.atan2(2 * (q[0] * q[1] + q[2] * q[3]), 1 - 2 * (q[1] ** 2 + q[2] ** 2)))
        assert roll == pytest.approx(expected["initial.roll_deg"], rel=1e-9)
    # an explicit seed replaces the file's
    assert draw_runs(sf, 1, seed=8)[0]["seed"] == int(np.random.default_rng([8, 0]).integers(0, 2**32))


def _result(ok: bool, max_tilt: float, speed: float, spec_ok=(True, True), error=None) -> dict:
    return {"ok": ok, "spec_ok": list(spec_ok), "metrics": {"max_tilt_deg": max_tilt, "final_speed_mps": speed,
                                                            "finite": True},
            "error": error, "failure": None}


def test_summary_statistics_on_a_small_set_with_known_answers():
    sf = parse_scenario(TABLE)
    results = [_result(True, 1.0, 0.1), _result(True, 2.0, 0.2), _result(False, 3.0, 2.0, (True, False)),
               _result(True, 4.0, math.nan), _result(False, 5.0, 0.4, (False, False), error="boom")]
    s = summarize(sf, draw_runs(sf, 5), results)
    assert s["n"] == 5 and s["n_failed"] == 2
    assert s["success_rate"] == pytest.approx(0.6, abs=1e-15)
    assert [r["pass_rate"] for r in s["specs"]] == pytest.approx([0.8, 0.6], abs=1e-15)
    tilt = s["metric_stats"]["max_tilt_deg"]
    # linear-interpolation 95th percentile of 1..5: 1 + 0.95 * 4 = 4.8
    assert tilt["p95"] == pytest.approx(4.8, abs=1e-12)
    assert (tilt["mean"], tilt["min"], tilt["max"]) == pytest.approx((3.0, 1.0, 5.0), abs=1e-15)
    assert tilt["std"] == pytest.approx(math.sqrt(2.0), rel=1e-12)   # population std of 1..5
    speed = s["metric_stats"]["final_speed_mps"]                   # the NaN is left out
    assert speed["mean"] == pytest.approx(0.675, rel=1e-12)
    assert speed["p95"] == pytest.approx(0.4 + 0.85 * 1.6, rel=1e-12)  # rank 2.85 of (0.1, 0.2, 0.4, 2.0)
    assert "finite" not in s["metric_stats"]
    assert s["errors"] == ["boom"] and s["seed"] == 7
    assert [d["param"] for d in s["dispersions"]] == [d["param"] for d in TABLE["montecarlo"]["dispersion"]]

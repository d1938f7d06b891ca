"""The sta_noise study's rows on stand-in runs (issue 23, test strength): per-axis values
averaged over the seeds, scalars the worst seed's, the gain rule applied to each ``L``
scale, the best row, the floor ratio's range, and the report's cells read back."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ballbot_casadi.control.super_twisting import STA_DEFAULT_L
from ballbot_casadi.studies import sta_noise as S


@pytest.fixture()
def study(monkeypatch, tmp_path):
    calls = []

    def run(sim, k, seed, duration, estimator):
        calls.append((k.copy(), seed, duration, estimator))
        scale = len({c[0].tobytes() for c in calls})  # 1, 2: the row
        base = np.array([1.0, 2.0, 4.0]) * 1e-3 * scale
        return {"S_hat_rms": base * (seed + 1), "S_hat_max": 0.1 * scale + seed, "S_rms": base * (seed + 2),
                "S_max": 0.2 * scale - seed, "e_S_rms": base * (seed + 3), "torque_tv_per_s": 7.0 + seed}

    monkeypatch.setattr(S, "_run", run)
    monkeypatch.setattr(S, "levant_gains", lambda L: (np.asarray(L) * 10.0, np.asarray(L) * 100.0))
    var = [4e-4, 1e-4, 16e-4]
    monkeypatch.setattr(S, "load_sensor_params", lambda: type("P", (), {"gyro_noise_var": var}))
    out = tmp_path / "new" / "sta_noise"  # a folder not there yet, nor its parent
    m = S.run_sta_noise_study(out, seeds=(0, 2), L_scales=(0.5, 2.0), duration=3.0, sim=object(),
                              estimator="ukf")
    return m, calls, out


def test_rows_average_the_axes_and_take_the_worst_scalar(study):
    m, calls, _ = study
    r1, r2 = m["rows"]
    assert r1["L_scale"] == 0.5 and r2["L_scale"] == 2.0
    np.testing.assert_allclose(r1["L"], 0.5 * STA_DEFAULT_L, rtol=1e-15)
    base = np.array([1.0, 2.0, 4.0]) * 1e-3
    np.testing.assert_allclose(r1["S_hat_rms"], base * (1 + 3) / 2, rtol=1e-12)   # seeds 0, 2
    np.testing.assert_allclose(r2["S_rms"], 2 * base * (2 + 4) / 2, rtol=1e-12)
    np.testing.assert_allclose(r1["e_S_rms"], base * (3 + 5) / 2, rtol=1e-12)
    assert r1["S_hat_max"] == pytest.approx(0.1 + 2) and r1["S_max"] == pytest.approx(0.2)
    assert r2["torque_tv_per_s"] == 9.0
    # the gain rule per scale, the seeds, duration and estimator passed through
    assert [(c[1], c[2], c[3]) for c in calls] == [(0, 3.0, "ukf"), (2, 3.0, "ukf")] * 2
    k = calls[2][0]
    np.testing.assert_allclose(k[S._K1], 2.0 * STA_DEFAULT_L * 10.0, rtol=1e-15)
    np.testing.assert_allclose(k[S._K2], 2.0 * STA_DEFAULT_L * 100.0, rtol=1e-15)


def test_the_floor_the_best_row_and_the_verdict(study):
    m, _, out = study
    np.testing.assert_allclose(m["gyro_floor_rms"], [0.01, 0.005, 0.02], rtol=1e-12)   # sqrt(var) / 2
    base = np.array([1.0, 2.0, 4.0]) * 1e-3
    assert m["best_S_rms"] == pytest.approx(4e-3 * 3, rel=1e-12)   # row 1's worst axis, (2 + 4) / 2
    ratios = np.concatenate([base * 4 / [0.01, 0.005, 0.02], 2 * base * 4 / [0.01, 0.005, 0.02]])
    assert m["e_S_over_floor"] == pytest.approx([ratios.min(), ratios.max()], rel=1e-12)
    assert m["reached"] is False and m["target"] == 1e-3 and m["after_s"] == 1.0
    assert m["rate_noise_needed_rad_s"] == 2e-3
    np.testing.assert_allclose(m["rate_noise_rad_s"], [0.02, 0.01, 0.04], rtol=1e-12)
    assert (m["seeds"], m["duration_s"], m["estimator"]) == ([0, 2], 3.0, "ukf")
    assert json.loads((out / "metrics.json").read_text()) == json.loads(json.dumps(m))
    report = (out / "report.md").read_text().splitlines()
    assert report[0] == "# Super-twisting with noisy sensors and the QUKF + VUKF"
    assert "| 0.5 | (0.002, 0.004, 0.008) | 2.1 | (0.003, 0.006, 0.012) | 0.2 | (0.004, 0.008, 0.016) | 9 |" in report
    text = "\n".join(report)
    assert "(0.01, 0.005, 0.02) RMS" in text and "NOT reached" in text and "the best RMS is 0.012" in text
    assert "rate noise below ~2e-03 rad/s per sample against the thesis's (0.02, 0.01, 0.04)" in text


def test_reached_at_the_target():
    m = {"rows": [], "seeds": [0], "duration_s": 1.0, "after_s": 1.0, "gyro_floor_rms": [1, 2, 3],
         "target": 1e-3, "reached": True, "best_S_rms": 1e-3, "e_S_over_floor": [1, 2],
         "rate_noise_needed_rad_s": 2e-3, "rate_noise_rad_s": [1, 1, 1]}
    assert "reached with the estimators" in "\n".join(S.sta_noise_report_lines(m))
    assert "NOT reached" not in "\n".join(S.sta_noise_report_lines(m))


def test_one_run_starts_tilted_and_measures_after_the_settling_time(monkeypatch):
    """One run: the thesis's 5 deg / 5 deg start, the standing robot (cascade) under the STA
    with the given gains, estimator and seed; S_hat = de + K e from the controller's
    diagnostics, S from the true state, each measured from t = 1 s on; the torque's total
    variation per second over the whole run."""
    from ballbot_casadi.control import BALANCE_DIAG_NAMES
    from ballbot_casadi.control.super_twisting import STA_GAIN_NAMES
    from ballbot_casadi.sim.scenario import initial_state

    n, dt = 8, 0.25  # samples at 0, 0.25, ..., 1.75 s: the last four from 1 s on
    t = np.arange(n + 1) * dt
    diag = np.zeros((n, len(BALANCE_DIAG_NAMES)))
    e = np.arange(n)[:, None] * [1.0, -2.0, 0.5]
    de = np.ones((n, 3)) * [0.1, 0.2, -0.3]
    diag[:, BALANCE_DIAG_NAMES.index("e1"):BALANCE_DIAG_NAMES.index("e3") + 1] = e
    diag[:, BALANCE_DIAG_NAMES.index("de1"):BALANCE_DIAG_NAMES.index("de3") + 1] = de
    tau = np.zeros((n, 3))
    tau[3] = [1.0, -2.0, 0.0]  # total variation 2 x 3 N m
    k = np.arange(1.0, len(STA_GAIN_NAMES) + 1) * 0.5  # all > 0, as the scenario requires
    K = np.array([2.0, 3.0, 4.0])
    k[STA_GAIN_NAMES.index("K1"):STA_GAIN_NAMES.index("K3") + 1] = K
    S_true = np.tile([0.01, -0.02, 0.04], (n, 1)) * np.arange(1, n + 1)[:, None]
    seen = {}

    def run_scenario(sc, sim):
        seen["sc"], seen["sim"] = sc, sim
        return {"time": t, "diag": diag, "tau_cmd": tau}

    monkeypatch.setattr(S, "run_scenario", run_scenario)
    monkeypatch.setattr(S, "true_sliding_variable", lambda log, KK: seen.setdefault("K", KK) is not None
                        and S_true)
    sim = object()
    r = S._run(sim, k, seed=7, duration=2.0, estimator="ukf")
    sc = seen["sc"]
    assert seen["sim"] is sim and np.array_equal(seen["K"], K)
    assert (sc.name, sc.controller, sc.duration, sc.estimator, sc.cascade, sc.seed) == (
        "sta_noise", "sta", 2.0, "ukf", True, 7)
    assert tuple(sc.x0) == tuple(initial_state(5, 5)) and tuple(sc.k_bal) == tuple(k)
    late = slice(4, None)
    S_hat = de + K * e
    np.testing.assert_allclose(r["S_hat_rms"], np.sqrt(np.mean(S_hat[late] ** 2, axis=0)), rtol=1e-14)
    assert r["S_hat_max"] == pytest.approx(np.abs(S_hat[late]).max(), rel=1e-14)
    np.testing.assert_allclose(r["S_rms"], np.sqrt(np.mean(S_true[late] ** 2, axis=0)), rtol=1e-14)
    assert r["S_max"] == pytest.approx(0.04 * 8, rel=1e-14)
    np.testing.assert_allclose(r["e_S_rms"], np.sqrt(np.mean((S_hat - S_true)[late] ** 2, axis=0)),
                               rtol=1e-14)
    assert r["torque_tv_per_s"] == pytest.approx(6.0 / 2.0, rel=1e-14)

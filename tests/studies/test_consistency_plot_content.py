"""The consistency study's ``nis.png`` read back: each filter's 1 s mean NIS of each run on
its own panel, the thesis filter's velocity NIS dashed beside the shipped one, and the
chi2(6) 95 % band of a 200-sample mean, with stand-in runs whose NIS differ by filter,
estimator and time (no simulation)."""

from __future__ import annotations

import numpy as np
import pytest
from _figures import assert_style, line
from scipy.stats import chi2

from ballbot_casadi.studies import consistency as C

N = 600


def _nis(estimator: str) -> np.ndarray:
    k = np.arange(N)
    base = {C.ADAPTIVE: 5.0, C.THESIS_ESTIMATOR: 30.0, C.MATCHED: 8.0}[estimator]
    return np.column_stack([4.0 + 0.01 * k, base + np.sin(0.05 * k)])


def test_nis_figure_draws_each_filter_on_its_panel_with_the_band(monkeypatch, tmp_path, saved):
    def run(sc, sim):
        return {"time": np.arange(N + 1) * 0.005, "nis": _nis(sc.estimator)}

    monkeypatch.setattr(C, "run_scenario", run)
    monkeypatch.setattr(C, "estimation_metrics", lambda log: {"estimator_velocity_rms_mps": 0.01})
    monkeypatch.setattr(C, "final_walk", lambda log, est: [1e-3, 2e-3])
    monkeypatch.setattr(C, "acceleration_random_walk", lambda log, Ts: (1e-4, 2e-4))
    C.run_consistency_study(tmp_path / "new" / "consistency", names=["full_sine"], sim=object())
    att, vel = saved["nis.png"]
    t = (np.arange(N + 1) * 0.005)[:-1][199:]

    def mean_200(y):
        c = np.concatenate([[0.0], np.cumsum(y)])
        return (c[200:] - c[:-200]) / 200

    x, y = line(att, "full_sine")
    np.testing.assert_allclose(x, t, rtol=0, atol=0)
    np.testing.assert_allclose(y, mean_200(_nis(C.ADAPTIVE)[:, 0]), rtol=1e-12)
    np.testing.assert_allclose(line(vel, "full_sine")[1], mean_200(_nis(C.ADAPTIVE)[:, 1]), rtol=1e-12)
    np.testing.assert_allclose(line(vel, f"full_sine, {C.THESIS_ESTIMATOR}")[1],
                               mean_200(_nis(C.THESIS_ESTIMATOR)[:, 1]), rtol=1e-12)
    assert [lab for lab, *_ in att["lines"]] == ["full_sine"]  # the dashed one on the velocity panel only
    band = (chi2.ppf(0.025, 1200) / 200, chi2.ppf(0.975, 1200) / 200)
    for ax in (att, vel):
        (label, lo, hi), = ax["spans"]
        assert label == "chi2(6) 95 % band, 1 s mean"
        assert (lo, hi) == pytest.approx(band, rel=1e-9)
        assert ax["yscale"] == "log"
    assert (att["ylabel"], vel["ylabel"], vel["xlabel"]) == (
        "attitude NIS (1 s mean)", "velocity NIS (1 s mean)", "time (s)")
    assert_style(saved, "nis.png")

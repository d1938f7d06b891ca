"""The heading study's bookkeeping on stand-in runs with known errors: which runs it asks
for (initial bias, seeds, loss window) and every metric against a hand computation
(windows, RMS, drift per hour, pass/fail at the bound)."""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest
from _figures import assert_style, line

import studies.heading as H
from ballbot_casadi.core.sensor_params import load_sensor_params

DEG = np.pi / 180


def _run(time, err_deg, bias=None, bias_hat=None):
    bias = np.zeros_like(time) if bias is None else bias
    return SimpleNamespace(time=time, error_deg=lambda e=err_deg: e, bias=bias,
                           bias_hat=bias if bias_hat is None else bias_hat)


@pytest.fixture
def study(tmp_path, monkeypatch):
    return _study(tmp_path, monkeypatch, plot=False)


def _study(tmp_path, monkeypatch, plot):
    t = np.arange(0.0, 200.0, 1.0)  # duration 200 s: the loss window is (100, 160)
    aided_err = np.where(t < 60.0, 5.0, 0.0) + np.where(t >= 60.0, (-1.0) ** np.arange(t.size) * 0.2, 0.0)
    aided_err[120] = 0.4  # the largest after the first minute
    bias = np.full_like(t, 0.1 * DEG)
    bias_hat = bias + np.where(np.arange(t.size) % 2 == 0, 0.03, -0.03) * DEG
    lost_err = np.zeros_like(t)
    lost_err[100:160] = np.linspace(0.0, 1.2, 60)
    lost_err[160:170] = 2.0       # still recovering: not counted (back = t >= 170)
    lost_err[175] = -0.3
    lost_err[170] = 0.35          # the first sample counted (t = end of loss + 10 s)
    calls = []

    def fake(duration, seed, aided, bias0=(0.0, 0.0, 0.0), loss=None):
        calls.append((duration, seed, aided, tuple(bias0), loss))
        if aided and loss is None:
            return _run(t, aided_err, bias, bias_hat)
        if aided:
            return _run(t, lost_err)
        return _run(t, 0.5 * (seed + 1) * (t / t[-1]) * (1 if seed % 2 else -1))  # a drift ramp

    monkeypatch.setattr(H, "heading_run", fake)
    kwargs = {} if plot is None else {"plot": plot}   # None: the study's default
    out = tmp_path / "new" / "heading"  # the study makes its folder and the parents
    m = H.run_heading_study(out, duration=200.0, seeds=(3, 4), **kwargs)
    return m, calls, out, (t, aided_err, lost_err)


def test_the_runs_asked_for(study):
    _, calls, _, _ = study
    bias0 = (0.0, 0.0, 0.1 * DEG)
    assert calls[0] == (200.0, 3, True, pytest.approx(bias0), None)
    assert calls[1] == (200.0, 3, True, pytest.approx(bias0), (100.0, 160.0))
    assert calls[2:] == [(200.0, 3, False, (0.0, 0.0, 0.0), None), (200.0, 4, False, (0.0, 0.0, 0.0), None)]


@pytest.mark.parametrize("duration, loss", [
    (200.0, (100.0, 160.0)),       # half-way in a short run, still 60 s long
    (3600.0, (1800.0, 1860.0)),    # the hour: from 30 min on
    (3700.0, (1800.0, 1860.0)),    # longer runs: the same 60 s from 30 min
    (7200.0, (1800.0, 1860.0)),
])
def test_the_loss_window_for_each_duration(tmp_path, monkeypatch, duration, loss):
    t = np.arange(0.0, duration, 10.0)
    asked = []

    def fake(d, seed, aided, bias0=(0.0, 0.0, 0.0), loss=None):
        asked.append(loss)
        return _run(t, np.zeros_like(t))

    monkeypatch.setattr(H, "heading_run", fake)
    H.run_heading_study(tmp_path, plot=False, duration=duration, seeds=(0,))
    assert asked == [None, loss, None]


def test_every_metric_by_hand(study):
    m, _, out, (t, e, _) = study
    late = e[t >= 60.0]
    assert m["duration_s"] == 199.0
    assert m["aided_error_max_deg"] == pytest.approx(0.4, abs=1e-12)
    assert m["aided_error_rms_deg"] == pytest.approx(np.sqrt(np.mean(late ** 2)), rel=1e-12)
    assert m["aided_error_rms_deg"] != pytest.approx(np.mean(np.abs(late)), rel=1e-3)
    assert m["aided_bias_error_rms_deg_s"] == pytest.approx(0.03, rel=1e-9)
    assert m["loss_error_at_end_deg"] == pytest.approx(1.2, rel=1e-12)
    assert m["loss_error_max_deg"] == pytest.approx(1.2, rel=1e-12)
    assert m["loss_error_after_recovery_max_deg"] == pytest.approx(0.35, rel=1e-12)
    # seed 3 -> +2.0 deg, seed 4 -> -2.5 deg at t = 199 s, per hour x 3600 / 199
    assert m["unaided_drift_per_hour_deg"] == pytest.approx([2.0 * 3600 / 199, -2.5 * 3600 / 199], rel=1e-12)
    assert m["unaided_drift_per_hour_abs_mean_deg"] == pytest.approx(2.25 * 3600 / 199, rel=1e-12)
    assert m["unaided_drift_per_hour_abs_max_deg"] == pytest.approx(2.5 * 3600 / 199, rel=1e-12)
    assert m["seeds"] == [3, 4] and m["passed"] is True
    # the heading sensor's noise in degrees (the shipped 0.2 deg, 1 sigma) and its rate
    sp = load_sensor_params()
    assert m["heading_sensor_sigma_deg"] == pytest.approx(np.degrees(np.sqrt(sp.heading_noise_var[0])),
                                                          rel=1e-12)
    assert m["heading_sensor_sigma_deg"] == pytest.approx(0.2, rel=1e-6)
    assert m["heading_sensor_rate_hz"] == sp.heading_rate[0] == 10.0
    assert json.loads((out / "metrics.json").read_text()) == m
    report = (out / "report.md").read_text()
    assert "| aided heading error, max after 1 min | 0.400 deg |" in report
    assert "| after the sensor returns (+10 s on), max | 0.350 deg |" in report


def test_the_verdict_at_and_past_the_bound(tmp_path, monkeypatch):
    t = np.arange(0.0, 200.0, 1.0)
    for peak, ok in ((H.HEADING_SPEC_DEG, True), (np.nextafter(H.HEADING_SPEC_DEG, 1.0), False)):
        err = np.zeros_like(t)
        err[100] = peak
        monkeypatch.setattr(H, "heading_run", lambda d, seed, aided, bias0=(0, 0, 0), loss=None, e=err:
                            _run(t, e if loss is None else np.zeros_like(t)))
        assert H.run_heading_study(tmp_path, plot=False, duration=200.0, seeds=(0,))["passed"] is ok


def test_the_plot_draws_each_run_in_minutes_against_its_band(tmp_path, monkeypatch, saved):
    _, _, _, (t, aided_err, lost_err) = _study(tmp_path, monkeypatch, plot=None)  # draws by default
    top, bottom = saved["heading.png"]
    x, y = line(top, "aided (10 Hz heading)")
    np.testing.assert_allclose(x, t / 60, rtol=1e-15)
    np.testing.assert_array_equal(y, aided_err)
    np.testing.assert_array_equal(line(top, "aided, 60 s loss")[1], lost_err)
    np.testing.assert_allclose(line(top, "aided, 60 s loss")[0], t / 60, rtol=1e-15)
    for seed, sign in ((3, 1), (4, -1)):
        xu, yu = line(bottom, f"unaided QUKF, seed {seed}")
        np.testing.assert_allclose(xu, t / 60, rtol=1e-15)   # minutes on both panels
        np.testing.assert_allclose(yu, sign * 0.5 * (seed + 1) * t / t[-1], rtol=1e-14, atol=0)
    assert top["spans"] == [("±0.5 deg", -H.HEADING_SPEC_DEG, H.HEADING_SPEC_DEG)]
    assert bottom["spans"] == [("thesis §7.1: ±5 deg", -5.0, 5.0)]
    assert (top["ylabel"], bottom["ylabel"], bottom["xlabel"]) == (
        "heading error (deg)", "heading error (deg)", "time (min)")
    assert_style(saved, "heading.png")

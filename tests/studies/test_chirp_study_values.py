"""The chirp study's bookkeeping on hand-built runs (issue 23, test strength): each
feed-forward mode's metrics from its own run, the per-wheel run's figures under their
prefix and the lead of its cross-axis onset before the fall, the thesis-mode FLC's -3 dB
frequency against a numerical root of ``|T|^2 = 1/2``, and ``--axis`` / ``--amplitude``."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.optimize import brentq

from ballbot_casadi.studies import chirp as CH

PER_WHEEL = ("first_saturation_s", "first_saturation_motor", "cross_axis_onset_s", "cross_axis_onset_hz",
             "cross_axis_error_max_deg", "fell_at_s", "bandwidth_hz")


def _log(ff, limit, i, duration=100.0):
    sc = {"feedforward": ff, "duration": duration, "controller": "flc", **({"torque_limit": limit} if limit else {})}
    return SimpleNamespace(scenario=sc, params="P", i=i)


@pytest.fixture()
def patched(monkeypatch):
    def chirp(log):
        m = {k: 10.0 * log.i + j for j, k in enumerate(PER_WHEEL)}
        return {**m, "chirp_axis": "pitch", "response": "big", "tag": log.i}

    monkeypatch.setattr(CH, "chirp_metrics", chirp)
    monkeypatch.setattr(CH, "run_metrics", lambda log: {"peak_tilt_deg": 1.0 + log.i, "other": 0.0})
    seen = []
    monkeypatch.setattr(CH, "linear_response", lambda p, c, axis: seen.append((p, c, axis)) or {
        "linear_bandwidth_hz": 0.7, "none": {"bandwidth_hz": 0.9}})
    return seen


def test_each_mode_from_its_own_run_and_the_per_wheel_run(patched):
    logs = [_log("exact", None, 0), _log("none", "per-wheel", 1), _log("none", None, 2)]
    m = CH.chirp_study_metrics(logs)
    assert m["tag"] == 2 and "response" not in m and m["peak_tilt_deg"] == 3.0
    assert set(m["by_feedforward"]) == {"exact", "none"}
    assert m["by_feedforward"]["exact"]["tag"] == 0 and m["by_feedforward"]["none"]["tag"] == 2
    assert "other" not in m["by_feedforward"]["exact"]
    for j, k in enumerate(PER_WHEEL):
        assert m[f"per_wheel_{k}"] == 10.0 + j, k
    # lead: the fall (15 s) minus the cross-axis onset (12 s)
    assert m["per_wheel_cross_axis_lead_s"] == pytest.approx(15.0 - 12.0)
    assert (m["linear_bandwidth_hz"], m["linear_bandwidth_none_hz"]) == (0.7, 0.9)
    assert patched == [("P", "flc", "pitch")]


def test_without_a_fall_the_lead_runs_to_the_end_of_the_per_wheel_run(patched, monkeypatch):
    base = CH.chirp_metrics

    def no_fall(log):
        m = base(log)
        m["fell_at_s"] = None
        return m

    monkeypatch.setattr(CH, "chirp_metrics", no_fall)
    m = CH.chirp_study_metrics([_log("none", "per-wheel", 1, 80.0), _log("exact", "direction", 0)])
    assert m["per_wheel_cross_axis_lead_s"] == pytest.approx(80.0 - 12.0)  # its own run's end
    assert set(m["by_feedforward"]) == {"exact"}
    m = CH.chirp_study_metrics([_log("exact", None, 0)])
    assert not any(k.startswith("per_wheel") for k in m)


@pytest.mark.parametrize("axis, i", [("roll", 0), ("pitch", 1), ("yaw", 2)])
def test_the_thesis_mode_bandwidth_is_the_half_power_frequency(monkeypatch, axis, i):
    monkeypatch.setattr(CH.an, "analyze_plant", lambda p: (None, None))
    monkeypatch.setattr(CH.cla, "analyze_closed_loop", lambda p, lin: {"bandwidth_inner_hz": 0.6})
    # gains distinct per axis (the defaults share roll's and pitch's): each axis its own
    monkeypatch.setattr(CH, "default_balance_gains", lambda c: [90.0, 110.0, 25.0, 18.0, 22.0, 10.0])
    r = CH.linear_response("P", axis=axis)
    k = np.array([90.0, 110.0, 25.0, 18.0, 22.0, 10.0])
    kp, kd = k[i], k[3 + i]
    assert r["gains"] == {"Kp": kp, "Kd": kd}

    def half(w):
        s = 1j * w
        return abs((kd * s + kp) / (s**2 + kd * s + kp)) ** 2 - 0.5

    w3 = brentq(half, 1e-3, 1e4)
    assert r["none"]["bandwidth_hz"] == pytest.approx(w3 / (2 * math.pi), rel=1e-9)
    assert r["linear_bandwidth_hz"] == 0.6 and r["analyze"] is None
    w = np.asarray(r["none"]["omega"])
    j = int(np.argmin(np.abs(w - 2.0)))
    s = 1j * w[j]
    assert r["none"]["mag"][j] == pytest.approx(abs((kd * s + kp) / (s**2 + kd * s + kp)), rel=1e-12)
    assert w[0] == pytest.approx(0.01) and w[-1] == pytest.approx(2 * math.pi * 10)


def test_axis_and_amplitude_overrides():
    t = {"attitude": {"roll": {"type": "chirp", "amplitude_deg": 3.0, "f0_hz": 0.05}, "yaw": {"type": "sine"}}}
    assert CH.axis_overrides(t, "pitch", 2.0) == [("attitude", {"yaw": {"type": "sine"}, "pitch": {
        "type": "chirp", "amplitude_deg": 2.0, "f0_hz": 0.05}})]
    assert CH.axis_overrides(t, None, None) == [("attitude", t["attitude"])]
    assert CH.axis_overrides({"attitude": {"roll": {"type": "sine"}}}, "pitch", 1.0) == []
    assert t["attitude"]["roll"]["amplitude_deg"] == 3.0   # the table is not changed

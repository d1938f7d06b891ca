"""The bandwidth analysis at its edges: a chirp it cannot mean is refused, mismatched
signals are refused, windows holding a non-finite sample (a fall) or a silent reference
are dropped rather than fitted, a log without a chirp is refused naming the axis, and a
measured response read at a frequency between its windows is interpolated."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from ballbot_casadi.analysis.bandwidth import chirp_metrics, chirp_phase, response_at, sliding_response
from ballbot_casadi.errors import ScenarioError

T = np.arange(0.0, 40.0, 0.01)
PHI, F = chirp_phase(T, 0.2, 2.0, 40.0)


@pytest.mark.parametrize("args", [(0.2, 2.0, 0.0), (0.2, 2.0, -1.0), (-0.1, 2.0, 10.0), (0.2, -2.0, 10.0),
                                  (0.2, 2.0, float("nan")), (float("nan"), 2.0, 10.0)])
def test_a_chirp_it_cannot_mean_is_refused(args):
    f0, f1, d = args
    with pytest.raises(ScenarioError, match=rf"^chirp needs duration > 0 and f0, f1 >= 0, got {d}, {f0}, {f1}$"):
        chirp_phase(T, f0, f1, d)


@pytest.mark.parametrize("d", [1e-3, 0.5, 1.0])
def test_a_short_chirp_is_a_chirp(d):
    """Any positive duration: the frequency ramps from f0 to f1 over it and stays at f1,
    the phase is its integral (by hand: 2 pi (f0 t + (f1 - f0) t^2 / (2 d)), then f1 on)."""
    f0, f1 = 0.5, 3.0
    t = np.array([0.0, 0.25 * d, d, d + 0.2])
    phi, f = chirp_phase(t, f0, f1, d)
    np.testing.assert_allclose(f, [f0, f0 + 0.25 * (f1 - f0), f1, f1], rtol=1e-15, atol=0)
    at_end = f0 * d + 0.5 * (f1 - f0) * d
    want = 2 * np.pi * np.array([0.0, f0 * 0.25 * d + 0.5 * (f1 - f0) * 0.0625 * d, at_end, at_end + 0.2 * f1])
    np.testing.assert_allclose(phi, want, rtol=1e-14, atol=0)


def test_zero_frequencies_are_allowed():
    phi, f = chirp_phase(T, 0.0, 0.0, 10.0)
    assert np.all(phi == 0.0) and np.all(f == 0.0)


def test_mismatched_signals_are_refused():
    r = np.sin(PHI)
    for bad in ((T[:-1], r, r, PHI, F), (T, r, r[:-1], PHI, F), (T, r, r, PHI, F[:-1]),
                (T[:, None], r[:, None], r[:, None], PHI[:, None], F[:, None])):
        with pytest.raises(ScenarioError, match=r"^sliding_response: t, y, r, phi and f must be 1-D "
                                                r"arrays of one length$"):
            sliding_response(*bad)


def test_windows_with_a_fall_or_no_reference_are_dropped():
    r = np.sin(PHI)
    whole = sliding_response(T, 0.5 * r, r, PHI, F)
    y = 0.5 * r
    y[T >= 30.0] = np.nan                      # the robot fell at 30 s
    fell = sliding_response(T, y, r, PHI, F)
    n = fell["t"].size
    assert 0 < n < whole["t"].size
    np.testing.assert_array_equal(fell["t"], whole["t"][:n])   # the same windows, up to the fall
    assert np.all(fell["t"] + 0.5 * 3.0 / np.maximum(fell["f_hz"], 1e-9) <= 30.0 + 0.5)
    np.testing.assert_allclose(fell["gain"], 0.5, rtol=1e-6)
    quiet = r.copy()
    quiet[T < 20.0] = 0.0                       # no reference before 20 s: no window there
    part = sliding_response(T, 0.5 * quiet, quiet, PHI, F)
    assert part["t"].size > 0 and np.all(part["t"] > 20.0 - 5.0)
    assert part["t"][0] > whole["t"][0]
    np.testing.assert_allclose(part["gain"], 0.5, rtol=1e-6)


def test_response_at_interpolates_gain_and_phase():
    resp = {"f_hz": np.array([0.5, 1.0, 2.0]), "gain_db": np.array([0.0, -1.0, -5.0]),
            "phase_deg": np.array([-10.0, -30.0, -110.0])}
    assert response_at(resp, 1.5) == pytest.approx((-3.0, -70.0), rel=1e-12)
    assert response_at(resp, 1.0) == pytest.approx((-1.0, -30.0), rel=1e-12)


def test_a_log_without_a_chirp_is_refused():
    log = SimpleNamespace(scenario={"name": "still", "attitude": {"roll": {"type": "sine"}}})
    with pytest.raises(ScenarioError, match=r"^scenario 'still' has no chirp on axis None$"):
        chirp_metrics(log)
    with pytest.raises(ScenarioError, match=r"^scenario 'still' has no chirp on axis 'roll'$"):
        chirp_metrics(log, axis="roll")


def test_a_window_holds_the_samples_on_both_of_its_edges():
    """Windows [tc - 1.5 s, tc + 1.5 s] (3 cycles at 1 Hz) on a grid of 1/8 s: the samples
    at exactly the first window's start (t = 0) and the last window's end (t = 8 s) count,
    so a one-sample outlier there moves those windows' gains and no other."""
    t = np.arange(65) * 0.125
    phi, f = 2 * np.pi * t, np.ones_like(t)
    r = np.sin(phi)
    y = 0.5 * r
    y[0] += 1.0
    y[-1] += 1.0
    res = sliding_response(t, y, r, phi, f)
    np.testing.assert_allclose(res["t"], np.arange(1.5, 6.5 + 1e-9, 0.25), rtol=0, atol=1e-12)
    edge = np.isin(np.round(res["t"], 9), [1.5, 6.5])
    np.testing.assert_allclose(res["gain"][~edge], 0.5, rtol=1e-12)
    assert np.all(np.abs(res["gain"][edge] - 0.5) > 1e-3)

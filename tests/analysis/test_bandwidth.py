"""Chirp bandwidth analysis against systems with a known answer; precise small angles."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.signal as ss

from ballbot_casadi.analysis.bandwidth import (
    bandwidth_from_response,
    chirp_phase,
    second_order_bandwidth_hz,
    sliding_response,
)
from ballbot_casadi.analysis.metrics import _wrap, tilt_deg
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.sim import references as R

T = np.arange(0.0, 100.0, 0.005)
PHI, F = chirp_phase(T, 0.05, 5.0, 99.0)


def _measure(num, den):
    r = np.sin(PHI)
    _, y, _ = ss.lsim(ss.lti(num, den), r, T)
    resp = sliding_response(T, y, r, PHI, F)
    return resp, bandwidth_from_response(resp["f_hz"], resp["gain_db"], resp["phase_deg"])


def test_chirp_phase_matches_the_reference_generator():
    sig = R.chirp(T, 1.0, 0.05, 5.0, 99.0)
    np.testing.assert_allclose(np.sin(PHI), sig.value, rtol=0, atol=1e-12)
    assert F[0] == pytest.approx(0.05, abs=1e-15) and F[-1] == pytest.approx(5.0, abs=1e-15)


def test_recovers_the_minus_3db_bandwidth_of_a_second_order_system():
    # critically damped: -3 dB (0.64 wn) comes before the 90 deg lag (at wn)
    wn = 2 * math.pi * 2.0
    resp, (bw, reason) = _measure([wn**2], [1, 2 * wn, wn**2])
    assert reason == "gain"
    assert bw == pytest.approx(second_order_bandwidth_hz(wn, 1.0), rel=0.02)
    # the measured gain follows |H| at 1 Hz (well inside the sweep)
    k = np.argmin(np.abs(resp["f_hz"] - 1.0))
    w = 2 * math.pi * resp["f_hz"][k]
    exact = 20 * math.log10(wn**2 / abs(wn**2 - w**2 + 2j * wn * w))
    assert resp["gain_db"][k] == pytest.approx(exact, abs=0.05)


def test_phase_criterion_fires_for_a_resonant_system():
    # zeta = 0.3: the gain peaks above 0 dB and the lag reaches 90 deg at wn, before -3 dB
    wn = 2 * math.pi * 1.0
    _, (bw, reason) = _measure([wn**2], [1, 0.6 * wn, wn**2])
    assert reason == "phase"
    assert bw == pytest.approx(1.0, rel=0.04)


def test_no_loss_no_bandwidth():
    r = np.sin(PHI)
    resp = sliding_response(T, r.copy(), r, PHI, F)
    assert bandwidth_from_response(resp["f_hz"], resp["gain_db"], resp["phase_deg"]) == (None, None)
    np.testing.assert_allclose(resp["gain_db"], 0.0, atol=1e-9)


def test_second_order_closed_form():
    assert second_order_bandwidth_hz(2 * math.pi, 1 / math.sqrt(2)) == pytest.approx(1.0, rel=1e-12)


def test_tilt_and_error_keep_precision_near_zero():
    for a in (1e-12, 1e-9, 1e-6):
        q = Q.from_rpy(math.radians(a), 0.0, 0.0)
        assert tilt_deg(q[None, :])[0] == pytest.approx(a, rel=1e-9)
    assert _wrap(np.array([1e-14]))[0] == 1e-14
    np.testing.assert_allclose(_wrap(np.array([190.0, -190.0, 540.0])), [-170.0, 170.0, -180.0], atol=1e-12)
    # every angle in [-180, 180] comes back bit for bit (180 stays 180: not wrapped to -180;
    # 123.456789 and 90.1 would lose their last bits through the modulo)
    inside = np.array([180.0, -180.0, 123.456789, 90.1, -179.3, 0.0])
    np.testing.assert_array_equal(_wrap(inside), inside)

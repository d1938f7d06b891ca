"""Metrics against hand-computed values on signals built so that the plausible wrong
versions (a sign, one sample early or late, a window twice as long) give other numbers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.analysis.bandwidth import chirp_phase, sliding_response
from ballbot_casadi.analysis.metrics import (
    _yaw_rate,
    limit_metrics,
    push_metrics,
    tilt_rate_deg_s,
    zero_metrics,
)

TS = 0.01


def _hamilton(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise Hamilton product written out from its definition (independent of the package)."""
    a0, av = a[:, 0], a[:, 1:]
    b0, bv = b[:, 0], b[:, 1:]
    return np.column_stack([a0 * b0 - np.sum(av * bv, axis=1),
                            a0[:, None] * bv + b0[:, None] * av + np.cross(av, bv)])


def _qx(angle: np.ndarray) -> np.ndarray:
    return np.column_stack([np.cos(angle / 2), np.sin(angle / 2), np.zeros_like(angle), np.zeros_like(angle)])


def _random_q_dq(n: int = 40) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(23)
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    dq = rng.normal(size=(n, 4))
    return q, dq


def test_tilt_rate_and_yaw_rate_are_the_body_rate_2_vec_dq_conj_q_with_every_cross_term():
    q, dq = _random_q_dq()
    assert np.all(np.abs(q) > 1e-3) and np.all(np.abs(dq) > 1e-3)  # every cross term contributes
    conj = q * np.array([1.0, -1, -1, -1])
    omega = 2 * _hamilton(dq, conj)[:, 1:]
    x = np.zeros((q.shape[0], 12))
    x[:, 2:6], x[:, 8:12] = q, dq
    np.testing.assert_allclose(tilt_rate_deg_s(x), np.degrees(np.hypot(omega[:, 0], omega[:, 1])),
                               rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(_yaw_rate(x), omega[:, 2], rtol=1e-12, atol=1e-12)


def test_tilt_rate_of_a_world_frame_rate_is_its_horizontal_part():
    # a world-frame rate w from a yawed and tilted attitude: dq = 1/2 (0, w) o q
    w = np.array([0.3, -0.2, 0.7])
    q0 = np.array([[math.cos(0.4), 0.1, -0.2, math.sin(0.4)]])
    q0 /= np.linalg.norm(q0)
    q = q0
    dq = 0.5 * _hamilton(np.array([[0.0, *w]]), q)  # dq/dt = 1/2 (0, w) o q
    x = np.zeros((1, 12))
    x[:, 2:6], x[:, 8:12] = q, dq
    assert tilt_rate_deg_s(x)[0] == pytest.approx(math.degrees(math.hypot(0.3, -0.2)), rel=1e-12)
    assert _yaw_rate(x)[0] == pytest.approx(0.7, rel=1e-12)


def _attitude_log(roll_deg: np.ndarray) -> dict:
    n = roll_deg.size
    state = np.zeros((n + 1, 12))
    state[:-1, 2:6] = _qx(np.radians(roll_deg))
    state[-1] = state[-2]
    return {"time": np.arange(n + 1) * TS, "state": state,
            "q_ref": np.tile([1.0, 0, 0, 0], (n, 1))}


def test_settling_time_is_the_sample_after_the_last_one_outside_the_band():
    err = np.full(100, 0.02)
    err[:8] = 1.0        # last sample outside the 0.1 deg band: k = 7
    err[48], err[49] = 0.09, 0.08   # t = 0.48 just before, t = 0.49 first inside the last 0.5 s
    m = zero_metrics(_attitude_log(err), window_s=0.5, band_deg=0.1)
    assert m["settling_time_s"] == pytest.approx(8 * TS, abs=1e-12)
    assert m["steady_state_error_deg"] == pytest.approx(0.08, rel=1e-9)
    assert m["max_error_deg"] == pytest.approx(1.0, rel=1e-9)
    # a negative error counts by its size; never settling inside the run is inf; never out is 0
    m = zero_metrics(_attitude_log(-err), window_s=0.5, band_deg=0.1)
    assert m["settling_time_s"] == pytest.approx(8 * TS, abs=1e-12)
    late = err.copy()
    late[-1] = 0.5
    assert zero_metrics(_attitude_log(late), band_deg=0.1)["settling_time_s"] == math.inf
    assert zero_metrics(_attitude_log(np.full(100, 0.05)), band_deg=0.1)["settling_time_s"] == 0.0


def test_push_recovery_counts_from_the_push_to_the_sample_after_the_last_tilt_outside_the_band():
    tilt = np.full(100, 0.01)
    tilt[5] = 3.0                      # before the push: ignored
    tilt[30:42] = np.linspace(4.0, 0.5, 12)   # after the push at t = 0.30: last outside k = 41
    log = _attitude_log(tilt)
    m = push_metrics(log, 0.30, band_deg=0.1)
    assert m["recovery_time_s"] == pytest.approx(42 * TS - 0.30, abs=1e-12)
    assert m["push_max_tilt_deg"] == pytest.approx(4.0, rel=1e-9)
    tilt[-1] = 1.0
    assert push_metrics(_attitude_log(tilt), 0.30)["recovery_time_s"] == math.inf


def test_limit_metrics_count_commands_at_the_limit_and_read_the_first_sample():
    roll = np.array([2.0, 1.0, 0.5, 0.1])
    log = _attitude_log(roll)
    log["state"][0, 8:12] = 0.5 * _hamilton(np.array([[0.0, 0.1, 0.0, 0.0]]), log["state"][:1, 2:6])
    log["tau_cmd"] = np.array([[0.1, -0.2, 0.0], [0.0, -1.0, 0.3], [0.2, 0.2, 0.2], [1.5, 0.0, 0.0]])
    log["dq_ref"] = np.zeros((4, 4))
    m = limit_metrics(log, tau_max=1.0)
    assert m["torque_saturated_fraction"] == pytest.approx(0.5, abs=1e-15)
    assert m["peak_torque_nm"] == pytest.approx(1.5, abs=1e-15)
    assert m["initial_tilt_deg"] == pytest.approx(2.0, rel=1e-9)
    assert m["initial_tilt_rate_deg_s"] == pytest.approx(math.degrees(0.1), rel=1e-9)
    assert m["peak_tilt_deg"] == pytest.approx(2.0, rel=1e-9)


def test_sliding_fit_window_spans_the_given_number_of_local_periods():
    # constant 1 Hz "chirp": a 3-cycle window is 3 s, so the first centre with a full
    # window is t0 + 1.5 s and the last t_end - 1.5 s
    t = np.arange(0.0, 10.0 + 1e-9, TS)
    phi, f = chirp_phase(t, 1.0, 1.0, 10.0)
    r = np.sin(phi)
    resp = sliding_response(t, r, r, phi, f, cycles=3.0, step_s=0.25)
    assert resp["t"][0] == pytest.approx(1.5, abs=1e-9)
    assert resp["t"][-1] == pytest.approx(8.5, abs=1e-9)
    # an output whose amplitude doubles at t = 5 s: a window centred at 6.25 s holds
    # only doubled samples with the 3 s window (it starts at 4.75 s: one quarter of old ones)
    y = np.where(t < 5.0, 1.0, 2.0) * r
    resp = sliding_response(t, y, r, phi, f, cycles=3.0, step_s=0.25)
    k = int(np.argmin(np.abs(resp["t"] - 6.75)))
    assert resp["gain"][k] == pytest.approx(2.0, rel=1e-9)
    k = int(np.argmin(np.abs(resp["t"] - 3.25)))
    assert resp["gain"][k] == pytest.approx(1.0, rel=1e-9)
    # the window is clipped to min_window_s at high frequency: 20 Hz, 3 cycles = 0.15 s < 0.5 s
    phi, f = chirp_phase(t, 20.0, 20.0, 10.0)
    resp = sliding_response(t, np.sin(phi), np.sin(phi), phi, f, cycles=3.0, step_s=0.25)
    assert resp["t"][0] == pytest.approx(0.25, abs=1e-9)

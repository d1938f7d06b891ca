"""The sensor helpers against hand values: the heading sensor's schedule at a rate that
does not divide the control rate (and exactly on a sample instant), its refusals, the
angle wrap, the encoder rounding and the gyroscope bias step."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.core.sensor_params import load_sensor_params
from ballbot_casadi.errors import ShapeError
from ballbot_casadi.model.sensors import (
    HEADING_SCHEDULE_EPS,
    NOISE_STREAMS,
    SENSOR_NAMES,
    encoder_count,
    heading_schedule,
    make_encoders,
    make_gyro_bias_step,
    wrap_angle,
)
from ballbot_casadi.core.params import load_params


def test_schedule_at_three_hertz_hits_the_periods_holding_j_over_three_seconds():
    # instants 0, 1/3, 2/3, 1 s at Ts = 5 ms: periods 0, 66 (0.330-0.335), 133, 200 (exact)
    on = np.nonzero(heading_schedule(0, 201, 0.005, 3.0))[0]
    np.testing.assert_array_equal(on, [0, 66, 133, 200])
    np.testing.assert_array_equal(np.nonzero(heading_schedule(60, 140, 0.005, 3.0))[0] + 60,
                                  [66, 133])
    # 200 Hz: every period; 400 Hz: still one flag per period
    assert heading_schedule(0, 7, 0.005, 200.0).tolist() == [1.0] * 7
    assert heading_schedule(5, 9, 0.005, 400.0).tolist() == [1.0] * 4
    assert heading_schedule(3, 3, 0.005, 10.0).size == 0
    assert HEADING_SCHEDULE_EPS == 1e-9


@pytest.mark.parametrize("Ts,rate", [(0.005, -1.0), (0.0, 10.0), (-0.005, 10.0),
                                     (0.005, math.nan), (math.inf, 10.0), (0.005, math.inf)])
def test_schedule_refuses_a_negative_rate_or_a_non_positive_period(Ts, rate):
    with pytest.raises(ShapeError, match="heading schedule needs rate >= 0 and Ts > 0"):
        heading_schedule(0, 10, Ts, rate)


def test_wrap_angle_numpy_and_casadi():
    a = np.array([0.0, math.pi, -math.pi + 1e-9, 1.5 * math.pi, -2.5 * math.pi, 7.0])
    want = np.array([0.0, math.pi, -math.pi + 1e-9, -0.5 * math.pi, -0.5 * math.pi,
                     7.0 - 2 * math.pi])
    np.testing.assert_allclose(wrap_angle(a), want, rtol=0, atol=1e-12)
    x = ca.SX.sym("x")
    f = ca.Function("w", [x], [wrap_angle(x)])
    np.testing.assert_allclose([float(f(v)) for v in a], want, rtol=0, atol=1e-12)


def test_encoder_count_rounds_halves_away_from_zero_in_numpy_and_casadi():
    n = 2 * math.pi  # one tick per radian
    phi = np.array([2.5, -2.5, 2.4999, -2.5001, 0.0, 0.49])
    want = [3.0, -3.0, 2.0, -3.0, 0.0, 0.0]
    np.testing.assert_array_equal(encoder_count(phi, n), want)
    x = ca.SX.sym("x")
    f = ca.Function("c", [x], [encoder_count(x, n)])
    assert [float(f(v)) for v in phi] == want


def test_encoder_increment_and_rate_over_a_period():
    P = load_params()
    p = P.to_vector()
    per_rad = P.n_ticks / (2 * math.pi)
    phi_prev = np.array([10.2, -3.0, 0.0]) / per_rad  # counts 10, -3, 0
    phi = np.array([13.6, -7.5, 0.4]) / per_rad  # counts 14, -8, 0
    enc, dticks = (np.asarray(o, float).ravel() for o in make_encoders()(phi, phi_prev, p, 0.004))
    np.testing.assert_array_equal(dticks, [4.0, -5.0, 0.0])
    np.testing.assert_allclose(enc, [1000.0, -1250.0, 0.0], rtol=1e-12)


def test_gyro_bias_step_adds_sqrt_ts_sigma_n_per_axis():
    s = load_sensor_params().replace(gyro_bias_rw=[1e-3, 2e-3, 4e-3])
    b = np.asarray(make_gyro_bias_step()([0.1, -0.2, 0.3], s.to_vector(), 0.04, [1.0, -2.0, 0.5]),
                   float).ravel()
    np.testing.assert_allclose(b, [0.1 + 0.2 * 1e-3, -0.2 - 0.4 * 2e-3, 0.3 + 0.1 * 4e-3],
                               rtol=1e-14)


def test_sensor_names_and_noise_streams():
    assert SENSOR_NAMES == ("acc", "gyro", "enc")
    assert dict(NOISE_STREAMS) == {"acc": 0, "gyro": 1, "gyro_bias_rw": 2, "enc": 3, "heading": 4}

"""Sensor parameter record (thesis §3.1): defaults, vector layout, file loading, validation."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from ballbot_casadi.core.params import PARAM_NAMES, load_params
from ballbot_casadi.core.sensor_params import (
    NS,
    SENSOR_PARAM_NAMES,
    SENSOR_VECTOR_NAMES,
    SensorParams,
    SensorView,
    load_sensor_params,
)
from ballbot_casadi.errors import BallbotTypeError, ParameterError


def test_defaults_are_thesis_values():
    s = load_sensor_params()
    # diagonals of thesis (3.4) and (3.8), MPU-9250 measurements
    assert s.acc_noise_var == pytest.approx((0.3945e-3, 0.3922e-3, 0.9941e-3), rel=0, abs=1e-18)
    assert s.gyro_noise_var == pytest.approx((0.4969e-3, 0.1749e-3, 1.3970e-3), rel=0, abs=1e-18)
    assert s.enc_noise_var == (1 / 9, 1 / 9, 1 / 9)  # Sigma_enc = I/9, (3.17), exactly
    # calibrated IMU at the ball centre (3.6), (3.10), (5.18)
    assert s.acc_bias == s.gyro_bias0 == s.imu_position == s.imu_misalignment == (0.0, 0.0, 0.0)
    assert s.acc_scale == s.gyro_scale == (1.0, 1.0, 1.0)
    assert all(0 < v < 1e-3 for v in s.gyro_bias_rw)
    assert "n_ticks" in PARAM_NAMES and not any("tick" in n for n in SENSOR_PARAM_NAMES)


def test_vector_layout_and_round_trip():
    s = load_sensor_params(acc_bias=[0.1, -0.2, 0.3], enc_noise_var=[1.0, 2.0, 3.0])
    v = s.to_vector()
    assert NS == 33 and v.shape == (NS,) and s.names == SENSOR_VECTOR_NAMES
    assert SENSOR_VECTOR_NAMES[3:6] == ("acc_bias_x", "acc_bias_y", "acc_bias_z")
    assert SENSOR_VECTOR_NAMES[-6:-3] == ("enc_noise_var_0", "enc_noise_var_1", "enc_noise_var_2")
    assert SENSOR_VECTOR_NAMES[-3:] == ("heading_noise_var_yaw", "heading_bias_yaw",
                                        "heading_rate_yaw")
    for i, name in enumerate(SENSOR_VECTOR_NAMES):
        field, comp = name.rsplit("_", 1)
        idx = "xyz".index(comp) if comp in "xyz" else 0 if comp == "yaw" else int(comp)
        assert v[i] == getattr(s, field)[idx]
    assert SensorParams.from_vector(v) == s
    view = SensorView(v)
    np.testing.assert_array_equal(view.acc_bias, [0.1, -0.2, 0.3])
    np.testing.assert_array_equal(SensorView(s).enc_noise_var, [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(s.enc_noise_cov, np.diag([1.0, 2.0, 3.0]))
    np.testing.assert_array_equal(s.gyro_bias_cov, np.diag(np.square(s.gyro_bias_rw)))
    with pytest.raises(AttributeError, match="unknown sensor parameter 'n_ticks'"):
        _ = view.n_ticks
    with pytest.raises(ParameterError, match="expected 33"):
        SensorView(np.ones(29))
    with pytest.raises(ParameterError, match="expected 33"):
        SensorParams.from_vector(np.ones(3))


def test_immutable_and_replace():
    s = load_sensor_params()
    with pytest.raises(AttributeError):
        s.acc_bias = (1.0, 0.0, 0.0)
    t = s.replace(imu_misalignment=["1 deg", 0, "-2deg"], acc_scale=np.array([1.01, 0.99, 1.0]))
    assert t.imu_misalignment == pytest.approx((math.radians(1), 0, math.radians(-2)), abs=1e-16)
    assert t.acc_scale == (1.01, 0.99, 1.0) and s.acc_scale == (1.0, 1.0, 1.0)
    with pytest.raises(ParameterError, match="unknown sensor parameter"):
        s.replace(acc_biass=[0, 0, 0])


def test_file_sensors_table_read_here_and_skipped_by_load_params(tmp_path):
    f = tmp_path / "robot.toml"
    f.write_text(
        "[body]\nMb = 18.5\n"
        "[sensors]\ngyro_bias0 = [0.01, -0.02, 0.0]\n"
        "[sensors.imu]\nimu_position = [0.0, 0.0, 0.4]\n"
    )
    s = load_sensor_params(f, acc_bias=[0.0, 0.0, 0.05])
    assert s.gyro_bias0 == (0.01, -0.02, 0.0) and s.imu_position == (0.0, 0.0, 0.4)
    assert s.acc_bias == (0.0, 0.0, 0.05)
    assert s.acc_noise_var == load_sensor_params().acc_noise_var  # rest from the defaults
    assert load_params(f).Mb == 18.5  # the [sensors] table does not disturb the model
    plain = tmp_path / "plain.toml"
    plain.write_text("[body]\nMb = 17.0\n")
    assert load_sensor_params(plain) == load_sensor_params()


@pytest.mark.parametrize(
    "kw, fragment",
    [
        ({"acc_noise_var": [-1e-4, 1e-4, 1e-4]}, "'acc_noise_var_x'.*>= 0"),
        ({"gyro_noise_var": [1e-4, float("nan"), 1e-4]}, "'gyro_noise_var_y'"),
        ({"enc_noise_var": [0.1, 0.1, float("inf")]}, "'enc_noise_var_2'"),
        ({"gyro_bias_rw": [0.0, -1e-9, 0.0]}, "'gyro_bias_rw_y'"),
        ({"acc_scale": [1.0, 0.0, 1.0]}, "'acc_scale_y'.*> 0"),
        ({"acc_bias": [0.0, 0.0]}, "'acc_bias'.*list of 3 numbers"),
        ({"acc_bias": 0.0}, "'acc_bias'.*list of 3 numbers"),
        ({"acc_bias": "0 0 0"}, "'acc_bias'.*list of 3 numbers"),
        ({"imu_position": [0, 0, 0, 0]}, "'imu_position'.*list of 3"),
        ({"imu_misalignment": [0.0, 0.0, 1.0]}, "'imu_misalignment_z'.*45 deg"),
        ({"imu_misalignment": ["50 deg", 0, 0]}, "'imu_misalignment_x'"),
        ({"mass": [1, 2, 3]}, "unknown sensor parameter.*allowed names: acc_noise_var"),
    ],
)
def test_invalid_values_rejected(kw, fragment):
    with pytest.raises(ParameterError, match=fragment):
        load_sensor_params(**kw)


@pytest.mark.parametrize("value", [[True, 0, 0], [None, 0, 0], ["x", 0, 0], ["1 deg", 0, 0]])
def test_wrong_entry_types_rejected(value):
    with pytest.raises(BallbotTypeError, match="'acc_bias_x'"):
        load_sensor_params(acc_bias=value)


def test_range_boundaries_exactly():
    """On each boundary: closed sides accepted, open sides and one ulp outside rejected."""
    tiny = 5e-324
    lim = math.pi / 4
    ok = [
        {"acc_noise_var": [0.0, 0.0, 0.0]},
        {"gyro_bias_rw": [0.0, 0.0, 0.0]},
        {"acc_scale": [tiny, tiny, tiny]},
        {"imu_misalignment": [lim, -lim, 0.0]},
    ]
    bad = [
        {"acc_noise_var": [-tiny, 0.0, 0.0]},
        {"gyro_scale": [0.0, 1.0, 1.0]},
        {"imu_misalignment": [math.nextafter(lim, 1.0), 0.0, 0.0]},
        {"imu_misalignment": [0.0, math.nextafter(-lim, -1.0), 0.0]},
    ]
    for kw in ok:
        load_sensor_params(**kw)
    for kw in bad:
        with pytest.raises(ParameterError):
            load_sensor_params(**kw)


def test_bad_files(tmp_path):
    unknown = tmp_path / "unknown.toml"
    unknown.write_text("[sensors]\nacc_noise = [1, 1, 1]\n")
    with pytest.raises(ParameterError, match="unknown sensor parameter.*'acc_noise'"):
        load_sensor_params(unknown)
    not_table = tmp_path / "not_table.toml"
    not_table.write_text("sensors = 3\n")
    with pytest.raises(ParameterError, match="must be a table"):
        load_sensor_params(not_table)
    with pytest.raises(ParameterError, match="must be a table"):
        load_params(not_table)
    dup = tmp_path / "dup.toml"
    dup.write_text("[sensors.a]\nacc_bias = [0, 0, 0]\n[sensors.b]\nacc_bias = [1, 0, 0]\n")
    with pytest.raises(ParameterError, match="given twice"):
        load_sensor_params(dup)
    negative = tmp_path / "negative.toml"
    negative.write_text("[sensors]\ngyro_noise_var = [1e-4, 1e-4, -1e-4]\n")
    with pytest.raises(ParameterError, match="'gyro_noise_var_z'"):
        load_sensor_params(negative)
    with pytest.raises(ParameterError, match="does not exist"):
        load_sensor_params(tmp_path / "missing.toml")
    misplaced = tmp_path / "misplaced.toml"
    misplaced.write_text("[body]\nacc_bias = [0, 0, 0]\n")  # sensor name outside [sensors]
    with pytest.raises(ParameterError, match=r"unknown parameter.*\[sensors\] table"):
        load_params(misplaced)


def test_noise_covariances_are_the_diagonal_of_the_per_axis_variances():
    """Sigma_acc and Sigma_gyro, thesis (3.4) and (3.8): each axis its own variance."""
    s = dataclasses.replace(load_sensor_params(), acc_noise_var=(1e-3, 2e-3, 3e-3),
                            gyro_noise_var=(4e-6, 5e-6, 6e-6))
    np.testing.assert_array_equal(s.acc_noise_cov, np.diag([1e-3, 2e-3, 3e-3]))
    np.testing.assert_array_equal(s.gyro_noise_cov, np.diag([4e-6, 5e-6, 6e-6]))

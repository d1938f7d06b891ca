"""Sensor parameters (thesis §3.1) as an immutable, validated record.

Every IMU and encoder parameter is a 3-vector: one entry per IMU axis (x, y, z of the
IMU frame, which is the body frame unless ``imu_misalignment`` rotates it) or per wheel
encoder (wheels 0, 1, 2 in the thesis wheel order); the heading sensor's parameters
have one entry (``yaw``).  The flat vector ``s``
(:meth:`SensorParams.to_vector`, order of :data:`SENSOR_VECTOR_NAMES`) is a runtime
input of the noisy sensor Functions of :mod:`ballbot_casadi.model.sensors`, like the
model parameter vector ``p``.

Defaults and sources (``[sensors]`` table of ``default_params.toml``):

==================  ====================  ======================================  ==================
name                unit                  default                                 source
==================  ====================  ======================================  ==================
acc_noise_var       (m/s2)^2              [0.3945e-3, 0.3922e-3, 0.9941e-3]       diag of (3.4)
acc_bias            m/s2                  [0, 0, 0]                               calibrated (3.6)
acc_scale           1                     [1, 1, 1]                               K_acc = I (3.6)
gyro_noise_var      (rad/s)^2             [0.4969e-3, 0.1749e-3, 1.3970e-3]       diag of (3.8)
gyro_scale          1                     [1, 1, 1]                               K_gyro = I (3.10)
gyro_bias0          rad/s                 [0, 0, 0]                               calibrated (3.10)
gyro_bias_rw        rad/s/sqrt(s)         [2e-5, 2e-5, 2e-5]                      see below (3.9)
imu_position        m                     [0, 0, 0]                               ball centre (5.18)
imu_misalignment    rad                   [0, 0, 0]                               calibrated (3.6)
enc_noise_var       tick^2                [1/9, 1/9, 1/9]                         (3.16)-(3.17)
heading_noise_var   rad^2                 [(0.2 deg)^2] = [1.2185e-5]             see below
heading_bias        rad                   [0]                                     see below
heading_rate        Hz                    [10]                                    see below
==================  ====================  ======================================  ==================

* The noise covariances (3.4) and (3.8) were measured on an MPU-9250 (thesis §3.1,
  from the predecessor project); only their diagonals are kept (the largest
  off-diagonal correlation coefficient is 0.04 for the accelerometer and 0.07 for the
  gyroscope).
* The thesis assumes a calibrated IMU expressed in the body frame ((3.6), (3.10)):
  zero bias, unit scale factors, no misalignment.  Realistic *uncalibrated*
  MPU-9250 values, for robustness studies, are of the order of the data-sheet
  tolerances: accelerometer zero-g offset +-60 mg (x, y) and +-80 mg (z), gyroscope
  zero-rate offset +-5 deg/s, sensitivity (scale-factor) tolerance +-3 %.
* ``gyro_bias_rw`` is the standard deviation density sigma_rw of the bias rate
  w_bias of (3.9), ``Sigma_bias = diag(sigma_rw^2)`` (rad^2/s^3): over a step Ts the
  bias changes by ``sqrt(Ts) sigma_rw n``, n ~ N(0, 1), so its variance grows as
  ``sigma_rw^2 t``.  The thesis leaves Sigma_bias tunable; 2e-5 rad/s/sqrt(s)
  (0.07 deg/s drift standard deviation after one hour) is an order-of-magnitude value
  for a consumer MEMS gyroscope of the MPU-9250 class (industrial MEMS IMUs reach a few
  1e-6).
* ``imu_position`` is the IMU location in the body frame measured from the ball
  centre.  The thesis' accelerometer measurement model (5.18) has no lever arm, i.e.
  the IMU at the ball centre; that is the default.  A real mounting point adds the
  rotational acceleration of the lever arm (see ``ballbot_imu``).
* ``enc_noise_var`` is Sigma_enc = I/9 of thesis (3.16)-(3.17), the covariance the
  filters assume for the per-sample tick count ``Delta i_ticks``: the quantisation
  error is at most one tick, taken as 3 sigma, so sigma_enc = 1/3 tick per sample
  (in ticks/s at a sample period Ts: sigma_enc / Ts).  The simulated encoders
  (``ballbot_encoders``) quantise instead of adding this noise; their actual error
  variance is about 1/6 tick^2 when the wheels turn through many ticks per sample.
* ``n_ticks`` (encoder ticks per revolution) stays a model parameter (App. A).
* The **heading sensor** is not part of the thesis's robot (§3.1; its ch. 11 names the
  missing heading correction): an absolute yaw reading (ZYX yaw of the body in {K}, e.g.
  a dual-antenna GNSS compass or an external optical tracker) sampled at
  ``heading_rate`` (0 = no heading sensor) with white noise of variance
  ``heading_noise_var`` and a constant offset ``heading_bias``.  0.2 deg standard
  deviation at 10 Hz is an order-of-magnitude value of a dual-antenna GNSS heading with
  a 2 m baseline or an optical tracker (a magnetometer indoors is far worse and biased
  by the motors).
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from pathlib import Path
from types import MappingProxyType
from typing import Any, Mapping

import numpy as np

from ballbot_casadi.core.params import (
    SENSOR_TABLE,
    check_value,
    flatten_tables,
    layered_values,
    read_param_file,
    to_float,
)
from ballbot_casadi.errors import ParameterError

__all__ = [
    "SENSOR_PARAM_INFO",
    "SENSOR_PARAM_NAMES",
    "SENSOR_VECTOR_NAMES",
    "NS",
    "SENSOR_SLICES",
    "SensorParams",
    "SensorView",
    "load_sensor_params",
]

_XYZ = ("x", "y", "z")
_WHEELS = ("0", "1", "2")
_YAW = ("yaw",)

# name: (unit, description, rule key of params.PARAM_RULES, component labels)
SENSOR_PARAM_INFO: Mapping[str, tuple[str, str, str, tuple[str, ...]]] = MappingProxyType({
    "acc_noise_var": ("(m/s2)2", "accelerometer white-noise variance, diag of Sigma_acc (3.4)",
                      "nonneg", _XYZ),
    "acc_bias": ("m/s2", "accelerometer bias b_acc (3.3)", "any", _XYZ),
    "acc_scale": ("1", "accelerometer scale factors, diag of K_acc (3.3)", "pos", _XYZ),
    "gyro_noise_var": ("(rad/s)2", "gyroscope white-noise variance, diag of Sigma_gyro (3.8)",
                       "nonneg", _XYZ),
    "gyro_scale": ("1", "gyroscope scale factors, diag of K_gyro (3.7)", "pos", _XYZ),
    "gyro_bias0": ("rad/s", "initial gyroscope bias b_gyro(0) (3.7)", "any", _XYZ),
    "gyro_bias_rw": ("rad/s/sqrt(s)",
                     "gyroscope bias random walk sigma_rw, Sigma_bias = diag(sigma_rw^2) (3.9)",
                     "nonneg", _XYZ),
    "imu_position": ("m", "IMU location in the body frame from the ball centre", "any", _XYZ),
    "imu_misalignment": ("rad", "rotation vector of the IMU frame in the body frame",
                         "misalignment", _XYZ),
    "enc_noise_var": ("tick2", "encoder count variance per sample, diag of Sigma_enc (3.17)",
                      "nonneg", _WHEELS),
    "heading_noise_var": ("rad2", "heading-sensor white-noise variance", "nonneg", _YAW),
    "heading_bias": ("rad", "heading-sensor constant offset", "any", _YAW),
    "heading_rate": ("Hz", "heading-sensor sample rate (0: no heading sensor)", "nonneg", _YAW),
})

#: Sensor parameter names (each a 3-vector), in vector order.
SENSOR_PARAM_NAMES: tuple[str, ...] = tuple(SENSOR_PARAM_INFO)

#: Names of the entries of the flat sensor vector ``s`` (e.g. ``acc_bias_x``).
SENSOR_VECTOR_NAMES: tuple[str, ...] = tuple(
    f"{name}_{c}" for name, info in SENSOR_PARAM_INFO.items() for c in info[3]
)

#: Length of the sensor parameter vector ``s``.
NS = len(SENSOR_VECTOR_NAMES)

#: Position of each sensor parameter in ``s`` (a slice over its components).
SENSOR_SLICES: Mapping[str, slice] = MappingProxyType({
    name: slice(SENSOR_VECTOR_NAMES.index(f"{name}_{info[3][0]}"),
                SENSOR_VECTOR_NAMES.index(f"{name}_{info[3][0]}") + len(info[3]))
    for name, info in SENSOR_PARAM_INFO.items()})


def _to_triple(name: str, value: Any) -> tuple[float, float, float]:
    unit, _, rule, comps = SENSOR_PARAM_INFO[name]
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if not isinstance(value, (list, tuple)) or len(value) != len(comps):
        raise ParameterError(
            f"sensor parameter {name!r} = {value!r} is invalid: must be a list of "
            f"{len(comps)} numbers [{', '.join(comps)}] in {unit}"
        )
    out = []
    for c, raw in zip(comps, value):
        label = f"{name}_{c}"
        v = to_float(label, raw, unit)
        check_value(label, v, rule, unit, raw)
        out.append(v)
    return tuple(out)  # type: ignore[return-value]


@dataclass(frozen=True)
class SensorParams:
    """Immutable, validated sensor parameter set (thesis §3.1; SI units, radians).

    Build it with :func:`load_sensor_params`.  Each field is a tuple of floats (3, or 1
    for the heading sensor); see the module docstring for units, defaults and sources.
    """

    acc_noise_var: tuple[float, float, float]
    acc_bias: tuple[float, float, float]
    acc_scale: tuple[float, float, float]
    gyro_noise_var: tuple[float, float, float]
    gyro_scale: tuple[float, float, float]
    gyro_bias0: tuple[float, float, float]
    gyro_bias_rw: tuple[float, float, float]
    imu_position: tuple[float, float, float]
    imu_misalignment: tuple[float, float, float]
    enc_noise_var: tuple[float, float, float]
    heading_noise_var: tuple[float]
    heading_bias: tuple[float]
    heading_rate: tuple[float]

    def __post_init__(self) -> None:
        for f in fields(self):
            object.__setattr__(self, f.name, _to_triple(f.name, getattr(self, f.name)))

    @property
    def names(self) -> tuple[str, ...]:
        """Names of the entries of :meth:`to_vector` (``acc_noise_var_x``, ...)."""
        return SENSOR_VECTOR_NAMES

    def to_vector(self) -> np.ndarray:
        """Sensor parameter vector ``s`` (float64, length :data:`NS`)."""
        return np.array([v for n in SENSOR_PARAM_NAMES for v in getattr(self, n)], dtype=float)

    def as_dict(self) -> dict[str, tuple[float, ...]]:
        """Plain ``{name: (v0, ...)}`` dictionary in vector order."""
        return {n: getattr(self, n) for n in SENSOR_PARAM_NAMES}

    def replace(self, **overrides: Any) -> "SensorParams":
        """Return a copy with some parameters changed (validated)."""
        _reject_unknown(overrides)
        return SensorParams(**{**self.as_dict(), **overrides})

    @classmethod
    def from_vector(cls, s: Any) -> "SensorParams":
        """Build from a sensor vector in :data:`SENSOR_VECTOR_NAMES` order."""
        arr = np.asarray(s, dtype=float).ravel()
        if arr.size != NS:
            raise ParameterError(f"sensor parameter vector has {arr.size} entries, expected {NS}")
        return cls(**{n: arr[SENSOR_SLICES[n]].tolist() for n in SENSOR_PARAM_NAMES})

    @property
    def acc_noise_cov(self) -> np.ndarray:
        """Sigma_acc (3x3 diagonal, (m/s^2)^2), thesis (3.4)."""
        return np.diag(self.acc_noise_var)

    @property
    def gyro_noise_cov(self) -> np.ndarray:
        """Sigma_gyro (3x3 diagonal, (rad/s)^2), thesis (3.8)."""
        return np.diag(self.gyro_noise_var)

    @property
    def gyro_bias_cov(self) -> np.ndarray:
        """Sigma_bias = diag(sigma_rw^2) (rad^2/s^3), intensity of w_bias in thesis (3.9)."""
        return np.diag(np.square(self.gyro_bias_rw))

    @property
    def enc_noise_cov(self) -> np.ndarray:
        """Sigma_enc (3x3 diagonal, ticks^2 per sample), thesis (3.17)."""
        return np.diag(self.enc_noise_var)


def _reject_unknown(values: Mapping[str, Any]) -> None:
    unknown = sorted(set(values) - set(SENSOR_PARAM_NAMES))
    if unknown:
        raise ParameterError(
            f"unknown sensor parameter name(s) {unknown}; allowed names: "
            f"{', '.join(SENSOR_PARAM_NAMES)}"
        )


def _sensor_values(path: Path) -> dict[str, Any]:
    _, table = read_param_file(path)
    values = flatten_tables(table, f"{path} [{SENSOR_TABLE}]")
    _reject_unknown(values)
    return values


def load_sensor_params(path: str | Path | None = None, **overrides: Any) -> SensorParams:
    """Load the sensor parameters from the ``[sensors]`` table of a parameter file.

    Parameters
    ----------
    path
        TOML parameter file (the same file :func:`~ballbot_casadi.core.params.load_params`
        reads).  Its ``[sensors]`` table may give any subset of the sensor parameters;
        the rest come from the packaged defaults.  ``None`` loads the defaults.
    **overrides
        Values (lists of 3 numbers) that replace those of the file.

    Returns
    -------
    SensorParams
        The validated, immutable sensor parameter set.

    Raises
    ------
    ParameterError
        Unknown name, missing file, wrong length, non-finite value, negative variance,
        non-positive scale factor or too large misalignment.
    BallbotTypeError
        An entry of the wrong type.
    """
    return SensorParams(**layered_values(_sensor_values, _reject_unknown, SENSOR_PARAM_NAMES, path,
                                         overrides, "sensor parameters"))


class SensorView:
    """Attribute access to the parameters of a sensor vector ``s`` (numpy or CasADi).

    ``SensorView(s).acc_bias`` is ``s[SENSOR_SLICES["acc_bias"]]``; used by the symbolic sensor models so that
    sensor parameters stay runtime inputs of the generated Functions.
    """

    __slots__ = ("_s",)

    def __init__(self, s: Any) -> None:
        if isinstance(s, SensorParams):
            s = s.to_vector()
        n = s.numel() if hasattr(s, "numel") else np.asarray(s).size
        if n != NS:
            raise ParameterError(f"sensor parameter vector has {n} entries, expected {NS}")
        self._s = s

    def __getattr__(self, name: str) -> Any:
        try:
            sl = SENSOR_SLICES[name]
        except KeyError:
            raise AttributeError(f"unknown sensor parameter {name!r}") from None
        return self._s[sl]

"""State estimators of the ballbot (thesis ch. 3-6): QUKF, VUKF and the predecessor's EKFs.

Every estimator is a CasADi Function ``ballbot_<name>``; one call is one filter period
(predict + correct).  They are built from a generic filter core
(:mod:`~ballbot_casadi.estimation.core`) that knows only CasADi Functions for the
process and measurement models and the state manifold
(:mod:`~ballbot_casadi.estimation.manifold`).  The estimators never import the model:
the velocity filters receive the wheel kinematics as a Function.

======  =====================================================  =========  ==========
name    filter                                                 P          builder
======  =====================================================  =========  ==========
qukf    quaternion UKF, attitude and rate (thesis ch. 4)       6 x 6      make_qukf()
qekf    predecessor's additive quaternion EKF (baseline)       7 x 7      make_qekf()
vukf    velocity UKF (thesis ch. 5)                            7 x 7      make_vukf(ws)
vekf    predecessor's velocity EKF (baseline)                  7 x 7      make_vekf(ws)
qukf_   heading-aided QUKF, z gyro bias a state (thesis 4.30)  7 x 7      make_qukf_
heading                                                                   heading()
qekf_   predecessor's QEKF: heading reading, 3 gyro biases     10 x 10    make_qekf_
heading (thesis §6, V2019)                                                heading()
======  =====================================================  =========  ==========

``ws`` is the model's ``ballbot_wheel_speeds`` Function.  ``make_tilt_correction()``
(:mod:`~ballbot_casadi.estimation.tilt_aiding`) combines the two: the attitude filter's
slow tilt error, read from the velocity filter's accelerometer bias.  Inputs and outputs:

* attitude: ``(xhat[7], P, z[6], Q[6x6], R[6x6], dt, p[NP])`` ->
  ``(xhat_next, P_next, nu[6], nis, n_valid, n_repair, P_att[3x3])``;
* velocity: ``(xhat[7], P[7x7], z[6], att[7], P_att[3x3], Q[7x7], R[6x6], dt, p[NP])`` ->
  ``(xhat_next, P_next, nu[6], nis, n_valid, n_repair)``.

:data:`DEFAULT_TUNING` holds the thesis' ``Q``, ``R``, ``P0`` and ``x0`` of every filter
(numbers in :mod:`~ballbot_casadi.estimation.tuning`); :func:`initial_state` returns
fresh copies of the initial state and covariance.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

import casadi as ca
import numpy as np

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.constants import TS_CONTROL
from ballbot_casadi.core.sensor_params import load_sensor_params
from ballbot_casadi.errors import (
    ArgumentError,
    BallbotTypeError,
    ShapeError,
    StateError,
)
from ballbot_casadi.estimation.attitude import (
    make_qekf,
    make_qukf,
    qekf_initial_covariance,
)
from ballbot_casadi.estimation.heading import heading_tuning, make_qukf_heading
from ballbot_casadi.estimation.predecessor import make_qekf_heading, qekf_heading_tuning
from ballbot_casadi.estimation.tuning import (
    QUKF_P0,
    QUKF_Q,
    QUKF_R,
    QUKF_X0,
    VUKF_P0,
    VUKF_Q,
    VUKF_R,
    VUKF_X0,
    read_only,
)
from ballbot_casadi.estimation.tilt_aiding import make_tilt_correction
from ballbot_casadi.estimation.velocity import make_vekf, make_vukf

__all__ = [
    "DEFAULT_TUNING",
    "ESTIMATORS",
    "Tuning",
    "build_estimator",
    "initial_state",
    "make_qekf",
    "make_qukf",
    "make_qukf_heading",
    "make_qekf_heading",
    "make_tilt_correction",
    "make_vekf",
    "make_vukf",
]

#: Estimator name -> builder.  The velocity builders take the wheel-speed Function.
ESTIMATORS: Mapping[str, Callable[..., ca.Function]] = MappingProxyType({
    "qukf": make_qukf,
    "qekf": make_qekf,
    "vukf": make_vukf,
    "vekf": make_vekf,
    "qukf_heading": make_qukf_heading,
    "qekf_heading": make_qekf_heading,
})

_ATTITUDE = ("qukf", "qekf", "qukf_heading", "qekf_heading")


@dataclass(frozen=True)
class Tuning:
    """Default noise covariances and initial condition of one filter (read-only arrays)."""

    Q: np.ndarray
    R: np.ndarray
    P0: np.ndarray
    x0: np.ndarray


# the heading-aided QUKF: the thesis's QUKF tuning with the nominal heading sensor's
# variance and the nominal z gyro bias random walk at the control period
_SENSORS = load_sensor_params()
_HEADING_TUNING = heading_tuning(_SENSORS.heading_noise_var[0], _SENSORS.gyro_bias_rw[2],
                                 TS_CONTROL)
_QEKF_HEADING_TUNING = qekf_heading_tuning(_SENSORS.heading_noise_var[0],
                                           _SENSORS.gyro_bias_rw[2], TS_CONTROL)

#: Thesis default tuning per estimator (see :mod:`~ballbot_casadi.estimation.tuning`).
DEFAULT_TUNING: Mapping[str, Tuning] = MappingProxyType({
    "qukf": Tuning(QUKF_Q, QUKF_R, QUKF_P0, QUKF_X0),
    "qekf": Tuning(QUKF_Q, QUKF_R, read_only(qekf_initial_covariance(QUKF_X0[:4])), QUKF_X0),
    "vukf": Tuning(VUKF_Q, VUKF_R, VUKF_P0, VUKF_X0),
    "vekf": Tuning(VUKF_Q, VUKF_R, VUKF_P0, VUKF_X0),
    "qukf_heading": Tuning(**_HEADING_TUNING),
    "qekf_heading": Tuning(**_QEKF_HEADING_TUNING),
})


def _check_name(name: str) -> None:
    if name not in ESTIMATORS:
        raise ArgumentError(f"unknown estimator {name!r}; allowed: {', '.join(ESTIMATORS)}")


def build_estimator(name: str, wheel_speeds: ca.Function | None = None) -> ca.Function:
    """Build ``ballbot_<name>``; the velocity filters need ``wheel_speeds``.

    Raises
    ------
    ArgumentError
        Unknown name.
    BallbotTypeError
        ``wheel_speeds`` missing for a velocity filter or given to an attitude filter.
    """
    _check_name(name)
    if name in _ATTITUDE:
        if wheel_speeds is not None:
            raise BallbotTypeError(f"estimator {name!r} takes no wheel_speeds Function")
        return ESTIMATORS[name]()
    if wheel_speeds is None:
        raise BallbotTypeError(
            f"estimator {name!r} needs wheel_speeds, e.g. make_model_functions()['wheel_speeds']"
        )
    return ESTIMATORS[name](wheel_speeds)


def initial_state(name: str, x0: Any = None) -> tuple[np.ndarray, np.ndarray]:
    """Fresh ``(xhat0, P0)`` of estimator ``name`` (thesis 4.3-4.4, 5.3-5.4).

    Parameters
    ----------
    name
        One of :data:`ESTIMATORS`.
    x0
        Optional initial state (7 finite numbers) replacing the default; for the
        attitude filters its quaternion must be unit (within 1e-9).  The QEKF's
        covariance is built around that quaternion.

    Raises
    ------
    ArgumentError, ShapeError, StateError
        Unknown name, wrong size, or a non-finite / non-unit initial state.
    """
    _check_name(name)
    tun = DEFAULT_TUNING[name]
    x = np.array(tun.x0 if x0 is None else x0, dtype=float).ravel()
    if x.shape != tun.x0.shape:
        raise ShapeError(f"x0 of {name!r} must have {tun.x0.size} entries, got {x.size}")
    if not np.all(np.isfinite(x)):
        raise StateError(f"x0 of {name!r} must be finite, got {x}")
    if name in _ATTITUDE and abs(Q.norm(x[:4]) - 1.0) > 1e-9:
        raise StateError(
            f"x0 of {name!r}: quaternion norm {Q.norm(x[:4])!r} must be 1 (within 1e-9)"
        )
    P0 = np.array(tun.P0)
    if name in ("qekf", "qekf_heading"):  # the additive chart's covariance around q
        P0[:7, :7] = qekf_initial_covariance(x[:4])
    return x, P0

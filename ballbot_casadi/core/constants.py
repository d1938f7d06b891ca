"""Constants defined once for the whole package.

``TS_CONTROL``
    Control period of the embedded loop: 200 Hz (thesis §7.1, §3.1: the IMU and
    encoders are sampled and the controllers run at 200 Hz).
``N_SUB``
    Classical RK4 sub-steps of the plant per control period in simulation (1 ms plant
    step; converged against 0.25 ms to 1e-11, see the integrator tests).
``THESIS_LIMITS``
    Design specifications of thesis §7.1 (SI units, radians).
"""

from __future__ import annotations

import math
from types import MappingProxyType
from typing import Mapping

__all__ = ["TS_CONTROL", "N_SUB", "THESIS_LIMITS"]

#: Control period (s): 200 Hz, thesis §7.1.
TS_CONTROL = 0.005
#: RK4 sub-steps of the plant per control period (plant step TS_CONTROL / N_SUB = 1 ms).
N_SUB = 5

#: Thesis §7.1 design specifications.
THESIS_LIMITS: Mapping[str, float] = MappingProxyType({
    "v_max": 0.5,  # m/s, translational velocity
    "a_max": 1.0,  # m/s^2, linear acceleration
    "yaw_rate_max": 1.0,  # rad/s, heading velocity
    "yaw_acc_max": 10.0,  # rad/s^2, heading acceleration
    "tilt_max": math.radians(5.0),  # rad, inclination
    "tilt_rate_max": math.radians(20.0),  # rad/s, inclination rate
})

"""The plant FMU's continuous outputs (evaluated lazily from the state) after fmi2DoStep are
those of the stepped state: reading them before a step must not leave stale values behind
(fmi2DoStep marks them for re-evaluation).  The reference is the same FMU forced to
re-evaluate by setting an input to its own value."""

from __future__ import annotations

import numpy as np
import pytest
from _fmu_support import STATES, Plant

from ballbot_casadi.model.numeric import make_state

pytestmark = [pytest.mark.needs_cc]

OUT = ("roll", "pitch", "yaw", "dphi0", "dphi1", "dphi2", "acc_x", "acc_y", "acc_z",
       "gyro_x", "gyro_y", "gyro_z")


def test_outputs_read_after_a_step_are_of_the_new_state():
    x0 = make_state(roll=0.03, pitch=-0.02, yaw=0.4, dx=0.1, omega_body=(0.05, -0.02, 0.1))
    p = Plant("cs")
    p.init(**{n: v for n, v in zip(STATES, np.asarray(x0).tolist())}, tau0=0.3, tau1=-0.2, tau2=0.1)
    try:
        before = p.get(*OUT)  # evaluated at the start state
        p.step(0.005, 20)
        after = p.get(*OUT)
        p.set(tau0=0.3)  # the same value: only forces a re-evaluation
        fresh = p.get(*OUT)
        np.testing.assert_array_equal(after, fresh)
        moved = np.abs(after[:3] - before[:3])
        assert np.all(moved > 1e-6), moved  # 0.1 s with a torque and a body rate
    finally:
        p.free()

"""The controller FMU refuses a power-on state that overflows
(``initialize`` in ``fmu/controller/controller_model.c``).

The start values ``x0_*`` are each finite (the setters refuse NaN and Inf), but a
quaternion rate of 1e308 makes the body rate the filters start from, and what the power-on
Function builds from it, leave the doubles.  The FMU must refuse with its line and
fmi2Error, and a large but finite rate must still start.
"""

from __future__ import annotations

import numpy as np
import pytest
from _controller_support import Controller

pytestmark = pytest.mark.needs_cc


def _exit_init(**values) -> tuple[int, Controller]:
    c = Controller()
    c.fmu.setupExperiment(startTime=0.0)
    c.fmu.enterInitializationMode()
    c.set(**values)
    return c.raw("fmi2ExitInitializationMode"), c


def test_a_power_on_state_that_overflows_is_refused():
    st, c = _exit_init(x0_dq1=1e308)  # omega_x = 2 dq1 = 2e308: Inf
    assert st == 3  # fmi2Error
    assert c.logs[-1][1].endswith("the state at power-on from x0_* and ctrl_* is NaN or Inf")
    c.fmu.freeInstance()


def test_a_large_finite_power_on_rate_starts_and_is_the_estimate():
    st, c = _exit_init(x0_dq1=1e150)  # omega_x = 2e150: its square still a double
    assert st == 0 and [s for s, _ in c.logs if s >= 2] == []
    np.testing.assert_array_equal(c.get(*(f"dq_hat{i}" for i in range(4))), [0.0, 1e150, 0.0, 0.0])
    c.fmu.freeInstance()

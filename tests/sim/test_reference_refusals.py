"""The reference signals refuse what they cannot mean with one line naming the argument
and the value: non-numbers, non-finite numbers, a negative rise time, a non-positive ramp
rate, a negative frequency, an angle that is neither a number nor a triple; and the
boundary values each check allows are accepted."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.errors import ScenarioError, ShapeError
from ballbot_casadi.sim.references import ramp, rpy_reference, sine, step

T = np.linspace(0.0, 1.0, 11)


@pytest.mark.parametrize("call, kind, message", [
    (lambda: step(T, amplitude="big"), ScenarioError, r"^amplitude must be a real number, got 'big'$"),
    (lambda: step(T, t_step=None), ScenarioError, r"^t_step must be a real number, got None$"),
    (lambda: step(T, offset=float("inf")), ScenarioError, r"^offset must be finite, got inf$"),
    (lambda: step(T, rise_time=-0.1), ScenarioError, r"^rise_time must be >= 0, got -0\.1$"),
    (lambda: ramp(T, rate=0.0), ScenarioError, r"^rate must be > 0, got 0\.0$"),
    (lambda: ramp(T, rate=-2.0), ScenarioError, r"^rate must be > 0, got -2\.0$"),
    (lambda: ramp(T, t_start=float("nan")), ScenarioError, r"^t_start must be finite, got nan$"),
    (lambda: sine(T, 1.0, -0.5), ScenarioError, r"^frequency must be >= 0 Hz, got -0\.5$"),
    (lambda: sine(T, 1.0, 1.0, phase=[1, 2]), ScenarioError, r"^phase must be a real number, got \[1, 2\]$"),
    (lambda: rpy_reference(object(), 0.0, 0.0), ShapeError,
     r"^angles must be numbers or \(value, d1, d2\) triples$"),
    (lambda: rpy_reference((T, T), 0.0, 0.0), ShapeError, r"^roll must be a \(value, d1, d2\) triple, got 2 parts$"),
    (lambda: rpy_reference(0.0, ("a", T, T), 0.0), ShapeError,
     r"^angles must be numbers or \(value, d1, d2\) triples$"),
    (lambda: rpy_reference(0.0, (T, T[:3], T), 0.0), ShapeError,
     r"^pitch must be a number or a \(value, d1, d2\) triple of length-11 arrays$"),
    (lambda: rpy_reference(0.0, 0.0, (T, T * np.nan, T)), ScenarioError, r"^yaw contains NaN or inf$"),
    (lambda: rpy_reference((T, T, T * np.nan), 0.0, 0.0), ScenarioError, r"^roll contains NaN or inf$"),
    (lambda: rpy_reference(0.0, (np.where(T > 0.5, np.inf, T), T, T), 0.0), ScenarioError,
     r"^pitch contains NaN or inf$"),
    (lambda: rpy_reference(float("nan"), 0.0, 0.0), ScenarioError, r"^roll must be finite, got nan$"),
])
def test_refusals_name_the_argument_and_value(call, kind, message):
    with pytest.raises(kind, match=message):
        call()


def test_the_boundary_values_are_allowed():
    s = step(T, amplitude=2.0, t_step=0.5, rise_time=0.0)   # an ideal step
    np.testing.assert_array_equal(s.value, np.where(T >= 0.5, 2.0, 0.0))
    np.testing.assert_array_equal(sine(T, 3.0, 0.0, phase=np.pi / 2).value, np.full(T.size, 3.0))
    r = ramp(T, amplitude=1.0, rate=1e-9)                     # any positive rate
    np.testing.assert_allclose(r.value, 1e-9 * T, rtol=1e-12, atol=0)

"""make_state refuses non-finite and non-numeric arguments (never returns NaN states)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.errors import BallbotTypeError, StateError
from ballbot_casadi.model.numeric import make_state


@pytest.mark.parametrize("name", ["x", "y", "roll", "pitch", "yaw", "dx", "dy"])
@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
def test_non_finite_scalars_are_refused_by_name(name, value):
    with pytest.raises(StateError, match=rf"make_state: {name} must be finite"):
        make_state(**{name: value})


def test_non_finite_or_misshaped_body_rate_is_refused():
    with pytest.raises(StateError, match="omega_body"):
        make_state(omega_body=(0.0, math.nan, 0.0))
    with pytest.raises(ValueError, match="omega_body"):
        make_state(omega_body=(0.0, 1.0))


def test_non_numeric_scalar_is_a_type_error():
    with pytest.raises(BallbotTypeError, match="roll must be a real number"):
        make_state(roll="5 deg")


def test_valid_state_is_unchanged():
    x = make_state(x=1.0, roll=0.1, yaw=np.float64(0.3), dx=0.2, omega_body=(0.0, 0.0, 1.0))
    assert x.shape == (12,) and np.all(np.isfinite(x))
    assert np.linalg.norm(x[2:6]) == pytest.approx(1.0, abs=1e-15)
    # dq = 1/2 q o (0, w) keeps the unit norm: q . dq = 0
    assert x[8:12] @ x[2:6] == pytest.approx(0.0, abs=1e-15)

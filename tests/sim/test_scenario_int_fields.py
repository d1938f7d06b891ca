"""The scenario's integer fields (RK4 sub-steps, noise seed) take ints only: a float of
integral value and a boolean are refused with one line naming the field (a TOML ``true``
or ``2.0`` is a user's mistake, not 1 or 2)."""

from __future__ import annotations

import pytest

from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.sim.scenario import Scenario


@pytest.mark.parametrize("field, value, needle", [
    ("n_sub", 2.0, "n_sub must be an int >= 1, got 2.0"),
    ("n_sub", True, "n_sub must be an int >= 1, got True"),
    ("seed", 3.0, "seed must be an int in [0, 2^32), got 3.0"),
    ("seed", False, "seed must be an int in [0, 2^32), got False"),
])
def test_integer_fields_refuse_floats_and_booleans(field, value, needle):
    with pytest.raises(ScenarioError) as exc:
        Scenario(name="ints", duration=0.1, **{field: value})
    assert str(exc.value) == f"scenario 'ints': {needle}"


@pytest.mark.parametrize("field, value", [("n_sub", 3), ("seed", 0), ("seed", 2**32 - 1)])
def test_integer_fields_take_ints(field, value):
    assert getattr(Scenario(name="ints", duration=0.1, **{field: value}), field) == value

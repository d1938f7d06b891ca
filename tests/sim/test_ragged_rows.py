"""Rows of different lengths (a real bug found for issue 23): a file whose ``[[velocity]]``
rows give ``accel_mps2`` on some rows only is valid (each row's own acceleration, the
others at ``a_max``) but crashed with numpy's "inhomogeneous shape" ValueError (exit 3);
a scenario built in code with rows of different lengths got the same ValueError instead
of a keyed ScenarioError naming the row."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.errors import ScenarioError, ShapeError
from ballbot_casadi.sim import references as R
from ballbot_casadi.sim.scenario import Scenario, parse_scenario

TABLE = {"name": "mixed", "duration_s": 1.0, "cascade": True,
         "velocity": [{"t_s": 0.0, "vx_mps": 0.2},
                      {"t_s": 0.5, "vy_mps": 0.1, "accel_mps2": 0.5}]}


def test_velocity_rows_with_and_without_their_own_acceleration():
    sf = parse_scenario(TABLE, "mixed.toml")
    sc = sf.scenario
    assert sc.velocity_keyframes == ((0.0, 0.2, 0.0, 0.0), (0.5, 0.0, 0.1, 0.0, 0.5))
    v = sc.velocity_reference()
    # row 0 at a_max = 1 m/s^2: 0.2 m/s after 0.2 s; row 1 at 0.5 m/s^2 along (-0.2, 0.1)
    np.testing.assert_allclose(v[20], [0.1, 0.0, 0.0], rtol=1e-12, atol=1e-15)  # t = 0.1 s
    np.testing.assert_allclose(v[60], [0.2, 0.0, 0.0], rtol=1e-12)             # t = 0.3 s
    dur = math.hypot(0.2, 0.1) / 0.5
    np.testing.assert_allclose(v[120], np.array([0.2, 0.0, 0.0]) + 0.1 / dur * np.array([-0.2, 0.1, 0.0]),
                               rtol=1e-12, atol=1e-15)  # t = 0.6 s
    again = parse_scenario(sf.to_file(), "again.toml")
    assert again.scenario == sc and again.to_file() == sf.to_file()


def test_velocity_profile_pads_each_short_row_with_a_max():
    mixed = R.velocity_profile(np.array([0.05, 0.9]), [(0.0, 0.3, 0.0, 0.0), (0.7, 0.0, 0.0, 0.0, 0.25)], a_max=0.5)
    same = R.velocity_profile(np.array([0.05, 0.9]), [(0.0, 0.3, 0.0, 0.0, 0.5), (0.7, 0.0, 0.0, 0.0, 0.25)])
    np.testing.assert_array_equal(mixed.value, same.value)
    np.testing.assert_allclose(mixed.value[:, 0], [0.025, 0.3 - 0.2 * 0.25], rtol=1e-12)
    for bad in ([(0.0, 0.3, 0.0)], [], [(0.0, 0.3, 0.0, 0.0), (1.0, 0.1)], 1.0, [[(0.0, 0.1), (0.0, 0.0)]]):
        with pytest.raises(ShapeError, match=r"keyframes must be rows \(t_start, vx, vy, yaw_rate\[, accel\]\)"):
            R.velocity_profile(np.zeros(1), bad)


@pytest.mark.parametrize("change, key", [
    ({"pushes": ((0.0, 1.0, 0.0, 0.0), (0.5, 1.0))}, "push[1]"),
    ({"torque_disturbances": ((0.0, 0.1, 1.0, 0.0, 0.0), (0.2, 0.3, 1.0))}, "torque_disturbance[1]"),
    ({"pushes": ((0.0, 1.0, 0.0, "x"),)}, "push"),
    ({"pushes": ((0.0, math.nan, 0.0, 0.0),)}, "push"),
])
def test_ragged_rows_in_code_name_their_key(change, key):
    with pytest.raises(ScenarioError) as info:
        Scenario("r", "flc", 1.0, **change)
    assert info.value.key == key

"""A torque disturbance covers exactly the control instants in ``[t_start, t_end)``, also
when the instant ``k Ts`` computed in floating point falls a hair below the decimal start
time (``3 * 0.009 = 0.026999...``) (issue 23, second fresh batch: the start's tolerance
dropped went unnoticed; every test used Ts = 0.005, whose multiples never fall below)."""

from __future__ import annotations

import numpy as np

from ballbot_casadi.core.layout import DISTURBANCE
from ballbot_casadi.sim.scenario import parse_scenario


def _tau(Ts, t0, t1, duration=0.2):
    table = {"name": "edges", "duration_s": duration, "control_period_s": Ts,
             "torque_disturbance": [{"t_start_s": t0, "t_end_s": t1, "tau_nm": [0.5, -0.25, 0.125]}]}
    sc = parse_scenario(table, "edges").scenario
    return sc.time(), sc.disturbance()[:, DISTURBANCE["tau_dist"]]


def test_the_window_is_start_inclusive_end_exclusive_on_the_decimal_times():
    assert 3 * 0.009 < 0.027  # the case: k Ts a hair below the start time
    t, tau = _tau(0.009, 0.027, 0.054)
    on = np.nonzero(tau[:, 0])[0]
    np.testing.assert_array_equal(on, [3, 4, 5])  # 0.027, 0.036, 0.045; not 0.054
    np.testing.assert_array_equal(tau[on], np.tile([0.5, -0.25, 0.125], (3, 1)))
    t, tau = _tau(0.005, 0.015, 0.03)  # 3 * 0.005 = 0.015000000000000001: a hair above
    np.testing.assert_array_equal(np.nonzero(tau[:, 1])[0], [3, 4, 5])

"""The simulation's documented constants against the quantity their documentation names
(one hour of 5 ms periods, one second per chunk, 10 Hz guidance, 60 s segments, ten times
the motors' torque), computed here from the control period rather than copied: other
tests read these names, so a changed constant moves their bound with it and only a value
pinned here shows (issue 23: ``MAX_PERIODS = 720001`` survived a scout batch)."""

from __future__ import annotations

import pytest

from ballbot_casadi.core.constants import TS_CONTROL
from ballbot_casadi.core.params import load_params
from ballbot_casadi.sim.closed_loop import DECIMATED_SEGMENT_PERIODS
from ballbot_casadi.sim.guided import GUIDANCE_EVERY, GUIDANCE_LAWS, PATH_LOG_SPACING, PURSUIT_GAINS
from ballbot_casadi.sim.mission import CHUNK
from ballbot_casadi.sim.period import TORQUE_LIMIT_MODES
from ballbot_casadi.sim.scenario.path_section import GUIDANCE_CHOICES
from ballbot_casadi.sim.scenario.sections import MAX_PERIODS, TORQUE_DISTURBANCE_MAX_NM


def test_period_counts_are_their_documented_durations():
    assert TS_CONTROL == 0.005
    assert MAX_PERIODS == round(3600.0 / TS_CONTROL) == 720_000  # one hour
    assert CHUNK == round(1.0 / TS_CONTROL) == 200  # one second per compiled chunk
    assert GUIDANCE_EVERY == round(0.1 / TS_CONTROL) == 20  # 10 Hz guidance
    assert DECIMATED_SEGMENT_PERIODS == round(60.0 / TS_CONTROL) == 12_000  # 60 s segments


def test_the_torque_disturbance_bound_is_ten_motor_torques():
    tau_max = load_params().tau_max
    assert tau_max == pytest.approx(1.9825, abs=1e-12)
    assert TORQUE_DISTURBANCE_MAX_NM == 20.0
    assert TORQUE_DISTURBANCE_MAX_NM == pytest.approx(10 * tau_max, abs=0.2)


def test_choices_in_their_documented_order():
    assert TORQUE_LIMIT_MODES == ("direction", "per-wheel")  # ours first: the default
    assert GUIDANCE_LAWS == ("mpc", "pursuit")
    assert GUIDANCE_CHOICES == ("mpc", "pursuit", "mpc_balance")
    assert PURSUIT_GAINS == (0.6, 1.0)  # look-ahead (m), lateral gain (1/s): the sweep's best
    assert PATH_LOG_SPACING == 0.02

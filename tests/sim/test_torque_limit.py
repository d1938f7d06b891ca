"""The torque-limit switch (sim/period.py step 5): ours (direction-preserving) against the
thesis's per-wheel clipping (§9.1), and the refused cascade + attitude-sine scenario."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.sim.closed_loop import run_scenario
from ballbot_casadi.sim.period import TORQUE_LIMIT_MODES, controller_torque_limit
from ballbot_casadi.sim.scenario import Scenario, initial_state, parse_scenario

#: A 3 deg roll sine at 2 Hz: past the saturation frequency (~1.2 Hz), so the FLC asks
#: for more than tau_max on motor 0 within the first second.
_FAST_SINE = {"roll": {"type": "sine", "amplitude_deg": 3.0, "frequency_hz": 2.0}}


def _run(limit: str):
    sc = Scenario("lim", duration=0.6, attitude=_FAST_SINE, torque_limit=limit,
                  x0=initial_state(0.0, 0.0, 0.0))
    log = run_scenario(sc)
    return log.arrays["tau_cmd"], log.arrays["tau"], log.params.tau_max


def test_direction_limit_scales_all_three_torques_together():
    cmd, tau, tau_max = _run("direction")
    m = np.max(np.abs(cmd), axis=1)
    sat = m > tau_max * (1 + 1e-9)
    assert np.count_nonzero(sat) >= 5, "the scenario must saturate"
    # parallel to the command, largest wheel exactly at the limit
    np.testing.assert_allclose(tau[sat], cmd[sat] * (tau_max / m[sat])[:, None], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(tau[~sat], cmd[~sat], rtol=0, atol=1e-12)


def test_per_wheel_limit_clips_each_motor_on_its_own():
    cmd, tau, tau_max = _run("per-wheel")
    sat = np.max(np.abs(cmd), axis=1) > tau_max * (1 + 1e-9)
    assert np.count_nonzero(sat) >= 5
    np.testing.assert_allclose(tau, np.clip(cmd, -tau_max, tau_max), rtol=0, atol=1e-12)
    # the unsaturated wheels keep their full command: the direction turns
    mixed = sat & np.any(np.abs(cmd) < tau_max, axis=1)
    assert np.any(mixed)
    scale = tau[mixed] / cmd[mixed]
    assert np.all(np.ptp(scale, axis=1) > 1e-3), "per-wheel clipping must not keep the direction"


def test_controller_limit_values_and_unknown_mode():
    assert TORQUE_LIMIT_MODES[0] == "direction"
    assert controller_torque_limit(2.0, "direction") == 2.0
    assert controller_torque_limit(2.0, "per-wheel") == np.inf
    with pytest.raises(ScenarioError, match=r"torque_limit 'both' unknown; allowed: direction, per-wheel"):
        controller_torque_limit(2.0, "both")


def test_scenario_file_key_and_bad_value():
    ok = parse_scenario({"duration_s": 1.0, "torque_limit": "per-wheel"})
    assert ok.scenario.torque_limit == "per-wheel"
    with pytest.raises(ScenarioError, match="torque_limit"):
        parse_scenario({"duration_s": 1.0, "torque_limit": "scaled"})


def test_cascade_with_attitude_sine_refused_naming_the_key():
    table = {"duration_s": 1.0, "cascade": True,
             "attitude": {"roll": {"type": "sine", "amplitude_deg": 3.0, "frequency_hz": 0.5}}}
    with pytest.raises(ScenarioError, match=r"attitude\.roll.*ignored with cascade = true"):
        parse_scenario(table)
    # with several axes the refusal names the first in sorted order (pitch before roll, yaw)
    table["attitude"] = {"yaw": table["attitude"]["roll"], **table["attitude"],
                         "pitch": table["attitude"]["roll"]}
    with pytest.raises(ScenarioError, match=r"key 'attitude\.pitch': an attitude reference is ignored"):
        parse_scenario(table)
    with pytest.raises(ScenarioError, match="ignored with cascade = true"):
        Scenario("s", cascade=True, attitude=_FAST_SINE)

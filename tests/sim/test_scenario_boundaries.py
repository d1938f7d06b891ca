"""Scenario-file limits at their boundaries: the last value allowed is read, the first one
beyond is refused naming its key (issue 23: ``<`` against ``<=`` and dropped checks in the
scenario reader survived the tests).

Each case is a base file plus one change; ``None`` means the file is read, otherwise the
error must name that key.  The values sit exactly at a documented limit or one step past
it, so an off-by-one comparison or a dropped check changes the outcome.
"""

from __future__ import annotations

import math

import pytest

from ballbot_casadi.errors import ScenarioError, ScenarioFileError
from ballbot_casadi.sim.scenario import parse_scenario
from ballbot_casadi.sim.scenario.file import MAX_PERIODS, TORQUE_DISTURBANCE_MAX_NM


def _table(**top):
    t = {"name": "b", "duration_s": 1.0}
    t.update(top)
    return t


_DISP = {"param": "plant.Mb", "dist": "uniform", "relative": True}

CASES = [
    # [initial]: pitch inside (-90, 90), speeds |v| <= 10 m/s
    ("pitch 89.9", _table(initial={"pitch_deg": 89.9}), None),
    ("pitch 90", _table(initial={"pitch_deg": 90.0}), "initial.pitch_deg"),
    ("pitch -90", _table(initial={"pitch_deg": -90.0}), "initial.pitch_deg"),
    ("vx 10", _table(initial={"vx_mps": 10.0}), None),
    ("vx 10.5", _table(initial={"vx_mps": 10.5}), "initial.vx_mps"),
    ("vy -10.5", _table(initial={"vy_mps": -10.5}), "initial.vy_mps"),
    ("roll 180", _table(initial={"roll_deg": 180.0}), None),
    ("roll 180.5", _table(initial={"roll_deg": 180.5}), "initial.roll_deg"),
    ("yaw -181", _table(initial={"yaw_deg": -181.0}), "initial.yaw_deg"),
    ("roll -180", _table(initial={"roll_deg": -180.0}), None),
    ("yaw -180", _table(initial={"yaw_deg": -180.0}), None),
    ("yaw 180", _table(initial={"yaw_deg": 180.0}), None),
    ("yaw 181", _table(initial={"yaw_deg": 181.0}), "initial.yaw_deg"),
    ("roll -180.5", _table(initial={"roll_deg": -180.5}), "initial.roll_deg"),
    # the run: periods, sub-steps, control period
    # (at 1 ms: the period cap, not the 3600 s duration cap, is what refuses)
    ("max periods", _table(duration_s=MAX_PERIODS * 0.001, control_period_s=0.001), None),
    ("max periods + 1", _table(duration_s=(MAX_PERIODS + 1) * 0.001, control_period_s=0.001), "duration_s"),
    ("half a period", _table(duration_s=0.002), "duration_s"),
    ("0.6 of a period (rounds to one)", _table(duration_s=0.003), None),
    ("1.6 periods at 0.1 s", _table(duration_s=0.16, control_period_s=0.1), None),
    ("one period", _table(duration_s=0.005), None),
    ("0 substeps", _table(rk4_substeps=0), "rk4_substeps"),
    ("100 substeps", _table(rk4_substeps=100), None),
    ("101 substeps", _table(rk4_substeps=101), "rk4_substeps"),
    ("period 0", _table(control_period_s=0.0), "control_period_s"),
    ("period 0.1", _table(control_period_s=0.1, duration_s=1.0), None),
    ("period 0.11", _table(control_period_s=0.11, duration_s=1.0), "control_period_s"),
    ("duration 3600", _table(duration_s=3600.0), None),
    ("duration 3601", _table(duration_s=3601.0), "duration_s"),
    # pushes before the end; torque disturbances within +-20 N m, end after start
    ("push at 0", _table(push=[{"t_s": 0.0, "roll_deg": 1.0}]), None),
    ("push at the end", _table(push=[{"t_s": 1.0, "roll_deg": 1.0}]), "push[0].t_s"),
    ("push roll 90", _table(push=[{"t_s": 0.5, "roll_deg": 90.0}]), None),
    ("push roll 91", _table(push=[{"t_s": 0.5, "roll_deg": 91.0}]), "push[0].roll_deg"),
    ("push before 0", _table(push=[{"t_s": -0.1}]), "push[0].t_s"),
    ("torque at the limit", _table(torque_disturbance=[{"t_start_s": 0.1, "t_end_s": 0.2,
                                                        "tau_nm": [-TORQUE_DISTURBANCE_MAX_NM, 0.0, 0.0]}]), None),
    ("torque beyond -limit", _table(torque_disturbance=[{"t_start_s": 0.1, "t_end_s": 0.2,
                                                         "tau_nm": [-TORQUE_DISTURBANCE_MAX_NM - 1, 0.0, 0.0]}]),
     "torque_disturbance[0].tau_nm"),
    ("torque empty interval", _table(torque_disturbance=[{"t_start_s": 0.2, "t_end_s": 0.2,
                                                          "tau_nm": [1.0, 0.0, 0.0]}]), "torque_disturbance[0].t_end_s"),
    ("dropout empty interval", _table(sensor_dropout=[{"t_start_s": 0.3, "t_end_s": 0.3, "sensor": "acc"}]),
     "sensor_dropout[0].t_end_s"),
    ("dropout before 0", _table(sensor_dropout=[{"t_start_s": -0.1, "t_end_s": 0.3, "sensor": "acc"}]),
     "sensor_dropout[0].t_start_s"),
    # sensor seed in [0, 2^32)
    ("seed 2^32 - 1", _table(seed=2**32 - 1), None),
    ("seed 2^32", _table(seed=2**32), "seed"),
    ("seed -1", _table(seed=-1), "seed"),
    # [montecarlo]: sd >= 0, high >= low
    ("sd 0", _table(montecarlo={"dispersion": [{"param": "plant.Mb", "dist": "normal", "sd": 0.0}]}), None),
    ("sd < 0", _table(montecarlo={"dispersion": [{"param": "plant.Mb", "dist": "normal", "sd": -0.01}]}),
     "montecarlo.dispersion[0].sd"),
    ("uniform high = low", _table(montecarlo={"dispersion": [{**_DISP, "low": 0.1, "high": 0.1}]}), None),
    ("uniform high < low", _table(montecarlo={"dispersion": [{**_DISP, "low": 0.1, "high": 0.05}]}),
     "montecarlo.dispersion[0].high"),
    ("uniform high > low", _table(montecarlo={"dispersion": [{**_DISP, "low": -0.1, "high": 0.1}]}), None),
    # references: frequencies below Nyquist (100 Hz at 5 ms), ramp rate > 0
    ("sine 99 Hz", _table(attitude={"roll": {"type": "sine", "amplitude_deg": 1.0, "frequency_hz": 99.0}}), None),
    ("sine at Nyquist", _table(attitude={"roll": {"type": "sine", "amplitude_deg": 1.0, "frequency_hz": 100.0}}),
     "attitude.roll.frequency_hz"),
    ("ramp rate 0", _table(attitude={"roll": {"type": "ramp", "amplitude_deg": 1.0, "rate_deg_s": 0.0}}),
     "attitude.roll.rate_deg_s"),
    ("velocity accel 0", _table(cascade=True, velocity=[{"t_s": 0.0, "vx_mps": 0.1, "accel_mps2": 0.0}]),
     "velocity[0].accel_mps2"),
    ("glitch at the end", _table(sensor_glitch=[{"t_s": 1.0, "sensor": "gyro", "value": 1.0}]),
     "sensor_glitch[0]"),
]


@pytest.mark.parametrize("label, table, bad_key", CASES, ids=[c[0] for c in CASES])
def test_limits_at_their_boundaries(label, table, bad_key):
    if bad_key is None:
        parse_scenario(table, "b.toml")
        return
    with pytest.raises(ScenarioFileError) as e:
        parse_scenario(table, "b.toml")
    assert f"key '{bad_key}'" in str(e.value), str(e.value)


# the same limits through the Scenario API (sections' own checks, without the file reader)

def _scenario():
    return parse_scenario(_table(), "b.toml").scenario


@pytest.mark.parametrize("change, bad_key", [
    ({"pushes": ((0.999, 1.0, 0.0, 0.0),)}, None),
    ({"pushes": ((1.0, 1.0, 0.0, 0.0),)}, "push[0]"),
    ({"torque_disturbances": ((0.5, 0.5, 1.0, 0.0, 0.0),)}, "torque_disturbance[0]"),
    ({"torque_disturbances": ((0.5, 0.6, 1.0, 0.0, 0.0),)}, None),
    ({"sensor_dropouts": ((0.5, 0.5, "acc"),)}, "sensor_dropout[0]"),
    # each time a finite number: an endless or textual window is refused, not compared
    ({"sensor_dropouts": ((0.5, math.inf, "acc"),)}, "sensor_dropout[0]"),
    ({"sensor_dropouts": ((0.5, "2", "acc"),)}, "sensor_dropout[0]"),
    ({"sensor_dropouts": ((math.nan, 1.0, "acc"),)}, "sensor_dropout[0]"),
    ({"sensor_dropouts": (("0", 1.0, "acc"),)}, "sensor_dropout[0]"),
    ({"sensor_dropouts": ((0.5, 1.0, "acc"), (0.5, math.inf, "gyro"))}, "sensor_dropout[1]"),
    ({"sensor_dropouts": ((0.5, 1e300, "acc"),)}, None),
    ({"sensor_glitches": ((1.0, "gyro", "x", 1.0),), "estimator": "ukf"}, "sensor_glitch[0]"),
    ({"sensor_glitches": ((0.995, "gyro", "x", 1.0),), "estimator": "ukf"}, None),
    ({"seed": 2**32}, "seed"),
    ({"seed": 2**32 - 1}, None),
])
def test_scenario_api_limits_at_their_boundaries(change, bad_key):
    sc = _scenario()
    if bad_key is None:
        sc.replace(**change)
        return
    with pytest.raises(ScenarioError) as e:
        sc.replace(**change)
    assert e.value.key == bad_key, (e.value.key, str(e.value))

"""What the path-following controller FMU cannot carry is refused in one line naming the
key (exit 2), before anything is built: the per-wheel torque limit, whose controller limit
is +inf (not a value of the FMU's ctrl_tau_max, a torque in (0, 1000] N m), and a guidance
latency."""

from __future__ import annotations

import math

import pytest

from ballbot_casadi import cli
from ballbot_casadi.core.params import PARAM_INFO, PARAM_NAMES, PARAM_RULES
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.fmi.controller.path import path_law
from ballbot_casadi.sim.scenario.file import parse_scenario

SCENARIO = {"name": "pw", "duration_s": 2.0, "cascade": True, "estimator": "ukf",
            "path": {"type": "line", "start": [0.0, 0.0], "end": [2.0, 0.0]}}
_TAU_MAX = PARAM_NAMES.index("tau_max")


def test_the_per_wheel_limit_is_inf_in_the_controller_inputs():
    """The documented convention the refusal protects the FMU from: per-wheel lifts the
    controller's own limit to +inf (only the plant's per-wheel clipping acts), while the
    plant keeps its finite tau_max."""
    sc = parse_scenario({**SCENARIO, "torque_limit": "per-wheel"}).scenario
    inp = sc.inputs(periods=(0, 1))
    assert inp["p_ctrl"][_TAU_MAX] == math.inf
    assert math.isfinite(inp["p_plant"][_TAU_MAX]) and inp["p_plant"][_TAU_MAX] > 0
    rule = PARAM_RULES[PARAM_INFO["tau_max"][2]]  # the FMU's ctrl_tau_max rule
    assert rule.hi < math.inf  # a finite torque: +inf is not a value of it


def test_the_path_fmu_refuses_the_per_wheel_limit_in_one_line():
    sc = parse_scenario({**SCENARIO, "torque_limit": "per-wheel"}).scenario
    with pytest.raises(ScenarioError) as exc:
        path_law(sc)
    msg = str(exc.value)
    assert exc.value.key == "torque_limit" and "\n" not in msg
    assert "'per-wheel'" in msg and "+inf" in msg and "allowed: direction" in msg
    # the direction limit (the default) passes this check
    ok = parse_scenario(SCENARIO).scenario
    assert ok.torque_limit == "direction"


def test_cli_build_controller_refuses_the_per_wheel_limit_with_exit_2(tmp_path, capsys):
    f = tmp_path / "pw.toml"
    f.write_text('name = "pw"\nduration_s = 2.0\ncascade = true\nestimator = "ukf"\n'
                 'torque_limit = "per-wheel"\n[path]\ntype = "line"\nstart = [0.0, 0.0]\n'
                 'end = [2.0, 0.0]\n')
    assert cli.main(["fmu", "build-controller", "--scenario", str(f), "--out",
                     str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "torque_limit" in err and "+inf" in err


PLAIN = {"name": "pw_plain", "duration_s": 2.0, "estimator": "ukf", "torque_limit": "per-wheel"}


def test_the_plain_controller_fmu_and_the_firmware_refuse_the_per_wheel_limit():
    """The same refusal where a scenario's parameters become the controller FMU's start
    values (controller_values, the SIL's parameter sets) or the firmware's constants
    (scenario_values; +inf would be written into the C), before anything is built."""
    import casadi as ca

    from ballbot_casadi.fmi.controller.controller import controller_values
    from ballbot_casadi.firmware.sources import scenario_values

    sc = parse_scenario(PLAIN).scenario
    x = ca.SX.sym("x")
    dummy = ca.Function("ballbot_dummy", [x], [x])
    for call in (lambda: controller_values(sc, embedded=dummy),
                 lambda: scenario_values(dummy, sc)):
        with pytest.raises(ScenarioError) as exc:
            call()
        msg = str(exc.value)
        assert exc.value.key == "torque_limit" and "\n" not in msg
        assert "'per-wheel'" in msg and "allowed: direction" in msg

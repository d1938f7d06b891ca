"""The scenario file's ``guidance_latency`` (sim/scenario/path_section): bounds with one-line
errors (exit 2), the round trip, and a file with latency 5 runs the mission of
``mpc_law(..., latency=5)``."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi import cli
from ballbot_casadi.errors import ScenarioError, ScenarioFileError
from ballbot_casadi.fmi.controller.path import path_law
from ballbot_casadi.sim.guided import mpc_law, run_guided, run_path_scenario
from ballbot_casadi.sim.scenario import Scenario
from ballbot_casadi.sim.scenario.file import parse_scenario
from ballbot_casadi.sim.scenario.path_section import LATENCY_LIMIT

PATH = {"type": "line", "start": [0.0, 0.0], "end": [2.0, 0.0], "speed": 0.4}
BASE = {"duration_s": 1.0, "cascade": True, "path": PATH}
#: Periods a sample's reference is late in the reproduced run.
L = 5


def test_the_limit_is_one_sample_interval():
    assert LATENCY_LIMIT == 20  # MPC dt 0.1 s over the 5 ms control period


def test_guidance_latency_round_trips():
    sc = parse_scenario({**BASE, "guidance_latency": L}).scenario
    assert sc.guidance_latency == L
    assert sc.to_file()["guidance_latency"] == L
    assert parse_scenario(sc.to_file()).scenario == sc
    assert Scenario.from_dict(sc.to_dict()) == sc
    assert sc.replace(guidance_latency=0) != sc
    # the default: 0, and absent from the file
    sc0 = parse_scenario(BASE).scenario
    assert sc0.guidance_latency == 0 and "guidance_latency" not in sc0.to_file()
    assert parse_scenario({**BASE, "guidance_latency": LATENCY_LIMIT - 1}).scenario \
        .guidance_latency == LATENCY_LIMIT - 1


@pytest.mark.parametrize("extra, needle", [
    ({"guidance_latency": -1}, "integer >= 0"),
    ({"guidance_latency": 20}, "0..19"),
    ({"guidance_latency": 2.5}, "integer"),
    ({"guidance_latency": True}, "integer"),
    ({"guidance_latency": "5"}, "integer"),
    ({"guidance_latency": 5, "guidance": "pursuit"}, "guidance = \"mpc\""),
    ({"guidance_latency": 5, "guidance": "mpc_balance"}, "guidance = \"mpc\""),
])
def test_bad_latencies_are_refused_in_one_line(extra, needle):
    with pytest.raises(ScenarioFileError) as exc:
        parse_scenario({**BASE, **extra})
    msg = str(exc.value)
    assert "key 'guidance_latency'" in msg and needle in msg and "\n" not in msg


def test_a_latency_needs_a_path():
    with pytest.raises(ScenarioFileError, match="key 'guidance_latency'.*needs a \\[path\\]"):
        parse_scenario({"duration_s": 1.0, "cascade": True, "guidance_latency": 3})
    with pytest.raises(ScenarioError, match="guidance_latency"):
        Scenario("s", cascade=True, path=PATH, guidance_latency=LATENCY_LIMIT)


def test_cli_refuses_a_bad_latency_with_exit_2(tmp_path, capsys):
    f = tmp_path / "bad.toml"
    f.write_text('duration_s = 1.0\ncascade = true\nguidance_latency = 20\n[path]\n'
                 'type = "line"\nstart = [0.0, 0.0]\nend = [2.0, 0.0]\n')
    assert cli.main(["simulate", str(f), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "guidance_latency" in err and "0..19" in err


@pytest.mark.needs_cc
def test_a_file_with_latency_5_runs_the_mission_of_latency_5():
    sc = parse_scenario({**BASE, "guidance_latency": L}).scenario
    log = run_path_scenario(sc).arrays
    sc0 = sc.replace(guidance_latency=0)
    inp = sc0.inputs(periods=(0, 1))
    ref = run_guided(sc0.route.build(), mpc_law(inp["p_ctrl"], inp["k_vel"], latency=L),
                     sc0.duration, scenario=sc0)
    assert set(ref) - {"xz_final"} <= set(log)
    for key in ("state", "tau", "v_ref_used", "guide"):
        np.testing.assert_array_equal(log[key], ref[key], err_msg=key)
    # and the latency acts: without it the references change in the sample's own period
    now = run_path_scenario(sc0).arrays
    assert np.max(np.abs(now["v_ref_used"] - log["v_ref_used"])) > 1e-3


def test_the_path_fmu_refuses_a_latency_it_does_not_build():
    sc = parse_scenario({**BASE, "guidance_latency": L, "estimator": "ukf"}).scenario
    with pytest.raises(ScenarioError, match="guidance_latency = 5; allowed: 0") as exc:
        path_law(sc)
    assert exc.value.key == "guidance_latency"

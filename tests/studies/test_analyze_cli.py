"""``ballbot analyze`` end to end, in-process on the default robot."""

from __future__ import annotations

import json
import math

import pytest

from ballbot_casadi import cli


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("analysis")
    rc = cli.main(["analyze", "--out", str(out)])
    return rc, out


def test_analyze_writes_all_files(run):
    rc, out = run
    assert rc == 0
    for name in ("analysis.json", "analysis.md", "pole_zero.png", "singular_values.png"):
        f = out / name
        assert f.is_file() and f.stat().st_size > 0, name
    for png in out.glob("*.png"):
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_analysis_json_contents(run):
    _, out = run
    data = json.loads((out / "analysis.json").read_text())
    assert data["n_states_reduced"] == 10
    assert data["controllability_rank"] == 10
    assert len(data["unstable_poles"]) == 2
    assert all(isinstance(p, float) and 3.0 < p < 4.5 for p in data["unstable_poles"])
    assert len(data["rhp_zeros_position"]) == 2
    assert all(z > 0 for z in data["rhp_zeros_position"])
    # the default robot's cascade is analysed; its inner loop is the FLC's double pole at
    # -10 rad/s, Kp / (s + 10)^2: |T| = -3 dB at 10 sqrt(sqrt(2) - 1) rad/s and
    # |1 - T| = -3 dB at sqrt(-300 + sqrt(100000)) rad/s (sampled at 200 Hz: within 2 %)
    assert data["closed_loop"]["status"] == "ok" and (out / "closed_loop.png").is_file()
    assert data["bandwidth_inner_hz"] == pytest.approx(10 * math.sqrt(math.sqrt(2) - 1) / (2 * math.pi), rel=0.02)
    assert data["bandwidth_sensitivity_inner_hz"] == pytest.approx(
        math.sqrt(-300 + math.sqrt(100000)) / (2 * math.pi), rel=0.02)
    # the velocity loop is slower by at least the thesis's factor 3 (§7.1)
    assert data["bandwidth_sensitivity_ratio"] >= 3.0 and data["cascade_rule_ok"] is True
    assert 0 < data["bandwidth_sensitivity_outer_hz"] < data["bandwidth_sensitivity_inner_hz"] / 3
    # standard JSON: no NaN/Infinity tokens
    json.loads((out / "analysis.json").read_text(), parse_constant=lambda c: pytest.fail(c))


def test_markdown_report_explains_the_results(run):
    _, out = run
    md = (out / "analysis.md").read_text()
    for phrase in ("non-minimum phase", "Controllability", "PBH", "Gramian", "constraint modes",
                   "thesis §2.5", "Closed loop"):
        assert phrase in md, phrase
    for png in ("pole_zero.png", "singular_values.png"):
        assert f"]({png})" in md


def test_analyze_at_state_and_no_plots(tmp_path, capsys):
    rc = cli.main(["analyze", "--out", str(tmp_path), "--at", "yaw=45", "--no-plots"])
    assert rc == 0
    data = json.loads((tmp_path / "analysis.json").read_text())
    assert data["operating_point"]["rpy_deg"][2] == pytest.approx(45.0, abs=1e-9)
    assert not list(tmp_path.glob("*.png"))
    assert "controllability rank 10" in capsys.readouterr().out


def test_analyze_with_params_file(tmp_path):
    pfile = tmp_path / "robot.toml"
    pfile.write_text("[body]\nl = 0.6\n")
    out = tmp_path / "out"
    assert cli.main(["analyze", "--params", str(pfile), "--out", str(out), "--no-plots"]) == 0
    data = json.loads((out / "analysis.json").read_text())
    assert data["parameters"]["l"] == 0.6
    hand = data["planar_reduction"]
    assert max(data["unstable_poles"]) == pytest.approx(max(hand["pole_pitch"], hand["pole_roll"]), rel=1e-9)


@pytest.mark.parametrize(
    "args, message",
    [
        (["--at", "roll=4"], "not an equilibrium"),
        (["--at", "tilt=4"], "key=value"),
        (["--at", "1,2"], "expected 12"),
        (["--params", "/nonexistent/robot.toml"], "does not exist"),
    ],
)
def test_bad_input_exits_2_with_message(tmp_path, capsys, args, message):
    rc = cli.main(["analyze", "--out", str(tmp_path / "o"), "--no-plots", *args])
    assert rc == 2
    err = capsys.readouterr().err
    assert "ballbot analyze: error:" in err and message in err
    assert not (tmp_path / "o" / "analysis.json").exists()


def test_demo_step_is_registered_and_writes_into_out_analysis(tmp_path, capsys):
    from ballbot_casadi.studies.analyze import demo_step

    assert demo_step(tmp_path) == 0
    assert (tmp_path / "analysis" / "analysis.json").is_file()
    assert (tmp_path / "analysis" / "analysis.md").is_file()
    text = capsys.readouterr().out
    assert "unstable poles" in text and "RHP zeros" in text
    assert not math.isnan(json.loads((tmp_path / "analysis" / "analysis.json").read_text())["unstable_poles"][0])

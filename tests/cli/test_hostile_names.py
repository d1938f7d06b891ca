"""Security: every name that becomes a path is one plain file-name component.

A scenario ``name`` (in the file or by ``--set name=...``) becomes
``worst/<name>_mcNNNN.toml`` under ``ballbot montecarlo``'s output folder; a name with a
separator, ``..`` or an absolute path must be refused (one line, exit 2) before anything
is simulated or written.
"""

from __future__ import annotations

import pytest

from ballbot_casadi import cli
from ballbot_casadi.cli import montecarlo as cli_montecarlo
from ballbot_casadi.core.safe_paths import check_file_name, member_problem, name_problem
from ballbot_casadi.errors import PathError, ScenarioFileError
from ballbot_casadi.sim.scenario import parse_scenario

BAD_NAMES = ["../../../x", "/abs/path", "a/b", "a\\b", "..", " .. ", ".", "   ", "C:evil",
             "new\nline", "nul\x00byte", "-rf", "é" * 150]
GOOD_NAMES = ["com", "my run", "sine_asym-2", "v1.2", "ü", "x..y"]


@pytest.mark.parametrize("name", BAD_NAMES)
def test_bad_names_are_refused(name):
    assert name_problem(name) is not None
    with pytest.raises(PathError, match="scenario name"):
        check_file_name(name, "scenario name")


@pytest.mark.parametrize("name", GOOD_NAMES)
def test_plain_names_are_kept(name):
    assert name_problem(name) is None and check_file_name(name, "x") == name


@pytest.mark.parametrize("name", ["../../../x", "/abs/path", "a/b"])
def test_scenario_file_name_key_is_refused(name):
    with pytest.raises(ScenarioFileError, match=r"key 'name': must"):
        parse_scenario({"name": name, "duration_s": 1.0}, "f.toml")


@pytest.mark.parametrize("member, bad", [
    ("SystemStructure.ssd", False), ("resources/a.fmu", False), ("a/b/../c", True),
    ("../../../../x", True), ("/etc/x", True), ("\\x", True), ("C:/x", True),
    ("resources\\..\\..\\x", True), ("", True), ("a\x00b", True), ("..data", False)])
def test_archive_member_paths(member, bad):
    assert (member_problem(member) is not None) is bad


def _never(*_a, **_k):
    pytest.fail("montecarlo simulated before checking the scenario name")


@pytest.mark.parametrize("how", ["file", "set-abs", "set-dotdot"])
def test_montecarlo_refuses_path_names_before_running(tmp_path, capsys, monkeypatch, how):
    monkeypatch.setattr(cli_montecarlo, "run_montecarlo", _wrap_no_execute(monkeypatch))
    target = tmp_path / "outside"
    scen = tmp_path / "s.toml"
    name = {"file": "../../../outside", "set-abs": str(target), "set-dotdot": "../outside"}[how]
    if how == "file":
        scen.write_text(f'name = "{name}"\nduration_s = 0.05\n')
        argv = ["montecarlo", str(scen), "--n", "2", "--workers", "0", "--out", str(tmp_path / "o")]
    else:
        scen.write_text("duration_s = 0.05\n")
        argv = ["montecarlo", str(scen), "--n", "2", "--workers", "0", "--out", str(tmp_path / "o"),
                "--set", f"name={name}"]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith("ballbot montecarlo: error:"), err
    assert "name" in err and "Traceback" not in err
    assert not list(tmp_path.rglob("*_mc*.toml")) and not target.exists()


def _wrap_no_execute(monkeypatch):
    from ballbot_casadi.studies import montecarlo_report as study_mc

    monkeypatch.setattr(study_mc, "execute", _never)
    return study_mc.run_montecarlo

"""The study registry's ``--set`` handling against hand-written expectations: which runs
an override reaches, which keys ``--set`` accepts (issue 23, test strength)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from ballbot_casadi.errors import ScenarioFileError
from ballbot_casadi.studies.registry import (SET_EVERY_RUN, get_study, parse_overrides,
                                             resolve_scenario, shipped_scenarios)


def test_set_main_only_studies_change_the_main_run_except_for_every_run_keys():
    study = get_study("robustness")
    assert study.set_main_only and len(study.files) > 1
    tables = study.tables("flc", [("duration_s", 0.5), ("seed", 9)])
    assert [t["duration_s"] == 0.5 for t in tables] == [False] * (len(tables) - 1) + [True]
    assert all(t["seed"] == 9 for t in tables)  # seed is in SET_EVERY_RUN
    assert "seed" in SET_EVERY_RUN and all(t["controller"] == "flc" for t in tables)


def test_a_runs_source_names_the_overrides_only_where_they_reached_it():
    """Each run's file path says "(with --set ...)" exactly when an override changed it: every
    run for a key of SET_EVERY_RUN, else the main run only (a set_main_only study)."""
    study = get_study("robustness")
    where = {str(shipped_scenarios()[f]) for f in study.files}
    files = study.scenario_files("flc", [("duration_s", 0.5)])
    assert [f.path.endswith(" (with --set duration_s=0.5)") for f in files] == \
        [False] * (len(files) - 1) + [True]
    assert all(f.path in where for f in files[:-1])
    files = study.scenario_files("flc", [("duration_s", 0.5), ("seed", 9)])
    assert all(f.path.endswith(" (with --set duration_s=0.5, seed=9)") for f in files)
    assert all(f.path in where for f in study.scenario_files("flc"))


def test_overrides_parse_toml_values_and_dotted_keys():
    assert parse_overrides(["duration_s=20", "attitude.roll.amplitude_deg = 5.5", "estimator=ukf",
                            "noise=false", "name=a b"]) == [
        ("duration_s", 20), ("attitude.roll.amplitude_deg", 5.5), ("estimator", "ukf"),
        ("noise", False), ("name", "a b")]


@pytest.mark.parametrize("item", ["duration_s", "=5", "a b=1", "a..b=1", "a.=1", "x/y=1", "a-b=2"])
def test_malformed_overrides_are_refused(item):
    with pytest.raises(ScenarioFileError, match="KEY=VALUE"):
        parse_overrides([item])


def test_a_scenario_is_a_file_when_it_looks_like_one_else_a_shipped_name(tmp_path, monkeypatch):
    """``resolve_scenario``: a ``.toml`` name, a path with a folder or an existing file is read
    as a file (missing: "not found", never the shipped file of that stem); a bare name is a
    shipped scenario."""
    monkeypatch.chdir(tmp_path)
    shipped = shipped_scenarios()
    assert resolve_scenario("com") == shipped["com"]
    for ref in ("com.toml", "sub/com", str(tmp_path / "com")):
        with pytest.raises(ScenarioFileError, match=f"^{re.escape(ref)}: scenario file not found$"):
            resolve_scenario(ref)
    (tmp_path / "com").write_text("")  # an existing file of a shipped name, without the suffix
    assert resolve_scenario("com") == Path("com")
    (tmp_path / "com").unlink()
    (tmp_path / "com").mkdir()  # a folder of that name is not a scenario file
    with pytest.raises(ScenarioFileError, match="^com: scenario file not found$"):
        resolve_scenario("com")
    with pytest.raises(ScenarioFileError, match="^nope: no such scenario file, nor a shipped "
                                                 "scenario; shipped: .*com"):
        resolve_scenario("nope")


def test_the_studies_com_offset_is_the_thesis_one():
    """Thesis §8.4.2 / §9.2: the COM moved by (-2, -3, +3) cm in the body frame."""
    from ballbot_casadi.studies.registry import COM_CHANGES

    assert dict(COM_CHANGES) == {"com_x": ("set", -0.02), "com_y": ("set", -0.03), "l": ("add", 0.03)}

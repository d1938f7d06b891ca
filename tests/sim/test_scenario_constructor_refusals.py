"""Scenario objects and files refuse what they cannot hold, each with one line naming what is
wrong and what is allowed: the ``Scenario(...)`` constructor's arguments, sections given by
name, a spec threshold that is neither a finite number nor true/false, a ``path`` that is not
a table; and a Scenario compares only with a Scenario and shows every field."""

from __future__ import annotations

import math

import pytest

from ballbot_casadi.errors import ScenarioFileError
from ballbot_casadi.sim.scenario import Scenario, parse_scenario
from ballbot_casadi.sim.scenario.scenario import SCENARIO_FIELDS


def test_the_constructor_takes_at_most_one_positional_argument_per_field():
    n = len(SCENARIO_FIELDS)
    with pytest.raises(TypeError, match=rf"^Scenario\(\) takes at most {n} positional arguments$"):
        Scenario(*(["x"] * (n + 1)))


def test_the_constructor_needs_a_name_and_known_fields_once():
    with pytest.raises(TypeError, match=r"^Scenario\(\) needs a name$"):
        Scenario(duration=1.0)
    with pytest.raises(TypeError, match=r"got field\(s\) \['name'\] twice or unknown field\(s\) "
                                        r"\[\]; allowed: \['name', 'controller'"):
        Scenario("a", name="b")
    with pytest.raises(TypeError, match=r"\[\] twice or unknown field\(s\) \['speed'\]"):
        Scenario("a", speed=1.0)
    assert Scenario("a", "smc").controller == "smc"  # positional in SCENARIO_FIELDS order


def test_sections_are_given_by_their_own_names():
    with pytest.raises(TypeError, match=r"^unknown scenario section\(s\) \['runs'\]$"):
        Scenario.from_sections(runs=None)
    sc = Scenario("a")
    assert Scenario.from_sections(run=sc.run) == sc  # the others default


def test_a_scenario_equals_only_a_scenario_and_shows_every_field():
    sc = Scenario("a", duration=2.0)
    assert sc.__eq__("a") is NotImplemented and sc != "a" and sc != Scenario("a")
    assert sc == Scenario("a", duration=2.0)
    text = repr(sc)
    assert text.startswith("Scenario(name='a', controller='flc', duration=2.0, x0=(")
    assert all(f"{f}=" in text for f in SCENARIO_FIELDS) and text.endswith(")")


@pytest.mark.parametrize("thr", [math.nan, math.inf, "x", [1.0]])
def test_a_spec_threshold_is_a_finite_number_or_a_boolean(thr):
    table = {"name": "a", "duration_s": 1.0,
             "spec": [{"metric": "peak_tilt_deg", "op": "<=", "threshold": thr}]}
    with pytest.raises(ScenarioFileError, match=r"key 'spec\[0\]\.threshold': expected a finite "
                                                r"number or true/false, got "):
        parse_scenario(table)
    for ok in (True, 3, 2.5):
        table["spec"][0]["threshold"] = ok
        assert parse_scenario(table).specs[0]["threshold"] == ok


@pytest.mark.parametrize("path", [3, "line", [1, 2]])
def test_a_path_is_a_table(path):
    with pytest.raises(ScenarioFileError, match=rf"key 'path': expected a table, got "
                                                rf"{type(path).__name__}$"):
        parse_scenario({"name": "a", "duration_s": 1.0, "path": path})

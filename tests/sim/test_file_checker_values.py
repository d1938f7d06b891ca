"""The scenario file's key-by-key checker (sim.scenario.checker.FileChecker) on its own:
each bound exactly at and just past its limit, the default of a missing key, the value
returned and the one-line message naming the file and the dotted key (issue 23: a ``<``
for ``<=``, a wrong default or a message naming the wrong key must show)."""

from __future__ import annotations

import math

import pytest

from ballbot_casadi.errors import ScenarioError, ScenarioFileError
from ballbot_casadi.sim.scenario.checker import FileChecker

C = FileChecker("f.toml")


def _fails(call, key: str, *needles: str) -> str:
    with pytest.raises(ScenarioFileError) as info:
        call()
    text = str(info.value)
    assert text.startswith(f"f.toml: key '{key}': "), text
    for needle in needles:
        assert needle in text, text
    return text


def test_fail_names_file_and_key():
    err = C.fail("a.b", "why")
    assert isinstance(err, ScenarioFileError) and str(err) == "f.toml: key 'a.b': why"


def test_num_bounds_closed_and_open():
    t = {"v": 1.0, "z": 0, "neg": -1e-12, "big": 2.0, "i": 3}
    assert C.num(t, "missing", "x", 7.5) == 7.5 and C.num(t, "missing", "x") is None
    got = C.num(t, "i", "x")
    assert got == 3.0 and isinstance(got, float)
    assert C.num(t, "z", "x", lo=0.0) == 0.0  # closed lower bound: 0 allowed
    _fails(lambda: C.num(t, "neg", "s.neg", lo=0.0), "s.neg", "must be >= 0")
    _fails(lambda: C.num(t, "z", "s.z", lo=0.0, lo_open=True), "s.z", "must be > 0")
    assert C.num(t, "v", "x", lo=0.0, lo_open=True, hi=1.0) == 1.0  # hi inclusive
    _fails(lambda: C.num(t, "big", "s.big", hi=1.0), "s.big", "must be <= 1", "2.0")
    _fails(lambda: C.num({"b": True}, "b", "s.b"), "s.b", "expected a number", "bool")
    _fails(lambda: C.num({"s": "1"}, "s", "s.s"), "s.s", "expected a number")
    _fails(lambda: C.num({"n": math.nan}, "n", "s.n"), "s.n", "must be finite")
    _fails(lambda: C.num({"n": -math.inf}, "n", "s.n", lo=0.0), "s.n", "must be finite")


def test_integer_bound_default_and_types():
    assert C.integer({}, "k", "k", 5, 1) == 5
    assert C.integer({"k": 1}, "k", "k", 5, 1) == 1  # at the bound
    _fails(lambda: C.integer({"k": 0}, "k", "r.k", 5, 1), "r.k", "integer >= 1", "got 0")
    _fails(lambda: C.integer({"k": True}, "k", "r.k", 5, 0), "r.k")
    _fails(lambda: C.integer({"k": 2.0}, "k", "r.k", 5, 0), "r.k")


def test_choice_text_boolean():
    assert C.choice({}, "c", "c", "a", ("a", "b")) == "a"
    assert C.choice({"c": "b"}, "c", "c", "a", ("a", "b")) == "b"
    _fails(lambda: C.choice({"c": "d"}, "c", "t.c", "a", ("a", "b")), "t.c", "allowed: a, b", "'d'")
    _fails(lambda: C.choice({"c": 1}, "c", "t.c", "a", ("a", "b")), "t.c")
    assert C.text({}, "t", "t") == "" and C.text({}, "t", "t", "dflt") == "dflt"
    assert C.text({"t": "x"}, "t", "t", "dflt") == "x"
    _fails(lambda: C.text({"t": 3}, "t", "t.t"), "t.t", "expected a string")
    assert C.boolean({}, "b", "b", True) is True and C.boolean({}, "b", "b", False) is False
    assert C.boolean({"b": False}, "b", "b", True) is False
    _fails(lambda: C.boolean({"b": 1}, "b", "t.b", False), "t.b", "true or false")


def test_keys_unknown_and_missing_name_the_dotted_key():
    assert C.keys({"a": 1}, "sec", ("a", "b")) == {"a": 1}
    _fails(lambda: C.keys({"c": 1}, "sec", ("a", "b")), "sec.c", "unknown key", "a, b")
    _fails(lambda: C.keys({"c": 1}, "", ("a",)), "c", "unknown key")
    _fails(lambda: C.keys({"a": 1}, "sec", ("a", "b"), ("b",)), "sec.b", "missing (required)")
    _fails(lambda: C.keys([1], "sec", ("a",)), "sec", "expected a table", "list")


def test_rows_vector_interval():
    assert C.rows({}, "push") == [] and C.rows({"push": [{"a": 1}]}, "push") == [{"a": 1}]
    _fails(lambda: C.rows({"push": {"a": 1}}, "push"), "push", "[[push]]")
    _fails(lambda: C.rows({"push": [1]}, "push"), "push")
    assert C.vector({}, "v", "g.v") == () and C.vector({"v": [1, 2.5]}, "v", "g.v", 2) == (1.0, 2.5)
    _fails(lambda: C.vector({"v": [1, 2]}, "v", "g.v", 3), "g.v", "expected 3 numbers, got 2")
    _fails(lambda: C.vector({"v": [1, True]}, "v", "g.v"), "g.v", "array of numbers")
    _fails(lambda: C.vector({"v": 1.0}, "v", "g.v"), "g.v", "array of numbers")
    _fails(lambda: C.vector({"v": [1.0, math.inf]}, "v", "g.v"), "g.v", "finite")
    row = {"t_start_s": 0.0, "t_end_s": 0.5, "tau_nm": 1}
    assert C.interval(row, "td[0]", "tau_nm") == (0.0, 0.5)
    _fails(lambda: C.interval({**row, "t_end_s": 0.0}, "td[0]", "tau_nm"), "td[0].t_end_s",
           "must be after t_start_s (0)")
    _fails(lambda: C.interval({**row, "t_start_s": -0.1}, "td[0]", "tau_nm"), "td[0].t_start_s", ">= 0")
    _fails(lambda: C.interval({"t_start_s": 0.0, "t_end_s": 1.0}, "td[0]", "tau_nm"),
           "td[0].tau_nm", "missing")


def test_keyed_turns_a_keyed_scenario_error_into_a_file_error():
    def parse(x):
        raise ScenarioError("bad thing", key="path.speed_mps")
    _fails(lambda: C.keyed(parse, 1), "path.speed_mps", "bad thing")

    def unkeyed(x):
        raise ScenarioError("bad thing")
    _fails(lambda: C.keyed(unkeyed, 1), "scenario", "bad thing")
    assert C.keyed(lambda a, b: a - b, 5, 3) == 2

"""The FMU refuses exactly the parameter values that core.params refuses (boundaries too);
Integer parameters exactly outside their bounds, Booleans other than 0 and 1."""

from __future__ import annotations

import math
from ctypes import c_double, c_int, c_uint

import pytest
from _fmu_support import Plant

from ballbot_casadi.core.params import PARAM_RULES
from ballbot_casadi.fmi.build import plant_variables

pytestmark = pytest.mark.needs_cc


def _probes(lo: float, hi: float) -> list[float]:
    vals = [0.0, 1.0, -1.0]
    for b in (lo, hi):
        if math.isfinite(b):
            vals += [b, math.nextafter(b, -math.inf), math.nextafter(b, math.inf)]
    return vals


def test_fmu_parameter_checks_equal_the_python_rules():
    p = Plant("cs", name="rules")
    checked = 0
    for v in plant_variables():
        if v.kind != "parameter" or v.type != "Real" or v.name.startswith("x0_"):
            continue  # the start state x0_* need only be finite (and a unit quaternion)
        rule = PARAM_RULES[v.rule]
        for value in _probes(rule.lo, rule.hi):
            st = p.raw("fmi2SetReal", (c_uint * 1)(v.vr), 1, (c_double * 1)(value))
            assert (st == 0) == rule.contains(value), (v.name, value, p.errors()[-1:])
            checked += 1
        # restore the start value for the next parameter
        assert p.raw("fmi2SetReal", (c_uint * 1)(v.vr), 1, (c_double * 1)(v.start)) == 0
    assert checked > 100
    refused = [m for m in p.errors() if "'alpha'" in m]
    assert refused and "radians" in refused[-1]
    p.free()


def test_integer_and_boolean_parameters_are_range_checked():
    p = Plant("cs", name="int_rules")
    ints = [v for v in plant_variables() if v.kind == "parameter" and v.type == "Integer"]
    bools = [v for v in plant_variables() if v.kind == "parameter" and v.type == "Boolean"]
    assert [v.name for v in ints] == ["seed"]
    assert [v.name for v in bools] == ["noise_on", "heading_sensor"]
    for v in ints:
        lo, hi = v.bounds
        for value, ok in ((lo, True), (lo - 1, False), (hi, True), (7, True), (-2**31, False)):
            st = p.raw("fmi2SetInteger", (c_uint * 1)(v.vr), 1, (c_int * 1)(value))
            assert (st == 0) == ok, (v.name, value, p.errors()[-1:])
            if not ok:
                assert "an integer in [0, 2147483647]" in p.errors()[-1]
    for v in bools:
        for value, ok in ((0, True), (1, True), (2, False), (-1, False)):
            st = p.raw("fmi2SetBoolean", (c_uint * 1)(v.vr), 1, (c_int * 1)(value))
            assert (st == 0) == ok, (v.name, value)
        assert "must be fmi2True (1) or fmi2False (0), got -1" in p.errors()[-1]
    p.init()
    assert p.get_int("seed") == [7] and p.get_bool("noise_on") == [True]
    p.free()

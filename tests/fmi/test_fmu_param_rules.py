"""The FMU refuses exactly the parameter values that core.params refuses (boundaries too)."""

from __future__ import annotations

import math
from ctypes import c_double, c_uint

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
        if v.kind != "parameter":
            continue
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

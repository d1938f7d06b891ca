"""SSP parameter sets against the FMU's variable types: an Integer value may set a Real,
not the reverse; Booleans only Booleans; non-finite values and unknown names are refused
(issue 23, test strength)."""

from __future__ import annotations

import math

import pytest

from ballbot_casadi.errors import FileFormatError
from ballbot_casadi.fmi.system.ssp import check_parameters

VARS = {"c": {"r": ("Real", "parameter"), "i": ("Integer", "parameter"), "b": ("Boolean", "parameter")}}


@pytest.mark.parametrize("name, value", [("r", 2.5), ("r", 3), ("i", 4), ("b", True)])
def test_accepted(name, value):
    check_parameters({"c": {name: value}}, VARS)


@pytest.mark.parametrize("name, value, needle", [
    ("i", 2.5, "i is a Integer"), ("b", 1, "b is a Boolean"), ("r", True, "r is a Real"),
    ("i", True, "i is a Integer"), ("r", math.nan, "not finite"), ("r", math.inf, "not finite"),
    ("x", 1.0, "no variable 'x'"),
])
def test_refused(name, value, needle):
    with pytest.raises(FileFormatError, match=needle):
        check_parameters({"c": {name: value}}, VARS)
    with pytest.raises(FileFormatError, match="no such component"):
        check_parameters({"d": {"r": 1.0}}, VARS)


@pytest.mark.parametrize("xml, want", [
    ('<ssv:Real xmlns:ssv="{ssv}" value="2.5"/>', 2.5),
    ('<ssv:Integer xmlns:ssv="{ssv}" value="-7"/>', -7),
    ('<ssv:Boolean xmlns:ssv="{ssv}" value="true"/>', True),
    ('<ssv:Boolean xmlns:ssv="{ssv}" value=" 1 "/>', True),
    ('<ssv:Boolean xmlns:ssv="{ssv}" value="false"/>', False),
    ('<Integer value="12"/>', 12),                  # no namespace: read by its local name
    ('<Boolean value="TRUE"/>', True),
])
def test_a_value_element_is_read_by_its_local_name(xml, want):
    from xml.etree import ElementTree

    from ballbot_casadi.fmi.system.ssp import NS, _value

    got = _value(ElementTree.fromstring(xml.format(ssv=NS["ssv"])))
    assert got == want and type(got) is type(want)

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

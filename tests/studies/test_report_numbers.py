"""How the demo report writes a value (``studies.report._num``): lists element by element
in the same format, booleans as yes/no, None as n/a (issue 23, second fresh batch: the
list branch with its arguments swapped printed the format string for every element)."""

from __future__ import annotations

from ballbot_casadi.studies.report import _num


def test_values_lists_booleans_and_missing():
    assert _num(1.23456) == "1.235"
    assert _num(1.23456, ".2f") == "1.23"
    assert _num([1.23456, 2, -0.5], ".3g") == "1.23, 2, -0.5"
    assert _num((3.14159, [1.0, 2.5]), ".2f") == "3.14, 1.00, 2.50"
    assert _num([True, None, "x"]) == "yes, n/a, x"
    assert _num(None) == "n/a" and _num(False) == "no"

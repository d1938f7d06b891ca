"""How reports print values: floats (numpy's too) to four significant digits, the rest as
``str`` (issue 23: a precision change survived the tests)."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.studies.formatting import fmt, md_cell, write_metrics


@pytest.mark.parametrize("value, text", [
    (1.23456, "1.235"), (0.000123456, "0.0001235"), (123456.0, "1.235e+05"), (2.5, "2.5"),
    (np.float64(0.987654), "0.9877"), (float("nan"), "nan"), (3, "3"), (True, "True"), (None, "None"),
    ("x", "x"),
])
def test_fmt(value, text):
    assert fmt(value) == text


@pytest.mark.parametrize("text, cell", [
    ("pass if |drift| <= 5x", "pass if \\|drift\\| <= 5x"),
    ("already \\|x\\| escaped", "already \\|x\\| escaped"),   # not escaped twice
    ("two\nlines", "two lines"), (0.5, "0.5"), ("plain", "plain"),
])
def test_md_cell_escapes_pipes_once_and_joins_lines(text, cell):
    assert md_cell(text) == cell


def test_metrics_json_is_indented_by_two_with_a_final_newline(tmp_path):
    """Every study's metrics.json: two-space indentation, one final newline, keys in their order."""
    path = write_metrics(tmp_path, {"b": [1, 2.5], "a": {"passed": True}})
    assert path == tmp_path / "metrics.json"
    assert path.read_text() == '{\n  "b": [\n    1,\n    2.5\n  ],\n  "a": {\n    "passed": true\n  }\n}\n'

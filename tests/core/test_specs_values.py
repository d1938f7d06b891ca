"""Spec operators and the failure rule on values that separate ``<`` from ``<=``, a signed
value from its magnitude, and a bound from its reciprocal (issue 23, test strength)."""

from __future__ import annotations

import math

import pytest

from ballbot_casadi.core.specs import FALL_TILT_DEG, SPEC_OPS, Spec, run_failure, spec_ok, spec_usage

#: (value, op, threshold, expected): at, just inside and just beyond each threshold.
TABLE = [
    (1.0, "<", 1.0, False), (0.999, "<", 1.0, True),
    (1.0, "<=", 1.0, True), (1.001, "<=", 1.0, False),
    (1.0, ">", 1.0, False), (1.001, ">", 1.0, True),
    (1.0, ">=", 1.0, True), (0.999, ">=", 1.0, False),
    (-2.0, "abs<=", 2.0, True), (-2.001, "abs<=", 2.0, False), (2.001, "abs<=", 2.0, False),
    (True, "==", True, True), (False, "==", True, False),
    (math.nan, "<=", 1.0, False), (math.nan, ">=", 1.0, False), (None, "<", 1.0, False),
    ("text", "<", 1.0, False),
]


@pytest.mark.parametrize("value, op, threshold, expected", TABLE)
def test_spec_ok_at_the_threshold(value, op, threshold, expected):
    assert spec_ok(value, op, threshold) is expected
    assert Spec("m", op, threshold, "s").ok({"m": value}) is expected


def test_every_operator_is_in_the_table():
    assert set(SPEC_OPS) == {op for _, op, _, _ in TABLE}


def test_a_missing_metric_fails_and_a_row_reports_the_value():
    s = Spec("tilt", "abs<=", 2.0, "why", "thesis 2 deg")
    assert s.ok({}) is False
    assert s.evaluate({"tilt": -1.5}) == {"metric": "tilt", "value": -1.5, "op": "abs<=", "threshold": 2.0,
                                          "ok": True, "source": "why", "thesis": "thesis 2 deg"}


@pytest.mark.parametrize("value, op, threshold, usage", [
    (3.0, "<", 4.0, 0.75), (5.0, "<=", 4.0, 1.25),
    (-3.0, "abs<=", 4.0, 0.75), (3.0, "abs<=", -4.0, 0.75),
    (8.0, ">=", 4.0, 0.5), (2.0, ">", 4.0, 2.0), (-1.0, ">", 4.0, math.inf),
])
def test_spec_usage_is_the_fraction_of_the_allowance(value, op, threshold, usage):
    assert spec_usage(value, op, threshold) == pytest.approx(usage, rel=1e-15)


@pytest.mark.parametrize("value, op, threshold", [
    (True, "<", 2.0), (False, ">=", 1.0), (None, "<=", 1.0), ("0.5", "<", 1.0), ([0.5], "<", 1.0),
    (0.5, "<", True), (0.5, "<", "1"), (0.5, "<", 0), (0.5, "<", 0.0), (math.nan, "<", 1.0),
    (math.inf, "<=", 1.0), (1.0, "==", 1.0),
])
def test_spec_usage_has_no_fraction_for_what_is_not_a_number(value, op, threshold):
    """Booleans, missing and non-numeric values or thresholds, a zero threshold, a
    non-finite value and equality specs have no fraction of an allowance."""
    assert spec_usage(value, op, threshold) is None


def test_the_fall_rule_at_its_boundary():
    """A fall is a body at or beyond horizontal: 90 deg of tilt."""
    assert FALL_TILT_DEG == 90.0
    assert run_failure({"finite": True, "peak_tilt_deg": 90.0}) == (
        "the robot fell: peak tilt 90 deg >= 90 deg")
    assert run_failure({"finite": True, "peak_tilt_deg": 123.456}) == (
        "the robot fell: peak tilt 123.5 deg >= 90 deg")
    assert run_failure({"finite": True, "peak_tilt_deg": math.nextafter(90.0, 0.0)}) is None
    assert run_failure({"finite": False, "peak_tilt_deg": 1.0}) == (
        "the state or the torques became NaN or Inf")
    assert run_failure({"peak_tilt_deg": math.inf}) == "peak tilt is inf"
    assert run_failure({"peak_tilt_deg": math.nan}) == "peak tilt is nan"
    assert run_failure({"peak_tilt_deg": True}) is None  # not a number: the specs judge it
    assert run_failure({"finite": True, "peak_tilt_deg": 100}) is not None  # an int
    assert run_failure({}) is None

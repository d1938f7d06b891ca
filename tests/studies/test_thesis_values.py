"""Thesis-table verdicts on hand-built rows that separate the candidates: the distance to
the thesis's number taken as ``value - target`` (not the reverse), the thesis's set-up
judged before ours, ratios as ``num / den`` (issue 23, test strength)."""

from __future__ import annotations

import pytest

from ballbot_casadi.studies import thesis as TH

A, B = TH.Col("s", "a"), TH.Col("s", "b")


def _row(thesis_setup, ours, op, threshold, target=None, runs=None):
    r = TH.ThesisResult("k", "§9.1", "claim", "1", thesis_setup, ours, op, threshold, "why", target)
    return TH.thesis_table(runs or {("s", "flc"): {"a": 12.0, "b": 4.0}}, [r])[0]


def test_the_distance_to_the_target_is_value_minus_target():
    # 12 - 10 = 2 <= 3 passes; the reverse distance (-2) would pass ">= 1" wrongly
    assert _row(A, None, "<=", 3.0, target=10.0)["verdict"] == "pass"
    assert _row(A, None, ">=", 1.0, target=10.0)["verdict"] == "pass"
    assert _row(A, None, "<=", 1.0, target=10.0)["verdict"] == "differs"
    assert _row(A, None, "<=", -1.0, target=14.0)["verdict"] == "pass"   # 12 - 14 = -2


def test_the_thesis_setup_is_judged_before_ours():
    row = _row(A, B, "<=", 5.0)            # a = 12 (thesis set-up) fails, b = 4 (ours) would pass
    assert row["verdict"] == "differs" and (row["thesis_setup"], row["ours"]) == (12.0, 4.0)
    assert _row(None, B, "<=", 5.0)["verdict"] == "pass"


def test_a_ratio_is_num_over_den():
    row = _row(TH.Ratio(A, B), None, "<=", 3.5)
    assert row["thesis_setup"] == pytest.approx(3.0) and row["verdict"] == "pass"
    assert _row(TH.Ratio(B, A), None, ">=", 0.5)["verdict"] == "differs"   # 4 / 12 = 0.33
    assert _row(TH.Ratio(A, B), None, "<=", 3.5, runs={("s", "flc"): {"a": 1.0, "b": 0.0}})["verdict"] \
        == "not reproducible"

"""The thesis §7.1 limit rows at their boundaries: a commanded torque *at* ``tau_max`` is a
saturated command (exceeded), a tilt or tilt rate at the limit is within it; ``by_scenario``
reads the initial state and the reference (issue 23, test strength)."""

from __future__ import annotations

import math

import pytest

from ballbot_casadi.analysis.metrics import limit_rows

LIMITS = {"tilt_max": math.radians(5.0), "tilt_rate_max": math.radians(20.0)}


def _rows(**m):
    base = {"peak_tilt_deg": 1.0, "peak_tilt_rate_deg_s": 2.0, "peak_torque_nm": 0.5, "tau_max_nm": 2.0,
            "initial_tilt_deg": 0.0, "initial_tilt_rate_deg_s": 0.0, "reference_peak_tilt_deg": 0.0,
            "reference_peak_tilt_rate_deg_s": 0.0}
    return {r["metric"]: r for r in limit_rows({**base, **m}, LIMITS)}


@pytest.mark.parametrize("torque, exceeded", [(2.0, True), (2.0 * (1 - 1e-9), False), (2.5, True), (1.0, False)])
def test_a_command_at_tau_max_counts_as_exceeded(torque, exceeded):
    row = _rows(peak_torque_nm=torque)["peak_torque_nm"]
    assert row["exceeded"] is exceeded and row["limit"] == 2.0


@pytest.mark.parametrize("tilt, exceeded", [(5.0, False), (5.0 * (1 + 1e-6), True), (4.9, False)])
def test_a_tilt_at_the_limit_is_within(tilt, exceeded):
    row = _rows(peak_tilt_deg=tilt)["peak_tilt_deg"]
    assert row["exceeded"] is exceeded and row["limit"] == pytest.approx(5.0, rel=1e-15)


def test_rate_limit_in_deg_s_and_the_scenario_flag():
    rows = _rows(peak_tilt_rate_deg_s=21.0, initial_tilt_deg=6.0, reference_peak_tilt_rate_deg_s=25.0)
    assert rows["peak_tilt_rate_deg_s"]["limit"] == pytest.approx(20.0, rel=1e-15)
    assert rows["peak_tilt_rate_deg_s"]["exceeded"] and rows["peak_tilt_rate_deg_s"]["by_scenario"]
    assert rows["peak_tilt_deg"]["by_scenario"] and not rows["peak_tilt_deg"]["exceeded"]
    assert not rows["peak_torque_nm"]["by_scenario"]
    assert _rows(peak_tilt_deg=math.nan)["peak_tilt_deg"]["exceeded"] is True  # not measured = not within


@pytest.mark.parametrize("rel, beyond", [(0.5e-9, False), (1.5e-9, True)])
def test_the_relative_tolerance_of_a_limit_is_1e_9(rel, beyond):
    """Rounding of a value computed in radians: within 1e-9 of the limit is at it; a start
    or a peak 1.5e-9 beyond is beyond (for the value and for the scenario flag alike)."""
    v = 5.0 * (1 + rel)
    rows = _rows(peak_tilt_deg=v, initial_tilt_deg=v, peak_tilt_rate_deg_s=20.0 * (1 + rel),
                 reference_peak_tilt_rate_deg_s=20.0 * (1 + rel))
    for key in ("peak_tilt_deg", "peak_tilt_rate_deg_s"):
        assert rows[key]["exceeded"] is beyond and rows[key]["by_scenario"] is beyond


def test_a_run_without_its_start_values_is_not_flagged_by_the_scenario():
    """Metrics without the initial-state and reference keys (nothing known of the start)
    count the start as zero: not beyond even a tight limit."""
    tight = {"tilt_max": math.radians(0.5), "tilt_rate_max": math.radians(0.5)}
    rows = {r["metric"]: r for r in limit_rows({"peak_tilt_deg": 0.1, "peak_tilt_rate_deg_s": 0.1,
                                                "peak_torque_nm": 0.5, "tau_max_nm": 2.0}, tight)}
    assert [rows[k]["by_scenario"] for k in rows] == [False, False, False]
    assert [rows[k]["exceeded"] for k in rows] == [False, False, False]

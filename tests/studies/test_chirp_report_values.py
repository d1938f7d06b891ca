"""The chirp study's report section (studies.chirp.chirp_report_lines) read back on
hand-made metrics: each mode's row with its own bandwidth, saturation and fall, the
linear numbers and the thesis comparison quoting the right mode, and the torque-limit
table with our limit's numbers beside the per-wheel ones."""

from __future__ import annotations

import studies.chirp as CH

MODES = {
    "exact": {"bandwidth_hz": 1.61, "bandwidth_reason": "gain -3 dB", "first_saturation_s": 22.5,
              "first_saturation_hz": 1.234, "first_saturation_motor": 0, "saturation_hz_per_motor": [1.23, 1.5, None],
              "fell_at_s": None, "fell_at_hz": None, "peak_torque_nm": 4.0},
    "none": {"bandwidth_hz": 1.42, "bandwidth_reason": "lag 90 deg", "first_saturation_s": None,
             "first_saturation_hz": 1.111, "first_saturation_motor": 2, "saturation_hz_per_motor": [None, None, 1.9],
             "fell_at_s": 30.25, "fell_at_hz": 1.75, "peak_torque_nm": 3.5, "cross_axis_onset_s": 24.0,
             "cross_axis_onset_hz": 1.3, "cross_axis_error_max_deg": 0.77},
}


def _metrics(per_wheel: bool = True) -> dict:
    m = {"by_feedforward": MODES, "bandwidth_criterion": "CRIT", "linear_bandwidth_hz": 0.987,
         "linear_bandwidth_none_hz": 0.654}
    if per_wheel:
        m.update({"per_wheel_first_saturation_s": 21.0, "per_wheel_first_saturation_motor": 1,
                  "per_wheel_cross_axis_onset_s": 21.5, "per_wheel_cross_axis_onset_hz": 1.2,
                  "per_wheel_cross_axis_error_max_deg": 3.3, "per_wheel_fell_at_s": 27.0})
    return m


def test_each_mode_in_its_row_and_the_comparison_quotes_the_right_one():
    lines = CH.chirp_report_lines(_metrics(per_wheel=False))
    assert lines[0] == "## Chirp results" and lines[2].startswith("Bandwidth criterion: CRIT. ")
    i = lines.index("| --- | --- | --- | --- | --- | --- | --- |")
    assert lines[i + 1:i + 3] == [
        "| exact | 1.61 | gain -3 dB | 22.50 s / 1.234 Hz, motor 0 | 1.23, 1.5, none | no | 4 |",
        "| none | 1.42 | lag 90 deg | never | none, none, 1.9 | 30.25 s / 1.75 Hz | 3.5 |"]
    text = "\n".join(lines)
    assert "−3 dB at 0.987 Hz; linear FLC without feed-forward (thesis (8.45) with dq_ref): −3 dB at 0.654 Hz" in text
    assert "- Thesis: ≈1.25 Hz, read where" in text
    assert "Our motors first saturate at 1.23 Hz (exact feed-forward) and 1.11 Hz (thesis mode)" in text
    assert "reached only at 1.61 Hz (exact) and 1.42 Hz (thesis mode)" in text
    assert "Torque limit" not in text


def test_the_torque_limit_table_puts_ours_beside_the_per_wheel_limit():
    lines = CH.chirp_report_lines(_metrics())
    i = lines.index("## Torque limit: ours (direction-preserving) beside the thesis's (per-wheel)")
    assert lines[i + 4:i + 6] == ["| direction (ours) | none, motor 2 | 24.00 / 1.3 | 0.77 | 30.25 |",
                                  "| per-wheel (thesis §9.1) | 21.00, motor 1 | 21.50 / 1.2 | 3.3 | 27.00 |"]
    assert f"> {CH.CROSS_AXIS_DEG:g}° from (s / Hz)" in lines[i + 2]

"""The envelope study's report (studies.envelope.envelope_report_lines) read back on
hand-made metrics: each table cell under its controller, column and envelope kind, '>='
only where the bisection's upper end was recovered, the observer's verdict per estimator
with its allowance note only for the estimators' runs, and the sweep's rows."""

from __future__ import annotations

import studies.envelope as E

COLS = ("push_roll", "push_pitch", "push_diagonal", "torque_step")


def _row(base: float, open_end: str = "", open_limits: str = "push_diagonal") -> dict:
    """Envelope values base + column index (+ 10 for the within-limits kind); the column
    named in ``open_end`` (``open_limits`` for the within-limits kind) not bracketed (its
    search's upper end recovered)."""
    r = {}
    for kind, add, open_col in (("", 0.0, open_end), ("_limits", 10.0, open_limits)):
        for i, col in enumerate(COLS):
            r[E._key(col, kind)] = base + i + add
            b = "torque" if col == "torque_step" else col
            r[f"{b}{kind}_bracketed"] = b != open_col
    return r


def _metrics() -> dict:
    table = {"true": {"flc": _row(1.0), "flc_dob": _row(2.0, "push_pitch")},
             "ukf": {"flc": _row(3.0, "torque"), "flc_dob": _row(4.0)}}
    dob = {est: E.dob_verdict(rows, 0.25, 0.05) for est, rows in table.items()}
    return {"table": table, "dob": dob, "limits": E.LIMITS,
            "recovery": {"final_window_s": 0.5, "tilt_deg": 0.5, "tilt_rate_deg_s": 2.0, "heading_deg": 5.0},
            "dob_same_allowance": {"ukf": {"undisturbed_within": False}},
            "dob_gain_sweep": {"ukf": [
                {"controller": "flc", "separation": None, "tilt_deg": 0.1234, "tilt_rate_deg_s": 1.234,
                 "speed_mps": 0.0123, "torque_tv_nm_per_s": 12.4},
                {"controller": "flc_dob", "separation": 2.5, "tilt_deg": 0.5, "tilt_rate_deg_s": 3.0,
                 "speed_mps": 0.02, "torque_tv_nm_per_s": 99.6}]},
            "disturbance_time_s": 0.5, "duration_s": 4.0, "push_tol_deg": 0.25, "torque_tol_nm": 0.05}


def _section(lines: list[str], title: str) -> list[str]:
    i = lines.index(title)
    return lines[i + 4:i + 6]


def test_every_cell_under_its_controller_column_and_kind():
    lines = E.envelope_report_lines(_metrics())
    assert lines[0] == "# Push-recovery envelope per balance controller"
    assert _section(lines, "## recovered, controllers on the true state") == [
        "| flc | 1.00 | 2.00 | 3.00 | 4.00 |", "| flc_dob | 2.00 | >= 3.00 | 4.00 | 5.00 |"]
    assert _section(lines, "## recovered within the §7.1 limits, controllers on the true state") == [
        "| flc | 11.00 | 12.00 | >= 13.00 | 14.00 |", "| flc_dob | 12.00 | 13.00 | >= 14.00 | 15.00 |"]
    assert _section(lines, "## recovered, controllers on the QUKF + VUKF") == [
        "| flc | 3.00 | 4.00 | 5.00 | >= 6.00 |", "| flc_dob | 4.00 | 5.00 | 6.00 | 7.00 |"]
    i = lines.index("## recovered, controllers on the true state")
    assert lines[i + 2] == ("| controller | roll push (deg) | pitch push (deg) | diagonal push (deg) | "
                            "wheel-0 torque pulse 0.5 s (N m) |")


def test_the_observer_verdict_per_estimator_and_the_sweep():
    lines = E.envelope_report_lines(_metrics())
    true = next(s for s in lines if s.startswith("- true state: "))
    ukf = next(s for s in lines if s.startswith("- QUKF + VUKF: "))
    # every column is 1 higher with the observer: raised beyond 0.25 deg and 0.05 N m
    assert true.startswith("- true state: **raises** (beyond the bisection resolution; raised: push_roll_deg "
                           "1.00 -> 2.00, push_pitch_deg 2.00 -> 3.00")
    assert true.endswith("; lowered: none).") and "allowance" not in true
    assert ukf.startswith("- QUKF + VUKF: **raises** (beyond the bisection resolution, flc_dob judged with "
                          "the FLC's undisturbed allowance; its undisturbed run is already outside it; "
                          "raised: push_roll_deg 3.00 -> 4.00")
    i = lines.index("| controller | separation | tilt (deg) | tilt rate (deg/s) | speed (m/s) | "
                    "torque TV (N m/s) |")
    assert lines[i - 2].startswith("Observer bandwidth sweep, standing robot on the UKFs (seed 0, peaks from "
                                   "t = 0.5 s;")
    assert lines[i + 2:i + 4] == ["| flc | - | 0.123 | 1.23 | 0.012 | 12 |",
                                  "| flc_dob | 2.5 | 0.500 | 3.00 | 0.020 | 100 |"]


def test_an_estimator_run_inside_its_allowance_says_so_by_omission():
    m = _metrics()
    m["dob_same_allowance"] = {"ukf": {"undisturbed_within": True}}
    ukf = next(s for s in E.envelope_report_lines(m) if s.startswith("- QUKF + VUKF: "))
    assert ", flc_dob judged with the FLC's undisturbed allowance; raised:" in ukf
    m["dob_same_allowance"] = {}  # no same-allowance run recorded: no note of one outside
    ukf = next(s for s in E.envelope_report_lines(m) if s.startswith("- QUKF + VUKF: "))
    assert ", flc_dob judged with the FLC's undisturbed allowance; raised:" in ukf
    m["dob"]["ukf"] = E.dob_verdict({"flc": _row(3.0), "flc_dob": _row(3.1)}, 0.25, 0.05)
    ukf = next(s for s in E.envelope_report_lines(m) if s.startswith("- QUKF + VUKF: "))
    assert "**raises**" in ukf and "push_roll_deg" not in ukf  # only the torque columns moved > tol

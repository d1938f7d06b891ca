"""The studies' specs agree with the thesis bound each one cites (issue 23, fresh mutants:
a lag spec quoting "< 0.1 s" judged at 0.2 s went unnoticed).  Read from the spec's own
texts: "within +-N deg" is N; a §7.1 limit is thesis §7.1's value (5 deg, 20 deg/s, read
here from the thesis numbers, not from the constants); a spec whose source is the thesis
item and whose quote is "< N s" is N; "within Nx" is N; "within 3 sigma" is 3."""

from __future__ import annotations

import re

import pytest

from ballbot_casadi.studies.registry import STUDIES

SPECS = [(name, s) for name, st in STUDIES.items() for s in (st.specs or ())]
NUM = r"\d+(?:\.\d+)?"


def _expected(spec) -> float | None:
    src, quote = spec.source, spec.thesis or ""
    if m := re.search(rf"within (?:±|\+-)\s*({NUM})\s*(?:deg|°)", src):
        return float(m.group(1))
    if "§7.1 inclination limit" in src:
        return 5.0
    if "§7.1 inclination-rate limit" in src:
        return 20.0
    if src.startswith("thesis §") and (m := re.fullmatch(rf"<\s*({NUM})\s*s", quote.strip())):
        return float(m.group(1))
    if m := re.search(rf"within ({NUM})x", src):
        return float(m.group(1))
    if "within 3σ" in src:
        return 3.0
    return None


def test_each_spec_citing_a_thesis_bound_has_that_threshold():
    checked = []
    for name, s in SPECS:
        want = _expected(s)
        if want is None:
            continue
        assert s.threshold == pytest.approx(want, rel=1e-12), (name, s.metric, s.threshold, want)
        assert s.op in ("<", "<=", "abs<="), (name, s.metric)
        checked.append((name, s.metric))
    for want in [("lag", "ramp_lag_none_s"), ("lag", "sine_no_rate_lag_s"), ("full", "tilt_error_max_deg"),
                 ("full", "heading_error_max_deg"), ("full", "peak_tilt_deg_all"),
                 ("full", "peak_tilt_rate_deg_s_all"), ("full_cascade", "tilt_error_max_deg"),
                 ("predecessor", "ukf_vs_ekfh_roll_rms_ratio"), ("yaw_seeds", "thesis_yaw_mean_z")]:
        assert want in checked, want


def test_the_lag_specs_by_hand():
    lag = {s.metric: (s.op, s.threshold) for s in STUDIES["lag"].specs}
    assert lag == {"step_lag_none_s": ("<", 1.0), "step_lag_exact_s": ("abs<=", 0.05),
                   "ramp_lag_none_s": ("abs<=", 0.1), "sine_no_rate_lag_s": ("abs<=", 1.0)}

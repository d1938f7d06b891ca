"""The closed-loop analysis reports both tilt axes and both velocity axes: every per-axis
list has an x and a y entry, each loop's bandwidth is the smaller axis, the ratios and
verdicts follow from the reported bandwidths, and the frequency grid and stored response
are the documented ones (600 points from 0.01 rad/s to Nyquist)."""

from __future__ import annotations

import re

import numpy as np
import pytest

from ballbot_casadi import load_params
from ballbot_casadi.analysis import closed_loop as cla
from ballbot_casadi.analysis import linear as an
from ballbot_casadi.core.constants import TS_CONTROL


@pytest.fixture(scope="module")
def result(model_functions):
    params = load_params()
    lin, _ = an.analyze_plant(params, functions=model_functions)
    return cla.analyze_closed_loop(params, lin, model_functions)


def test_both_axes_of_both_loops_are_reported_and_the_smaller_one_counts(result):
    d = result["closed_loop"]
    assert d["status"] == "ok" and d["Ts"] == TS_CONTROL
    for key in ("inner", "outer"):
        loop = d[key]
        for field in ("bandwidth_axes_hz", "bandwidth_sensitivity_axes_hz", "dc_gain", "peak_gain_db"):
            assert len(loop[field]) == 2, (key, field)
        axes, axes_s = loop["bandwidth_axes_hz"], loop["bandwidth_sensitivity_axes_hz"]
        assert all(a is not None and a > 0 for a in axes + axes_s)
        assert result[f"bandwidth_{key}_hz"] == min(axes)
        assert result[f"bandwidth_sensitivity_{key}_hz"] == min(axes_s)
        # the peak of |H| over the grid is at least its value at the first frequency
        for i in range(2):
            assert loop["peak_gain_db"][i] >= 20 * np.log10(loop["dc_gain"][i]) - 1e-12
        resp = d["frequency_response"][key]
        assert len(resp["omega"]) == len(resp["mag"]) == len(resp["phase_deg"]) == 600
        assert resp["mag"][0] == pytest.approx(loop["dc_gain"][0], rel=1e-15)
        # the stored response is the x axis' tracking (|H| ~ 1, a small lag at 0.01 rad/s),
        # magnitude and phase of the same entry
        assert -1.0 < resp["phase_deg"][0] < 0.0 and abs(resp["mag"][0] - 1.0) < 1e-3, key
    w = np.asarray(d["frequency_response"]["inner"]["omega"])
    assert w[0] == pytest.approx(0.01, rel=1e-12) and w[-1] == pytest.approx(np.pi / TS_CONTROL, rel=1e-12)
    assert np.all(np.diff(np.log10(w)) == pytest.approx(np.log10(np.pi / TS_CONTROL / 0.01) / 599, rel=1e-9))


def test_ratios_and_verdicts_follow_from_the_bandwidths(result):
    bi, bo = result["bandwidth_inner_hz"], result["bandwidth_outer_hz"]
    si, so = result["bandwidth_sensitivity_inner_hz"], result["bandwidth_sensitivity_outer_hz"]
    assert result["bandwidth_ratio"] == pytest.approx(bi / bo, rel=1e-15)
    assert result["bandwidth_sensitivity_ratio"] == pytest.approx(si / so, rel=1e-15)
    assert result["cascade_rule_ok_3db"] is bool(bi / bo >= 3.0)
    assert result["cascade_rule_ok"] is bool(si / so >= 3.0)
    d = result["closed_loop"]
    assert d["max_real_pole"] == max(d["inner"]["max_real_pole"], d["outer"]["max_real_pole"])


def test_an_operating_point_the_controllers_do_not_hold_is_skipped_with_each_mismatch(model_functions):
    """Trim torques other than the ones the default controllers command at the operating
    point: the closed loop is not analysed, and the message names every mismatch (the
    balance and the cascade torque both off by the 0.25 N m added to one wheel; the
    velocity controller's state held)."""
    import dataclasses

    params = load_params()
    lin, _ = an.analyze_plant(params, functions=model_functions)
    off = dataclasses.replace(lin, op=dataclasses.replace(lin.op, tau=lin.op.tau + [0.0, 0.25, 0.0]))
    r = cla.analyze_closed_loop(params, off, model_functions)
    assert r["closed_loop"]["status"] == "skipped" and set(r["closed_loop"]) == {"status", "message"}
    m = re.fullmatch(r"the default controllers do not hold this operating point \(balance torque "
                     r"mismatch 0\.25, cascade torque mismatch 0\.25, velocity-controller state "
                     r"mismatch (\S+)\)", r["closed_loop"]["message"])
    assert m is not None, r["closed_loop"]["message"]
    assert float(m.group(1)) < 1e-9  # held, to round-off
    assert all(r[k] is None for k in ("bandwidth_inner_hz", "bandwidth_outer_hz", "bandwidth_ratio",
                                      "cascade_rule_ok", "cascade_rule_ok_3db"))

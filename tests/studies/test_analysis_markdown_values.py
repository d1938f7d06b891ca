"""``analysis.md`` read back against the analysis's own numbers (issue 23, test strength):
each bandwidth in Hz and rad/s under its loop's row, the unstable poles and RHP zeros, the
rank line and the 3x-rule verdict from the ratio it prints, and the file written whole."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.analysis import closed_loop as cla
from ballbot_casadi.analysis import linear as an
from ballbot_casadi.core.layout import STATE_DXY
from ballbot_casadi.core.params import load_params
from ballbot_casadi.studies import analysis_report as AR


@pytest.fixture(scope="module")
def result():
    params = load_params()
    lin, res = an.analyze_plant(params)
    res.update(cla.analyze_closed_loop(params, lin))
    res["parameters"] = params.as_dict()
    return res


def test_the_markdown_carries_the_analysis_numbers(result, tmp_path):
    path = AR.write_markdown(result, tmp_path, "thesis App. A defaults", [])
    assert path == tmp_path / "analysis.md"
    text = path.read_text(encoding="utf-8")
    assert text.endswith("\n") and not text.endswith("\n\n\n")
    lines = text.splitlines()
    for key, label in (("inner", "inner: FLC, tilt ref -> tilt"),
                       ("outer", "outer: velocity ctrl, v_ref -> ball velocity")):
        f3, fs = result[f"bandwidth_{key}_hz"], result[f"bandwidth_sensitivity_{key}_hz"]
        row = next(ln for ln in lines if ln.startswith(f"| {label} |"))
        cells = row.split(" | ")
        assert cells[1] == f"{f3:.3f} Hz ({2 * math.pi * f3:.2f} rad/s)", key
        assert cells[2] == f"{fs:.3f} Hz ({2 * math.pi * fs:.2f} rad/s)", key
        d = result["closed_loop"][key]
        assert cells[3] == f"{max(d['peak_gain_db']):+.2f} dB" and cells[4] == f"{d['max_real_pole']:.3f}"
    rs, r3 = result["bandwidth_sensitivity_ratio"], result["bandwidth_ratio"]
    assert rs == pytest.approx(result["bandwidth_sensitivity_inner_hz"] / result["bandwidth_sensitivity_outer_hz"])
    ok = "satisfied" if result["cascade_rule_ok"] else "NOT satisfied"
    assert (f"**3x rule (thesis §7.1: inner loop at least three times faster than the outer): {ok}** on the "
            f"tracking bandwidths (ratio {rs:.2f}); on the -3 dB points of |T| the ratio is {r3:.2f}") in text
    poles = ", ".join(f"{p:.4f}" for p in result["unstable_poles"])
    assert f"Unstable poles: {poles} rad/s" in text
    assert len(result["unstable_poles"]) == 2 and all(3.0 < p < 4.5 for p in result["unstable_poles"])
    assert f"**{result['controllability_rank']} of {result['n_states_reduced']}**" in text
    assert "Stability: all modes stable apart from the neutral ones" in text
    assert "## Plots" not in text


def test_number_cells():
    assert AR._hz(None) == "n/a (not reached on the grid)"
    assert AR._hz(1.0) == f"1.000 Hz ({2 * np.pi:.2f} rad/s)" == "1.000 Hz (6.28 rad/s)"
    assert AR._num(None) == "n/a" and AR._num(3.14159) == "3.14"
    assert AR._verdict(None) == "n/a" and AR._verdict(True) == "satisfied" and AR._verdict(False) == "NOT satisfied"
    assert AR._fmt_list([]) == "none"


def test_the_limitation_line_reads_the_largest_pole_and_smallest_rhp_zero(result, tmp_path):
    """|z+p|/|z-p| for the largest unstable pole and the smallest RHP zero, by hand, the
    z < p remark exactly when it holds, and the z/2 outer bandwidth."""
    text = AR.write_markdown(result, tmp_path, "thesis App. A defaults", []).read_text(encoding="utf-8")
    line = next(ln for ln in text.splitlines() if ln.startswith("Limitation:"))
    p = max(result["unstable_poles"])
    z = float(line.split("zero z = ")[1].split(" rad/s")[0])
    assert line.startswith(f"Limitation: with a real RHP pole p = {p:.3f} and zero z = ")
    assert f"least |z+p|/|z-p| = {abs(z + p) / abs(z - p):.1f}" in line
    assert ("practically uncontrollable" in line) == (z < p)
    assert f"roughly z/2 = {z / 2:.2f} rad/s = {z / 4 / np.pi:.2f} Hz" in line
    # the bound by hand on numbers that separate z+p from z-p and their order
    assert AR._sensitivity_bound(2.0, 3.0) == pytest.approx(5.0, rel=1e-15)
    assert AR._sensitivity_bound(3.0, 2.0) == pytest.approx(5.0, rel=1e-15)
    assert AR._sensitivity_bound(1.0, 5.0) == pytest.approx(1.5, rel=1e-15)


_EXACT_KEYS = ("com_x", "com_y", "Bvk", "Bvm", "Bvb")
_APPROX = "The planar reduction is exact only at rest with a centred COM and no friction"


def _with(result, params=None, velocity=(0.0, 0.0)):
    res = dict(result)
    res["parameters"] = params if params is not None else dict(result["parameters"], **dict.fromkeys(_EXACT_KEYS, 0.0))
    op = dict(result["operating_point"])
    state = np.array(op["state"], float)
    state[STATE_DXY] = velocity
    res["operating_point"] = dict(op, state=state)
    return res


def test_the_planar_reduction_remark_exactly_off_the_exact_case(result, tmp_path):
    """The hand check is called an approximation exactly when the COM is off-centre, a
    friction coefficient is non-zero or the ball moves; a parameter the result does not carry
    counts as zero (nothing to make the reduction inexact)."""
    def remark(res):
        return _APPROX in AR.write_markdown(res, tmp_path, "src", []).read_text(encoding="utf-8")

    assert not remark(_with(result))
    assert not remark(_with(result, params={}))
    for key in _EXACT_KEYS:
        assert remark(_with(result, params={key: 0.01})), key
        assert remark(_with(result, params={key: -0.01})), key
    assert remark(_with(result, velocity=(0.0, 0.2)))
    assert remark(_with(result, velocity=(-0.2, 0.0)))


def test_an_eigenvalue_is_printed_real_when_its_imaginary_part_is_round_off(result, tmp_path):
    """Below 1e-9 the imaginary part is the solver's round-off: printed as a real number."""
    res = {**result, "eigenvalues_full": [[1.0, 9.9e-10], [-1.0, -9.9e-10], [1.0, 1e-9],
                                          [-2.0, -0.5], [0.0, 0.0]]}
    text = AR.write_markdown(res, tmp_path, "thesis App. A defaults", []).read_text()
    row = next(ln for ln in text.splitlines() if ln.startswith("| 12-state |"))
    assert row == "| 12-state | +1.0000, -1.0000, +1.0000 +0.0000j, -2.0000 -0.5000j, +0.0000 |"

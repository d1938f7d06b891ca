"""``analysis.md`` written whole from hand-built analysis results and compared with pinned
copies (``report_snapshots/analysis_*.md``): every number, cell, verdict and branch of the
report a reader sees.  The inputs are written here, not computed, so the copies change only
when the report does; every value is distinct, so a swapped key or cell shows.  Re-pin after
a deliberate change with ``BALLBOT_PIN_REPORTS=1`` and review the difference."""

from __future__ import annotations

import copy
from pathlib import Path

import pytest
from _snapshots import assert_snapshot, snapshot_text

from ballbot_casadi.studies import analysis_report as AR


def _result() -> dict:
    """A full analysis: an unstable plant with RHP zeros, the closed loop computed."""
    mode = {"eigenvalues": [[-1.5, 0.25], [-1.5, -0.25]], "dominant_states": ["x", "dx"],
            "weakest_direction": ["dx"], "energy": 12.345}
    return {
        "operating_point": {"state": [0.11, -0.22, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0],
                            "tau": [0.015, -0.025, 0.035], "rpy_deg": [1.5, -2.5, 30.0],
                            "trim_residual": 3.2e-14},
        "reduced_state_names": ["x", "y", "v1", "v2", "v3", "dx", "dy", "dv1", "dv2", "dv3"],
        "reduction_invariance_error": 4.4e-16,
        "eigenvalues_full": [[3.75, 0.0], [-3.75, 0.0], [0.0, 0.0], [-10.0, 2e-12], [-2.25, 1.125]],
        "eigenvalues_reduced": [[3.75, 0.0], [-3.75, 0.0], [0.0, 0.0], [1e-8, 0.0], [0.0, 5e-7],
                                [0.0, 0.0], [0.0, 0.0], [0.0, 0.0], [-2.25, 1.125], [-2.25, -1.125]],
        "constraint_eigenvalues": [[-10.0, 0.0], [-10.5, 0.0]],
        "unstable_poles": [3.7467, 3.7419],
        "controllability_rank": 10,
        "n_states_reduced": 10,
        "controllability": {
            "singular_values": [87.6, 5.4, 0.0321],
            "rtol": 1e-9,
            "pbh": [{"eigenvalue": [3.75, 0.0], "sigma_min": 0.0123, "controllable": True},
                    {"eigenvalue": [0.0, 0.5], "sigma_min": 1.5e-17, "controllable": False}],
            "gramian_horizon_s": 1.5,
            "modes": [mode, {"eigenvalues": [[3.75, 0.0]], "dominant_states": ["v1", "dv1"],
                             "weakest_direction": ["v1"], "energy": 0.00789}],
            "weakest_mode": mode,
        },
        "channels": {
            "position": {"outputs": ["x", "y"], "minimal_order": 8, "poles": [[3.75, 0.0], [-3.75, 0.0]],
                         "zeros": [[2.9, 0.0], [-2.9, 0.0]], "rhp_zeros": [[2.9, 0.0]]},
            "tilt": {"outputs": ["v1", "v2"], "minimal_order": 4, "poles": [[3.74, 0.0]], "zeros": [],
                     "rhp_zeros": []},
        },
        "rhp_zeros_position": [2.9059, 2.9037],
        "planar_reduction": {"pole_pitch": 3.7467049, "zero_pitch": 2.9059444, "pole_roll": 3.7419871,
                             "zero_roll": 2.9037416},
        "parameters": {"com_x": 0.0, "com_y": 0.0, "Bvk": 0.0, "Bvm": 0.0, "Bvb": 0.0},
        "closed_loop": {
            "status": "ok", "description": "Cascade closed at Ts = 5 ms (a description).",
            "inner": {"peak_gain_db": [0.5, 1.25], "max_real_pole": -4.5221, "n_neutral_modes": 4,
                      "stable_apart_from_neutral": True},
            "outer": {"peak_gain_db": [2.5, -0.75], "max_real_pole": -0.4007, "n_neutral_modes": 3,
                      "stable_apart_from_neutral": True},
        },
        "bandwidth_inner_hz": 1.0344, "bandwidth_outer_hz": 5.2644,
        "bandwidth_sensitivity_inner_hz": 0.6427, "bandwidth_sensitivity_outer_hz": 0.1520,
        "bandwidth_ratio": 0.1965, "bandwidth_sensitivity_ratio": 4.2292,
        "cascade_rule_ok": True, "cascade_rule_ok_3db": False,
    }


def _variants() -> dict[str, tuple[dict, list[Path]]]:
    full = _result()
    # friction, a COM offset, rolling: three zero eigenvalues, the approximate planar remark,
    # z > p, the weakest mode a tilt mode; one loop unstable, the 3x verdicts the other way
    off = copy.deepcopy(full)
    off["eigenvalues_reduced"][5:8] = [[-0.5, 0.0], [-0.25, 0.0], [-0.125, 0.0]]
    off["parameters"]["Bvk"] = 0.01
    off["rhp_zeros_position"] = [4.5, 5.0]
    off["controllability"]["weakest_mode"] = off["controllability"]["modes"][1]
    off["closed_loop"]["outer"]["stable_apart_from_neutral"] = False
    off["cascade_rule_ok"], off["cascade_rule_ok_3db"] = False, True
    off["bandwidth_inner_hz"] = None
    # no RHP zero, no closed loop (with and without its message), other zero counts
    plant = copy.deepcopy(full)
    plant["rhp_zeros_position"] = []
    plant["eigenvalues_reduced"][3:8] = [[-1.0, 0.0]] * 4 + [[1.5e-6, 0.0]]   # 1.5e-6: not zero
    plant["closed_loop"] = {"status": "failed", "message": "the FLC is not available here"}
    bare = copy.deepcopy(plant)
    del bare["closed_loop"]
    bare["eigenvalues_reduced"][2] = [-1.0, 0.0]
    bare["unstable_poles"] = []
    moving = copy.deepcopy(full)
    moving["operating_point"]["state"][7] = -0.44   # rolling along y only: not exact
    return {"full": (full, [Path("/elsewhere/pole_zero.png"), Path("/elsewhere/closed_loop.png")]),
            "off_exact": (off, []), "plant_only": (plant, []), "bare": (bare, []),
            "moving": (moving, [])}


@pytest.mark.parametrize("name", list(_variants()))
def test_analysis_markdown_is_the_pinned_copy(tmp_path, name):
    result, plots = _variants()[name]
    before = copy.deepcopy(result)
    path = AR.write_markdown(result, tmp_path, "params/test robot.toml", plots)
    assert path == tmp_path / "analysis.md"
    assert result == before  # the report does not change its input
    assert_snapshot(f"analysis_{name}", path.read_text(encoding="utf-8"))


def test_the_variants_differ_where_their_branches_do():
    texts = {name: snapshot_text(f"analysis_{name}") for name in _variants()}
    assert "6 eigenvalues at zero: the double integrators" in texts["full"]
    assert "3 eigenvalues at zero: the ball position and heading" in texts["off_exact"]
    assert "1 eigenvalues at zero: rigid-body modes." in texts["plant_only"]
    assert "0 eigenvalues at zero: rigid-body modes." in texts["bare"]
    assert "(z < p: practically uncontrollable from position alone)" in texts["full"]
    assert "(z < p" not in texts["off_exact"]
    assert "at this operating point it is an approximation" in texts["off_exact"]
    assert "at this operating point it is an approximation" in texts["moving"]
    assert "at this operating point it is an approximation" not in texts["full"]
    assert "Not computed: the FLC is not available here." in texts["plant_only"]
    assert "Not computed: the controllers are not available." in texts["bare"]
    assert "No right-half-plane zeros at this operating point." in texts["bare"]
    assert "Unstable poles: none (one real" in texts["bare"]
    assert "UNSTABLE modes present" in texts["off_exact"]
    assert "![pole_zero](pole_zero.png)" in texts["full"] and "## Plots" not in texts["bare"]

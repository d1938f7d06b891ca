"""``ballbot analyze``'s printed summary (``summary_text``) line by line on a hand-made
result: rounding, the non-minimum-phase remark only with RHP zeros, the weakest modes,
and the closed-loop lines (not analysed only when neither bandwidth exists; ``n/a`` for
a missing one; the 3x-rule verdict of each kind)."""

from __future__ import annotations

import pytest

from ballbot_casadi.studies.analyze import summary_text


def _result(**kw):
    res = {"operating_point": {"rpy_deg": [1.23456, -0.0004, 90.0]},
           "n_states_reduced": 10, "controllability_rank": 9,
           "unstable_poles": [3.712345, 3.7], "rhp_zeros_position": [2.000049],
           "controllability": {"weakest_mode": {"weakest_direction": ["yaw", "x"], "energy": 0.012345},
                               "gramian_horizon_s": 2.5},
           "bandwidth_inner_hz": 1.23449, "bandwidth_outer_hz": 0.3,
           "bandwidth_sensitivity_inner_hz": 0.9, "bandwidth_sensitivity_outer_hz": 0.25,
           "bandwidth_sensitivity_ratio": 3.6, "cascade_rule_ok": True,
           "closed_loop": {"message": "m"}}
    res.update(kw)
    return res


def test_plant_lines():
    lines = summary_text(_result()).splitlines()
    assert lines[:5] == [
        "operating point rpy = [1.235, -0.0, 90.0] deg",
        "reduced model: 10 states, controllability rank 9",
        "unstable poles (rad/s): [3.7123, 3.7]",
        "RHP zeros torques->position (rad/s): [2.0]  (non-minimum phase)",
        "weakest controllable modes: yaw, x (energy 0.0123 tau_max^2 s in 2.5 s)",
    ]
    assert summary_text(_result(rhp_zeros_position=[])).splitlines()[3] == \
        "RHP zeros torques->position (rad/s): []"


@pytest.mark.parametrize("ok, verdict", [(True, "satisfied"), (False, "NOT satisfied"), (None, "n/a")])
def test_closed_loop_lines(ok, verdict):
    lines = summary_text(_result(cascade_rule_ok=ok)).splitlines()
    assert lines[5:] == [
        "-3 dB bandwidth |T|: inner (FLC) 1.234 Hz, outer (velocity) 0.300 Hz",
        "tracking bandwidth |1-T| = -3 dB: inner 0.900 Hz, outer 0.250 Hz, ratio 3.600; "
        f"3x rule (thesis 7.1): {verdict}",
    ]


@pytest.mark.parametrize("missing", ["bandwidth_inner_hz", "bandwidth_outer_hz"])
def test_one_missing_bandwidth_is_n_a_not_an_unanalysed_loop(missing):
    text = summary_text(_result(**{missing: None}))
    assert "not analysed" not in text
    inner, outer = ("n/a", "0.300") if missing == "bandwidth_inner_hz" else ("1.234", "n/a")
    assert f"-3 dB bandwidth |T|: inner (FLC) {inner} Hz, outer (velocity) {outer} Hz" in text


def test_without_either_bandwidth_the_closed_loop_is_not_analysed():
    both = {"bandwidth_inner_hz": None, "bandwidth_outer_hz": None}
    assert summary_text(_result(**both)).splitlines()[5:] == ["closed loop: not analysed (m); plant only"]
    assert summary_text(_result(**both, closed_loop=None)).splitlines()[5:] == [
        "closed loop: not analysed (controllers not available); plant only"]

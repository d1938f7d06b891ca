"""The reference player FMU's table and specification, value by value (no FMU is built).

A balance scenario with a roll sine and a torque disturbance on wheels 0 and 2 (different
values), and a cascade scenario with a velocity keyframe moving diagonally (vx != vy): the
table's columns are the scenario's attitude reference, its derivatives, the velocity
reference and the disturbance, each in its own column; the spec's row count, mode,
experiment and units are written out; the table Function interpolates between rows.
"""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.fmi.reference_player.player import (
    DISTURBANCE_NAMES,
    OUTPUT_NAMES,
    reference_player_spec,
    reference_player_variables,
    reference_table,
)
from ballbot_casadi.sim.scenario.file import parse_scenario

BAL = parse_scenario({"name": "rb", "duration_s": 0.5, "estimator": "ukf",
                      "attitude": {"roll": {"type": "sine", "amplitude_deg": 3.0,
                                            "frequency_hz": 2.0}},
                      "torque_disturbance": [{"t_start_s": 0.1, "t_end_s": 0.2,
                                              "tau_nm": [0.5, 0.0, -0.25]}]}).scenario
CAS = parse_scenario({"name": "rc", "duration_s": 0.5, "estimator": "ukf", "cascade": True,
                      "velocity": [{"t_s": 0.1, "vx_mps": 0.3, "vy_mps": -0.1,
                                    "yaw_rate_rps": 0.2}]}).scenario


def test_balance_table_columns_are_the_scenarios_references_and_disturbance():
    t = reference_table(BAL)
    n = int(round(0.5 / 0.005))
    assert t.shape == (n, 18) and len(OUTPUT_NAMES) == 18
    q, dq, ddq = BAL.attitude_reference()
    np.testing.assert_array_equal(t[:, 0:4], q)
    np.testing.assert_array_equal(t[:, 4:8], dq)
    np.testing.assert_array_equal(t[:, 8:12], ddq)
    assert np.ptp(t[:, 1]) > 0.04 and np.all(t[:, 2:4] == 0.0)  # roll only: q1 moves
    np.testing.assert_array_equal(t[:, 12:15], 0.0)
    on = (np.arange(n) >= 20) & (np.arange(n) < 40)
    assert t[on, 15].tolist() == [0.5] * 20 and t[on, 17].tolist() == [-0.25] * 20
    assert np.all(t[~on, 15:18] == 0.0) and np.all(t[:, 16] == 0.0)
    assert OUTPUT_NAMES[15:] == DISTURBANCE_NAMES


def test_cascade_table_has_the_diagonal_velocity_in_x_y_and_yaw_order():
    t = reference_table(CAS)
    k = np.arange(t.shape[0])
    np.testing.assert_allclose(t[-1, 12:15], [0.3, -0.1, 0.2], rtol=0, atol=1e-12)
    moving = np.abs(t[:, 12]) > 0.01  # ramping or at the keyframe: along (3, -1)
    assert moving.sum() > 10
    np.testing.assert_allclose(t[moving, 13], -t[moving, 12] / 3.0, rtol=1e-9, atol=1e-12)
    np.testing.assert_array_equal(t[k < 10, 12:15], 0.0)
    np.testing.assert_array_equal(t[:, 12:15], CAS.velocity_reference())


def test_pushes_are_refused():
    sc = parse_scenario({"name": "rp", "duration_s": 0.5, "estimator": "ukf",
                         "push": [{"t_s": 0.1, "roll_deg": 2.0}]}).scenario
    with pytest.raises(ScenarioError, match="'rp' has attitude pushes"):
        reference_table(sc)


def test_spec_rows_mode_experiment_and_units():
    s = reference_player_spec(BAL)
    d = dict(s.defines)
    assert d["NROWS"] == "100" and d["BALANCE_ONLY"] == "1"
    assert s.default_experiment == (0.0, pytest.approx(0.5), 0.005)
    assert "'rb' (100 periods of 0.005 s)" in s.description
    assert dict(reference_player_spec(CAS).defines)["BALANCE_ONLY"] == "0"
    by = {v.name: v for v in reference_player_variables(0.01)}
    assert by["Ts"].start == 0.01 and by["Ts"].rule == "pos"
    assert by["row"].type == "Integer" and by["row"].kind == "local"
    assert by["balance_only"].type == "Boolean" and by["balance_only"].kind == "discrete_output"
    units = {n: by[n].unit for n in ("q_ref0", "q_ref3", "dq_ref1", "ddq_ref2", "v_ref_x",
                                     "v_ref_y", "yaw_rate_ref", "tau_dist1")}
    assert units == {"q_ref0": "1", "q_ref3": "1", "dq_ref1": "1/s", "ddq_ref2": "1/s2",
                     "v_ref_x": "m/s", "v_ref_y": "m/s", "yaw_rate_ref": "rad/s",
                     "tau_dist1": "N.m"}
    assert [v.name for v in reference_player_variables(0.01)][:18] == list(OUTPUT_NAMES)


def test_the_table_function_gives_row_k_and_interpolates_between_rows():
    s = reference_player_spec(BAL)
    f = s.functions[0]
    t = reference_table(BAL)
    np.testing.assert_allclose(np.asarray(f(7.0)).ravel(), t[7], rtol=0, atol=1e-15)
    np.testing.assert_allclose(np.asarray(f(7.5)).ravel(), 0.5 * (t[7] + t[8]), rtol=0,
                               atol=1e-15)
    one = parse_scenario({"name": "r1", "duration_s": 0.005, "estimator": "ukf"}).scenario
    s1 = reference_player_spec(one)
    assert dict(s1.defines)["NROWS"] == "2"

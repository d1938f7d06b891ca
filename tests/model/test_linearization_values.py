"""The operating-point helpers against hand values: ``--at`` text parsed key by key (units,
defaults, the speed bound exactly at and just past its limit, every refusal's message),
the tangent basis's blocks, the eigenvalue order and the trim's refusals."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.params import load_params
from ballbot_casadi.errors import StateError
from ballbot_casadi.model import linearization as lz

PAR = load_params().replace(com_x=0.0, com_y=0.0)


def test_key_value_items_in_their_units():
    x = lz.parse_state_spec(" x=1.5, y=-2 ,roll=3, pitch=-4, yaw=30, dx=0.25, dy=-0.5", PAR)
    np.testing.assert_array_equal(x[[0, 1, 6, 7]], [1.5, -2.0, 0.25, -0.5])
    want = Q.from_rpy(math.radians(3), math.radians(-4), math.radians(30))
    np.testing.assert_allclose(x[2:6], want, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(x[8:], np.zeros(4))
    # one of roll/pitch given: the other is 0 and yaw defaults to 0
    x = lz.parse_state_spec("PITCH=2", PAR)
    np.testing.assert_allclose(x[2:6], Q.from_rpy(0.0, math.radians(2), 0.0), atol=1e-15)
    x = lz.parse_state_spec("roll=-1", PAR)
    np.testing.assert_allclose(x[2:6], Q.from_rpy(math.radians(-1), 0.0, 0.0), atol=1e-15)


def test_without_roll_and_pitch_a_centred_robot_is_upright_at_the_heading():
    x = lz.parse_state_spec("yaw=90, x=0.5", PAR)
    np.testing.assert_allclose(x[2:6], [math.sqrt(0.5), 0, 0, math.sqrt(0.5)], atol=1e-15)
    assert x[0] == 0.5 and x[1] == 0.0


def test_keys_left_out_are_zero():
    """Position, speeds and heading default to 0: the robot at the origin facing x."""
    x = lz.parse_state_spec("dy=0.2", PAR)
    assert (x[0], x[1], x[6], x[7]) == (0.0, 0.0, 0.0, 0.2)
    np.testing.assert_array_equal(x[2:6], lz.balance_tilt(PAR, x)[2:6])
    assert abs(Q.to_rpy(x[2:6])[2]) < 1e-12  # heading 0
    x = lz.parse_state_spec("roll=1", PAR)
    assert (x[0], x[1], x[6], x[7]) == (0.0, 0.0, 0.0, 0.0)


def test_twelve_numbers_are_the_full_state():
    vals = [0.1, 0.2, 1, 0, 0, 0, 0.3, -0.4, 0, 0.01, 0.02, 0.03]
    np.testing.assert_array_equal(lz.parse_state_spec(",".join(map(str, vals)), PAR), vals)


def test_speed_bound_exactly_at_and_just_past_the_limit():
    assert lz.MAX_SPEED == 10.0
    assert lz.parse_state_spec("dx=10, roll=0", PAR)[6] == 10.0
    assert lz.parse_state_spec("dy=-10, roll=0", PAR)[7] == -10.0
    for item in ("dx=10.000001", "dy=-10.000001"):
        with pytest.raises(StateError, match=f"^operating point item '{item}': a ball speed "
                                             "above 10 m/s is outside"):
            lz.parse_state_spec(item + ",roll=0", PAR)
    assert lz.parse_state_spec("x=1000, roll=0", PAR)[0] == 1000.0  # positions are not bounded


@pytest.mark.parametrize("text,msg", [
    ("", "^empty operating point"),
    (" , ", "^empty operating point"),
    ("1,2,3", r"got 3 numbers, expected 12"),
    ("1,2,3,4,5,6,7,8,9,10,11,a", "expected 12 numbers"),
    ("z=1", r"item 'z=1': expected key=value with key in x, y, dx, dy, roll, pitch, yaw"),
    ("yaw=1, roll", r"item 'roll': expected key=value"),
    ("yaw=1,yaw=2", r"'yaw' given twice"),
    ("roll=abc", r"item 'roll=abc': 'abc' is not a number"),
    ("roll=nan", r"item 'roll=nan': value must be finite"),
    ("dx=inf", r"item 'dx=inf': value must be finite"),
])
def test_malformed_text_is_refused_by_name(text, msg):
    with pytest.raises(StateError, match=msg):
        lz.parse_state_spec(text, PAR)


def test_tangent_basis_blocks_at_a_turned_attitude():
    q = np.array([math.cos(0.3), 0.0, 0.0, math.sin(0.3)])
    T = lz.tangent_basis(2.0 * q)  # normalised inside
    G = Q.Gamma(q)[:, 1:]
    want = np.zeros((12, 10))
    want[0:2, 0:2] = np.eye(2)
    want[2:6, 2:5] = G
    want[6:8, 5:7] = np.eye(2)
    want[8:12, 7:10] = G
    np.testing.assert_allclose(T, want, rtol=0, atol=1e-15)
    np.testing.assert_allclose(T.T @ T, np.eye(10), atol=1e-15)
    np.testing.assert_allclose(q @ T[2:6], 0.0, atol=1e-15)  # tangent: orthogonal to q


def test_eigenvalues_sorted_by_decreasing_real_then_imaginary_part():
    A = np.diag([-3.0, 2.0, 0.5, 2.0])
    A[0, 3] = 0.0
    np.testing.assert_array_equal(lz.sorted_eig(A), [2.0, 2.0, 0.5, -3.0])
    R = np.array([[1.0, -2.0], [2.0, 1.0]])  # 1 +- 2j
    B = np.block([[R, np.zeros((2, 1))], [np.zeros((1, 2)), np.array([[4.0]])]])
    np.testing.assert_allclose(lz.sorted_eig(B), [4.0, 1 - 2j, 1 + 2j], atol=1e-14)


def test_trim_refuses_a_moving_attitude_and_a_state_that_is_no_equilibrium():
    x = np.r_[0.0, 0.0, 1.0, 0, 0, 0, 0, 0, 0, 0.0, 2e-12, 0]
    with pytest.raises(StateError, match=r"the attitude must be at rest \(dq0..dq3 = 0\)"):
        lz.trim(x, PAR)
    x[9:] = [1e-13, 0.0, 0.0]
    op = lz.trim(x, PAR)  # within 1e-12: at rest
    assert op.residual <= lz.TRIM_TOL
    np.testing.assert_allclose(op.tau, 0.0, atol=1e-9)
    np.testing.assert_allclose(op.rpy_deg(), [0.0, 0.0, 0.0], atol=1e-12)
    tilted = np.r_[0.0, 0.0, Q.from_rpy(math.radians(10), 0.0, 0.0), np.zeros(6)]
    with pytest.raises(StateError, match=r"roll, pitch, yaw = \[10.0, 0.0, 0.0\] deg.*"
                                         r"is not an equilibrium"):
        lz.trim(tilted, PAR)
    assert lz.TRIM_TOL == 1e-8

"""The control package's constants, default gains and gain registry against hand values
(docstrings, thesis §7.1 and §8.3), and each check of :func:`check_gains` and
:func:`default_balance_gains` on inputs just at and just past its rule."""

from __future__ import annotations

import math

import numpy as np
import pytest

import ballbot_casadi.control as C
from ballbot_casadi.control import decoupling as D
from ballbot_casadi.control import disturbance_observer as DOB
from ballbot_casadi.control import flc as F
from ballbot_casadi.control import smc as S
from ballbot_casadi.control import super_twisting as ST
from ballbot_casadi.control import velocity as V
from ballbot_casadi.errors import ArgumentError


def test_default_gain_tables_are_the_documented_values():
    # FLC: critically damped double poles at -10 (tilt) and -5 rad/s (yaw)
    np.testing.assert_array_equal(F.FLC_DEFAULT_GAINS, [100.0, 100.0, 25.0, 20.0, 20.0, 10.0])
    assert F.FLC_GAIN_NAMES == ("Kp1", "Kp2", "Kp3", "Kd1", "Kd2", "Kd3")
    # SMC: the predecessor V2019's (thesis §8.3)
    np.testing.assert_array_equal(S.SMC_DEFAULT_GAINS, [15.0, 15.0, 6.0, 6.0, 6.0, 3.0, 0.5, 0.5, 0.2])
    assert S.SMC_GAIN_NAMES == ("K1", "K2", "K3", "eta1", "eta2", "eta3", "eps1", "eps2", "eps3")
    np.testing.assert_array_equal(ST.STA_DEFAULT_L, [1.5, 1.5, 0.75])
    assert ST.STA_NZ == 3
    k1, k2 = ST.levant_gains([4.0, 0.25])
    np.testing.assert_allclose(k1, [3.0, 0.75], rtol=1e-15)
    np.testing.assert_allclose(k2, [4.4, 0.275], rtol=1e-15)
    assert DOB.DOB_SEPARATION == 10.0 and DOB.DOB_NZ == 7
    assert DOB.DOB_GAIN_NAMES[6:] == ("L1", "L2", "L3", "h")
    assert D.QE0_MIN == 0.05 and D.RCOND_MIN == 0.01 and D.DAMPING_MU == 0.1


def test_velocity_limits_are_the_thesis_specifications():
    want = dict(tilt_max=math.radians(5.0), tilt_rate_max=math.radians(20.0), tilt_acc_max=2.0,
                v_max=0.5, yaw_rate_max=1.0, p_e_max=2.0, yaw_acc_max=10.0, k_r=10.0)
    assert V.VELOCITY_LIMIT_NAMES == tuple(want)
    np.testing.assert_allclose(V.VELOCITY_DEFAULT_LIMITS, list(want.values()), rtol=1e-15, atol=0)
    assert V.VELOCITY_NKV == 2 * 12 + 8


@pytest.mark.parametrize("name,want", [
    ("flc", [100.0, 100.0, 25.0, 20.0, 20.0, 10.0]),
    ("smc", [15.0, 15.0, 6.0, 6.0, 6.0, 3.0, 0.5, 0.5, 0.2]),
    ("sta", [10.0, 10.0, 6.0, 1.5 * math.sqrt(1.5), 1.5 * math.sqrt(1.5), 1.5 * math.sqrt(0.75),
             1.65, 1.65, 0.825, 0.002]),
    ("flc_dob", [100.0, 100.0, 25.0, 20.0, 20.0, 10.0, 100.0, 100.0, 50.0, 0.002]),
])
def test_default_balance_gains_per_controller_with_the_step_set_to_ts(name, want):
    k = C.default_balance_gains(name, Ts=0.002)
    np.testing.assert_allclose(k, want, rtol=1e-12, atol=0)
    assert len(C.BALANCE_GAIN_NAMES[name]) == len(want)
    k[0] = -1.0  # a copy: the table is not changed
    assert C.default_balance_gains(name)[0] > 0


def test_state_sizes_and_registry():
    assert {n: C.balance_state_size(n) for n in ("flc", "smc", "sta", "lqr", "flc_dob")} == {
        "flc": 0, "smc": 0, "sta": 3, "lqr": 0, "flc_dob": 7}
    assert set(C.BALANCE_CONTROLLERS) == {"flc", "smc", "sta", "lqr", "flc_dob"}
    assert C.LINEAR_DESIGNED == ("lqr",)
    with pytest.raises(ArgumentError, match="^unknown balance controller 'pid'; allowed: "
                                            "flc, flc_dob, lqr, smc, sta$"):
        C.balance_state_size("pid")
    with pytest.raises(ArgumentError, match="pass linear=linearize"):
        C.default_balance_gains("lqr")


def test_check_gains_rules():
    k = C.check_gains("smc", [1] * 9)
    assert k.dtype == float and k.shape == (9,)
    with pytest.raises(ArgumentError, match=r"smc gains need 9 entries .*got 8"):
        C.check_gains("smc", [1] * 8)
    with pytest.raises(ArgumentError, match="finite and > 0; invalid: eta2$"):
        C.check_gains("smc", [1, 1, 1, 1, 0.0, 1, 1, 1, 1])
    with pytest.raises(ArgumentError, match="invalid: K1, eps3$"):
        C.check_gains("smc", [float("nan"), 1, 1, 1, 1, 1, 1, 1, -1e-300])
    with pytest.raises(ArgumentError, match="must be numbers"):
        C.check_gains("flc", ["a"] * 6)
    # a linearly designed gain may have any sign, but must be finite
    assert C.check_gains("lqr", [-1.0] * 18)[0] == -1.0
    with pytest.raises(ArgumentError, match="must be finite; invalid: K00$"):
        C.check_gains("lqr", [math.inf] + [0.0] * 17)
    assert C.check_gains("flc", [1e-300] * 6)[0] == 1e-300

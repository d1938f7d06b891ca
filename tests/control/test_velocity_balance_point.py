"""The velocity controller's balance point: tilts fed back about the model COM's equilibrium."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.control.velocity import (
    default_velocity_gains,
    equilibrium_tilt,
    make_velocity_controller,
    measured_tilt,
    tilt_heading_quaternion,
)
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import STATE
from ballbot_casadi.core.layout import VELOCITY_CONTROLLER_STATE as Z
from ballbot_casadi.core.params import PARAM_NAMES, load_params
from ballbot_casadi.model.dynamics import make_jacobians

TS = 0.005
OFFSET = load_params().replace(com_x=-0.02, com_y=-0.03, l=0.4513)


@pytest.fixture(scope="module")
def velocity():
    return make_velocity_controller()


@pytest.fixture(scope="module")
def gains():
    return default_velocity_gains(make_jacobians(), load_params().to_vector())


def _sym_equilibrium():
    p, psi = ca.SX.sym("p", len(PARAM_NAMES)), ca.SX.sym("psi")
    return ca.Function("eq", [p, psi], [equilibrium_tilt(p, psi)])


@pytest.mark.parametrize("psi", [0.0, 1.0, -2.5, 4.0])
@pytest.mark.parametrize("com", [(-0.02, -0.03, 0.4513), (0.03, 0.0, 0.39), (0.0, 0.01, 0.4213)])
def test_balance_point_puts_the_com_above_the_ball(psi, com):
    p = load_params().replace(com_x=com[0], com_y=com[1], l=com[2]).to_vector()
    th = np.ravel(np.asarray(_sym_equilibrium()(p, psi)))
    np.testing.assert_allclose(th, equilibrium_tilt(p, psi), rtol=0, atol=1e-15)
    r = Q.rotation_matrix(tilt_heading_quaternion(th[0], th[1], psi)) @ np.array(com)
    np.testing.assert_allclose(r[:2], 0.0, atol=1e-15)
    assert r[2] > 0


@pytest.mark.parametrize("psi", [0.0, 2.5, -2.0, 4.0, -0.0])
def test_a_centred_com_gives_exactly_plus_zero(psi):
    p = load_params().to_vector()
    for th in (np.ravel(np.asarray(_sym_equilibrium()(p, psi))), equilibrium_tilt(p, psi)):
        np.testing.assert_array_equal(th, [0.0, 0.0])
        assert not np.any(np.signbit(th))  # x - (+0) == x bit for bit, also for x = -0


def _state(th, psi, v=(0.0, 0.0)):
    x = np.zeros(STATE.size)
    x[STATE["q"]] = tilt_heading_quaternion(th[0], th[1], psi)
    x[STATE["dx"]], x[STATE["dy"]] = v
    return x


def test_tilts_are_fed_back_about_the_balance_point(velocity, gains):
    # shifting the measured tilt and the tilt reference by the balance point of the
    # model's COM leaves the commanded tilt acceleration unchanged
    psi = 0.6
    th_eq = equilibrium_tilt(OFFSET.to_vector(), psi)
    th, th_r = np.array([0.004, -0.003]), np.array([0.002, 0.001])
    z = np.zeros(Z.size)
    z[Z["theta_r"]], z[Z["dtheta_r"]], z[Z["p_e"]] = th_r, [0.01, -0.02], [0.05, 0.02]
    z[Z.index("psi_r")] = psi
    v_ref = np.array([0.1, -0.05, 0.0])
    zc = z.copy()
    zc[Z["theta_r"]] = th_r + th_eq
    x0, xc = _state(th, psi, (0.05, 0.0)), _state(th + th_eq, psi, (0.05, 0.0))
    np.testing.assert_allclose(measured_tilt(xc[STATE["q"]]), th + th_eq, rtol=0, atol=1e-15)
    out0 = [np.ravel(np.asarray(v)) for v in velocity(x0, v_ref, z, load_params().to_vector(), gains, TS)]
    outc = [np.ravel(np.asarray(v)) for v in velocity(xc, v_ref, zc, OFFSET.to_vector(), gains, TS)]
    # the tilt-reference rate after the period carries the commanded acceleration
    np.testing.assert_allclose(outc[3][Z["dtheta_r"]], out0[3][Z["dtheta_r"]], rtol=0, atol=1e-12)
    np.testing.assert_allclose(outc[3][Z["p_e"]], out0[3][Z["p_e"]], rtol=0, atol=1e-15)


def test_at_the_balance_point_with_zero_position_error_the_controller_rests(velocity, gains):
    # the fixed point of the position hold: standing on the balance point of a known COM
    # with p_e = 0 asks for no tilt change, so nothing integrates a position error
    psi = -1.2
    th_eq = equilibrium_tilt(OFFSET.to_vector(), psi)
    z = np.zeros(Z.size)
    z[Z["theta_r"]], z[Z.index("psi_r")] = th_eq, psi
    x = _state(th_eq, psi)
    q_ref, dq_ref, ddq_ref, z_next = (np.ravel(np.asarray(v)) for v in
                                      velocity(x, np.zeros(3), z, OFFSET.to_vector(), gains, TS))
    np.testing.assert_allclose(z_next, z, rtol=0, atol=1e-15)
    np.testing.assert_allclose(np.abs(ddq_ref).max(), 0.0, atol=1e-15)
    r = Q.rotation_matrix(q_ref) @ [OFFSET.com_x, OFFSET.com_y, OFFSET.l]
    np.testing.assert_allclose(r[:2], 0.0, atol=1e-15)
    # the same state with the nominal (centred) model is not at rest: its loop would
    # integrate the tilt into a position error (thesis §9.2)
    zn = np.ravel(np.asarray(velocity(x, np.zeros(3), z, load_params().to_vector(), gains, TS)[3]))
    assert np.max(np.abs(zn[Z["dtheta_r"]])) > 1e-3

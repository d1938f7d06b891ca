"""Checks of the model against geometry that does not go through its Lagrangian.

Every other model test compares two paths through the same energies, so a wrong wheel
angle or a swapped COM coordinate would pass them; these use only the robot's geometry.
The wheel zenith angle is tested away from 45 deg, where sin(alpha) = cos(alpha) would hide
a swap of alpha with its complement.
"""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.core.params import load_params
from ballbot_casadi.model.dynamics import make_model_functions
from ballbot_casadi.model.linearization import balance_point
from ballbot_casadi.model.numeric import make_state


@pytest.fixture(scope="module")
def funcs():
    return make_model_functions()


@pytest.mark.parametrize("alpha_deg", [40.0, 50.0])
def test_wheel_speeds_follow_the_contact_geometry(funcs, alpha_deg):
    a = np.radians(alpha_deg)
    p = load_params(alpha=a)
    # body spinning about the vertical on a resting ball: each contact point moves on a
    # circle of radius rk sin(alpha), so every wheel turns at rk sin(alpha) w / rw
    w = 0.7
    d = np.asarray(funcs["wheel_speeds"](make_state(omega_body=[0, 0, w]), p.to_vector())).ravel()
    np.testing.assert_allclose(np.abs(d), p.rk / p.rw * np.sin(a) * w, rtol=1e-12)
    assert np.all(np.sign(d) == np.sign(d[0]))
    # ball rolling at v under an upright, non-rotating body: the contact velocity has
    # size v cos(alpha) along the three wheel directions 120 deg apart, so
    # sum(dphi^2) = 3/2 (v cos(alpha) / rw)^2 for any direction of travel
    for heading in (0.0, 1.0, 2.5):
        v = 0.4
        x = make_state(dx=v * np.cos(heading), dy=v * np.sin(heading))
        d = np.asarray(funcs["wheel_speeds"](x, p.to_vector())).ravel()
        assert np.sum(d**2) == pytest.approx(1.5 * (v * np.cos(a) / p.rw) ** 2, rel=1e-12)
        assert np.sum(d) == pytest.approx(0.0, abs=1e-12)  # no net spin


@pytest.mark.parametrize("com", [(0.02, -0.03), (-0.03, 0.01), (0.0, 0.025)])
def test_offset_com_is_balanced_exactly_above_the_ball_centre(funcs, com):
    # static equilibrium from geometry alone: COM straight above the contact point
    p = load_params(com_x=com[0], com_y=com[1])
    xb = balance_point(p)
    acc = np.asarray(funcs["ode"](xb, np.zeros(3), p.to_vector())).ravel()
    np.testing.assert_allclose(acc, 0.0, atol=1e-12)
    # the mirrored offset is not in equilibrium at that attitude (com_x, com_y not swappable)
    q = load_params(com_x=com[1], com_y=com[0])
    if com[0] != com[1]:
        acc = np.asarray(funcs["ode"](xb, np.zeros(3), q.to_vector())).ravel()
        assert np.max(np.abs(acc)) > 1e-2

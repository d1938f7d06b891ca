"""The ``diag`` flags of every balance controller against hand values: the conditioning
margin ``min(qe0 / QE0_MIN, rcond_F(G) / RCOND_MIN)`` (numpy from the model's affine
form) and the singular flag, for the controllers that invert ``E``; the LQR, which
inverts nothing, reports margin 1 and never singular."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.control import default_balance_gains, make_balance_controller
from ballbot_casadi.control.decoupling import QE0_MIN, RCOND_MIN
from ballbot_casadi.control.quaternion_error import quaternion_error
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import GENERALISED
from ballbot_casadi.core.params import load_params
from ballbot_casadi.model.dynamics import make_affine
from ballbot_casadi.model.linearization import linearize
from ballbot_casadi.model.numeric import make_state

PAR = load_params()


def _case(tilt_deg):
    x = make_state(roll=np.radians(tilt_deg), pitch=np.radians(-0.3 * tilt_deg), yaw=0.4,
                   omega_body=(0.1, -0.2, 0.05))
    q_ref = np.asarray(Q.from_rpy(0.0, 0.0, 0.3), float).ravel()
    return x, q_ref


def _margin(x, q_ref):
    f, g = (np.asarray(v) for v in make_affine()(x, PAR.to_vector()))
    q = x[2:6]
    G = np.column_stack([2 * Q.vee(Q.mul(Q.conj(q), g[GENERALISED["q"], j])) for j in range(3)])
    rcond = 1.0 / (np.linalg.norm(G) * np.linalg.norm(np.linalg.inv(G)))
    qe = quaternion_error(q, q_ref)
    qe0 = abs(qe[0]) / np.linalg.norm(qe)
    return min(qe0 / QE0_MIN, rcond / RCOND_MIN)


@pytest.mark.parametrize("name", ["flc", "smc", "sta", "flc_dob", "lqr"])
@pytest.mark.parametrize("tilt_deg", [3.0, 100.0])
def test_margin_and_singular_flag(name, tilt_deg):
    x, q_ref = _case(tilt_deg)
    ctrl = make_balance_controller(name, make_affine())
    k = default_balance_gains(name, linearize(PAR) if name == "lqr" else None)
    zb = {"sta": [np.zeros(3)], "flc_dob": [np.zeros(7)]}.get(name, [])
    diag = np.asarray(ctrl(x, q_ref, np.zeros(4), np.zeros(4), PAR.to_vector(), k, *zb)[1]).ravel()
    if name == "lqr":
        assert diag[0] == 0.0 and diag[1] == 1.0
        return
    m = _margin(x, q_ref)
    assert diag[1] == pytest.approx(m, rel=1e-9)
    assert diag[0] == (1.0 if m < 1 else 0.0)
    assert (m < 1) == (tilt_deg > 90)  # the second case is near-singular, the first is not

"""The MPC's prediction model declares what it is built from (sim/path_following).

Independent reference: the numerical probe the path FMU used before the declaration
(each ``p_ctrl`` / ``k_vel`` entry moved by 1 %, counted when a matrix entry of the loop
model moves by more than 1e-10 of the largest; real dependencies move it by >= 1e-6, the
FLC's cancellations by rounding).
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.control.velocity import design_model
from ballbot_casadi.core.constants import TS_CONTROL
from ballbot_casadi.core.layout import STATE
from ballbot_casadi.core.params import PARAM_NAMES
from ballbot_casadi.errors import ShapeError
from ballbot_casadi.fmi.controller.path import mpc_model_dependencies
from ballbot_casadi.guidance.mpc import MpcConfig
from ballbot_casadi.guidance.paths import line_path
from ballbot_casadi.guidance.prediction import closed_velocity_loop
from ballbot_casadi.model.dynamics import make_jacobians
from ballbot_casadi.sim.path_following import (
    FLC_CANCELLED,
    LOOP_GAIN_ENTRIES,
    path_scenario,
    velocity_loop_dependencies,
    velocity_loop_model,
)

STEP, TOL = 1e-2, 1e-10


@pytest.fixture(scope="module")
def shipped():
    inp = path_scenario(line_path((0.0, 0.0), (2.0, 0.0)), 0.1).inputs()
    return (np.asarray(inp["p_ctrl"], float).ravel(), np.asarray(inp["k_vel"], float).ravel(),
            MpcConfig().dt)


def _probed(p, k, dt):
    jac = make_jacobians()

    def model(pp, kk):
        Ac, Bc, _, _ = design_model(jac, pp, TS_CONTROL)
        m = closed_velocity_loop(Ac, Bc, kk[:24].reshape(2, 12), TS_CONTROL, dt)
        return np.hstack([m.A, m.B])

    base = model(p, k)
    scale = 1.0 + np.max(np.abs(base))

    def moved(pp, kk):
        return np.max(np.abs(model(pp, kk) - base)) > TOL * scale

    def probe(v, i):
        out = v.copy()
        out[i] = v[i] * (1.0 + STEP) + STEP
        return out

    return (tuple(n for i, n in enumerate(PARAM_NAMES) if moved(probe(p, i), k)),
            tuple(i for i in range(k.size) if moved(p, probe(k, i))))


def test_the_declared_dependencies_equal_the_probed_ones(shipped):
    p, k, dt = shipped
    names, gains = _probed(p, k, dt)
    dep = velocity_loop_dependencies()
    assert dep.params == names
    assert dep.gains == gains == tuple(range(24))
    assert dep.period
    assert mpc_model_dependencies(p, k, dt) == (names, gains)
    # the reference model above is the shipped one
    m = velocity_loop_model(p, k, dt)
    Ac, Bc, _, _ = design_model(make_jacobians(), p, TS_CONTROL)
    ref = closed_velocity_loop(Ac, Bc, k[:24].reshape(2, 12), TS_CONTROL, dt)
    np.testing.assert_allclose(m.A, ref.A, rtol=0, atol=0)
    assert LOOP_GAIN_ENTRIES == 24


def test_a_parameter_added_to_the_prediction_model_is_declared():
    """tau_max made to act on the Jacobians (and a cancelled one left out): declared."""
    jac = make_jacobians()
    x, tau, p = ca.SX.sym("x", 12), ca.SX.sym("tau", 3), ca.SX.sym("p", len(PARAM_NAMES))
    A, B = jac(x, tau, p)
    A = A + 1e-3 * p[PARAM_NAMES.index("tau_max")] * ca.DM.eye(12)
    grown = ca.Function("ballbot_jac", [x, tau, p], [A, B], ["x", "tau", "p"], ["A", "B"])
    assert "tau_max" not in velocity_loop_dependencies().params
    dep = velocity_loop_dependencies(grown)
    assert "tau_max" in dep.params
    assert set(dep.params) - {"tau_max"} == set(velocity_loop_dependencies().params)
    assert not set(FLC_CANCELLED) & set(dep.params)


@pytest.mark.parametrize("factor, declared", [
    (lambda q: q[0] - 1.0, False),  # vanishes upright (q = 1, 0, 0, 0): not read there
    (lambda q: q[1], False),  # a roll term: zero upright
    (lambda q: q[0], True),
    (lambda q: q[0] ** 2 + q[3] - 0.5, True),
])
def test_the_dependencies_are_read_at_the_upright_equilibrium(factor, declared):
    """A parameter acting on the Jacobians through a state factor is declared exactly when
    the factor is non-zero at the upright equilibrium, the design model's linearisation point."""
    jac = make_jacobians()
    x, tau, p = ca.SX.sym("x", 12), ca.SX.sym("tau", 3), ca.SX.sym("p", len(PARAM_NAMES))
    A, B = jac(x, tau, p)
    A = A + p[PARAM_NAMES.index("tau_max")] * factor(x[STATE["q"]]) * ca.DM.eye(12)
    grown = ca.Function("ballbot_jac", [x, tau, p], [A, B], ["x", "tau", "p"], ["A", "B"])
    assert ("tau_max" in velocity_loop_dependencies(grown).params) == declared


@pytest.mark.parametrize("p_size, k_size, dt", [(20, 32, 0.1), (21, 24, 0.1), (21, 32, 0.0)])
def test_mpc_model_dependencies_checks_its_arguments(p_size, k_size, dt):
    with pytest.raises(ShapeError, match="p_ctrl must have 21 entries and k_vel 32"):
        mpc_model_dependencies(np.ones(p_size), np.ones(k_size), dt)

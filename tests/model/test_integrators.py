"""Fixed-step RK4 Functions built around the model ODE."""

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.errors import BallbotTypeError
from ballbot_casadi.model.integrators import make_rk4, make_rk4_n
from ballbot_casadi.model.numeric import make_state


def test_rk4_is_fourth_order(model_functions, default_params):
    ode, p = model_functions["ode"], default_params.to_vector()
    x0 = make_state(roll=0.05, pitch=-0.03, dx=0.1, omega_body=[0.1, 0.0, 0.2])
    tau = np.array([0.1, -0.05, 0.02])
    xs, us, ps = ca.MX.sym("x", 12), ca.MX.sym("u", 3), ca.MX.sym("p", 21)
    F = ca.integrator("F", "cvodes", {"x": xs, "p": ca.vertcat(us, ps), "ode": ode(xs, us, ps)},
                      0.0, 0.2, {"abstol": 1e-13, "reltol": 1e-13})
    exact = np.array(F(x0=x0, p=np.concatenate([tau, p]))["xf"]).ravel()
    errs = []
    for n in (10, 20, 40):
        x = np.array(make_rk4_n(ode, n)(x0, tau, p, 0.2)).ravel()
        errs.append(np.max(np.abs(x - exact)))
    rates = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(rates > 3.7), rates  # halving the step divides the error by ~16


def test_rk4_n_equals_n_single_steps(model_functions, default_params):
    ode, p = model_functions["ode"], default_params.to_vector()
    x = x0 = make_state(roll=0.1)
    step = make_rk4(ode)
    for _ in range(5):
        x = step(x, [0.2, 0.0, -0.1], p, 0.001)
    multi = make_rk4_n(ode, 5)(x0, [0.2, 0.0, -0.1], p, 0.005)
    np.testing.assert_allclose(np.array(multi), np.array(x), rtol=0, atol=1e-15)
    assert make_rk4_n(ode, 5).name_in() == ["x", "tau", "p", "h"]


def test_ode_stays_a_called_function(model_functions):
    f = make_rk4_n(model_functions["ode"], 5)
    # the MX graph calls the ODE Function (looped by fold) instead of inlining copies
    assert "ballbot_ode" in [g.name() for g in f.find_functions()]
    assert f.n_instructions() < 50


def test_bad_arguments(model_functions):
    with pytest.raises(BallbotTypeError, match="sub-steps"):
        make_rk4_n(model_functions["ode"], 0)
    with pytest.raises(BallbotTypeError, match="CasADi Function"):
        make_rk4("not a function")

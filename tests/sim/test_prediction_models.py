"""The "full" prediction model against an independent simulation of the closed loop."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.guidance.paths import figure_eight
from ballbot_casadi.sim.closed_loop import ClosedLoop
from ballbot_casadi.sim.path_following import make_loop_state, path_scenario, velocity_loop_model
from ballbot_casadi.sim.prediction_models import full_loop_model, reduced_nonlinear_loop

#: a small velocity-reference step (m/s): every limit of the velocity controller inactive
EPS = 1e-3
DT = 0.1


@pytest.fixture(scope="module")
def step_run():
    """2 s of the closed loop (the package's symbolic mission, COM observer off) after a
    held step v_ref = EPS * (1, -0.5) from upright at the origin; loop states every 0.1 s."""
    sc = path_scenario(figure_eight(), 2.0)
    inp = sc.inputs()
    for key in ("com_observer", "k_obs", "estimator"):
        inp.pop(key, None)
    x0 = np.array(inp["x0"], float)
    x0[0:2] = 0.0
    inp["x0"] = x0
    inp["v_ref"] = np.tile([EPS, -0.5 * EPS, 0.0], (400, 1))
    out = ClosedLoop(compiled=False).simulate("flc", **inp)
    ls = make_loop_state()
    X = np.array([np.asarray(ls(x, z), float).ravel()
                  for x, z in zip(out["state"][::20], out["z"][::20])])
    return inp, X


def test_full_model_equals_the_simulated_closed_loop(step_run) -> None:
    inp, X = step_run
    model, info = full_loop_model(inp, DT)
    assert info["equilibrium_residual"] < 1e-9
    assert info["reduction_residual"] < 1e-8  # the heading stays decoupled
    Xm = model.simulate(np.zeros(14), np.tile([EPS, -0.5 * EPS], (20, 1)))
    peak = np.max(np.abs(X), axis=0)
    # the linearisation is exact up to the O(EPS^2) nonlinearity: 1e-6 of each state's peak
    np.testing.assert_array_less(np.max(np.abs(Xm - X), axis=0), 1e-6 * peak + 1e-15)


def test_shipped_design_model_differs_measurably(step_run) -> None:
    """The shipped model closes the balance loop in continuous time: 1e-4 .. 1e-2 of the
    peaks off (the comparison is not between two copies of one model)."""
    inp, X = step_run
    Xs = velocity_loop_model(inp["p_ctrl"], inp["k_vel"], DT).simulate(
        np.zeros(14), np.tile([EPS, -0.5 * EPS], (20, 1)))
    rel = np.max(np.abs(Xs - X), axis=0) / np.max(np.abs(X), axis=0)
    assert 1e-4 < rel.max() < 1e-2


def test_reduced_nonlinear_step_is_the_closed_loop(step_run) -> None:
    """The NMPC's reduced nonlinear step, composed 20 times, follows the same run."""
    inp, X = step_run
    F, Y = reduced_nonlinear_loop(inp, DT)
    xs = [np.zeros(14)]
    for _ in range(20):
        xs.append(np.asarray(F(xs[-1], [EPS, -0.5 * EPS]), float).ravel())
    peak = np.max(np.abs(X), axis=0)
    np.testing.assert_array_less(np.max(np.abs(np.array(xs) - X), axis=0), 1e-6 * peak + 1e-12)
    model, _ = full_loop_model(inp, DT)
    y = np.asarray(Y(np.zeros(14), [EPS, 0.0]), float).ravel()
    np.testing.assert_allclose(y, np.concatenate([model.D["acc"] @ [EPS, 0.0],
                                                  model.D["tilt_acc"] @ [EPS, 0.0]]),
                               rtol=1e-6, atol=1e-12)


def test_output_rows_equal_the_design_models_where_both_are_exact(step_run) -> None:
    """The tilt-reference acceleration is the LQR's law -K (X - E v_ref) in both models;
    the ball acceleration at a period's start depends on the state, not on the balance
    loop's sampling: the rows agree to rounding."""
    inp, _ = step_run
    model, _ = full_loop_model(inp, DT)
    ship = velocity_loop_model(inp["p_ctrl"], inp["k_vel"], DT)
    for key in ("tilt_acc", "acc"):
        scale = np.max(np.abs(ship.C[key]))
        np.testing.assert_allclose(model.C[key], ship.C[key], rtol=0, atol=1e-8 * scale)
        np.testing.assert_allclose(model.D[key], ship.D[key], rtol=0, atol=1e-8 * scale)

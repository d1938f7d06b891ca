"""The embedded software's state at power-on as one CasADi Function
(sim/embedded.py: make_initial_controller_state), against an independent numpy oracle
built from the numpy helpers of control/ and estimation/ (velocity_initial_state,
estimation.initial_state, com_observer_initial_state), and the mission starting from it."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.control.velocity import VELOCITY_NZ, velocity_initial_state
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import STATE, STATE_DXY, STATE_XY, VELOCITY_FILTER_STATE
from ballbot_casadi.core.params import PARAM_NAMES, load_params
from ballbot_casadi.errors import ScenarioError, ShapeError
from ballbot_casadi.estimation import initial_state
from ballbot_casadi.estimation.com_observer import com_observer_initial_state
from ballbot_casadi.sim.closed_loop import ClosedLoop, power_on_inputs, run_scenario
from ballbot_casadi.sim.embedded import (
    ESTIMATOR_FILTERS,
    GATE_GROUPS,
    controller_layout,
    initial_controller_state,
    initial_controller_state_function,
    initial_estimator_state,
)
from ballbot_casadi.sim.scenario import Scenario
from ballbot_casadi.sim.scenario.scenario import initial_state as tilted_state

RNG = np.random.default_rng(20260)


def _numpy_filters(estimator: str, x0: np.ndarray) -> dict[str, np.ndarray]:
    """The filters' initial state by the numpy helpers (the pre-Function implementation)."""
    att, vel = ESTIMATOR_FILTERS[estimator]
    q = x0[STATE["q"]] / np.linalg.norm(x0[STATE["q"]])
    omega = 2 * Q.vee(Q.mul(Q.conj(q), x0[STATE["dq"]]))
    xa0, Pa0 = initial_state(att, np.concatenate([q, omega]))
    xv0, Pv0 = initial_state(vel)
    xv0 = xv0.copy()
    xv0[VELOCITY_FILTER_STATE["v"]] = x0[STATE_DXY]
    return {"xa": xa0, "Pa": np.asarray(Pa0, float).ravel(order="F"), "xv": xv0,
            "Pv": np.asarray(Pv0, float).ravel(order="F"), "pos": x0[STATE_XY],
            "gate": np.zeros(GATE_GROUPS.size)}  # no innovation-gate rejections yet


def _numpy_oracle(estimator: str, x0: np.ndarray, p: np.ndarray, observer: bool) -> np.ndarray:
    parts = {"z": velocity_initial_state(x0), **_numpy_filters(estimator, x0)}
    if observer:
        parts["obs"] = com_observer_initial_state(x0, p)
    L = controller_layout(estimator, VELOCITY_NZ, parts["obs"].size if observer else 0)
    return L.pack(parts)


def _random_state() -> np.ndarray:
    rpy = RNG.uniform(-0.4, 0.4, 3) * np.array([1, 1, 8])
    q = Q.from_rpy(*rpy) * RNG.uniform(0.9, 1.1)  # not unit: the Function normalises
    w = RNG.normal(0, 0.5, 3)
    dq = 0.5 * Q.mul(q / np.linalg.norm(q), np.concatenate([[0.0], w]))
    return np.concatenate([RNG.normal(0, 2, 2), q, RNG.normal(0, 0.5, 2), dq])


@pytest.mark.parametrize("estimator", ["ukf", "ekf"])
@pytest.mark.parametrize("observer", [False, True])
def test_the_function_equals_the_numpy_oracle(estimator, observer):
    p = load_params().to_vector().copy()
    for _ in range(25):
        x0 = _random_state()
        p[PARAM_NAMES.index("com_x")], p[PARAM_NAMES.index("com_y")] = RNG.normal(0, 0.01, 2)
        got = initial_controller_state(estimator, x0, p, observer)
        want = _numpy_oracle(estimator, x0, p, observer)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-15)


def test_the_function_is_named_and_sized():
    f = initial_controller_state_function("ukf", True)
    assert f.name() == "ballbot_initial_controller_state_ukf_obs"
    assert f.name_in() == ["x0", "p_ctrl"] and f.name_out() == ["c0"]
    assert initial_controller_state_function("ekf", False).name() == \
        "ballbot_initial_controller_state_ekf"
    L = controller_layout("ekf", VELOCITY_NZ)
    assert f.size1_in(0) == STATE.size and initial_controller_state_function(
        "ekf", False).size1_out(0) == L.size


def test_upright_at_rest_gives_the_thesis_start():
    x0 = np.zeros(STATE.size)
    x0[STATE["q"]] = [1.0, 0.0, 0.0, 0.0]
    e = initial_estimator_state("ukf", x0)
    want = _numpy_filters("ukf", x0)
    np.testing.assert_array_equal(e, np.concatenate(list(want.values())))
    c = initial_controller_state("ukf", x0, load_params().to_vector(), observer=False)
    L = controller_layout("ukf", VELOCITY_NZ)
    np.testing.assert_array_equal(c[L["z"]], np.zeros(VELOCITY_NZ))


def test_bad_input_is_refused():
    p = load_params().to_vector()
    with pytest.raises(ShapeError, match="12-state"):
        initial_controller_state("ukf", np.zeros(5), p)
    with pytest.raises(ShapeError, match="p_ctrl"):
        initial_controller_state("ukf", _random_state(), p[:3])
    with pytest.raises(ScenarioError, match="unknown estimator"):
        initial_controller_state("true", _random_state(), p)


def test_run_scenario_starts_from_the_function(monkeypatch):
    sc = Scenario(name="power_on", controller="flc", estimator="ekf", duration=0.005,
                  x0=tilted_state(4.0, 1.0, 0.0), seed=5)
    inp = sc.inputs()
    got = power_on_inputs("ekf", inp)
    c0 = initial_controller_state("ekf", inp["x0"], inp["p_ctrl"], observer=True)
    L = controller_layout("ekf", VELOCITY_NZ, got["o0"].size)
    np.testing.assert_array_equal(np.concatenate([got["z0"], got["estimation"]["e0"],
                                                  got["o0"]]), c0)
    assert L.size == c0.size and L.fields[-1] == "obs"
    sim = ClosedLoop()
    log = run_scenario(sc, sim)
    ref = sim.simulate(sc.controller, **got, n_sub=sc.n_sub)
    np.testing.assert_array_equal(log.arrays["c_final"], ref["c_final"])
    # whatever the Function gives is where the mission starts (a changed power-on state
    # changes the run: the mission does not build its own)
    import ballbot_casadi.sim.closed_loop as cl

    def shifted(*args, **kw):
        c = initial_controller_state(*args, **kw).copy()
        c[L["z"].start] += 1e-3
        return c

    monkeypatch.setattr(cl, "initial_controller_state", shifted)
    moved = run_scenario(sc, sim).arrays["c_final"]
    assert np.max(np.abs(moved - log.arrays["c_final"])) > 1e-5

"""The selectable balance controllers in the closed loop: super-twisting ("sta", a balance
controller with a state of its own carried by the period) and the balance LQR ("lqr",
gain designed on the controller model's linearisation)."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from _period_support import period_loop

from ballbot_casadi.control import (
    BALANCE_CONTROLLERS,
    BALANCE_DIAG_NAMES,
    balance_state_size,
    check_gains,
    default_balance_gains,
    make_balance_controller,
    make_velocity_controller,
    saturate_torques,
)
from ballbot_casadi.control.balance_lqr import design_balance_lqr
from ballbot_casadi.control.super_twisting import STA_GAIN_NAMES, STA_NZ
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.constants import THESIS_LIMITS
from ballbot_casadi.core.layout import STATE
from ballbot_casadi.core.params import Params
from ballbot_casadi.errors import ArgumentError, ScenarioError
from ballbot_casadi.estimation.com_observer import com_observer_initial_state, make_com_observer
from ballbot_casadi.model.dynamics import make_affine, make_model_functions, make_ode
from ballbot_casadi.model.integrators import make_rk4_n
from ballbot_casadi.model.linearization import linearize
from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario
from ballbot_casadi.sim.ports import (
    PERIOD_CONSTANTS,
    PeriodBlocks,
    check_blocks,
    controller_state,
)
from ballbot_casadi.sim.scenario import Scenario, initial_state
from ballbot_casadi.sim.scenario.file import parse_scenario

_Y = slice(BALANCE_DIAG_NAMES.index("e1"), BALANCE_DIAG_NAMES.index("e3") + 1)
_DY = slice(BALANCE_DIAG_NAMES.index("de1"), BALANCE_DIAG_NAMES.index("de3") + 1)
_K = slice(STA_GAIN_NAMES.index("K1"), STA_GAIN_NAMES.index("K3") + 1)


@pytest.fixture(scope="module")
def sim() -> ClosedLoop:
    return ClosedLoop(compiled=True)


def _python_loop(blocks: PeriodBlocks, scenario: Scenario) -> dict[str, np.ndarray]:
    """The scenario as a Python loop of control_period on numpy values (the state slot
    packed by the blocks' controller-state layout)."""
    inp = scenario.inputs()
    const = {k: inp[k] for k in PERIOD_CONSTANTS}
    const.update(com_observer=float(inp["com_observer"]), k_obs=inp["k_obs"])
    Z = controller_state(blocks, len(inp["p_ctrl"]))
    parts = {"z": inp["z0"], "obs": com_observer_initial_state(inp["x0"], inp["p_ctrl"])}
    if Z.has("bal"):
        parts["bal"] = np.zeros(Z.size_of("bal"))
    return period_loop(blocks, scenario, inp, Z.pack(parts), const)


def _sliding_variable(log, k_bal) -> np.ndarray:
    d = log["diag"]
    return d[:, _DY] + k_bal[_K] * d[:, _Y]


def test_every_controller_is_selectable_and_sta_carries_its_state():
    assert set(BALANCE_CONTROLLERS) == {"flc", "smc", "sta", "lqr", "flc_dob"}
    assert balance_state_size("sta") == STA_NZ and balance_state_size("flc") == 0
    affine, vel = make_affine(), make_velocity_controller()
    blocks = PeriodBlocks(make_balance_controller("sta", affine), vel, make_com_observer())
    assert blocks.balance_state == STA_NZ
    Z = controller_state(blocks, affine.numel_in(1))
    assert Z.fields[-1] == "bal" and Z.size_of("bal") == STA_NZ
    # a balance controller whose state output does not match its state input is refused
    x = ca.MX.sym("x", STATE.size)
    r = [ca.MX.sym(f"r{i}", 4) for i in range(3)]
    p, k, zb = ca.MX.sym("p", affine.numel_in(1)), ca.MX.sym("k", 1), ca.MX.sym("zb", 2)
    bad = ca.Function("ballbot_bad", [x, *r, p, k, zb], [ca.DM.zeros(3), ca.DM.zeros(1),
                                                         ca.DM.zeros(3)])
    with pytest.raises(ScenarioError, match="with a state"):
        check_blocks(PeriodBlocks(bad, vel), affine.numel_in(1))
    # the smallest state (one integrator) is a state; an empty one is not
    for n, ok in ((1, True), (0, False)):
        zb = ca.MX.sym("zb", n)
        f = ca.Function(f"ballbot_z{n}", [x, *r, p, k, zb], [ca.DM.zeros(3), ca.DM.zeros(1), zb])
        if ok:
            assert check_blocks(PeriodBlocks(f, vel), affine.numel_in(1))["nb"] == 1
            assert PeriodBlocks(f, vel).balance_state == 1
        else:
            with pytest.raises(ScenarioError, match="with a state"):
                check_blocks(PeriodBlocks(f, vel), affine.numel_in(1))


def test_scenario_file_selects_the_controller_and_the_default_gains():
    sc = parse_scenario({"name": "t", "controller": "sta", "duration_s": 0.1,
                         "control_period_s": 0.004}).scenario
    assert sc.controller == "sta"
    k = sc.inputs()["k_bal"]
    assert k[STA_GAIN_NAMES.index("h")] == 0.004  # the implicit step is the period
    lq = Scenario(name="t", controller="lqr", duration=0.1,
                  ctrl_changes={"Mb": ["scale", 1.2]})
    p = Params.from_vector(lq.inputs()["p_ctrl"])
    want = design_balance_lqr(linearize(p, functions=make_model_functions())).reshape(-1)
    np.testing.assert_allclose(lq.inputs()["k_bal"], want, rtol=1e-12, atol=0)
    with pytest.raises(ArgumentError, match="linearised model"):
        default_balance_gains("lqr")
    np.testing.assert_array_equal(check_gains("lqr", -want), -want)  # any sign
    with pytest.raises(ArgumentError, match="finite and > 0"):
        check_gains("sta", -default_balance_gains("sta"))


def test_sta_from_five_five_degrees_converges_in_the_compiled_mission(sim):
    """Thesis §8.2 initial tilt: |S| <= 1e-3 within 1 s and after, inside the §7.1 limits."""
    sc = Scenario(name="sta55", controller="sta", duration=2.0, x0=initial_state(5, 5))
    log = run_scenario(sc, sim)
    k = sc.inputs()["k_bal"]
    S = _sliding_variable(log, k)
    t = log["time"][:-1]
    assert np.abs(S[t >= 1.0]).max() <= 1e-3  # measured ~1e-8
    assert np.abs(S[0]).max() > 0.05  # it started off the manifold
    q, dq = log["state"][:, STATE["q"]], log["state"][:, STATE["dq"]]
    w = np.array([2 * Q.vee(Q.mul(Q.conj(a), b)) for a, b in zip(q, dq)])
    assert np.linalg.norm(w[:, :2], axis=1).max() <= THESIS_LIMITS["tilt_rate_max"]
    assert np.abs(np.degrees(Q.to_rpy(q[-1]))).max() < 0.01
    # an independent loop: the controller Function with its state carried by hand, the
    # direction-preserving limit, the plant's saturation and RK4
    inp = sc.inputs()
    p, tau_max = inp["p_plant"], Params.from_vector(inp["p_plant"]).tau_max
    ctrl = make_balance_controller("sta", make_affine())
    rk4 = make_rk4_n(make_ode(), sc.n_sub)
    x, zb = inp["x0"].copy(), np.zeros(STA_NZ)
    for i in range(sc.n_periods):
        tau, _, zb = (np.asarray(v).ravel() for v in ctrl(x, inp["q_ref"][i], inp["dq_ref"][i],
                                                             inp["ddq_ref"][i], p, k, zb))
        x = np.asarray(rk4(x, np.clip(saturate_torques(tau, tau_max), -tau_max, tau_max), p,
                           sc.Ts)).ravel()
    np.testing.assert_allclose(log["state"][-1], x, rtol=0, atol=1e-12)


@pytest.mark.parametrize("controller", ["sta", "lqr", "flc_dob"])
def test_mission_equals_the_python_loop(sim, controller):
    sc = Scenario(name="t", controller=controller, duration=0.8, x0=initial_state(3, -2, 10),
                  cascade=True, velocity_keyframes=((0.0, 0.2, -0.1, 0.3),),
                  pushes=((0.2, 1.0, -1.0, 0.5),),
                  torque_disturbances=((0.4, 0.5, 0.3, 0.0, -0.2),))
    log = run_scenario(sc, sim)
    affine = make_affine()
    blocks = PeriodBlocks(make_balance_controller(controller, affine), make_velocity_controller(),
                          make_com_observer())
    ref = _python_loop(blocks, sc)
    np.testing.assert_allclose(log["state"], ref["state"], rtol=0, atol=1e-10)
    np.testing.assert_allclose(log["tau"], ref["tau"], rtol=0, atol=1e-9)
    assert np.max(np.abs(log["state"][-1] - log["state"][0])) > 1e-2  # something happened
    if controller in ("sta", "flc_dob"):
        Z = controller_state(blocks, affine.numel_in(1))
        zb = ref["c_final"][Z["bal"]]
        assert np.abs(zb).max() > 1e-4  # the integral term / the disturbance estimate is in use


@pytest.mark.parametrize("controller", ["sta", "flc_dob"])
def test_stateful_controller_with_the_ukfs_balances_and_differs_from_a_reset_state(sim, controller):
    """With sensors and the embedded software: the state slot lives in the embedded
    software's state c (last field); the robot balances from 5/5 deg."""
    sc = Scenario(name="t", controller=controller, duration=3.0, x0=initial_state(5, 5),
                  estimator="ukf", cascade=True, seed=3)
    log = run_scenario(sc, sim)
    rpy = np.degrees([Q.to_rpy(q) for q in log["state"][:, STATE["q"]]])
    t = log["time"]
    assert np.abs(rpy[t >= 2.0, :2]).max() < 1.0
    assert np.abs(log["c_final"][-balance_state_size(controller):]).max() > 0.0


def test_power_on_state_of_a_stateful_controller_starts_its_own_state_at_rest():
    """The generated power-on Function (mission, controller FMU, firmware) gives the
    super-twisting controller's own state ``bal`` zero, as the mission starts it, and the
    rest of ``c`` as for a stateless controller."""
    from ballbot_casadi.core.params import load_params
    from ballbot_casadi.fmi.controller.controller import initial_state_function
    from ballbot_casadi.sim.embedded import embedded_software, software_layout

    sta, flc = embedded_software("sta", "ukf"), embedded_software("flc", "ukf")
    L = software_layout(sta, "ukf")
    x0 = np.array(initial_state(3.0, -2.0, 10.0))
    p = load_params().to_vector()
    c_sta = np.asarray(initial_state_function(sta, "ukf")(x0, p), float).ravel()
    c_flc = np.asarray(initial_state_function(flc, "ukf")(x0, p), float).ravel()
    assert L.size_of("bal") == 3 and c_sta.size == L.size
    np.testing.assert_array_equal(c_sta[L["bal"]], 0.0)
    np.testing.assert_array_equal(np.delete(c_sta, np.arange(L.size)[L["bal"]]), c_flc)

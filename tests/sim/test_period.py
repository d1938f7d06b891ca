"""One definition of a control period: every loop built from it agrees, and the period's
order (push -> controllers -> limits -> disturbance -> plant) is observable in the log."""

from __future__ import annotations

import numpy as np
import pytest
from _period_support import period_loop
from ballbot_casadi.studies.registry import study_scenarios

from ballbot_casadi.control import (
    make_balance_controller,
    make_velocity_controller,
    saturate_torques,
)
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import DISTURBANCE, STATE
from ballbot_casadi.core.params import PARAM_NAMES, load_params
from ballbot_casadi.model.dynamics import make_affine
from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario
from ballbot_casadi.sim.period import actuate, apply_push, control_period
from ballbot_casadi.sim.ports import PERIOD_CONSTANTS, PERIOD_SEQUENCES, PeriodBlocks
from ballbot_casadi.sim.scenario import Scenario, initial_state

TAU_MAX = PARAM_NAMES.index("tau_max")


@pytest.fixture(scope="module")
def sim() -> ClosedLoop:
    return ClosedLoop(compiled=True)


@pytest.fixture(scope="module")
def blocks() -> dict[str, PeriodBlocks]:
    affine, vel = make_affine(), make_velocity_controller()
    return {c: PeriodBlocks(make_balance_controller(c, affine), vel) for c in ("flc", "smc")}


def python_loop(blocks: PeriodBlocks, scenario: Scenario) -> dict[str, np.ndarray]:
    """The scenario as a Python loop of control_period with the RK4 plant."""
    inp = scenario.inputs()
    return period_loop(blocks, scenario, inp, inp["z0"].copy(),
                       {k: inp[k] for k in PERIOD_CONSTANTS})


def _disturbed(controller: str = "flc", **kw) -> Scenario:
    """Roll sine with 2.5 N m on wheel 0 for 0.1 s: beyond tau_max (1.98 N m)."""
    sc = study_scenarios("sine", controller)[0]
    return sc.replace(duration=1.0, torque_disturbances=((0.3, 0.4, 2.5, 0.0, 0.0),), **kw)


def test_disturbance_torque_is_added_after_the_plant_saturation(sim):
    sc = _disturbed()
    log = run_scenario(sc, sim)
    k = np.nonzero(log["w"][:, DISTURBANCE["tau_dist"]][:, 0])[0]
    assert k.size == 20  # 0.1 s at 200 Hz
    tau_max = load_params().tau_max
    lim = saturate_torques_rows(log["tau_cmd"], tau_max)
    # the order matters in this run: saturating after adding would clip the sum
    assert np.any(np.abs(lim[k, 0] + 2.5) > tau_max + 0.01)
    sat = np.clip(lim, -tau_max, tau_max)
    np.testing.assert_allclose(log["tau"], sat + log["w"][:, 3:6], rtol=0, atol=1e-15)
    # and it moves the robot: the undisturbed run differs
    calm = run_scenario(sc.replace(torque_disturbances=()), sim)
    assert np.max(np.abs(calm["state"] - log["state"])) > 1e-3


def saturate_torques_rows(tau_cmd: np.ndarray, tau_max: float) -> np.ndarray:
    return np.array([saturate_torques(t, tau_max) for t in tau_cmd])


@pytest.mark.parametrize("n_sub", [2, 5])
def test_compiled_mission_equals_the_python_loop_of_the_same_period(sim, blocks, n_sub):
    sc = _disturbed(n_sub=n_sub)
    log = run_scenario(sc, sim)
    ref = python_loop(blocks["flc"], sc)
    np.testing.assert_allclose(log["state"], ref["state"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(log["tau"], ref["tau"], rtol=0, atol=1e-12)


def test_n_sub_changes_the_plant_integration(sim):
    sc = _disturbed()
    fine, coarse = run_scenario(sc, sim), run_scenario(sc.replace(n_sub=1), sim)
    diff = np.max(np.abs(fine["state"] - coarse["state"]))
    assert 1e-9 < diff < 1e-3  # RK4 at 5 ms vs 1 ms: different, both converged-ish
    assert coarse.scenario["n_sub"] == 1


def test_symbolic_loop_uses_the_scenario_n_sub():
    sc = _disturbed(n_sub=2).replace(duration=0.2)
    a = run_scenario(sc, ClosedLoop(compiled=False))
    b = run_scenario(sc, ClosedLoop(compiled=False, n_sub=2))
    c = run_scenario(sc.replace(n_sub=5), ClosedLoop(compiled=False, n_sub=2))
    np.testing.assert_array_equal(a["state"], b["state"])
    assert np.max(np.abs(a["state"] - c["state"])) > 0


def test_push_rotates_q_and_dq_and_the_controllers_see_the_pushed_state(blocks):
    x = initial_state(2.0, -1.0, 10.0)
    x = np.array(x)
    x[STATE["dq"]] = 0.5 * Q.mul(x[STATE["q"]], Q.hat([0.3, -0.2, 0.1]))  # body rates
    push = np.array([0.05, -0.02, 0.01])
    xk = apply_push(x, push)
    r = Q.from_rotation_vector(push)
    np.testing.assert_allclose(xk[STATE["q"]], Q.mul(r, x[STATE["q"]]), atol=1e-15)
    np.testing.assert_allclose(xk[STATE["dq"]], Q.mul(r, x[STATE["dq"]]), atol=1e-15)
    # body angular velocity is unchanged by the jump: omega_B = 2 v(q* o dq)
    wb = lambda s: 2 * Q.vee(Q.mul(Q.conj(s[STATE["q"]]), s[STATE["dq"]]))  # noqa: E731
    np.testing.assert_allclose(wb(xk), wb(x), atol=1e-14)

    sc = study_scenarios("sine", "flc")[0]
    inp = sc.inputs()
    const = {k: inp[k] for k in PERIOD_CONSTANTS}
    seq = {s: inp[s][0] for s in PERIOD_SEQUENCES}
    seq["w"] = np.r_[push, 0.0, 0.0, 0.0]
    seen = []
    out = control_period(blocks["flc"], x, inp["z0"], seq, const,
                         lambda xk_, tau, tl, td: seen.append(xk_) or xk_)
    np.testing.assert_allclose(seen[0], xk, atol=1e-15)
    tau_after, _ = blocks["flc"].balance(xk, seq["q_ref"], seq["dq_ref"], seq["ddq_ref"],
                                         inp["p_ctrl"], inp["k_bal"])
    np.testing.assert_allclose(out["tau_cmd"], np.asarray(tau_after).ravel(), atol=1e-14)


@pytest.mark.parametrize("controller", ["flc", "smc"])
def test_logged_command_is_the_controller_on_the_logged_state_during_pushes(sim, blocks, controller):
    # pushes while the robot moves (roll sine): tau_cmd[k] = balance(state[k], refs[k])
    sc = study_scenarios("sine", controller)[0].replace(
        duration=2.0, pushes=((1.0, 2.0, -1.0, 3.0), (1.9, -1.5, 2.0, 0.0)))
    log = run_scenario(sc, sim)
    inp = sc.inputs()
    bal = blocks[controller].balance
    ks = [int(round(1.0 / sc.Ts)), int(round(1.9 / sc.Ts)), 17, 300]
    for k in ks:
        tau, _ = bal(log["state"][k], log["q_ref"][k], log["dq_ref"][k], log["ddq_ref"][k],
                     inp["p_ctrl"], inp["k_bal"])
        np.testing.assert_allclose(log["tau_cmd"][k], np.asarray(tau).ravel(), rtol=0, atol=1e-12)
    # the pushed state has body rates of a moving robot (the push hit a moving body)
    k = ks[0]
    assert np.max(np.abs(log["state"][k, STATE["dq"]])) > 0.05


def test_direction_preserving_limit_uses_the_controller_tau_max(sim):
    sc = study_scenarios("zero", "flc")[0].replace(duration=0.5)
    inp = sc.inputs()
    # controller believes in weaker motors than the plant has
    p_ctrl = load_params(tau_max=0.8).to_vector()
    res = sim.simulate("flc", **{**inp, "p_ctrl": p_ctrl})
    lim = saturate_torques_rows(res["tau_cmd"], 0.8)
    np.testing.assert_allclose(res["tau"], lim, rtol=0, atol=1e-15)
    assert np.max(np.abs(res["tau"])) == pytest.approx(0.8, abs=1e-15)
    # plant weaker than the controller believes: per-wheel clip at the plant's limit
    p_plant = load_params(tau_max=0.5).to_vector()
    res = sim.simulate("flc", **{**inp, "p_plant": p_plant})
    lim = np.clip(saturate_torques_rows(res["tau_cmd"], load_params().tau_max), -0.5, 0.5)
    np.testing.assert_allclose(res["tau"], lim, rtol=0, atol=1e-15)


def test_actuate_on_numbers_and_symbols_agree():
    import casadi as ca

    t, d = np.array([2.5, -3.0, 0.3]), np.array([0.1, -0.2, 0.0])
    num = actuate(t, d, 1.98)
    ts, ds = ca.MX.sym("t", 3), ca.MX.sym("d", 3)
    f = ca.Function("a", [ts, ds], [actuate(ts, ds, 1.98)])
    np.testing.assert_array_equal(num, np.asarray(f(t, d)).ravel())
    np.testing.assert_array_equal(num, [2.08, -2.18, 0.3])


def test_feedforward_none_gives_the_balance_controller_zero_reference_acceleration(sim):
    sc = study_scenarios("sine", "flc")[0].replace(duration=2.0)
    exact, none = run_scenario(sc, sim), run_scenario(sc.replace(feedforward="none"), sim)
    assert np.max(np.abs(exact["ddq_ref"])) > 1e-3
    np.testing.assert_array_equal(none["ddq_ref"], 0.0)
    np.testing.assert_array_equal(exact["q_ref"], none["q_ref"])
    # without the feed-forward the roll lags more (thesis FLC 8.44 tracks with a lag)
    roll = lambda log: np.degrees(2 * np.arcsin(log["state"][:-1, 3]))  # noqa: E731
    ref = np.degrees(2 * np.arcsin(exact["q_ref"][:, 1]))
    assert np.max(np.abs(roll(none) - ref)) > 3 * np.max(np.abs(roll(exact) - ref))


def test_balance_only_runs_need_no_velocity_design(sim):
    # g = 0: no stabilising velocity gain exists, but the balance controller alone runs
    sc = study_scenarios("zero", "flc")[0].replace(duration=0.5, plant_changes={"g": ["set", 0.0]},
                                                   ctrl_changes={"g": ["set", 0.0]})
    log = run_scenario(sc, sim)
    assert np.all(np.isfinite(log["state"]))
    with pytest.raises(ValueError, match="no stabilising velocity gain"):
        sc.replace(cascade=True).inputs()

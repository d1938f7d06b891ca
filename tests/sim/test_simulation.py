"""Closed-loop simulation engine: compiled vs symbolic, RK4 consistency, saturation, logs."""

from __future__ import annotations

import json

import casadi as ca
import numpy as np
import pytest
from ballbot_casadi.studies.registry import study_scenarios

from ballbot_casadi.core.params import load_params
from ballbot_casadi.errors import FileFormatError, ScenarioError, ShapeError
from ballbot_casadi.model.dynamics import NP, make_ode
from ballbot_casadi.model.integrators import make_rk4_n
from ballbot_casadi.model.numeric import make_state
from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario
from ballbot_casadi.sim.log import load_log, save_log
from ballbot_casadi.sim.mission import CHUNK, make_mission
from ballbot_casadi.sim.steps import make_closed_loop_step
from ballbot_casadi.sim.scenario import Scenario, initial_state


@pytest.fixture(scope="module")
def compiled() -> ClosedLoop:
    return ClosedLoop(compiled=True)


@pytest.fixture(scope="module")
def symbolic() -> ClosedLoop:
    return ClosedLoop(compiled=False)


def _zero_balance() -> ca.Function:
    """Balance-controller stand-in that commands no torque (interface of the contract)."""
    x, q, dq, ddq = ca.MX.sym("x", 12), ca.MX.sym("q_ref", 4), ca.MX.sym("dq_ref", 4), ca.MX.sym("ddq_ref", 4)
    p, k = ca.MX.sym("p", NP), ca.MX.sym("k", 1)
    return ca.Function("ballbot_zero", [x, q, dq, ddq, p, k], [ca.DM.zeros(3), ca.DM.zeros(1)],
                       ["x", "q_ref", "dq_ref", "ddq_ref", "p", "k"], ["tau", "diag"])


def _const_velocity() -> ca.Function:
    x, v, z = ca.MX.sym("x", 12), ca.MX.sym("v_ref", 3), ca.MX.sym("z", 1)
    p, k, Ts = ca.MX.sym("p", NP), ca.MX.sym("k", 1), ca.MX.sym("Ts")
    return ca.Function("ballbot_velocity", [x, v, z, p, k, Ts],
                       [ca.DM([1, 0, 0, 0]), ca.DM.zeros(4), ca.DM.zeros(4), z + Ts],
                       ["x", "v_ref", "z", "p", "k", "Ts"], ["q_ref", "dq_ref", "ddq_ref", "z_next"])


def _inputs(scenario: Scenario, n: int | None = None) -> dict:
    inp = scenario.inputs()
    if n is not None:
        for key in ("q_ref", "dq_ref", "ddq_ref", "v_ref", "w"):
            inp[key] = inp[key][:n]
    return inp


@pytest.mark.parametrize("controller", ["flc", "smc"])
@pytest.mark.parametrize("cascade", [False, True])
def test_compiled_equals_symbolic(compiled, symbolic, controller, cascade):
    # 2 compiled chunks of CHUNK periods + 7 periods of the compiled step
    sc = Scenario("t", controller, (2 * CHUNK + 7) * 0.005, initial_state(3, -2, 10), cascade=cascade,
                  velocity_keyframes=((0.0, 0.2, -0.1, 0.3),),
                  attitude={} if cascade else {"roll": {"type": "sine", "amplitude_deg": 2, "frequency_hz": 1}},
                  pushes=((0.2, 1.0, -1.0, 0.5), (1.3, -0.5, 0.5, 0.0)))
    inp = _inputs(sc)
    a = compiled.simulate(controller, **inp)
    b = symbolic.simulate(controller, **inp)
    for key in a:
        np.testing.assert_allclose(a[key], b[key], rtol=0, atol=1e-12, err_msg=key)
    assert np.max(np.abs(a["state"][-1] - a["state"][0])) > 1e-3  # something happened


def test_c_driver_equals_casadi_mission(compiled):
    via_casadi = ClosedLoop(compiled=True, use_driver=False)
    assert compiled.driver is not None and via_casadi.driver is None
    sc = study_scenarios("velocity", "flc")[-1].replace(duration=(CHUNK + 3) * 0.005)
    inp = _inputs(sc)
    a, b = compiled.simulate("flc", **inp), via_casadi.simulate("flc", **inp)
    for key in a:
        np.testing.assert_allclose(a[key], b[key], rtol=0, atol=1e-15, err_msg=key)


def test_zero_controller_equals_open_loop_rk4():
    ode = make_ode()
    step = make_closed_loop_step(_zero_balance(), _const_velocity(), ode, n_sub=5)
    sim = ClosedLoop(compiled=False, steps={"zero": step})
    p = load_params().to_vector()
    n, Ts = 40, 0.005
    x0 = make_state(roll=0.05, pitch=-0.03, omega_body=(0.1, 0.0, 0.2))
    res = sim.simulate("zero", x0, p_plant=p, p_ctrl=p, k_bal=np.zeros(1), k_vel=np.zeros(1),
                       z0=np.zeros(1), q_ref=np.tile([1.0, 0, 0, 0], (n, 1)), dq_ref=np.zeros((n, 4)),
                       ddq_ref=np.zeros((n, 4)), v_ref=np.zeros((n, 3)), w=np.zeros((n, 6)), Ts=Ts)
    rk4 = make_rk4_n(ode, 5)
    x = x0.copy()
    states = [x]
    for _ in range(n):
        x = np.asarray(rk4(x, np.zeros(3), p, Ts)).ravel()
        states.append(x)
    np.testing.assert_allclose(res["state"], np.array(states), rtol=0, atol=1e-13)
    np.testing.assert_array_equal(res["tau"], 0.0)
    np.testing.assert_allclose(res["time"], np.arange(n + 1) * Ts, rtol=0, atol=1e-15)
    np.testing.assert_allclose(res["z"][:, 0], np.arange(n + 1) * 0.0, atol=0)  # cascade off: z frozen


def test_cascade_flag_selects_reference_source():
    step = make_closed_loop_step(_zero_balance(), _const_velocity(), make_ode())
    sim = ClosedLoop(compiled=False, steps={"zero": step})
    p = load_params().to_vector()
    n = 5
    q_in = np.tile([0.0, 1.0, 0.0, 0.0], (n, 1))
    common = dict(p_plant=p, p_ctrl=p, k_bal=np.zeros(1), k_vel=np.zeros(1), z0=np.zeros(1),
                  q_ref=q_in, dq_ref=np.zeros((n, 4)), ddq_ref=np.zeros((n, 4)),
                  v_ref=np.zeros((n, 3)), w=np.zeros((n, 6)))
    off = sim.simulate("zero", make_state(), cascade=False, **common)
    on = sim.simulate("zero", make_state(), cascade=True, **common)
    np.testing.assert_array_equal(off["q_ref"], q_in)
    np.testing.assert_array_equal(on["q_ref"], np.tile([1.0, 0, 0, 0], (n, 1)))
    np.testing.assert_allclose(on["z"][:, 0], np.arange(n + 1) * 0.005, atol=1e-15)


def test_saturation_active_and_plant_tau_max_used(compiled):
    sc = study_scenarios("zero", "flc")[0].replace(duration=0.5)
    inp = _inputs(sc)
    res = compiled.simulate("flc", **inp)
    tau_max = load_params().tau_max
    peak = np.max(np.abs(res["tau_cmd"]), axis=1)
    sat = peak > tau_max
    assert sat.any(), "the 5 deg + 5 deg initial error must saturate the wheel torques"
    # direction-preserving limit: the largest wheel torque sits at tau_max, ratios kept
    np.testing.assert_allclose(np.max(np.abs(res["tau"][sat]), axis=1), tau_max, rtol=1e-15)
    np.testing.assert_allclose(res["tau"][sat], res["tau_cmd"][sat] * (tau_max / peak[sat])[:, None],
                               rtol=1e-14, atol=1e-15)
    np.testing.assert_array_equal(res["tau"][~sat], res["tau_cmd"][~sat])
    # a weaker plant motor saturates more; the controller model is unchanged
    p_weak = load_params(tau_max=0.5).to_vector()
    weak = compiled.simulate("flc", **{**inp, "p_plant": p_weak})
    assert np.max(np.abs(weak["tau"])) <= 0.5 + 1e-15
    assert np.mean(np.max(np.abs(weak["tau_cmd"]), axis=1) > 0.5) > np.mean(sat)


def test_plant_and_controller_parameters_are_separate_inputs(compiled):
    sc = study_scenarios("zero", "flc")[0].replace(duration=0.2)
    inp = _inputs(sc)
    base = compiled.simulate("flc", **inp)
    heavy = load_params(Mb=20.0).to_vector()
    plant = compiled.simulate("flc", **{**inp, "p_plant": heavy})
    ctrl = compiled.simulate("flc", **{**inp, "p_ctrl": heavy})
    assert not np.allclose(plant["state"], base["state"], rtol=0, atol=1e-6)
    assert not np.allclose(ctrl["tau_cmd"], base["tau_cmd"], rtol=0, atol=1e-6)
    # first command only depends on the controller's model, not on the plant
    np.testing.assert_allclose(plant["tau_cmd"][0], base["tau_cmd"][0], rtol=0, atol=1e-14)


def test_push_rotates_plant_attitude(compiled):
    sc = study_scenarios("push", "flc")[0].replace(duration=1.2)
    res = compiled.simulate("flc", **_inputs(sc))
    k = int(round(1.0 / sc.Ts))
    from ballbot_casadi.analysis.metrics import rpy_deg

    before, after = rpy_deg(res["state"][k - 1:k + 1, 2:6])
    assert abs(before[0]) < 1e-9
    np.testing.assert_allclose(after, [4.0, 0.0, 0.0], rtol=0, atol=1e-9)


def test_mission_is_one_function():
    step = make_closed_loop_step(_zero_balance(), _const_velocity(), make_ode())
    m = make_mission(step, 7)
    assert m.name() == "ballbot_mission_zero"
    assert m.size_in("q_ref") == (4, 7)
    assert m.size_out("xz_next") == (13, 7)
    with pytest.raises(ScenarioError):
        make_mission(step, 0)


def test_bad_inputs_rejected(compiled):
    sc = study_scenarios("zero", "flc")[0].replace(duration=0.05)
    inp = _inputs(sc)
    bad = inp["q_ref"].copy()
    bad[3, 1] = np.nan
    with pytest.raises(ScenarioError, match="NaN or Inf"):
        compiled.simulate("flc", **{**inp, "q_ref": bad})
    with pytest.raises(ShapeError, match=r"\(N, 3\)"):
        compiled.simulate("flc", **{**inp, "v_ref": np.zeros((inp["v_ref"].shape[0], 2))})
    with pytest.raises(ShapeError, match="rows"):
        compiled.simulate("flc", **{**inp, "w": np.zeros((3, 6))})
    with pytest.raises(ScenarioError, match="allowed: flc, smc, sta, lqr, flc_dob"):
        compiled.simulate("pid", **inp)
    with pytest.raises(ScenarioError, match="balance controller"):
        make_closed_loop_step(make_ode(), _const_velocity(), make_ode())


def test_run_scenario_log_and_npz_round_trip(compiled, tmp_path):
    sc = study_scenarios("sine", "smc")[0].replace(duration=0.3)
    log = run_scenario(sc, compiled)
    n = sc.n_periods
    assert log["state"].shape == (n + 1, 12)
    assert log["tau"].shape == log["tau_cmd"].shape == (n, 3)
    assert log["q_ref"].shape == (n, 4) and log["diag"].shape[0] == n
    assert log.diag_names[0] == "singular"
    path = save_log(log, tmp_path / "run.npz")
    back = load_log(path)
    assert set(back.arrays) == set(log.arrays)
    for key, val in log.arrays.items():
        np.testing.assert_array_equal(back[key], val)
    assert back.scenario == sc.to_dict()
    assert back.params == sc.plant_params() and back.ctrl_params == sc.controller_params()
    assert Scenario.from_dict(back.scenario) == sc
    with np.load(path) as data:
        meta = json.loads(str(data["meta_json"]))
    assert meta["params"]["tau_max"] == pytest.approx(load_params().tau_max, rel=0, abs=0)


def test_load_log_rejects_foreign_npz(tmp_path):
    path = tmp_path / "x.npz"
    np.savez(path, a=np.zeros(3))
    with pytest.raises(FileFormatError, match="not a ballbot simulation log"):
        load_log(path)


def test_one_ms_rk4_step_is_converged(compiled):
    """The default 1 ms plant step agrees with 0.25 ms to ~1e-11 (step size is adequate)."""
    fine = ClosedLoop(compiled=False, n_sub=20)
    sc = study_scenarios("zero", "flc")[0].replace(duration=1.0)
    inp = _inputs(sc)
    a, b = compiled.simulate("flc", **inp), fine.simulate("flc", **inp)
    np.testing.assert_allclose(a["state"], b["state"], rtol=0, atol=1e-9)

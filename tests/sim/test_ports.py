"""The period's one port list: sizes from the Functions, named layouts, the guidance slot."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.control import make_balance_controller, make_velocity_controller
from ballbot_casadi.core.layout import STATE, Layout
from ballbot_casadi.model.dynamics import NP, make_affine, make_ode
from ballbot_casadi.fmi.controller.controller import controller_spec
from ballbot_casadi.sim import library as sim_library
from ballbot_casadi.sim.embedded import embedded_software, software_layout
from ballbot_casadi.sim.library import closed_loop_steps
from ballbot_casadi.sim.ports import (
    GUIDANCE_CONSTANTS,
    GUIDANCE_OUTPUTS,
    PeriodBlocks,
    period_ports,
)
from ballbot_casadi.sim.scenario import Scenario, initial_state
from ballbot_casadi.sim.steps import make_closed_loop_step


def test_nested_layout_slices_offsets_and_packing_by_name():
    inner = Layout("inner", [("a", 2), ("b", 1)])
    L = Layout("outer", [("x", 3), ("c", inner), ("u", 2)])
    assert (L.offset("c"), L.size_of("c"), L["c.b"], L.slice("c.a")) == (3, 3, slice(5, 6), slice(3, 5))
    v = L.pack({"x": [1, 2, 3], "c.a": [4, 5], "c.b": 6, "u": [7, 8]})
    np.testing.assert_array_equal(v, np.arange(1, 9))
    with pytest.raises(ValueError, match="c.b"):
        L.pack({"x": [1, 2, 3], "c.a": [4, 5], "u": [7, 8]})


def test_the_library_steps_have_the_ports_inputs_and_outputs():
    for est, delay in (("true", False), ("ukf", False), ("ukf", True)):
        step = closed_loop_steps(5, est, delay)["flc"]
        assert step.name_in()[0] == "xz" and step.name_out()[0] == "xz_next"
        if est != "true":
            c = software_layout(embedded_software("flc", est), est)
            assert step.size1_in(0) == STATE.size + 3 + c.size + 9 + (3 if delay else 0)
    assert closed_loop_steps(5, "ukf", True)["flc"].name() == "ballbot_cl_step_delayed_flc_ukf"


def _guidance(gain_rows: int = 1) -> ca.Function:
    """A stand-in guidance block: v_ref_out = k_guid[0] * v_ref, a period counter as state."""
    x, v, g, z, p, k, Ts = (ca.MX.sym(n, m) for n, m in (
        ("x", 12), ("v_ref", 3), ("g", 1), ("z", 8), ("p", NP), ("k_guid", gain_rows), ("Ts", 1)))
    return ca.Function("ballbot_guidance_test", [x, v, g, z, p, k, Ts], [k[0] * v, g + 1],
                       ["x", "v_ref", "g", "z", "p", "k_guid", "Ts"], ["v_ref_out", "g_next"])


def test_a_guidance_block_slots_in_above_the_velocity_controller():
    bal, vel, ode = make_balance_controller("flc", make_affine()), make_velocity_controller(), make_ode()
    plain = make_closed_loop_step(bal, vel, ode)
    guided = make_closed_loop_step(bal, vel, ode, guidance=_guidance())
    ports = period_ports(PeriodBlocks(bal, vel, guidance=_guidance()), NP)
    assert GUIDANCE_CONSTANTS[0] in guided.name_in() and GUIDANCE_OUTPUTS[0] in guided.name_out()
    assert ports.state["c.guide"] == slice(ports.state.size - 1, ports.state.size)
    sc = Scenario("guided", "flc", 0.05, initial_state(0.0, 0.0, 0.0), cascade=True,
                  velocity_keyframes=((0.0, 0.3, 0.0, 0.0),))
    inp = sc.inputs()
    args = {"q_ref": inp["q_ref"][0], "dq_ref": inp["dq_ref"][0], "ddq_ref": inp["ddq_ref"][0],
            "v_ref": np.array([0.3, 0.0, 0.0]), "w": np.zeros(6), "p_plant": inp["p_plant"],
            "p_ctrl": inp["p_ctrl"], "k_bal": inp["k_bal"], "k_vel": inp["k_vel"], "Ts": inp["Ts"],
            "cascade": 1.0, "feedforward": 1.0}
    xz = np.concatenate([inp["x0"], inp["z0"]])
    ref = plain(xz=xz, **args)
    # gain 1: the guidance passes v_ref through, the loop is the plain one, the counter runs
    out = guided(xz=np.r_[xz, 0.0], k_guid=1.0, **args)
    np.testing.assert_allclose(np.asarray(out["xz_next"])[:-1], np.asarray(ref["xz_next"]),
                               rtol=0, atol=0)
    assert float(out["xz_next"][-1]) == 1.0
    np.testing.assert_array_equal(np.asarray(out["v_ref_used"]).ravel(), [0.3, 0.0, 0.0])
    # gain 0: the velocity controller follows zero instead of v_ref
    zero = guided(xz=np.r_[xz, 0.0], k_guid=0.0, **args)
    assert np.max(np.abs(np.asarray(zero["tau_cmd"]) - np.asarray(ref["tau_cmd"]))) > 1e-9


def test_the_controller_fmu_builds_no_mission(monkeypatch):
    def refuse(*a, **k):
        raise AssertionError("a mission step was built")

    for name in ("make_estimating_step", "make_closed_loop_step", "make_chunk"):
        monkeypatch.setattr(sim_library, name, refuse)
    spec = controller_spec("smc", "ekf")
    assert spec.functions[0].name() == "ballbot_embedded_smc_ekf"

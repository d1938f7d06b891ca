"""The guided missions' MPC is compiled once and linked (sim.guided, GuidanceLaw.relink):
the host variant's generated C calls the separately compiled sample by name and carries
none of the MPC, the variants of one MPC link the same library, and the linked mission
equals CasADi's own evaluation of the whole (inlined) closed loop."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.core.constants import N_SUB
from ballbot_casadi.model.dynamics import make_ode
from ballbot_casadi.sim.closed_loop import ClosedLoop
from ballbot_casadi.sim.embedded import controller_blocks
from ballbot_casadi.sim.guided import guided_simulator, mpc_law, pursuit_law, run_guided
from ballbot_casadi.sim.steps import make_closed_loop_step

#: 50 periods: the cold first sample (period 0) and two warm ones (20, 40).
DURATION = 0.25
#: The comment CasADi writes above the generated QP solver (the MPC's code).
QP_CODE = "/* ballbot_mpc:("


@pytest.fixture(scope="module")
def linked(guided_law):
    return guided_simulator(guided_law, "true")


def test_the_variant_links_the_separately_compiled_mpc(linked, guided_law, guided_inputs):
    lib = linked.library
    assert [d.name for d in lib.links] == [guided_law.sample.name()]
    assert QP_CODE in lib.links[0].source.read_text()
    src = lib.source.read_text()
    assert QP_CODE not in src
    assert f"int {guided_law.sample.name()}(const casadi_real** arg" in src  # an extern call
    # the latency variant's block is built on the same sample: the same compiled MPC
    law5 = mpc_law(guided_inputs["p_ctrl"], guided_inputs["k_vel"], latency=5)
    assert law5.sample is guided_law.sample and law5.relink is not None
    # the split block (a firmware interrupt step) calls no sample; pursuit is compiled whole
    assert mpc_law(guided_inputs["p_ctrl"], guided_inputs["k_vel"], latency=5,
                   split=True).relink is None
    assert pursuit_law().relink is None


def test_the_linked_mission_equals_casadis_evaluation_of_the_whole_loop(linked, guided_law,
                                                                        guided_path):
    blocks = controller_blocks("flc")
    whole = make_closed_loop_step(blocks.balance, blocks.velocity, make_ode(), N_SUB,
                                  blocks.observer, guided_law.function)  # the MPC inlined
    ref = run_guided(guided_path, guided_law, DURATION,
                     sim=ClosedLoop(compiled=False, steps={"flc": whole}))
    got = run_guided(guided_path, guided_law, DURATION, sim=linked)
    assert np.any(np.abs(got["v_ref_used"][:, :2]) > 1e-3)  # the samples gave references
    for key in ("state", "tau", "v_ref_used", "guide"):
        np.testing.assert_allclose(got[key], ref[key], rtol=0, atol=1e-12, err_msg=key)

"""The firmware with the path-following MPC in its period (issue 18): the guided mission
replayed on the host build and in QEMU (Cortex-M7), the guidance data given at init."""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np
import pytest

from ballbot_casadi.errors import BuildError, ScenarioError
from ballbot_casadi.firmware.build import default_scenario
from ballbot_casadi.firmware.replay import GUIDED_REPLAY_ATOL, run_host, run_qemu
from ballbot_casadi.firmware.sources import (
    FirmwareValues,
    codegen_work,
    default_guidance_path,
    firmware_function,
    firmware_guidance,
    generate_sources,
    scenario_values,
)
from ballbot_casadi.guidance.path_table import path_table_layout

from _guided_support import EVERY, N, replayed



def test_guided_period_is_the_missions_function_with_its_data_as_a_pointer():
    f = firmware_function("flc", "ukf", "mpc")
    law = firmware_guidance("mpc")
    assert "k_guid" in f.name_in() and "v_ref_used" in f.name_out()
    vals = scenario_values(f, default_scenario("flc", "ukf"), law, default_guidance_path())
    assert vals.guidance.size == path_table_layout(law.config.n_obstacles).size
    files = generate_sources(f, "double", vals, guidance_every=EVERY)
    config = files["ballbot_fw_config.h"]
    assert "#define BALLBOT_FW_GUIDANCE 1" in config
    assert f"#define BALLBOT_FW_N_GUIDANCE {vals.guidance.size}" in config
    assert f"#define BALLBOT_FW_GUIDANCE_EVERY {EVERY}" in config
    # the path table is not a parameter (not copied into the context), but flash data
    assert "k_guid[" not in config
    assert "ballbot_fw_default_guidance_data" in files["ballbot_fw_defaults.c"]
    assert "malloc" not in files["ballbot_fw_cg.c"]
    plain = generate_sources(firmware_function(), "double",
                             scenario_values(firmware_function(), default_scenario()))
    assert "#define BALLBOT_FW_GUIDANCE 0" in plain["ballbot_fw_config.h"]


@pytest.mark.parametrize("guidance", [None, "mpc"])
def test_context_work_vector_is_what_the_generated_c_uses(guidance):
    # the context's work vector is sized by the generated C's own _work function (less
    # than the Function's sz_w: the C reads inputs and constants in place), and every
    # work offset the generated C writes is inside it
    f = firmware_function("flc", "ukf", guidance)
    law = firmware_guidance(guidance)
    vals = scenario_values(f, default_scenario("flc", "ukf"), law,
                           None if law is None else default_guidance_path())
    files = generate_sources(f, "double", vals, guidance_every=EVERY if law else 0)
    sz_arg, sz_res, sz_iw, sz_w = codegen_work(f, files["ballbot_fw_cg.c"])
    assert f"#define BALLBOT_FW_SZ_W {sz_w}" in files["ballbot_fw_config.h"]
    assert sz_w <= f.sz_w() and sz_iw <= f.sz_iw()
    offsets = [int(m) for m in re.findall(r"\bw\+(\d+)", files["ballbot_fw_cg.c"])]
    assert max(offsets) < sz_w


def test_bad_guidance_refused():
    with pytest.raises(ScenarioError, match="unknown guidance 'lqr'"):
        firmware_guidance("lqr")
    with pytest.raises(ScenarioError, match="controller 'smc'"):
        firmware_guidance("mpc", controller="smc")
    f = firmware_function("flc", "ukf", "mpc")
    with pytest.raises(ScenarioError, match="guidance block"):
        scenario_values(f, default_scenario("flc", "ukf"))


@replayed
def test_guided_host_replay_is_the_compiled_mission(rec, host):
    # the library's period with the MPC, fed the mission's readings, gives the mission's
    # velocity references and torques
    np.testing.assert_allclose(host.v_ref, rec.v_ref_mission, rtol=0, atol=GUIDED_REPLAY_ATOL)
    np.testing.assert_allclose(host.tau, rec.tau_mission, rtol=0, atol=GUIDED_REPLAY_ATOL)
    # the MPC really drives: it sets off along the figure-eight (0.5 m/s) from rest
    assert np.max(np.hypot(rec.v_ref_mission[:, 0], rec.v_ref_mission[:, 1])) > 0.2
    # it changes its reference only at its samples (10 Hz), holds it in between
    dv = np.abs(np.diff(rec.v_ref_mission[:, :2], axis=0)).max(axis=1)
    changed = np.flatnonzero(dv > 0) + 1
    assert set(changed) <= set(range(0, N, EVERY))


@replayed
def test_guided_qemu_equals_host(fw, rec, host):
    q = run_qemu(fw, rec)
    np.testing.assert_allclose(q.v_ref, host.v_ref, rtol=0, atol=GUIDED_REPLAY_ATOL)
    np.testing.assert_allclose(q.tau, host.tau, rtol=0, atol=GUIDED_REPLAY_ATOL)
    assert q.rc.min() == 0 and q.rc.max() <= 1  # no rejected period
    assert q.instructions_per_tick == pytest.approx(40.0, rel=1e-3)
    insn = q.ticks * q.instructions_per_tick
    k = np.arange(N)
    solve, hold = insn[(k % EVERY == 0) & (k > 0)], insn[k % EVERY != 0]
    # a sample period runs the QP (60 ADMM iterations on 30 unknowns and 310 rows)
    assert solve.min() > 10 * hold.max()
    assert insn[0] > solve.max()  # the cold first sample solves 5 QPs


@replayed
def test_guidance_data_given_at_init_is_the_one_followed(fw, rec, host):
    # another path speed in the data (the same table otherwise): other references
    law = firmware_guidance("mpc")
    data = rec.values.guidance.copy()
    data[path_table_layout(law.config.n_obstacles)["speed"]] = 0.3
    slower = replace(rec, values=FirmwareValues(rec.values.params, rec.values.c0, data))
    h = run_host(fw, slower)
    assert np.max(np.abs(h.v_ref - host.v_ref)) > 1e-2
    # a data value that is not finite is refused by ballbot_fw_set_guidance
    data[5] = np.nan
    bad = replace(rec, values=FirmwareValues(rec.values.params, rec.values.c0, data))
    with pytest.raises(BuildError, match="ballbot_fw_set_guidance returned -1"):
        run_host(fw, bad)

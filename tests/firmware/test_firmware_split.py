"""The split firmware (issue 18): the MPC's sample in a background task, its reference
applied SPLIT_LATENCY periods after its snapshot.  The interrupt step's Function has no
MPC; the split build replayed on the host and in QEMU equals the compiled guided mission
with that latency; the mission's reference changes exactly at the due periods."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.firmware.build import build_firmware, default_scenario
from ballbot_casadi.firmware.replay import GUIDED_REPLAY_ATOL, run_host, run_qemu
from ballbot_casadi.firmware.sources import (
    SPLIT_LATENCY,
    default_guidance_path,
    firmware_function,
    firmware_guidance,
    generate_sources,
    scenario_values,
)
from ballbot_casadi.sim.embedded import software_layout
from ballbot_casadi.sim.guided import first_sample_latency

from _guided_support import EVERY, N, replayed

L = SPLIT_LATENCY


def _config(text: str) -> dict[str, str]:
    return {p[1]: p[2] for p in (line.split() for line in text.splitlines())
            if len(p) == 3 and p[0] == "#define"}


def test_split_step_has_no_mpc_and_its_config_points_at_the_guidance_state():
    f = firmware_function("flc", "ukf", "mpc", L)
    law = firmware_guidance("mpc", latency=L)
    with pytest.raises(RuntimeError):
        f.find_function("ballbot_mpc")  # the interrupt step never runs the QP
    law.sample.find_function("ballbot_mpc")  # the background sample does
    vals = scenario_values(f, default_scenario("flc", "ukf"), law, default_guidance_path())
    files = generate_sources(f, "double", vals, EVERY, law, "ukf")
    cfg = _config(files["ballbot_fw_config.h"])
    assert cfg["BALLBOT_FW_GUIDANCE_SPLIT"] == "1" and cfg["BALLBOT_FW_GUIDANCE_LATENCY"] == str(L)
    assert cfg["BALLBOT_FW_GUIDANCE_FIRST_LATENCY"] == str(first_sample_latency(EVERY))
    assert cfg["BALLBOT_FW_GUIDANCE_SAMPLE_FIRST"] == "ballbot_guidance_mpc_sample_first"
    off = software_layout(f, "ukf", law.block_size).offset("guide")
    assert int(cfg["BALLBOT_FW_GUIDE_OFFSET"]) == off
    g0 = vals.c0[off:off + law.block_size]
    assert g0[0] == 0.0 and g0[1 + law.state.offset("first")] == 1.0  # counter 0, cold start
    assert int(cfg["BALLBOT_FW_GUIDE_DUE"]) + 1 == int(cfg["BALLBOT_FW_GUIDE_SNAP"])
    assert int(cfg["BALLBOT_FW_GUIDE_SNAP"]) + int(cfg["BALLBOT_FW_GUIDE_NSNAP"]) == law.block_size
    # the background's result buffers: the sample's reference (v_x, v_y) and next state
    assert [law.sample.numel_out(i) for i in range(2)] == [int(cfg["BALLBOT_FW_GUIDE_NV"]),
                                                        int(cfg["BALLBOT_FW_GUIDE_NS"])] == [2, law.state.size]
    # the interrupt step's work vector is a fraction of the sample's, and the background's
    # is its larger branch's own (not the conditional's virtual-machine count)
    assert int(cfg["BALLBOT_FW_SZ_W"]) * 3 < int(cfg["BALLBOT_FW_BG_SZ_W"]) < law.sample.sz_w() / 3
    assert "malloc" not in files["ballbot_fw_cg.c"]


def test_bad_split_refused():
    with pytest.raises(ScenarioError, match="needs a guidance block"):
        build_firmware(guidance=None, latency=L)
    with pytest.raises(ScenarioError, match="latency is an option of the MPC"):
        firmware_guidance("pursuit", latency=L)
    with pytest.raises(ScenarioError, match=r"latency must be an int in 0\.\.19"):
        firmware_guidance("mpc", latency=EVERY)


@replayed
def test_split_host_replay_is_the_mission_with_latency(split_rec, split_host):
    np.testing.assert_allclose(split_host.v_ref, split_rec.v_ref_mission, rtol=0,
                               atol=GUIDED_REPLAY_ATOL)
    np.testing.assert_allclose(split_host.tau, split_rec.tau_mission, rtol=0, atol=GUIDED_REPLAY_ATOL)
    # the mission's reference changes exactly at the due periods: the cold first sample
    # (period 0) at first_sample_latency, every later one L periods after its sample
    v = np.vstack([np.zeros((1, 3)), split_rec.v_ref_mission])[:, :2]
    changed = np.flatnonzero(np.abs(np.diff(v, axis=0)).max(axis=1) > 0)
    due = [first_sample_latency(EVERY), *range(EVERY + L, N, EVERY)]
    assert list(changed) == due
    assert np.max(np.hypot(v[:, 0], v[:, 1])) > 0.2  # it sets off along the path


@replayed
def test_split_qemu_equals_the_mission_and_the_interrupt_never_runs_the_qp(split_fw, split_rec,
                                                                           split_host):
    q = run_qemu(split_fw, split_rec)
    np.testing.assert_allclose(q.v_ref, split_host.v_ref, rtol=0, atol=GUIDED_REPLAY_ATOL)
    np.testing.assert_allclose(q.tau, split_host.tau, rtol=0, atol=GUIDED_REPLAY_ATOL)
    np.testing.assert_allclose(q.v_ref, split_rec.v_ref_mission, rtol=0, atol=GUIDED_REPLAY_ATOL)
    assert q.rc.min() == 0 and q.rc.max() <= 1  # no rejected period, no failed sample
    isr, bg = q.ticks * q.instructions_per_tick, q.bg_ticks * q.instructions_per_tick
    k = np.arange(N)
    assert list(np.flatnonzero(bg > 0)) == list(k[k % EVERY == 0])  # one sample per snapshot
    # every interrupt step, snapshot periods included, is a small fraction of a sample
    assert isr.max() < 0.1 * bg[bg > 0].min()
    assert bg[0] > bg[EVERY:][bg[EVERY:] > 0].max()  # the cold first sample solves 5 QPs


@replayed
def test_a_late_background_result_is_never_applied_early_or_late(split_fw, split_rec, split_host):
    # the sample finished just before its due period: the same references and torques
    just = run_host(split_fw, split_rec, bg_delay=L - 1)
    np.testing.assert_array_equal(just.v_ref, split_host.v_ref)
    np.testing.assert_array_equal(just.tau, split_host.tau)
    assert just.guidance_late == 0 == split_host.guidance_late
    # one period later: every warm result misses its due period, is counted and never
    # applied; the reference holds the cold first sample's (due at period 19, in time)
    first = first_sample_latency(EVERY)
    late = run_host(split_fw, split_rec, bg_delay=L)
    assert late.guidance_late == len(range(EVERY + L, N, EVERY))
    np.testing.assert_array_equal(late.v_ref[:first, :2], 0.0)
    np.testing.assert_array_equal(late.v_ref[first:, :2],
                                  np.tile(split_host.v_ref[first, :2], (N - first, 1)))
    # the first one late too: nothing is ever applied, the reference stays 0
    never = run_host(split_fw, split_rec, bg_delay=first)
    assert never.guidance_late == len([first, *range(EVERY + L, N, EVERY)])
    np.testing.assert_array_equal(never.v_ref[:, :2], 0.0)
